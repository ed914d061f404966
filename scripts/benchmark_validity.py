"""Issue 26 speed targets, measured in one run as ratios against today's code paths:

* the stability-power Pareto front at the reference speed: today's sequential tracing
  (:func:`birdocp.studies.gait_fronts.stability_pareto` without an executor, each point from the previous
  one, IPOPT's default start) against the same bounds solved through the process executor in one
  chain per worker, each traced from its nearest known end with warm IPOPT starts (``executor=``;
  :mod:`birdocp.studies.pareto`; target <= 120 s for 12 points on 2 cores), and the same front over
  valid cycles (``valid=True``); besides the wall times, each point's own CPU seconds (independent
  of the machine's load) and IPOPT iterations;
* ``optimize_stability`` (reduced space, defaults) against ``optimize_stability(valid=True)``
  (target <= 60 s).

The bounds, the start (energy optimum) and the anchor (most stable gait) are the committed ones of
results/energetics/result.json (so both tracings solve the same points). The machine load at the
start of each part is recorded: other work on the shared machine inflates every number.

    python scripts/benchmark_validity.py [--points 12] [--jobs 2] [--out DIR] [--skip-sequential] [--skip-valid] [--skip-pareto]
"""

import argparse
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
AMP = "gait.shoulder_flap.amplitude_deg"


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def timed(fn):
    load = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, {"wall_s": time.perf_counter() - t0, "cpu_s_main_process": time.process_time() - c0,
                 "load_1min_at_start": load}


