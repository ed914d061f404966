"""Energetics of the ibis model: the power curve, the energy-optimal gait and what stability costs.

Writes results/energetics/ (JSON, summary.md, figures):

* the paper's gait in level flight (amplitude solved): power over the wingbeat and its outputs;
* the power curve of the paper's gait: level flight from 13 to 24 m/s (speed held by the shoulder
  incidence offset, level flight by the flapping amplitude), minimum-power and maximum-range speeds,
  the largest multiplier along it;
* the energy-optimal gait at the reference speed (the paper's gait's level-flight speed), free keys
  :data:`birdocp.studies.gait.DEFAULT_GAIT_FREE`;
* the most stable gait at that speed, and the Pareto front of minimum power against the bound R on
  the largest multiplier, from the unconstrained optimum down to the most stable gait.

    python scripts/energetics_study.py            # ~15-25 min on 2 shared cores
    python scripts/energetics_study.py --out /tmp/energetics   # elsewhere (default results/energetics)
    python scripts/energetics_study.py --only optimize-stability   # that part alone (~40 s), into the
                                                  # committed result.json and summary.md
    python scripts/energetics_study.py --only power-curve   # the power curve alone (every row with its
                                                  # validity; optima over valid rows): power_curve.json/png
"""

import json
import os
import re
import time
from pathlib import Path

import numpy as np

from birdocp.bird.config import Config
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.plots.energetics import plot_pareto, plot_power, plot_power_curve
from birdocp.studies.gait import optimize_gait, power_curve
from birdocp.studies.gait_fronts import stability_pareto
from birdocp.studies.level import level
from script_common import parse_with_out, script_parser

OUT = Path(__file__).resolve().parents[1] / "results" / "energetics"


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def summary_row(opt):
    d = opt.to_dict()
    v = d["verification"]
    return {k: d[k] for k in ("success", "status", "objective", "iterations", "objective_value", "x0",
                              "start_objective_value", "free", "amplitude_deg", "largest_modulus", "moduli",
                              "mean_forward_speed_mps", "max_multiplier", "kkt_residual", "constraint_violation",
                              "wall_s", "evaluations")} | {
        "verification": {k: v.get(k) for k in ("trim_success", "power_difference_W", "max_multiplier_difference",
                                                "trim_mean_positive_power_W", "trim_cost_of_transport",
                                                "trim_strouhal_number")}}


