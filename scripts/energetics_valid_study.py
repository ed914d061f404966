"""Energetics where the model holds: the power curve with every row's validity, the power curve over
valid gaits (least power at each speed with the limits of ``[validity]`` as constraints), the
energy-optimal valid gait at the reference speed and the valid stability-power Pareto front (points
solved in parallel through the process executor, each from its nearest solved neighbour). Writes
``OUT/result.json``, ``OUT/summary.md``, ``OUT/power_curve.png``, ``OUT/pareto.png`` (default OUT:
results/energetics/valid).

    python scripts/energetics_valid_study.py [--out DIR] [--jobs 2] [--pareto-points 12]
        [--stable-from results/stability_optimum/valid/result.json]
"""

import argparse
import json
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from birdocp.bird.config import Config  # noqa: E402
from birdocp.io.files import atomic_write_json, atomic_write_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
AMP = "gait.shoulder_flap.amplitude_deg"


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def row_of(opt) -> dict:
    d = opt.to_dict()
    keep = ("success", "status", "objective", "iterations", "objective_value", "x0", "free", "amplitude_deg",
            "largest_modulus", "moduli", "mean_forward_speed_mps", "max_multiplier", "kkt_residual",
            "constraint_violation", "wall_s", "validity", "validity_constraints", "validity_rounds",
            "mean_shoulder_power_W")
    return {k: d.get(k) for k in keep} | {"valid": bool((d.get("validity") or {}).get("valid"))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "energetics" / "valid"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--pareto-points", type=int, default=12)
    ap.add_argument("--speeds", type=float, nargs=3, default=(10.0, 24.0, 1.0), metavar=("FROM", "TO", "STEP"))
    ap.add_argument("--stable-from", default=str(ROOT / "results" / "stability_optimum" / "valid" / "result.json"),
                    help="the most stable valid gait at the reference speed (stability_valid_study.py), if present")
    ap.add_argument("--skip-curves", action="store_true", help="keep OUT/result.json's power curves")
    ap.add_argument("--reuse-optimum", action="store_true", help="keep OUT/result.json's energy-optimal valid gait")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from birdocp.engine.executors import get_executor
    from birdocp.studies.gait import optimize_gait, power_curve
    from birdocp.studies.gait_fronts import stability_pareto
    from birdocp.studies.level import level
    from birdocp.studies.gait_fronts import valid_power_curve

    cfg = Config()
    res = json.loads((out / "result.json").read_text()) if (out / "result.json").is_file() else {}
    lv = level(cfg)
    U_ref = float(lv.mean_forward_speed_mps)
    res["reference_speed_mps"] = U_ref
    speeds = np.arange(args.speeds[0], args.speeds[1] + 1e-9, args.speeds[2])
    t_all = time.perf_counter()
    with get_executor(jobs=args.jobs if args.jobs > 1 else None) as ex:
        if not args.skip_curves:
            log("power curve of the paper's gait, every row with its validity")
            t0 = time.perf_counter()
            pc = power_curve(cfg, speeds, bounds=(-10.0, 45.0))
            res["power_curve"] = pc | {"wall_s": time.perf_counter() - t0}
            atomic_write_json(out / "result.json", res)
            log(f"  {sum(r.get('valid', False) for r in pc['rows'])} of {len(pc['rows'])} rows valid; minimum power "
                f"over valid rows {pc['minimum_power']}")
        if args.reuse_optimum and "optimal_gait" in res:
            b = res["optimal_gait"]
        else:
            log(f"energy-optimal valid gait at {U_ref:.4f} m/s")
            best = optimize_gait(cfg, objective="power", speed_mps=U_ref, valid=True)
            b = res["optimal_gait"] = row_of(best) | {"mean_shoulder_power_W": best.objective_value}
            atomic_write_json(out / "result.json", res)
        log(f"  P {b['objective_value']:.5f} W, |L1| {b['largest_modulus']:.5f}, valid {b['valid']}, {b['status']}")
        start_gait = dict(b["free"]) | {AMP: b["amplitude_deg"]}
        if not args.skip_curves:
            log("power curve over valid gaits (least power at each speed), parallel")
            t0 = time.perf_counter()
            vc = valid_power_curve(ex, cfg, speeds, start=start_gait, x_guess=b["x0"], start_speed=U_ref, progress=log)
            res["valid_power_curve"] = vc | {"wall_s": time.perf_counter() - t0}
            atomic_write_json(out / "result.json", res)
        stable_path = Path(args.stable_from)
        st = json.loads(stable_path.read_text()).get("at_speed") if stable_path.is_file() else None
        if st is None or abs(st.get("speed_mps", 0) - U_ref) > 0.01:
            log("most stable valid gait at the reference speed")
            g = optimize_gait(cfg, objective="stability", speed_mps=U_ref, valid=True, max_iter=80)
            st = row_of(g) | {"radius": g.objective_value, "mean_shoulder_power_W": g.means.get("flapping_power_W")}
        if st.get("mean_shoulder_power_W") is None:  # its power: a trim at the gait, from its state
            from birdocp.bird.config import with_values
            from birdocp.studies.trim import trim

            tr = trim(with_values(cfg, dict(st["free"]) | {AMP: st["amplitude_deg"]}), x_guess=st["x0"])
            st["mean_shoulder_power_W"] = tr.energetics["mean_shoulder_power_W"] if tr.success else None
        res["most_stable_gait"] = st
        R_hi, R_min = float(b["largest_modulus"]), float(st["radius"])
        bounds = [float(R_min + 2e-3 * (R_hi - R_min)) if R == R_min else float(R)
                  for R in np.linspace(R_hi, R_min, args.pareto_points + 1)[1:]]
        log(f"valid Pareto front: {len(bounds)} bounds from {R_hi:.5f} to {R_min:.5f}, {args.jobs} jobs")
        t0 = time.perf_counter()
        rows = stability_pareto(cfg, U_ref, bounds, start=start_gait, x_guess=b["x0"], executor=ex, anchors=[{"bound": R_min, "free": st["free"],
                                                                         "amplitude_deg": st["amplitude_deg"],
                                                                         "x0": st["x0"]}],
                                start_bound=R_hi, progress=log, valid=True)
        res["pareto"] = rows
        res["pareto_wall_s"] = time.perf_counter() - t0
        res["pareto_jobs"] = args.jobs
    res["wall_s"] = time.perf_counter() - t_all
    atomic_write_json(out / "result.json", res)
    figures(res, out)
    atomic_write_text(out / "summary.md", summary(res))
    print((out / "summary.md").read_text())


def figures(res: dict, out: Path) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    pc = res.get("power_curve")
    if pc:
        ok = [r for r in pc["rows"] if r["success"]]
        U = np.array([r["speed_mps"] for r in ok])
        P = np.array([r["mean_shoulder_power_W"] for r in ok])
        v = np.array([bool(r.get("valid")) for r in ok])
        ax.plot(U, P, "--", color="0.7", lw=1)
        ax.plot(U[v], P[v], "o-", color="C0", label="paper's gait (incidence holds the speed): valid")
        ax.plot(U[~v], P[~v], "o", color="0.6", mfc="none", label="paper's gait: model NOT valid")
    vc = res.get("valid_power_curve")
    if vc:
        ok = [r for r in vc["rows"] if r["success"]]
        U = np.array([r["speed_mps"] for r in ok])
        P = np.array([r["mean_shoulder_power_W"] for r in ok])
        v = np.array([bool(r.get("valid")) for r in ok])
        ax.plot(U[v], P[v], "s-", color="C2", label="least power over valid gaits (4 shoulder keys free)")
        if (~v).any():
            ax.plot(U[~v], P[~v], "s", color="0.6", mfc="none", label="optimiser: NOT valid")
    ax.set(xlabel="mean forward speed U [m/s]", ylabel="mean shoulder power [W]",
           title="Power of level flight; grey open markers: the model does not hold")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(out / "power_curve.png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    rows = [r for r in res.get("pareto", []) if r["success"]]
    if rows:
        fig, ax = plt.subplots(figsize=(7, 4.6))
        pts = [(res["optimal_gait"]["largest_modulus"], res["optimal_gait"]["objective_value"], res["optimal_gait"]["valid"])]
        pts += [(r["largest_modulus"], r["objective_value"], bool(r["valid"])) for r in rows]
        st = res["most_stable_gait"]
        pts.append((max(st["moduli"]), st["mean_shoulder_power_W"], bool(st["validity"]["valid"])))
        pts.sort()
        x, y, v = (np.array(a) for a in zip(*pts))
        ax.plot(x, y, "-", color="0.7", lw=1)
        ax.plot(x[v], y[v], "o", color="C3", label="valid optimum")
        if (~v).any():
            ax.plot(x[~v], y[~v], "o", color="0.6", mfc="none", label="model NOT valid")
        ax.axvline(1.0, color="k", lw=0.6, ls=":")
        ax.set(xlabel="largest multiplier modulus", ylabel="minimum mean shoulder power [W]",
               title=f"Valid Pareto front at {res['reference_speed_mps']:.2f} m/s (limits of [validity] as constraints)")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        fig.savefig(out / "pareto.png", dpi=120, bbox_inches="tight")
        plt.close(fig)


def summary(res: dict) -> str:
    L = ["# Energetics where the model holds (scripts/energetics_valid_study.py)", ""]
    pc = res.get("power_curve")
    if pc:
        L += ["## Power curve of the paper's gait (speed held by the incidence offset), every row's validity", "",
              "| U [m/s] | incidence offset [deg] | amplitude [deg] | P [W] | largest modulus | valid | reasons |",
              "|---|---|---|---|---|---|---|"]
        for r in pc["rows"]:
            if r["success"]:
                L.append(f"| {r['speed_mps']:.1f} | {r[pc['key']]:.3f} | {r['amplitude_deg']:.3f} | "
                         f"{r['mean_shoulder_power_W']:.4f} | {r['largest_modulus']:.4f} | {'yes' if r['valid'] else 'NO'} | "
                         f"{'; '.join(r['validity']['reasons'])[:120]} |")
            else:
                L.append(f"| {r['speed_mps']:.1f} | failed | | | | | {r.get('message', '')[:80]} |")
        L += ["", f"Over the valid rows: minimum power {fmt_vertex(pc['minimum_power'])}; maximum range "
              f"{fmt_vertex(pc['maximum_range'])}. (Over all rows, valid or not: minimum power "
              f"{fmt_vertex(pc['minimum_power_all_rows'])}.)", ""]
    vc = res.get("valid_power_curve")
    if vc:
        L += ["## Least power over valid gaits at each speed", "",
              "| U [m/s] | P [W] | largest modulus | valid | active limits | free values | amplitude [deg] |",
              "|---|---|---|---|---|---|---|"]
        for r in vc["rows"]:
            if not r["success"]:
                L.append(f"| {r['speed_mps']:.1f} | not converged ({r['status']}) | | | | | |")
                continue
            act = [k for k, c in (r.get("validity_constraints") or {}).items() if c.get("active")]
            fv = ", ".join(f"{k.split('.', 1)[1]} {v:.2f}" for k, v in r["free"].items())
            L.append(f"| {r['speed_mps']:.1f} | {r['mean_shoulder_power_W']:.4f} | {r['largest_modulus']:.4f} | "
                     f"{'yes' if r['valid'] else 'NO'} | {', '.join(act) or 'none'} | {fv} | {r['amplitude_deg']:.2f} |")
        L += ["", f"Minimum power over valid gaits: {fmt_vertex(vc['minimum_power'])}; maximum range "
              f"{fmt_vertex(vc['maximum_range'])}; traced in {vc['wall_s']:.0f} s.", ""]
    b, st = res["optimal_gait"], res["most_stable_gait"]
    L += [f"## At the reference speed {res['reference_speed_mps']:.3f} m/s", "",
          "| gait | P [W] | largest modulus | valid | active limits | KKT |", "|---|---|---|---|---|---|"]
    for name, r, P in (("energy-optimal valid", b, b["objective_value"]), ("most stable valid", st, st["mean_shoulder_power_W"])):
        act = [k for k, c in (r.get("validity_constraints") or {}).items() if c.get("active")]
        L.append(f"| {name} | {P:.4f} | {max(r['moduli']):.5f} | {'yes' if r['validity']['valid'] else 'NO'} | "
                 f"{', '.join(act) or 'none'} | {r['kkt_residual']:.1e} |")
    L += ["", "## Valid Pareto front: least power with every multiplier inside radius R", "",
          f"{len(res['pareto'])} bounds solved in parallel ({res['pareto_jobs']} processes), each from its nearest "
          f"solved neighbour: {res['pareto_wall_s']:.0f} s.", "",
          "| bound R | P [W] | extra vs energy optimum | largest modulus | valid | active limits | started from | iterations | wall [s] |",
          "|---|---|---|---|---|---|---|---|---|"]
    P0 = b["objective_value"]
    for q in res["pareto"]:
        if not q["success"]:
            L.append(f"| {q['bound']:.5f} | not converged ({q['status']}) | | | | | {q.get('started_from')} | | |")
            continue
        act = [k for k, c in (q.get("validity_constraints") or {}).items() if c.get("active")]
        dP = q["objective_value"] - P0
        sf = q.get("started_from")
        L.append(f"| {q['bound']:.5f} | {q['objective_value']:.4f} | {dP:+.4f} W ({100 * dP / P0:+.2f} %) | "
                 f"{q['largest_modulus']:.5f} | {'yes' if q['valid'] else 'NO'} | {', '.join(act) or 'none'} | "
                 f"{'energy optimum' if sf is None else f'{sf:.5f}'} | {q['iterations']} | "
                 f"{q['wall_s'].get('total', float('nan')):.1f} |")
    return "\n".join(L) + "\n"


def fmt_vertex(v: dict) -> str:
    if not v or v.get("speed_mps") is None:
        return "none (fewer than three valid rows)"
    where = "interior" if v["interior"] else "at an END of the valid range: no interior minimum"
    return f"{v['speed_mps']:.3f} m/s ({v.get('power_W', float('nan')):.4f} W; {where})"


if __name__ == "__main__":
    main()
