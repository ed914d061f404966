"""Compiled vs interpreted: the state RHS, one period with its monodromy, a full trim; compile times.

Writes results/benchmark_compiled.json and prints a table. Medians of repeated runs; the compiled
RHS is built in a fresh temporary cache (so its compile time is measured), the exported C folder in
a temporary folder (export, make, and the C period map called through ctypes).

    python scripts/benchmark_compiled.py [--repeat R] [--out results/benchmark_compiled.json]
"""
from __future__ import annotations

import argparse
import ctypes
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np
from birdocp.io.files import atomic_write_json


def median_time(fn, repeat, inner=1):
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        out.append((time.perf_counter() - t) / inner)
    return statistics.median(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "results" / "benchmark_compiled.json"))
    args = ap.parse_args(argv)
    R = args.repeat

    tmp = Path(tempfile.mkdtemp(prefix="birdocp-bench-"))
    os.environ["BIRDOCP_CACHE"] = str(tmp / "cache")
    from birdocp.export import compiled
    from birdocp.studies import trim as studies
    from birdocp.export.codegen import export_c
    from birdocp.bird.config import Config
    from birdocp.engine.integrate import RK4Grid
    from birdocp.bird.model import get_model
    from birdocp.engine.cache import owned_cache

    cfg = Config()
    m = get_model(cfg)
    N = cfg.solve.steps_per_period
    res = {"machine": {"python": sys.version.split()[0], "casadi": ca.__version__, "platform": platform.platform(),
                       "cpus": os.cpu_count(), "compiler": " ".join(compiled.find_compiler() or ["none"]),
                       "flags": list(compiled.OPT_FLAGS)},
           "repeat": R, "steps_per_period": N}

    # --- compile the RHS (fresh cache) and a cache hit
    t = time.perf_counter()
    ode_c = compiled.compiled_ode(m.ode, key_extra=repr(m.structure))
    res["compile_rhs_s"] = {"total": time.perf_counter() - t, **{k: v for k, v in compiled.last_compile_s["birdocp_rhs"].items() if k != "path"}}
    owned_cache(m.ode, "compiled").clear()  # forget the compiled ODE kept by m.ode: the next call finds the library
    t = time.perf_counter()
    ode_c = compiled.compiled_ode(m.ode, key_extra=repr(m.structure))
    res["compile_rhs_s"]["cache_hit_total"] = time.perf_counter() - t
    assert ode_c is not None, "compilation failed"

    # --- RHS
    grid_i = RK4Grid(m.ode, N, 1)
    grid_c = RK4Grid(ode_c, N, 1)
    D = grid_i.blocks_numeric(0.0, m.p0)
    pd = ca.DM(m.p0)
    x0 = ca.DM([18.0, 0.5, 0.1, 0.01])
    d0 = D[:, 0]
    rhs_i, rhs_c = m.ode.rhs, ode_c.rhs
    Dall = ca.DM(np.asarray(D)[:, : 3 * N])
    mi, mc = rhs_i.map(3 * N), rhs_c.map(3 * N)
    X = ca.repmat(x0, 1, 3 * N)
    res["rhs_call_s"] = {"interpreted": median_time(lambda: rhs_i(x0, d0, pd), R, 2000),
                         "compiled": median_time(lambda: rhs_c(x0, d0, pd), R, 2000)}
    res["rhs_mapped_per_eval_s"] = {"interpreted": median_time(lambda: mi(X, Dall, pd), R, 20) / (3 * N),
                                    "compiled": median_time(lambda: mc(X, Dall, pd), R, 20) / (3 * N)}

    # --- the data on the 2N+1 stage times: pre (read from disk or evaluated), post and post with its
    # amplitude derivative (interpreted and compiled through the ODE's numeric hook), pre's graph read
    from birdocp.bird.config import PARAM_NAMES
    from birdocp.engine import datastore

    K = 2 * N + 1
    times = ca.DM(grid_i.times(0.0))
    L = grid_i.pre_numeric(0.0, m.p0)
    pre_map = m.ode.pre.map(K)
    disk_key = {"pre": m.ode.graph_key, "bench": True}
    datastore.store("bench", disk_key, np.asarray(L))
    res["data_pre_s"] = {"evaluated": median_time(lambda: pre_map(times, pd), R),
                         "read_from_disk": median_time(lambda: datastore.load("bench", disk_key), R)}
    text = m.ode.pre.serialize()
    res["data_pre_s"]["graph_read"] = median_time(lambda: ca.Function.deserialize(text), 3)
    nl = m.ode.pre.size1_out(0)
    ts_, ls_, ps_ = ca.SX.sym("t"), ca.SX.sym("local", nl), ca.SX.sym("p", m.ode.np)
    d_ = m.ode.post(ls_, ts_, ps_)
    seed = ca.DM.zeros(m.ode.np, 1)
    seed[PARAM_NAMES.index("gait.shoulder_flap.amplitude_deg")] = 1.0
    dfw = ca.Function("post_dpf", [ts_, ls_, ps_], [d_, ca.jtimes(d_, ps_, seed)])
    t = time.perf_counter()
    post_c = ode_c.fast(m.ode.post, "post")
    dfw_c = ode_c.fast(dfw, "post_dpf benchmark")
    res["compile_data_s"] = time.perf_counter() - t
    res["data_post_s"] = {"interpreted": median_time(lambda: m.ode.post.map(K)(L, times, pd), R),
                          "compiled": median_time(lambda: post_c.map(K)(L, times, pd), R)}
    res["data_post_amplitude_derivative_s"] = {
        "interpreted": median_time(lambda: dfw.map(K)(times, L, pd), R),
        "compiled": median_time(lambda: dfw_c.map(K)(times, L, pd), R)}
    res["data_instructions"] = {"post": int(m.ode.post.n_instructions()), "post_dpf": int(dfw.n_instructions()),
                                "pre": int(m.ode.pre.n_instructions())}

    # --- validity and power outputs of a trim: from the solve's stage data vs the wing evaluated again
    from birdocp.bird.energetics import cycle_energetics
    from birdocp.bird.validity import cycle_validity, grid_validity
    from birdocp.engine.integrate import clear_stage_data

    tr = studies.trim(cfg)
    c = tr.cycle
    grid_validity(cfg, c.trajectory_x, c.p, 0.0, N)
    cycle_validity(cfg, c.trajectory_t, c.trajectory_x, c.p)
    res["validity_s"] = {"stage_data": median_time(lambda: grid_validity(cfg, c.trajectory_x, c.p, 0.0, N), R),
                         "wing_evaluated_again": median_time(
                             lambda: cycle_validity(cfg, c.trajectory_t, c.trajectory_x, c.p), R)}

    def energetics_fresh():
        clear_stage_data()
        cycle_energetics(m, c.p, c.x0, N, 0.0)

    cycle_energetics(m, c.p, c.x0, N, 0.0)
    res["power_outputs_s"] = {"stage_data": median_time(lambda: cycle_energetics(m, c.p, c.x0, N, 0.0), R),
                              "data_evaluated_again": median_time(energetics_fresh, R)}

    # --- one period with its monodromy
    res["period_map_s"] = {"interpreted": median_time(lambda: grid_i.period_map(x0, D, pd), R, 5),
                           "compiled": median_time(lambda: grid_c.period_map(x0, D, pd), R, 5)}
    res["period_with_monodromy_s"] = {"interpreted": median_time(lambda: grid_i.period_jacobian(x0, D, pd), R, 3),
                                      "compiled": median_time(lambda: grid_c.period_jacobian(x0, D, pd), R, 3)}

    # --- exported C: export, build, and bird_period through ctypes
    out = tmp / "bird_c"
    t = time.perf_counter()
    info = export_c(cfg, out)
    res["export_c_s"] = {"export": time.perf_counter() - t}
    env = dict(os.environ, CC=" ".join(compiled.find_compiler()))
    if shutil.which("make"):
        for jobs in (1, 2):
            subprocess.run(["make", "clean"], cwd=out, check=True, capture_output=True)
            t = time.perf_counter()
            subprocess.run(["make", f"-j{jobs}", "bird_period", "libbird.so"], cwd=out, check=True,
                           capture_output=True, env=env)
            res["export_c_s"][f"make_j{jobs}"] = time.perf_counter() - t
        lib = ctypes.CDLL(str(out / "libbird.so"))
        dbl = ctypes.POINTER(ctypes.c_double)
        lib.bird_period.argtypes = [dbl, dbl, dbl, dbl, dbl]
        p = (ctypes.c_double * 4)(*info.runtime_p0)
        xin = (ctypes.c_double * 4)(18.0, 0.5, 0.1, 0.01)
        xT = (ctypes.c_double * 4)()
        M = (ctypes.c_double * 16)()
        res["period_map_s"]["exported_c"] = median_time(lambda: lib.bird_period(xin, p, xT, None, None), R, 20)
        res["period_with_monodromy_s"]["exported_c"] = median_time(lambda: lib.bird_period(xin, p, xT, M, None), R, 20)
        lib.bird_period(xin, p, xT, M, None)
        xT_py, J_py = (np.asarray(v) for v in grid_i.period_jacobian(x0, D, pd))
        res["exported_c_vs_python_max_abs"] = {
            "state": float(np.max(np.abs(np.array(xT[:]) - xT_py.ravel()))),
            "monodromy": float(np.max(np.abs(np.array(M[:]).reshape(4, 4) - J_py)))}

    # --- full trim (first call builds the graphs; then warm medians)
    trims = {}
    for name, kw in (("interpreted", {}), ("compiled", {"compiled": True})):
        t = time.perf_counter()
        r = studies.trim(cfg, **kw)
        first = time.perf_counter() - t
        times = []
        for _ in range(R):
            t = time.perf_counter()
            r = studies.trim(cfg, **kw)
            times.append(time.perf_counter() - t)
        trims[name] = {"first_s": first, "median_s": statistics.median(times), "success": bool(r.success),
                       "iterations": int(r.iterations), "multipliers": [[float(z.real), float(z.imag)] for z in r.multipliers],
                       "solve_s": float(r.wall_s["solve"]), "floquet_s": float(r.wall_s["floquet"])}
    mi_ = np.array([complex(*z) for z in trims["interpreted"]["multipliers"]])
    mc_ = np.array([complex(*z) for z in trims["compiled"]["multipliers"]])
    trims["multipliers_max_abs_diff"] = float(np.max(np.abs(mi_ - mc_)))
    res["trim"] = trims

    def sp(d):
        return {k: d["interpreted"] / v for k, v in d.items() if k != "interpreted" and v}

    res["speedup"] = {"rhs_call": sp(res["rhs_call_s"]), "rhs_mapped": sp(res["rhs_mapped_per_eval_s"]),
                      "period_map": sp(res["period_map_s"]), "period_with_monodromy": sp(res["period_with_monodromy_s"]),
                      "trim_warm": trims["interpreted"]["median_s"] / trims["compiled"]["median_s"]}
    shutil.rmtree(tmp, ignore_errors=True)

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(Path(args.out), res)

    def row(label, d, unit=1e3, u="ms"):
        cells = "  ".join(f"{k} {v * unit:9.4g} {u}" for k, v in d.items())
        print(f"{label:28s} {cells}")

    row("RHS, one Python call", res["rhs_call_s"], 1e6, "us")
    row("RHS, per eval in a map", res["rhs_mapped_per_eval_s"], 1e6, "us")
    row("one period (RK4)", res["period_map_s"])
    row("one period + monodromy", res["period_with_monodromy_s"])
    print(f"{'full trim (warm median)':28s} interpreted {trims['interpreted']['median_s']:.3f} s  "
          f"compiled {trims['compiled']['median_s']:.3f} s  (first: {trims['interpreted']['first_s']:.2f} / "
          f"{trims['compiled']['first_s']:.2f} s); multipliers differ by {trims['multipliers_max_abs_diff']:.1e}")
    print(f"compile: RHS library {res['compile_rhs_s']['compile']:.1f} s (cache hit {res['compile_rhs_s']['cache_hit_total']:.2f} s); "
          f"export {res['export_c_s']['export']:.1f} s, make -j1 {res['export_c_s'].get('make_j1', float('nan')):.1f} s, "
          f"-j2 {res['export_c_s'].get('make_j2', float('nan')):.1f} s")
    print("speed-ups:", json.dumps(res["speedup"]))
    ms = {k: {kk: round(vv * 1e3, 2) for kk, vv in res[k].items()} for k in
          ("data_pre_s", "data_post_s", "data_post_amplitude_derivative_s", "validity_s", "power_outputs_s")}
    print("data and outputs [ms]:", json.dumps(ms), f"compile post + post_dpf {res['compile_data_s']:.1f} s",
          json.dumps(res["data_instructions"]))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