def main():
    global OUT
    ap = script_parser(__doc__, "results/energetics")
    ap.add_argument("--pareto-points", type=int, default=12,
                    help="bounds R evenly spaced from the energy optimum's largest modulus to the most stable one")
    ap.add_argument("--pareto-bounds", type=float, nargs="*", default=None, metavar="R",
                    help="explicit bounds R of the Pareto points (default: evenly spaced, --pareto-points)")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse power_curve.json and optimal_gait.json of an earlier run (same code)")
    ap.add_argument("--only", choices=("optimize-stability", "power-curve"), default=None,
                    help="run only this part and update its entry of the committed result.json and summary.md")
    ap.add_argument("--threads", type=int, default=2,
                    help="optimize-stability's threads for the finite-difference Hessian (default 2)")
    args, OUT = parse_with_out(ap)  # --out: every writer below uses OUT
    cfg = Config()
    if args.only is not None:
        out = json.loads((OUT / "result.json").read_text())
        if args.only == "optimize-stability":
            out["optimize_stability"] = optimize_stability_part(cfg, args.threads)
        else:
            out["power_curve"] = power_curve_part(cfg)
        atomic_write_json(OUT / "result.json", out)
        atomic_write_text(OUT / "summary.md", summary_md(out))
        return
    t_all = time.perf_counter()
    out = {}

    # 1. the paper's gait in level flight
    lv = level(cfg)
    e = lv.energetics
    plot_power(lv.arrays(), OUT / "power_paper_gait.png",
               title=f"Paper's gait in level flight (A = {lv.amplitude_deg:.2f} deg, U = "
                     f"{lv.mean_forward_speed_mps:.2f} m/s)")
    U_ref = float(lv.mean_forward_speed_mps)
    out["paper_gait_level"] = {"amplitude_deg": lv.amplitude_deg, "mean_forward_speed_mps": U_ref,
                               "multipliers": [[float(z.real), float(z.imag)] for z in lv.multipliers],
                               **lv.energetics_dict()}
    log(f"paper's gait, level: U {U_ref:.4f} m/s, P {e['mean_shoulder_power_W']:.4f} W")

    # 2. the power curve
    t0 = time.perf_counter()
    if args.reuse and (OUT / "power_curve.json").is_file():
        pc = json.loads((OUT / "power_curve.json").read_text())
        plot_power_curve(pc["rows"], OUT / "power_curve.png",
                         title="Power curve of the paper's gait (speed held by the incidence offset, "
                               "level flight by the amplitude)")
    else:
        pc = power_curve_part(cfg)
    out["power_curve"] = pc

    # 3. the energy-optimal gait at the reference speed, and the most stable one
    log(f"energy-optimal gait at {U_ref:.4f} m/s")
    from birdocp.bird.config import with_values
    from birdocp.studies.trim import trim

    if args.reuse and (OUT / "optimal_gait.json").is_file():
        b = json.loads((OUT / "optimal_gait.json").read_text())
    else:
        best = optimize_gait(cfg, objective="power", speed_mps=U_ref)
        b = summary_row(best)
        atomic_write_json(OUT / "optimal_gait.json", b)
    out["optimal_gait"] = b
    log(f"  P {b['objective_value']:.4f} W (start {b['start_objective_value']:.4f} W), |L1| "
        f"{b['largest_modulus']:.5f}, {b['iterations']} iterations, {b['wall_s']['total']:.1f} s")
    tr = trim(with_values(cfg, b["free"] | {"gait.shoulder_flap.amplitude_deg": b["amplitude_deg"]}), x_guess=b["x0"])
    assert tr.success and abs(tr.energetics["mean_shoulder_power_W"] - b["objective_value"]) < 1e-6
    plot_power(tr.arrays() | {f"power_{k}": v for k, v in tr.energetics["samples"].items()},
               OUT / "power_optimal_gait.png",
               title=f"Energy-optimal gait at {U_ref:.2f} m/s (A = {b['amplitude_deg']:.2f} deg)")
    log("most stable gait at the same speed")
    if args.reuse and (OUT / "most_stable_gait.json").is_file():
        s = json.loads((OUT / "most_stable_gait.json").read_text())
    else:
        stab = optimize_gait(cfg, objective="stability", speed_mps=U_ref, max_iter=60)
        s = summary_row(stab) | {"mean_shoulder_power_W": stab.means.get("flapping_power_W")}
        atomic_write_json(OUT / "most_stable_gait.json", s)
    out["most_stable_gait"] = s
    P_stab = s["mean_shoulder_power_W"]
    log(f"  radius {s['objective_value']:.5f}, P {P_stab:.4f} W, {s['iterations']} iterations, {s['status']}")

    # 4. the Pareto front: minimum power with every multiplier inside radius R, traced from the energy
    # optimum down to the most stable gait, each point started from the previous optimum (a failed
    # step is retried from halfway)
    # the tightest bound: just above the most stable gait's r (its objective, the smallest r with the
    # Jury conditions >= their margin: r exceeds that gait's largest modulus by ~2e-4, so a bound
    # between the two is infeasible)
    R_hi, R_lo = b["largest_modulus"], s["largest_modulus"]
    R_min = s["objective_value"]
    start = dict(b["free"]) | {"gait.shoulder_flap.amplitude_deg": b["amplitude_deg"]}
    bounds = args.pareto_bounds if args.pareto_bounds is not None else [
        float(R_min + 2e-3 * (R_hi - R_min)) if R == R_min else float(R)
        for R in np.linspace(R_hi, R_min, args.pareto_points + 1)[1:]]
    t0 = time.perf_counter()
    traced = stability_pareto(cfg, U_ref, bounds, start=start, x_guess=tr.x0, progress=log)
    pareto = [{"bound": None, "objective_value": b["objective_value"], "largest_modulus": R_hi,
               "success": b["success"], "status": b["status"], "free": b["free"], "amplitude_deg": b["amplitude_deg"],
               "iterations": b["iterations"], "kkt_residual": b["kkt_residual"], "wall_s": b["wall_s"]}]
    pareto += traced
    pareto.append({"bound": "most stable", "objective_value": P_stab, "largest_modulus": R_lo,
                   "success": s["success"], "status": s["status"], "free": s["free"], "amplitude_deg": s["amplitude_deg"],
                   "iterations": s["iterations"], "kkt_residual": s["kkt_residual"], "wall_s": s["wall_s"]})
    out["pareto"] = pareto
    out["pareto_wall_s"] = time.perf_counter() - t0
    front = [q for q in pareto if q["success"]]
    Ps = [q["objective_value"] for q in sorted(front, key=lambda q: q["largest_modulus"])]
    out["pareto_monotone"] = bool(all(x >= y - 1e-9 for x, y in zip(Ps, Ps[1:])))  # power falls as R loosens
    out["pareto_failed_bounds"] = [q["bound"] for q in traced if not q["success"]]
    plot_pareto(pareto, OUT / "pareto.png",
                title=f"Minimum mean power of level flight at {U_ref:.2f} m/s against the stability bound")

    # 5. optimize-stability on the reference problem
    out["optimize_stability"] = optimize_stability_part(cfg, args.threads)
    out["wall_s"] = time.perf_counter() - t_all
    atomic_write_json(OUT / "result.json", out)
    atomic_write_text(OUT / "summary.md", summary_md(out))
    log(f"done in {out['wall_s']:.0f} s")


