"""Benchmark the bird model graphs: sizes, build times and evaluation times.

Prints a table and writes ``results/benchmark_model.json`` (or ``--out PATH``).

Rows:

* SX sizes (``n_instructions``, ``n_nodes``) of ``geometry``, ``data``, ``rhs``;
* graph build time of ``get_model`` in a fresh Python process (import time reported separately),
  for the default config, ``aero.circulation=relaxed`` and ``aero.kinematic_velocity=backward-difference``;
* median wall times (``time.perf_counter``) of one ``data`` call, one ``rhs`` call (numeric d reused),
  one ``f(x, t, p)`` call, and one RK4 period of 148 steps done
  (i) with the stage data precomputed (``data`` on the 297 stage times via ``data.map``, then a
      ``mapaccum`` of 148 RK4 steps that only call ``rhs``; :class:`birdocp.engine.integrate.RK4Grid`), and
  (ii) naively, a Python loop of 148 RK4 steps calling ``f(x, t, p)`` 4 times per step.

Total runtime is well under a minute on a laptop-class CPU.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

ROOT = Path(__file__).resolve().parents[1]

BUILD_SNIPPET = r"""
import json, sys, time
t0 = time.perf_counter()
from birdocp.bird.config import Config, with_values
from birdocp.bird.model import get_model
t1 = time.perf_counter()
cfg = with_values(Config(), json.loads(sys.argv[1]))
m = get_model(cfg)
t2 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "build_s": t2 - t1,
                  "data_n_instructions": int(m.data.n_instructions())}))