def _points(rows) -> dict:
    """Per-point counts of a tracing: converged points, IPOPT iterations and each point's own CPU
    seconds (its process's: independent of the other work on the machine, unlike the wall times)."""
    cpu = [r["wall_s"].get("cpu_total") for r in rows]
    return {"converged": sum(r["success"] for r in rows), "iterations": [r["iterations"] for r in rows],
            "cpu_s_points": cpu, "cpu_s_points_sum": sum(c for c in cpu if c is not None)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=12, help="the first N of the committed Pareto bounds")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "results" / "stability_optimum"))
    ap.add_argument("--skip-sequential", action="store_true")
    ap.add_argument("--skip-valid", action="store_true",
                    help="no valid front (scripts/energetics_valid_study.py times its own, with its own bounds)")
    ap.add_argument("--skip-stability", action="store_true")
    ap.add_argument("--skip-pareto", action="store_true",
                    help="only the optimize_stability pair; the Pareto entries already in OUT/benchmark_validity.json "
                         "are kept")
    args = ap.parse_args()
    from birdocp.bird.config import Config
    from birdocp.engine.executors import get_executor
    from birdocp.studies.gait_fronts import stability_pareto
    from birdocp.studies.optimize import optimize_stability

    committed = json.loads((ROOT / "results" / "energetics" / "result.json").read_text())
    b, s = committed["optimal_gait"], committed["most_stable_gait"]
    U = committed["paper_gait_level"]["mean_forward_speed_mps"]
    bounds = [q["bound"] for q in committed["pareto"] if isinstance(q["bound"], float) and not q.get("inserted")]
    bounds = bounds[:args.points]
    committed_P = [q["objective_value"] for q in committed["pareto"] if q["bound"] in bounds]
    start = dict(b["free"]) | {AMP: b["amplitude_deg"]}
    anchor = {"bound": s["objective_value"], "free": s["free"], "amplitude_deg": s["amplitude_deg"], "x0": s["x0"]}
    cfg = Config()
    res = {"points": len(bounds), "jobs": args.jobs, "cpu_count": os.cpu_count(), "bounds": bounds}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "benchmark_validity.json"
    if args.skip_pareto and path.is_file():  # keep the Pareto measurements of an earlier run
        res |= {k: v for k, v in json.loads(path.read_text()).items() if k.startswith("pareto") or k in (
            "points", "jobs", "bounds", "ratio_parallel_over_sequential", "ratio_parallel_valid_over_sequential",
            "max_objective_difference_W", "max_objective_difference_to_committed_W", "uptime")}
    if args.skip_stability and path.is_file():  # keep the optimize_stability measurements of an earlier run
        res |= {k: v for k, v in json.loads(path.read_text()).items() if k.startswith("optimize_stability")
                or k == "ratio_valid_over_today"}
    res["uptime"] = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip() if shutil.which(
        "uptime") else None

    def save():
        from birdocp.io.files import atomic_write_json

        atomic_write_json(path, res)

    if not args.skip_stability:
        log("optimize_stability (today: no validity constraints)")
        so, t = timed(lambda: optimize_stability(cfg))
        res["optimize_stability"] = t | {"radius": so.radius, "valid": so.validity["valid"], "iterations": so.iterations}
        log(f"  {t['wall_s']:.1f} s, r {so.radius:.6f}")
        log("optimize_stability(valid=True)")
        sv, t = timed(lambda: optimize_stability(cfg, valid=True))
        res["optimize_stability_valid"] = t | {"radius": sv.radius, "valid": sv.validity["valid"],
                                               "iterations": sv.iterations, "rounds": len(sv.validity_rounds or [])}
        res["ratio_valid_over_today"] = res["optimize_stability_valid"]["wall_s"] / res["optimize_stability"]["wall_s"]
        log(f"  {t['wall_s']:.1f} s, r {sv.radius:.6f}, valid {sv.validity['valid']}")
        save()
    if args.skip_pareto:
        print(json.dumps({k: v for k, v in res.items() if k != "bounds"}, indent=1))
        return
    if not args.skip_sequential:
        log(f"Pareto, today's sequential tracing: {len(bounds)} points")
        rows, t = timed(lambda: stability_pareto(cfg, U, bounds, start=start, x_guess=b["x0"], progress=log))
        res["pareto_sequential"] = t | _points(rows) | {
            "objective_values": [r["objective_value"] for r in rows if not r["inserted"]]}
        save()
    with get_executor(jobs=args.jobs) as ex:
        ex.start()
        log(f"Pareto in parallel chains ({args.jobs} processes, warm IPOPT starts)")
        rows, t = timed(lambda: stability_pareto(cfg, U, bounds, start=start, x_guess=b["x0"], executor=ex,
                                                 anchors=[anchor], start_bound=b["largest_modulus"], progress=log))
        res["pareto_parallel"] = t | _points(rows) | {"objective_values": [r["objective_value"] for r in rows],
                                                      "started_from": [r["started_from"] for r in rows]}
        res["max_objective_difference_to_committed_W"] = max(  # results/energetics/result.json
            abs(r["objective_value"] - c) for r, c in zip(rows, committed_P))
        save()
        if not args.skip_valid:
            log("the same front over valid cycles (valid=True), parallel")
            rows, t = timed(lambda: stability_pareto(cfg, U, bounds, start=start, x_guess=b["x0"], executor=ex,
                                                     anchors=[anchor], start_bound=b["largest_modulus"],
                                                     progress=log, valid=True))
            res["pareto_parallel_valid"] = t | {"converged": sum(r["success"] for r in rows),
                                                "valid": sum(bool(r.get("valid")) for r in rows)}
        else:
            for k in ("pareto_parallel_valid", "ratio_parallel_valid_over_sequential"):
                res.pop(k, None)
    if "pareto_sequential" in res:
        seq = res["pareto_sequential"]["wall_s"]
        res["ratio_parallel_over_sequential"] = res["pareto_parallel"]["wall_s"] / seq
        if "pareto_parallel_valid" in res:
            res["ratio_parallel_valid_over_sequential"] = res["pareto_parallel_valid"]["wall_s"] / seq
        a = [v for v in res["pareto_sequential"]["objective_values"]]
        c = res["pareto_parallel"]["objective_values"]
        if len(a) == len(c):
            res["max_objective_difference_W"] = max(abs(x - y) for x, y in zip(a, c))
    save()
    print(json.dumps({k: v for k, v in res.items() if k != "bounds"}, indent=1))


if __name__ == "__main__":
    main()