def optimize_stability_part(cfg, threads):
    """optimize-stability on the reference problem (free speed, its default keys and bounds), reduced
    space, against the result committed in results/stability_optimum (its method recorded with it)."""
    log(f"optimize-stability (reduced space) on the reference problem, {threads} threads")
    from birdocp.studies.optimize import optimize_stability

    load = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    so = optimize_stability(cfg, threads=threads)
    d = so.to_dict()
    full_path = OUT.parent / "stability_optimum" / "result.json"
    full = json.loads(full_path.read_text()) if full_path.is_file() else {}
    part = {
        "reduced": {k: d[k] for k in ("success", "status", "message", "iterations", "radius", "moduli", "free",
                                      "amplitude_deg", "kkt_residual", "wall_s", "evaluations", "method")}
        | {"wall_s_total": time.perf_counter() - t0, "cpu_s_total": time.process_time() - c0,
           "threads": threads, "load_average_1min_at_start": load,
           "verification": {k: d["verification"].get(k) for k in (
               "trim_success", "max_multiplier_difference", "trim_x0_difference", "radius_minus_spectral_radius",
               "scratch_trim_success", "scratch_finds_another_cycle")}},
        "committed_optimum": {k: full.get(k) for k in ("method", "coarse_steps", "iterations", "radius", "moduli", "free",
                                                      "amplitude_deg")}
        | {"wall_s_total": (full.get("wall_s") or {}).get("total"), "source": "results/stability_optimum/result.json"},
    }
    log(f"  r {so.radius:.6f}, {so.iterations} iterations, {so.wall_s['total']:.1f} s, KKT {so.kkt_residual:.1e}")
    return part


def _yes(valid) -> str:
    return "unknown" if valid is None else ("yes" if valid else "NO")


def _vertex_text(v) -> str:
    """A minimum of the power curve (:func:`birdocp.studies.power_curves.curve_optima`) in words."""
    if not v or v.get("speed_mps") is None:
        return "none (fewer than three rows)"
    where = "interior" if v["interior"] else "at an END of the rows: no interior minimum"
    return f"{v['speed_mps']:.3f} m/s ({v.get('power_W', float('nan')):.3f} W; {where})"


def power_curve_part(cfg) -> dict:
    """The power curve of the paper's gait (every row with its validity), written with its figure."""
    t0 = time.perf_counter()
    pc = power_curve(cfg, np.arange(9.0, 24.01, 1.0), bounds=(-10.0, 45.0), progress=True)
    pc["wall_s"] = time.perf_counter() - t0
    plot_power_curve(pc["rows"], OUT / "power_curve.png",
                     title="Power curve of the paper's gait (speed held by the incidence offset, "
                           "level flight by the amplitude)")
    atomic_write_json(OUT / "power_curve.json", pc)
    return pc