"""


def fresh_build(values: dict) -> dict:
    """Import and graph-build times of get_model in a fresh interpreter."""
    env = dict(os.environ, BIRDOCP_GRAPH_CACHE="0")  # the build itself, not a read of the graph cache
    res = subprocess.run([sys.executable, "-c", BUILD_SNIPPET, json.dumps(values)],
                         capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    return json.loads(res.stdout.strip().splitlines()[-1])


def median_time(fn, repeats: int, warmup: int = 1) -> dict:
    for _ in range(warmup):
        fn()
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return {"median_s": statistics.median(ts), "min_s": min(ts), "repeats": repeats}


def sizes(F: ca.Function) -> dict:
    out = {"n_instructions": int(F.n_instructions())}
    if hasattr(F, "n_nodes"):
        out["n_nodes"] = int(F.n_nodes())
    return out


def fmt_t(s: float) -> str:
    if s < 1e-3:
        return f"{s * 1e6:8.1f} us"
    if s < 1.0:
        return f"{s * 1e3:8.2f} ms"
    return f"{s:8.3f} s "


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmark_model.json"))
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args(argv)
    t_start = time.perf_counter()

    # -- graph build times, each in a fresh process -------------------------------------------
    builds = {
        "default": fresh_build({}),
        "circulation=relaxed": fresh_build({"aero.circulation": "relaxed"}),
        "kinematic_velocity=backward-difference": fresh_build({"aero.kinematic_velocity": "backward-difference"}),
    }

    from birdocp.bird.config import Config
    from birdocp.engine.integrate import RK4Grid, simulate
    from birdocp.bird.model import get_model

    cfg = Config()
    m = get_model(cfg)
    N = cfg.solve.steps_per_period
    T = m.period_s
    h = T / N
    p = ca.DM(m.p0)
    x0 = ca.DM(list(cfg.solve.initial_guess))
    t = 0.3 * T

    graph = {name: sizes(F) for name, F in (("geometry", m.geometry), ("data", m.data), ("rhs", m.rhs))}

    d = m.data(t, p)
    timings = {}
    R = args.repeats
    timings["data(t,p)"] = median_time(lambda: m.data(t, p), 5 * R)
    timings["rhs(x,d,p)"] = median_time(lambda: m.rhs(x0, d, p), 20 * R)
    timings["f(x,t,p)"] = median_time(lambda: m.f(x0, t, p), 5 * R)
    timings["geometry(t,p)"] = median_time(lambda: m.geometry(t, p), 5 * R)

    # (i) stage data precomputed, then a mapaccum of RK4 steps on rhs only.
    t0 = time.perf_counter()
    grid = RK4Grid(m.ode, N, 1)
    rk4grid_build_s = time.perf_counter() - t0
    times = ca.DM(grid.times(0.0))
    timings["RK4 period (i) data grid (297 stage times)"] = median_time(lambda: grid.data_grid(times, p), R)
    D = grid.blocks_numeric(0.0, m.p0)
    timings["RK4 period (i) 148 steps on rhs (mapaccum)"] = median_time(lambda: grid.period_map(x0, D, p), 3 * R)

    def precomputed_period():
        # Done by hand rather than with grid.blocks_numeric, which memoises by (t0, p).
        Dg = np.asarray(grid.data_grid(times, p))
        return grid.period_map(x0, ca.DM(Dg[:, grid.block_index]), p)

    timings["RK4 period (i) total: data grid + blocks + period_map"] = median_time(precomputed_period, R)
    # simulate() builds a new RK4Grid (with its Jacobian Functions) on every call.
    timings["RK4 period (i) simulate() incl. RK4Grid build"] = median_time(
        lambda: simulate(m.ode, cfg.solve.initial_guess, m.p0, N), max(3, R // 2))

    # (ii) naive: Python loop, 4 f(x, t, p) calls per step (data recomputed at every stage).
    def naive_period():
        x = x0
        for k in range(N):
            tk = k * h
            k1 = m.f(x, tk, p)
            k2 = m.f(x + h / 2 * k1, tk + h / 2, p)
            k3 = m.f(x + h / 2 * k2, tk + h / 2, p)
            k4 = m.f(x + h * k3, tk + h, p)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    timings["RK4 period (ii) naive loop over f(x,t,p)"] = median_time(naive_period, 5, warmup=0)

    # Consistency: both ways give the same end state.
    xi = np.asarray(grid.period_map(x0, D, p)[0]).ravel()
    xii = np.asarray(naive_period()).ravel()
    max_diff = float(np.max(np.abs(xi - xii)))

    tm = {k: v["median_s"] for k, v in timings.items()}
    ratios = {
        "data / rhs": tm["data(t,p)"] / tm["rhs(x,d,p)"],
        "f / rhs": tm["f(x,t,p)"] / tm["rhs(x,d,p)"],
        "f / (data + rhs)": tm["f(x,t,p)"] / (tm["data(t,p)"] + tm["rhs(x,d,p)"]),
        "naive period (ii) / precomputed period (i) total":
            tm["RK4 period (ii) naive loop over f(x,t,p)"] / tm["RK4 period (i) total: data grid + blocks + period_map"],
        "naive period (ii) / (i) steps only (data reused)":
            tm["RK4 period (ii) naive loop over f(x,t,p)"] / tm["RK4 period (i) 148 steps on rhs (mapaccum)"],
        "(i) data grid / (i) steps": tm["RK4 period (i) data grid (297 stage times)"] / tm["RK4 period (i) 148 steps on rhs (mapaccum)"],
        "(i) data grid / (297 x data)": tm["RK4 period (i) data grid (297 stage times)"] / (297 * tm["data(t,p)"]),
        "(ii) / (592 x f)": tm["RK4 period (ii) naive loop over f(x,t,p)"] / (4 * N * tm["f(x,t,p)"]),
        "backward-difference build / default build":
            builds["kinematic_velocity=backward-difference"]["build_s"] / builds["default"]["build_s"],
        "relaxed build / default build": builds["circulation=relaxed"]["build_s"] / builds["default"]["build_s"],
    }

    # -- report --------------------------------------------------------------------------------
    print(f"birdocp model benchmark  (casadi {ca.__version__}, python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs)")
    print("\nSX graph sizes")
    for name, s in graph.items():
        print(f"  {name:10s} n_instructions {s['n_instructions']:8d}   n_nodes {s.get('n_nodes', float('nan')):8d}")
    print("\nGraph build in a fresh process (get_model; import of birdocp+casadi separate)")
    for name, b in builds.items():
        print(f"  {name:42s} build {fmt_t(b['build_s'])}   import {fmt_t(b['import_s'])}"
              f"   data n_instructions {b['data_n_instructions']}")
    print(f"  {'RK4Grid(ode, 148, 1) construction':42s} build {fmt_t(rk4grid_build_s)}")
    print("\nEvaluation (median wall time; min; repeats)")
    for name, v in timings.items():
        print(f"  {name:52s} {fmt_t(v['median_s'])}   (min {fmt_t(v['min_s']).strip()}, n={v['repeats']})")
    print("\nRatios")
    for name, r in ratios.items():
        print(f"  {name:52s} {r:8.2f}")
    print("(times are wall clock on a shared machine: compare the min column when medians are noisy)")
    print(f"\nEnd state after one period, (i) vs (ii): max |difference| = {max_diff:.2e}")
    total = time.perf_counter() - t_start
    print(f"Benchmark wall time {total:.1f} s")

    result = {
        "casadi_version": ca.__version__,
        "python_version": platform.python_version(),
        "machine": platform.machine(),
        "cpu_count": os.cpu_count(),
        "steps_per_period": N,
        "period_s": T,
        "state_x0": list(cfg.solve.initial_guess),
        "graph_sizes": graph,
        "build_fresh_process_s": builds,
        "rk4grid_build_s": rk4grid_build_s,
        "timings_s": timings,
        "ratios": ratios,
        "period_end_state_max_abs_diff_i_vs_ii": max_diff,
        "benchmark_wall_time_s": total,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    from birdocp.io.files import atomic_write_json

    atomic_write_json(out, result)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
