"""The most stable level-flight gait *where the model holds*: optimize-stability with every limit of
``[validity]`` as a smooth constraint (``valid=True``), with the speed free and at 18.53 m/s, and a
multi-start over the gait bounds. Writes ``OUT/result.json``, ``OUT/table.md`` and ``OUT/optimum.png``
(default OUT: results/stability_optimum/valid).

* free speed: :func:`birdocp.studies.optimize.optimize_stability` (reduced space, default keys and
  bounds, coarse 32-step stage then 148 steps), ``valid=True``: r*, KKT residual, active limits;
* 18.53 m/s: :func:`birdocp.studies.gait.optimize_gait` (``objective="stability"``, the default gait
  keys and bounds, the speed held), ``valid=True``;
* multi-start at that speed: ``--starts`` (default 16) gaits from a Latin hypercube over the default
  gait bounds (seeded), each solved by ``optimize_gait(objective="stability", valid=True)`` on a
  ``--ms-steps`` grid (default 16: cheap, a coarse grid), ``--jobs`` at a time through the process
  executor: best r, spread, how many converged with a valid cycle (the evidence behind "r* > 1").

    python scripts/stability_valid_study.py [--out DIR] [--jobs 2] [--starts 16] [--skip-multistart]
"""

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from birdocp.bird.config import Config, with_values  # noqa: E402
from birdocp.io.files import atomic_write_json, atomic_write_text  # noqa: E402

AMP = "gait.shoulder_flap.amplitude_deg"
ROOT = Path(__file__).resolve().parents[1]


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def summary(d: dict) -> dict:
    keys = ("success", "status", "message", "iterations", "radius", "objective_value", "moduli", "multipliers",
            "free", "bounds", "amplitude_deg", "x0", "kkt_residual", "constraint_violation", "wall_s", "validity",
            "validity_constraints", "validity_rounds", "active_bounds", "mean_forward_speed_mps", "verification")
    return {k: d[k] for k in keys if k in d}


def active_limits(d: dict) -> list:
    return [k for k, c in (d.get("validity_constraints") or {}).items() if c.get("active")]


def latin_hypercube(bounds: dict, n: int, seed: int = 26) -> list[dict]:
    """n points, one per stratum of every coordinate (random permutation per coordinate, seeded)."""
    rng = np.random.default_rng(seed)
    keys = list(bounds)
    u = np.stack([(rng.permutation(n) + rng.uniform(size=n)) / n for _ in keys], axis=1)
    return [{k: float(bounds[k][0] + u[i, j] * (bounds[k][1] - bounds[k][0])) for j, k in enumerate(keys)}
            for i in range(n)]


def multistart_job(job: dict) -> dict:
    from birdocp.studies.gait import optimize_gait

    t0 = time.perf_counter()
    cfg = with_values(Config(), job["start"] | {"solve.steps_per_period": job["steps"]})
    try:
        g = optimize_gait(cfg, job["free"], objective="stability", speed_mps=job["speed"], valid=True, verify=False,
                          max_iter=job["max_iter"])
        d = g.to_dict()
    except Exception as e:  # a start without a level cycle: recorded, not fatal
        return {"start": job["start"], "success": False, "status": f"error: {e}"[:300],
                "wall_s": time.perf_counter() - t0}
    return {"start": job["start"], "success": d["success"], "status": d["status"], "radius": d["objective_value"],
            "largest_modulus": d["largest_modulus"], "free": d["free"], "amplitude_deg": d["amplitude_deg"],
            "kkt_residual": d["kkt_residual"], "valid": bool((d.get("validity") or {}).get("valid")),
            "iterations": d["iterations"], "active_limits": active_limits(d), "wall_s": time.perf_counter() - t0}


