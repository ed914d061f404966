"""Six degrees of freedom against the planar model, in one run: the wall time of a warm trim of the
paper's reference case (graphs built once, as in a sweep) with 4 and 6 degrees of freedom, and the
ratio (target: at most 4). With ``--sweep DIR`` also the Experiment 3 sweep with the lateral
multipliers (scripts/lateral_sweep.py, 2 processes; target: under 120 s), whose outputs are written
to DIR. ``--skip-trims`` keeps the trim measurements of an earlier benchmark_sixdof.json. Writes
benchmark_sixdof.json.

    python scripts/benchmark_sixdof.py --out results --repeats 5 --sweep results/lateral/sweep
"""
from __future__ import annotations

import json
import os
import statistics
import time

from birdocp.bird.config import Config
from birdocp.io.files import atomic_write_json
from birdocp.studies.lateral import lateral_trim
from birdocp.studies.trim import trim
from script_common import parse_with_out, script_parser


def timed(fn, repeats: int) -> tuple[float, list[float]]:
    """Median and all wall times [s] of ``repeats`` calls after one warm-up call."""
    fn()
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = fn()
        walls.append(time.perf_counter() - t0)
        assert res.success
    return statistics.median(walls), walls


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results")
    ap.add_argument("--repeats", type=int, default=5, help="timed calls of each (default %(default)s)")
    ap.add_argument("--sweep", metavar="DIR", help="also time the lateral margin sweep, writing its outputs to DIR")
    ap.add_argument("--skip-trims", action="store_true", help="keep the trim timings of the existing JSON")
    args, out = parse_with_out(ap, argv)
    cfg = Config()
    if args.skip_trims:
        res = json.loads((out / "benchmark_sixdof.json").read_text())
    else:
        t4, w4 = timed(lambda: trim(cfg), args.repeats)
        t6, w6 = timed(lambda: lateral_trim(cfg), args.repeats)
        res = {"trim_4dof_s": t4, "trim_6dof_s": t6, "ratio_6_to_4": t6 / t4, "target_ratio": 4.0,
               "walls_4dof_s": w4, "walls_6dof_s": w6, "repeats": args.repeats}
        print(f"warm trim, median of {args.repeats}: 4 DOF {t4:.3f} s, 6 DOF {t6:.3f} s, ratio {t6 / t4:.2f} "
              "(target <= 4)")
    if args.sweep:
        import lateral_sweep

        sw = lateral_sweep.main(["--out", args.sweep])
        rows = [r for fam in sw["families"].values() for r in fam]
        res["lateral_sweep"] = {"wall_s": sw["wall_s"], "target_s": 120.0, "jobs": sw["jobs"],
                                "points": len(rows), "converged": sum(bool(r["success"]) for r in rows),
                                "line_wall_s": sw["line_wall_s"], "load_average_1min": os.getloadavg()[0]}
        print(f"lateral margin sweep: {sw['wall_s']:.1f} s for {len(rows)} points (target < 120 s)")
    atomic_write_json(out / "benchmark_sixdof.json", res)


if __name__ == "__main__":
    main()
