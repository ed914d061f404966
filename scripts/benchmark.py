"""Issue 7 benchmark: every row of the performance table as measured medians, the floor, the ratios.

Rows (targets from issue 7; 2-core machine; medians of ``--repeats`` runs unless said otherwise):

* ``birdocp trim`` whole process, cold (a fresh interpreter: import, graph build, solve, Floquet, run
  folder): <= 3 s; its peak resident memory (``ru_maxrss`` of the child, from ``os.wait4``): <= 1 GB;
* the trim's solve + Floquet with the graphs already built (second call in one process): <=
  2 x iterations x (one period map with its state Jacobian) -- the *floor*;
* ``birdocp level`` whole process: <= 4 s;
* ``birdocp sweep amplitude --from 40 --to 46 --step 0.5`` (13 warm-started trims) whole process: <= 10 s;
* the paper reproduction scripts (``experiment1.py --skip-studies``, ``experiment2.py``,
  ``experiment3.py`` when present), each once, into a temporary folder: <= 60 s in total;
* the default trim (IPOPT, exact derivatives) vs ``--solver lm --derivatives fd`` (the paper's
  method, same model) in one process with the graphs built: faster, and the ratio.

Also reported: per-iteration cost against the paper's quoted 40 s per LM iteration and the reference
implementation's ~200 s per iteration (quoted, not re-measured), and the machine load (other work on
the machine inflates every number).

    python scripts/benchmark.py [--repeats 3] [--out results/benchmark.json]
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAPER_S_PER_ITER = 40.0
REFERENCE_S_PER_ITER = 200.0
TARGETS = {"trim_process_s": 3.0, "level_process_s": 4.0, "sweep_process_s": 10.0,
           "reproduction_s": 60.0, "memory_trim_mb": 1024.0}


def run_child(argv: list[str]) -> tuple[float, float, int]:
    """(wall seconds, peak resident MB, exit code) of one child process."""
    t = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if proc.returncode not in (0,):
        print(f"  ! {' '.join(argv[1:])} exited {proc.returncode}: {err.strip()[-300:]}", file=sys.stderr)
    return wall, ru.ru_maxrss / 1024.0, proc.returncode


def median_child(argv_of, repeats: int) -> dict:
    walls, mems, codes = [], [], []
    for k in range(repeats):
        w, m, c = run_child(argv_of(k))
        walls.append(w)
        mems.append(m)
        codes.append(c)
    return {"median_s": float(np.median(walls)), "runs_s": walls, "max_rss_mb": float(max(mems)),
            "exit_codes": codes}


def median_call(fn, repeats: int) -> float:
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def in_process(repeats: int) -> dict:
    """Floor, trim with graphs built, and the default vs the paper's LM-fd (one process)."""
    import casadi as ca

    from birdocp.engine import shooting
    from birdocp.studies.trim import trim

    out: dict = {}
    t = time.perf_counter()
    r = trim()
    out["first_trim_in_process_s"] = time.perf_counter() - t
    b = next(iter(shooting._BUILDERS.values()))
    grid = b.grid
    D = grid.blocks_numeric(0.0, r.p)
    pd, x0 = ca.DM(r.p), ca.DM(r.x0)
    X = ca.DM(np.asarray(r.shooting_points)[:grid.S].T)
    grid.period_jacobian(x0, D, pd)  # build
    grid.segment_jacobians(X, D, pd)
    R = max(5, 3 * repeats)
    out["floor"] = {
        "period_map_s": median_call(lambda: grid.period_map(x0, D, pd), R),
        "period_map_with_state_jacobian_s": median_call(lambda: grid.period_jacobian(x0, D, pd), R),
        "segment_jacobians_mapped_s": median_call(lambda: grid.segment_jacobians(X, D, pd), R),
        "data_on_stage_grid_s": median_call(lambda: grid.data_grid(ca.DM(grid.times(0.0)), pd), 3),
    }
    floor = out["floor"]["period_map_with_state_jacobian_s"]

    def timed(**kw):
        rows = []
        for _ in range(repeats):
            grid._memo.clear()  # the data on the stage grid is recomputed, as in a new solve
            t = time.perf_counter()
            res = trim(**kw)
            w = time.perf_counter() - t
            rows.append((w, res))
        wall = float(np.median([w for w, _ in rows]))
        res = rows[-1][1]
        ws = res.wall_s
        return {"total_s": wall, "iterations": int(res.iterations), "success": bool(res.success),
                "solve_s": float(ws["solve"]), "floquet_s": float(ws["floquet"]), "data_s": float(ws["data"]),
                "build_s": float(ws["build"]),
                "largest_multiplier_modulus": float(np.max(np.abs(res.multipliers)))}

    default = timed()
    default["solve_plus_floquet_s"] = default["solve_s"] + default["floquet_s"]
    default["target_s"] = 2 * default["iterations"] * floor
    out["trim_graphs_built"] = default
    trim(solver="lm", derivatives="fd")  # build its graphs
    fd = timed(solver="lm", derivatives="fd")
    trim(solver="lm", derivatives="exact")
    lm = timed(solver="lm", derivatives="exact")
    out["lm_fd_graphs_built"] = fd
    out["lm_exact_graphs_built"] = lm
    out["lm_fd_over_default_total"] = fd["total_s"] / default["total_s"]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmark.json"))
    ap.add_argument("--skip-scripts", action="store_true", help="skip the reproduction-scripts row")
    args = ap.parse_args(argv)
    py = sys.executable
    cli = [py, "-m", "birdocp"]
    tmp = Path(tempfile.mkdtemp(prefix="birdocp-bench-"))
    rep = args.repeats
    res: dict = {"date": _dt.datetime.now().isoformat(timespec="seconds"), "cores": os.cpu_count(),
                 "machine": platform.processor() or platform.machine(), "python": platform.python_version(),
                 "load_average_before": list(os.getloadavg())}
    try:
        import casadi

        res["casadi"] = casadi.__version__
        print("trim, whole process ...", flush=True)
        res["trim_process"] = median_child(lambda k: cli + ["trim", "--out", str(tmp / f"trim{k}")], rep)
        print("level, whole process ...", flush=True)
        res["level_process"] = median_child(lambda k: cli + ["level", "--out", str(tmp / f"level{k}")], rep)
        print("sweep 40..46 step 0.5, whole process ...", flush=True)
        res["sweep_process"] = median_child(
            lambda k: cli + ["sweep", "amplitude", "--from", "40", "--to", "46", "--step", "0.5", "--quiet",
                             "--out", str(tmp / f"sweep{k}")], rep)
        print("in-process: floor, trim with graphs built, LM-fd ...", flush=True)
        code = ("import json,sys; sys.path.insert(0, %r); from benchmark import in_process; "
                "print(json.dumps(in_process(%d)))" % (str(ROOT / "scripts"), rep))
        p = subprocess.run([py, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
        res["in_process"] = json.loads(p.stdout.strip().splitlines()[-1])
        if not args.skip_scripts:
            scripts = {"experiment1.py": ["--skip-studies"], "experiment2.py": [], "experiment3.py": []}
            rows = {}
            for name, extra in scripts.items():
                path = ROOT / "scripts" / name
                if not path.exists():
                    rows[name] = None
                    continue
                print(f"{name} ...", flush=True)
                w, m, c = run_child([py, str(path), *extra, "--out", str(tmp / name.replace(".py", ""))])
                rows[name] = {"wall_s": w, "max_rss_mb": m, "exit_code": c, "args": extra}
            res["reproduction_scripts"] = rows
            res["reproduction_total_s"] = sum(v["wall_s"] for v in rows.values() if v)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res["load_average_after"] = list(os.getloadavg())

    ip = res["in_process"]
    tg = ip["trim_graphs_built"]
    iters = tg["iterations"]
    table = [
        ("birdocp trim, whole process, cold", res["trim_process"]["median_s"], "<= 3 s"),
        ("  its solve + Floquet, graphs built", tg["solve_plus_floquet_s"],
         f"<= 2 x {iters} x {ip['floor']['period_map_with_state_jacobian_s']:.3f} = {tg['target_s']:.3f} s"),
        ("birdocp level, whole process", res["level_process"]["median_s"], "<= 4 s"),
        ("amplitude sweep 40-46 deg, 13 warm points (process)", res["sweep_process"]["median_s"], "<= 10 s"),
    ]
    if "reproduction_total_s" in res:
        table.append(("paper reproduction (Exp. 1, 2, 3 scripts)", res["reproduction_total_s"], "<= 60 s"))
    table += [
        ("default trim, graphs built", tg["total_s"], ""),
        ("--solver lm --derivatives fd, graphs built", ip["lm_fd_graphs_built"]["total_s"],
         f"slower than default: x{ip['lm_fd_over_default_total']:.2f}"),
        ("memory of a trim (peak RSS, MB)", res["trim_process"]["max_rss_mb"], "<= 1024 MB"),
    ]
    met = {
        "trim_process": res["trim_process"]["median_s"] <= TARGETS["trim_process_s"],
        "solve_floquet_vs_floor": tg["solve_plus_floquet_s"] <= tg["target_s"],
        "level_process": res["level_process"]["median_s"] <= TARGETS["level_process_s"],
        "sweep_process": res["sweep_process"]["median_s"] <= TARGETS["sweep_process_s"],
        "default_faster_than_lm_fd": ip["lm_fd_over_default_total"] > 1.0,
        "memory_trim": res["trim_process"]["max_rss_mb"] <= TARGETS["memory_trim_mb"],
    }
    if "reproduction_total_s" in res:
        met["reproduction"] = res["reproduction_total_s"] <= TARGETS["reproduction_s"]
    per_iter = tg["solve_s"] / max(iters, 1)
    res["per_iteration_s"] = per_iter
    res["speedup_vs_paper_per_iteration"] = PAPER_S_PER_ITER / per_iter
    res["speedup_vs_reference_per_iteration"] = REFERENCE_S_PER_ITER / per_iter
    res["table"] = [{"measure": a, "value": b, "target": c} for a, b, c in table]
    res["targets_met"] = met

    print(f"\n{res['date']}, {res['cores']} cores, load {res['load_average_before'][0]:.2f} -> "
          f"{res['load_average_after'][0]:.2f}, casadi {res['casadi']}")
    for a, b, c in table:
        print(f"  {a:52s} {b:10.3f}   {c}")
    fl = ip["floor"]
    print(f"  floor: period map {fl['period_map_s'] * 1e3:.1f} ms, with its state Jacobian "
          f"{fl['period_map_with_state_jacobian_s'] * 1e3:.1f} ms (mapped segment Jacobians "
          f"{fl['segment_jacobians_mapped_s'] * 1e3:.1f} ms); data on the stage grid {fl['data_on_stage_grid_s'] * 1e3:.0f} ms")
    print(f"  per IPOPT iteration {per_iter * 1e3:.0f} ms: x{res['speedup_vs_paper_per_iteration']:.0f} vs the paper's "
          f"40 s, x{res['speedup_vs_reference_per_iteration']:.0f} vs the reference implementation's ~200 s (quoted)")
    if "reproduction_scripts" in res:
        for k, v in res["reproduction_scripts"].items():
            print(f"  {k}: " + ("absent" if v is None else f"{v['wall_s']:.1f} s (exit {v['exit_code']})"))
    print("  targets met: " + ", ".join(f"{k} {'yes' if v else 'NO'}" for k, v in met.items()))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
