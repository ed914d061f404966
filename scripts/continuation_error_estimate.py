"""Error estimates of continuation points (``ContinuationOptions(error_estimate=True)``,
``birdocp continue --error-estimate``): how well they track the true error, what they say on the
bird's branch, and what they cost. Numbers quoted in docs/studies/continuation.md.

1. A forced linear system whose multipliers are known exactly, x' = lam x - 2y + sin(2 pi t),
   y' = 2x + lam y (multipliers exp((lam +- 2i) T), T = 1): the estimate of every point of a branch
   lam = -0.5 .. 0.5 on coarse RK4 grids against the true error of its multipliers.
2. The bird (reference configuration, its default grid): the branch root_ahead_m 5 -> 4.8 cm with and
   without error estimates (largest estimates over the points, wall times, their ratio measured in
   this run), and the estimate at the first point against ``trim(cfg, error_estimate=True)`` (a
   full LM re-solve on 2N steps, the other path to the same number).

    python scripts/continuation_error_estimate.py [--out results/engine/continuation_error_estimate.json]
"""
from __future__ import annotations

import argparse
import time

import casadi as ca
import numpy as np

from birdocp.engine import OrbitProblem, ODE, iter_branch


def linear_case(steps: int) -> dict:
    x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
    f = ca.Function("ns", [x, t, p], [ca.vertcat(p[0] * x[0] - 2 * x[1] + ca.sin(2 * np.pi * t),
                                                 2 * x[0] + p[0] * x[1])])
    prob = OrbitProblem(ODE.from_rhs(f, 1.0, ("x", "y"), ("lam",)), [-0.5], [0.0, 0.0])
    rows = []
    for step in iter_branch(prob, "lam", -0.5, 0.5, points=3, steps_per_period=steps, error_estimate=True):
        if step.point is None:
            continue
        true = float(np.min(np.abs(step.spectrum - np.exp(step.parameter + 2j))))
        rows.append({"lam": step.parameter, "true_error": true, "estimate": step.error_estimate["multipliers"],
                     "ratio": step.error_estimate["multipliers"] / true})
    return {"steps_per_period": steps, "points": rows,
            "ratio_range": [min(r["ratio"] for r in rows), max(r["ratio"] for r in rows)]}


def bird_case() -> dict:
    from birdocp import Config, trim
    from birdocp.studies.branch import bird_branch

    cfg = Config()
    out = {}
    for flag in (False, True):
        t0 = time.perf_counter()
        br = bird_branch(cfg, "root_ahead_m", 0.05, 0.048, error_estimate=flag)
        out["with" if flag else "without"] = {"wall_s": time.perf_counter() - t0, "points": len(br.points),
                                              "end_reason": br.end_reason}
        if flag:
            ests = [p.error_estimate for p in br.points]
            out["largest"] = {k: max(e[k] for e in ests) for k in ("multipliers", "multipliers_relative", "x0",
                                                                    "solver")}
            out["first_point"] = ests[0]
    out["wall_ratio"] = out["with"]["wall_s"] / out["without"]["wall_s"]
    tr = trim(cfg, error_estimate=True).cycle.error_estimate
    out["trim"] = {k: tr[k] for k in ("multipliers", "x0", "solver")}
    out["first_point_vs_trim"] = {k: abs(out["first_point"][k] - tr[k]) / tr[k] for k in ("multipliers", "x0")}
    out["steps_per_period"], out["shooting_points"] = cfg.solve.steps_per_period, cfg.solve.points
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", help="write the numbers to this JSON file")
    args = ap.parse_args()
    res = {"linear": [linear_case(n) for n in (20, 40)], "bird": bird_case()}
    for case in res["linear"]:
        lo, hi = case["ratio_range"]
        print(f"linear system, {case['steps_per_period']} RK4 steps: estimate / true error of the multipliers "
              f"{lo:.4f} .. {hi:.4f} over {len(case['points'])} points")
    b = res["bird"]
    print(f"bird branch root 5 -> 4.8 cm ({b['with']['points']} points, {b['shooting_points']} shooting points, "
          f"{b['steps_per_period']} steps): largest estimates multipliers {b['largest']['multipliers']:.2e}, "
          f"x0 {b['largest']['x0']:.2e}, solver {b['largest']['solver']:.1e}")
    print(f"  wall time with / without estimates {b['with']['wall_s']:.1f} / {b['without']['wall_s']:.1f} s "
          f"(ratio {b['wall_ratio']:.2f})")
    print(f"  first point against trim(error_estimate=True): multipliers {b['first_point_vs_trim']['multipliers']:.1e}"
          f", x0 {b['first_point_vs_trim']['x0']:.1e} relative")
    if args.out:
        from birdocp.io.files import atomic_write_json

        atomic_write_json(args.out, res)


if __name__ == "__main__":
    main()