def multistart(n: int, jobs: int, steps: int, max_iter: int, speed: float) -> dict:
    """The most stable valid gait at ``speed`` from ``n`` Latin-hypercube starts over the default gait
    bounds (optimize_gait, objective stability, valid=True), ``jobs`` processes."""
    from birdocp.engine.executors import get_executor
    from birdocp.studies.gait import DEFAULT_GAIT_FREE

    starts = latin_hypercube(DEFAULT_GAIT_FREE, n)
    t0 = time.perf_counter()
    items = [{"start": s, "free": DEFAULT_GAIT_FREE, "steps": steps, "max_iter": max_iter, "speed": speed}
             for s in starts]
    with get_executor(jobs=jobs if jobs > 1 else None) as ex:
        rows = ex.map(multistart_job, items,
                      on_result=lambda i, r: log(f"  start {i}: {r['status']}, r {r.get('radius')}, valid "
                                                 f"{r.get('valid')}, {r['wall_s']:.0f} s"))
    ok = [r for r in rows if r["success"] and r.get("valid")]
    rs = np.array([r["radius"] for r in ok]) if ok else np.array([])
    return {"problem": f"most stable valid gait at {speed} m/s (optimize_gait, objective stability, valid=True)",
            "design": "Latin hypercube over the default gait bounds (seed 26)", "starts": n, "steps_per_period": steps,
            "max_iter": max_iter, "jobs": jobs, "wall_s": time.perf_counter() - t0, "rows": rows,
            "converged_valid": len(ok), "best_radius": float(rs.min()) if len(rs) else None,
            "radius_spread": [float(rs.min()), float(np.median(rs)), float(rs.max())] if len(rs) else None,
            "within_1e-3_of_best": int(np.sum(rs <= rs.min() + 1e-3)) if len(rs) else 0,
            "any_below_1": bool(len(rs) and rs.min() < 1.0)}