def summary_md(out):
    pg = out["paper_gait_level"]
    pc = out["power_curve"]
    b, s = out["optimal_gait"], out["most_stable_gait"]  # noqa: F841
    lines = ["# Energetics of the ibis model (scripts/energetics_study.py)", "",
             "## The paper's gait in level flight", "",
             f"amplitude {pg['amplitude_deg']:.3f} deg, U = {pg['mean_forward_speed_mps']:.3f} m/s: "
             f"aerodynamic power {pg['mean_aerodynamic_power_W']:.3f} W, positive-work power "
             f"{pg['mean_positive_power_W']:.3f} W, cost of transport {pg['cost_of_transport']:.4f}, "
             f"Strouhal {pg['strouhal_number']:.3f}, reduced frequency {pg['reduced_frequency']:.3f}", "",
             "## Power curve (speed held by the incidence offset, level flight by the amplitude)", "",
             "| U [m/s] | incidence offset [deg] | amplitude [deg] | P [W] | P+ [W] | COT | St | largest modulus "
             "| valid | why not |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in pc["rows"]:
        if r["success"]:
            why = "; ".join((r.get("validity") or {}).get("reasons", []))[:110]
            lines.append(f"| {r['speed_mps']:.1f} | {r[pc['key']]:.3f} | {r['amplitude_deg']:.3f} | "
                         f"{r['mean_shoulder_power_W']:.3f} | {r['mean_positive_power_W']:.3f} | "
                         f"{r['cost_of_transport']:.4f} | {r['strouhal_number']:.3f} | {r['largest_modulus']:.4f} | "
                         f"{_yes(r.get('valid'))} | {why} |")
        else:
            lines.append(f"| {r['speed_mps']:.1f} | failed: {r.get('message', '')[:60]} | | | | | | | | |")
    lines += ["", f"Over the valid rows only: minimum-power speed {_vertex_text(pc.get('minimum_power'))}; "
              f"maximum-range speed {_vertex_text(pc.get('maximum_range'))}.",
              f"Over every converged row, valid or not (NOT flights where the model does not hold): minimum power "
              f"{_vertex_text(pc.get('minimum_power_all_rows'))}; maximum range "
              f"{_vertex_text(pc.get('maximum_range_all_rows'))}.", "",
              "## Energy-optimal and most stable gaits at the reference speed", "",
              "| gait | P [W] | largest modulus | amplitude [deg] | free values | iterations | KKT | wall [s] |",
              "|---|---|---|---|---|---|---|---|",
              f"| paper's, at the speed | {b['start_objective_value']:.4f} | - | - | - | - | - | - |"]
    for name, r, P in (("energy-optimal", b, b["objective_value"]), ("most stable", s, s["mean_shoulder_power_W"])):
        fv = ", ".join(f"{k.split('.', 1)[1]} {v:.3f}" for k, v in r["free"].items())
        lines.append(f"| {name} | {P:.4f} | {r['largest_modulus']:.5f} | {r['amplitude_deg']:.3f} | {fv} | "
                     f"{r['iterations']} | {r['kkt_residual']:.1e} | {r['wall_s']['total']:.1f} |")
    P0 = b["objective_value"]
    lines += ["", "## Pareto front: minimum power with every multiplier inside radius R", "",
              "Traced from the energy optimum (no bound) down to the most stable gait; every point is the "
              "energy optimum with all multipliers inside the circle of radius R, started from the previous "
              "point's optimum (rows marked 'retry' were inserted halfway after a failed step).", "",
              "| bound R | P [W] | extra power vs energy optimum | largest modulus | iterations | KKT | wall [s] | status |",
              "|---|---|---|---|---|---|---|---|"]
    for q in out["pareto"]:
        bnd = q["bound"] if isinstance(q["bound"], str) else ("none" if q["bound"] is None else f"{q['bound']:.5f}")
        if q.get("inserted"):
            bnd += " (retry)"
        if not q["success"]:
            lines.append(f"| {bnd} | - | - | - | {q.get('iterations', '-')} | - | - | {q.get('status')} (not converged) |")
            continue
        dP = q["objective_value"] - P0
        wall = q.get("wall_s") or {}
        kkt = q.get("kkt_residual")
        lines.append(f"| {bnd} | {q['objective_value']:.4f} | {dP:+.4f} W ({100 * dP / P0:+.2f} %) | "
                     f"{q['largest_modulus']:.5f} | {q.get('iterations', '-')} | "
                     f"{'-' if kkt is None else f'{kkt:.1e}'} | {wall.get('total', float('nan')):.1f} | {q['status']} |")
    lines += ["", f"Power non-increasing as R loosens: {out['pareto_monotone']}; tracing took "
              f"{out['pareto_wall_s']:.0f} s."]
    so = out["optimize_stability"]
    red, ful = so["reduced"], so["committed_optimum"]
    coarse = re.search(r"coarse stage \((\d+) steps\): \w+, (\d+) iterations", red["message"])
    split = f" (coarse {coarse[2]} on {coarse[1]} steps + fine {red['iterations'] - int(coarse[2])})" if coarse else ""
    w = red["wall_s"]
    fine = sum(w.get(k, 0.0) for k in ("build", "start", "solve"))
    stages = (f"; coarse stage {w['coarse_total']:.1f}, fine stage {fine:.1f}, verification "
              f"{w['total'] - w['coarse_total'] - fine:.1f}") if "coarse_total" in w else ""
    threads = f", {red['threads']} threads, load {red['load_average_1min_at_start']:.2f} at start" if "threads" in red else ""
    lines += ["", "## optimize-stability on the reference problem (free speed, default keys and bounds)", "",
              "| method | iterations | wall [s] | r | largest modulus | KKT |", "|---|---|---|---|---|---|",
              f"| reduced space (this run{threads}) | {red['iterations']}{split} | {red['wall_s_total']:.1f} "
              f"(CPU {red['cpu_s_total']:.1f}{stages}) | {red['radius']:.6f} | {max(red['moduli']):.6f} | "
              f"{red['kkt_residual']:.1e} |"]
    if ful.get("iterations") is not None:
        lines.append(f"| {ful.get('method') or 'full'} space (committed, {ful['source']}) | {ful['iterations']} | "
                     f"{ful['wall_s_total']:.1f} | "
                     f"{ful['radius']:.6f} | {max(ful['moduli']):.6f} | - |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    json.encoder.FLOAT_REPR = repr
    main()