def figure(d: dict, path: Path, title: str) -> None:
    lam = np.array([complex(*z) for z in d["multipliers"]])
    fig, ax = plt.subplots(figsize=(6.2, 6.2))
    th = np.linspace(0, 2 * np.pi, 600)
    ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8, label="unit circle")
    r = d.get("radius", d.get("objective_value"))
    ax.plot(r * np.cos(th), r * np.sin(th), "--", color="C1", lw=1, label=f"optimal radius r* = {r:.5f}")
    valid = bool((d.get("validity") or {}).get("valid"))
    ax.plot(lam.real, lam.imag, "x" if valid else "o", ms=9, mew=2, color="C3" if valid else "0.5",
            mfc="none", label="optimum" + ("" if valid else " (model NOT valid)"))
    ax.set_aspect("equal")
    ax.set(xlabel="Re Λ", ylabel="Im Λ")
    stable = max(abs(lam)) < 1
    verdict = ("stable" if stable else "unstable") if valid else "model NOT valid (neither stable nor unstable flight)"
    ax.set_title(f"{title}\n{verdict}: largest |Λ| {max(abs(lam)):.5f}; active limits: "
                 f"{', '.join(active_limits(d)) or 'none'}", fontsize=9)
    ax.legend(loc="lower left", fontsize=8)
    fig.savefig(path.with_suffix(".tmp.png"), dpi=120, bbox_inches="tight")
    plt.close(fig)
    path.with_suffix(".tmp.png").replace(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "stability_optimum" / "valid"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--starts", type=int, default=16)
    ap.add_argument("--ms-steps", type=int, default=16)
    ap.add_argument("--ms-max-iter", type=int, default=60)
    ap.add_argument("--free-speed-from", default=None, metavar="JSON",
                    help="take the speed-free optimum from this optimize_stability(valid=True).to_dict() JSON "
                         "(e.g. a run of 'birdocp optimize-stability --valid --json') instead of solving it again")
    ap.add_argument("--speed", type=float, default=18.53)
    ap.add_argument("--skip-multistart", action="store_true")
    ap.add_argument("--only-multistart", action="store_true", help="reuse OUT/result.json's optima")
    ap.add_argument("--retable", action="store_true",
                    help="solve nothing: re-judge the stored optima's active bounds "
                         "(birdocp.engine.oracle.active_bounds) and rewrite OUT/result.json, table.md and figures")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from birdocp.studies.gait import optimize_gait
    from birdocp.studies.optimize import optimize_stability

    reuse = args.only_multistart or args.retable
    res = json.loads((out / "result.json").read_text()) if reuse else {}
    if args.retable:
        from birdocp.engine.oracle import active_bounds

        for key in ("free_speed", "at_speed"):
            if res.get(key):
                res[key]["active_bounds"] = active_bounds(res[key]["free"], res[key]["bounds"])
    if not reuse:
        if args.free_speed_from:
            d = json.loads(Path(args.free_speed_from).read_text())
            res["free_speed"] = summary(d) | {"script_wall_s": d["wall_s"]["total"], "source": args.free_speed_from}
        else:
            log("optimize-stability --valid, speed free")
            t0 = time.perf_counter()
            so = optimize_stability(Config(), valid=True, progress=False)
            res["free_speed"] = summary(so.to_dict()) | {"script_wall_s": time.perf_counter() - t0}
        fs = res["free_speed"]
        log(f"  r* {fs['radius']:.6f}, KKT {fs['kkt_residual']:.1e}, valid {fs['validity']['valid']}, "
            f"active {active_limits(fs)}")
        atomic_write_json(out / "result.json", res)
        log(f"most stable valid gait at {args.speed} m/s")
        t0 = time.perf_counter()
        g = optimize_gait(Config(), objective="stability", speed_mps=args.speed, valid=True, max_iter=80)
        d = g.to_dict()
        res["at_speed"] = summary(d) | {"radius": d["objective_value"], "speed_mps": args.speed,
                                         "script_wall_s": time.perf_counter() - t0}
        log(f"  r* {g.objective_value:.6f}, KKT {g.kkt_residual:.1e}, valid {g.validity['valid']}, {g.status}")
        atomic_write_json(out / "result.json", res)
    if not (args.skip_multistart or args.retable):
        log(f"multi-start: {args.starts} starts, {args.ms_steps} steps, {args.jobs} jobs")
        res["multistart"] = multistart(args.starts, args.jobs, args.ms_steps, args.ms_max_iter, args.speed)
        atomic_write_json(out / "result.json", res)
    atomic_write_json(out / "result.json", res)
    atomic_write_text(out / "table.md", table(res))
    figure(res["free_speed"], out / "optimum.png", "Most stable level flight where the model holds (speed free)")
    figure(res["at_speed"], out / "optimum_at_speed.png",
           f"Most stable level flight where the model holds at {args.speed} m/s")
    print((out / "table.md").read_text())


def table(res: dict) -> str:
    lines = ["# The most stable level-flight gait where the model holds (scripts/stability_valid_study.py)", "",
             "Every limit of `[validity]` is a smooth constraint (stalled span-time share, minimum forward speed, "
             "|pitch|, airflow-to-body angle); the exact verdict of the optimum is checked.", "",
             "| problem | r* | largest modulus | stable | valid | KKT | active limits | active bounds | wall [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, key in (("speed free", "free_speed"), (f"at {res.get('at_speed', {}).get('speed_mps', '')} m/s", "at_speed")):
        d = res.get(key)
        if not d:
            continue
        lm = max(d["moduli"])
        valid = d["validity"]["valid"]
        lines.append(f"| {name} | {d['radius']:.6f} | {lm:.6f} | {'yes' if lm < 1 else 'no'} | "
                     f"{'yes' if valid else 'NO'} | {d['kkt_residual']:.1e} | {', '.join(active_limits(d)) or 'none'} | "
                     f"{', '.join(d.get('active_bounds') or []) or 'none'} | {d['script_wall_s']:.0f} |")
    for key in ("free_speed", "at_speed"):
        d = res.get(key)
        if d:
            lines += ["", f"{key}: free values " + ", ".join(f"{k} {v:.4f}" for k, v in d["free"].items())
                      + f"; amplitude {d['amplitude_deg']:.4f} deg; validity: "
                      + ("valid" if d["validity"]["valid"] else "NOT valid: " + "; ".join(d["validity"]["reasons"]))]
    ms = res.get("multistart")
    if ms:
        lines += ["", f"Multi-start, {ms['problem']} ({ms['design']}, {ms['starts']} starts on {ms['steps_per_period']} steps per "
                  f"period, {ms['jobs']} processes, {ms['wall_s']:.0f} s): {ms['converged_valid']} converged to a "
                  f"valid optimum; best r {ms['best_radius']}; r min/median/max {ms['radius_spread']}; "
                  f"{ms['within_1e-3_of_best']} within 1e-3 of the best."]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
