"""Beyond the paper: the most stable level-flight gait within bounds, the tail, and the ranked
sensitivities. Writes results/stability_optimum/ and results/tail/ (JSON, table.md, figures).

    python scripts/stability_study.py            # everything (~8 min on 2 cores: the optimum ~6.5 min)
    python scripts/stability_study.py --skip-tail
    python scripts/stability_study.py --reuse --reuse-optimum   # stored results: validity, tables, figures
"""

import argparse
import json
import time
from pathlib import Path

import casadi as ca
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import JOINT_NAMES, Config, get_value, with_values
from birdocp.studies.branch import bird_branch
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.bird.kinematics import joint_angles
from birdocp.studies.optimize import optimize_stability


def save(fig, path):
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=130, bbox_inches="tight")
    plt.close(fig)
    tmp.replace(path)


def unit_circle(ax):
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8, label="unit circle")
    ax.set_aspect("equal")
    ax.axhline(0, color="0.8", lw=0.5)
    ax.axvline(0, color="0.8", lw=0.5)


def joint_history(cfg, n=200):
    t = np.linspace(0, 1 / cfg.gait.frequency_hz, n)
    joints = {j: (getattr(cfg.gait, j).offset_deg, getattr(cfg.gait, j).amplitude_deg, getattr(cfg.gait, j).phase_deg)
              for j in JOINT_NAMES}
    q = joint_angles(ca.DM(t).T, cfg.gait.frequency_hz, joints)
    return t, {j: np.degrees(np.asarray(q[j]).ravel()) for j in JOINT_NAMES}


AMP = "gait.shoulder_flap.amplitude_deg"


def fmt_mults(lam):
    return ", ".join(f"{z.real:.4f}{z.imag:+.4f}j" if abs(z.imag) > 1e-12 else f"{z.real:.4f}" for z in lam)


def validity_cell(v: dict) -> str:
    if v["valid"]:
        return (f"valid (effective α up to {max(abs(v['alpha_eff_min_deg']), abs(v['alpha_eff_max_deg'])):.1f} deg, "
                f"{v['stalled_fraction']:.1%} of span-time beyond stall, min u {v['min_forward_speed_mps']:.1f} m/s, "
                f"airflow-body angle ≤ {v['max_airflow_body_angle_deg']:.1f} deg)")
    return "**NOT valid**: " + "; ".join(v["reasons"])


def stability_optimum(out: Path, reuse: bool = False):
    """The optimum (``reuse``: the stored result.json, whose cycle gets its validity by re-integrating
    one period from its x0; the optimisation itself takes ~6 min)."""
    out.mkdir(parents=True, exist_ok=True)
    from birdocp.bird.validity import periodic_validity
    from birdocp.studies.level import level

    if reuse and (out / "result.json").exists():
        d = json.loads((out / "result.json").read_text())
        d["validity_source"] = "re-evaluation of the stored optimal cycle (one RK4 period from x0, 148 steps)"
    else:
        t0 = time.perf_counter()
        res = optimize_stability(Config(), progress=True)
        d = res.to_dict()
        d["script_wall_s"] = time.perf_counter() - t0
        d["validity_source"] = "optimize_stability"
    cfg_best = with_values(Config(), {**d["free"], AMP: d["amplitude_deg"]})
    N = 148
    if d.get("validity") is None or reuse:
        d["validity"] = periodic_validity(cfg_best, d["x0"], steps_per_period=N).to_dict()
    v = d["verification"]
    if v.get("scratch_trim_success"):
        v["scratch_trim_validity"] = periodic_validity(cfg_best, v["scratch_trim_x0"], steps_per_period=N).to_dict()
    lv = level(Config())
    d["paper_gait_level"] = {"amplitude_deg": lv.amplitude_deg,
                             "multipliers": [[float(z.real), float(z.imag)] for z in lv.multipliers],
                             "validity": lv.validity.to_dict()}
    atomic_write_json(out / "result.json", d)

    lam_best = np.array([complex(*z) for z in d["multipliers"]])
    lam_lv = np.asarray(lv.multipliers)
    rows = ["| quantity | paper gait, level flight | optimum within the bounds |", "|---|---|---|",
            f"| flapping amplitude [deg] | {lv.amplitude_deg:.3f} | {d['amplitude_deg']:.3f} |"]
    for k, (lo, hi) in d["bounds"].items():
        rows.append(f"| {k} [{lo:g}, {hi:g}] | {get_value(Config(), k):.3f} | {d['free'][k]:.3f}"
                    f"{' (bound)' if k in d['active_bounds'] else ''} |")
    rows.append(f"| multipliers | {fmt_mults(lam_lv)} | {fmt_mults(lam_best)} |")
    rows.append(f"| largest modulus | {np.max(np.abs(lam_lv)):.4f} | {np.max(np.abs(lam_best)):.4f} |")
    rows.append(f"| x0 (u [m/s], w [m/s], q [rad/s], θ [deg]) | {lv.x0[0]:.2f}, {lv.x0[1]:.2f}, {lv.x0[2]:.3f}, "
                f"{np.degrees(lv.x0[3]):.1f} | {d['x0'][0]:.2f}, {d['x0'][1]:.2f}, {d['x0'][2]:.3f}, "
                f"{np.degrees(d['x0'][3]):.1f} |")
    rows.append(f"| model validity | {validity_cell(d['paper_gait_level']['validity'])} | {validity_cell(d['validity'])} |")
    other = ""
    if v.get("scratch_finds_another_cycle"):
        sm = [complex(*z) for z in v["scratch_trim_multipliers"]]
        other = (f" A trim from the default initial guess at the same gait converges to **another cycle** "
                 f"(x0 differs by {np.max(np.abs(np.array(v['scratch_trim_x0']) - np.array(d['x0']))):.3f}), with "
                 f"multipliers {fmt_mults(sm)} (largest modulus {max(abs(z) for z in sm):.4f}; model validity: "
                 f"{validity_cell(v['scratch_trim_validity'])}): two cycles coexist, a sign that the optimum lies "
                 f"next to a fold of cycles.")
    stable = bool(np.max(np.abs(lam_best)) < 1)
    text = ("# The most stable level-flight gait within the default bounds\n\n" + "\n".join(rows) + "\n\n"
            f"IPOPT: {d['status']}, {d['iterations']} iterations (coarse 48-step grid, then 148 steps), "
            f"{d['wall_s'].get('total', 0):.0f} s. Verification: multiple shooting (5 points) from the optimum's "
            f"state converges ({v.get('trim_success')}) to the same cycle (x0 within {v.get('trim_x0_difference'):.1e}) "
            f"and multipliers within {v.get('max_multiplier_difference'):.1e} (numpy eigenvalues), mean vertical "
            f"speed {v.get('trim_mean_vertical_speed_mps'):.1e} m/s; r - spectral radius = "
            f"{v.get('radius_minus_spectral_radius'):.1e}." + other + "\n\n"
            f"**A level cycle with all multipliers inside the unit circle {'exists' if stable else 'does not exist'} "
            "within these bounds"
            + (f", and the model {'holds' if d['validity']['valid'] else 'does NOT hold'} on it" if stable else "")
            + ("" if d["validity"]["valid"] else " (so it is not a stable *flight* of the model; the most stable "
               "valid gait: results/stability_optimum/valid, scripts/stability_valid_study.py)")
            + f"**: largest |Λ| {np.max(np.abs(lam_best)):.4f}, only {1 - np.max(np.abs(lam_best)):.4f} inside "
            "the unit circle (a complex pair at the optimum's radius; a disturbance decays by 1 % only after "
            f"{np.log(0.99) / np.log(np.max(np.abs(lam_best))):.1f} wingbeats).\n")
    atomic_write_text(out / "table.md", text)

    fig, axes = plt.subplots(1, 3, figsize=(17, 5.6), gridspec_kw={"width_ratios": [1, 1, 1.1], "wspace": 0.35})
    th = np.linspace(0, 2 * np.pi, 2000)
    for ax in axes[:2]:
        unit_circle(ax)
        ax.plot(d["radius"] * np.cos(th), d["radius"] * np.sin(th), "--", lw=1, color="C1",
                label=f"optimal radius r = {d['radius']:.5f}")
        ax.plot(lam_lv.real, lam_lv.imag, "o", mfc="none", ms=9, color="C0", label="paper gait, level flight")
        ax.plot(lam_best.real, lam_best.imag, "x", ms=9, mew=2, color="C3", label="optimum")
        ax.set_xlabel("Re Λ")
        ax.set_ylabel("Im Λ")
    axes[0].set_title("Floquet multipliers of level flight")
    axes[0].legend(loc="lower left", fontsize=8)
    z = lam_best[np.argmax(np.abs(lam_best))]
    half = 0.006
    axes[1].set_xlim(z.real - half, z.real + half)
    axes[1].set_ylim(-half, half)
    axes[1].ticklabel_format(useOffset=False)
    axes[1].set_title(f"zoom near Λ = {abs(z):.4f}:\nthe optimal pair just inside the unit circle", fontsize=10)
    axes[1].legend(loc="lower left", fontsize=8)
    ax = axes[2]
    t, qa = joint_history(Config())
    _, qb = joint_history(cfg_best)
    for k, j in enumerate(("shoulder_incidence", "shoulder_flap", "shoulder_sweep")):
        ax.plot(t / t[-1], qa[j], "-", color=f"C{k}", lw=1, label=f"{j} (paper)")
        ax.plot(t / t[-1], qb[j], "--", color=f"C{k}", lw=2, label=f"{j} (optimum)")
    ax.set(xlabel="t / T", ylabel="joint angle [deg]",
           title="shoulder joint laws over one wingbeat")
    ax.legend(fontsize=7, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.13), frameon=False)
    valid = bool(d["validity"]["valid"])
    vtext = "model valid" if valid else "model NOT valid: " + "; ".join(d["validity"]["reasons"])
    verdict = ("stable" if stable else "still unstable") if valid else "not a flight of the model: NOT valid"
    fig.suptitle("Smallest largest |Λ| of a level cycle within the default gait bounds (no validity constraint)"
                 f" ({verdict}: largest |Λ| {np.max(np.abs(lam_best)):.4f})\n{vtext}",
                 fontsize=11, y=1.06)
    save(fig, out / "optimum.png")
    return d


def branch_validity(cfg, d: dict) -> None:
    """Adds ``validity`` to every point of a branch dict (one RK4 period from its x0 with its parameters)."""
    from birdocp.bird.validity import periodic_validity

    n = int(d["settings"].get("steps_per_period", 148))
    for p in d["points"]:
        if "validity" not in p:
            p["validity"] = periodic_validity(cfg, p["x0"], np.asarray(p["p"], float), steps_per_period=n).to_dict()


def point_class(p) -> str:
    """flight (valid, |mean W| < 1 m/s), dive (valid, mean W <= -1 m/s) or invalid."""
    if not p["validity"]["valid"]:
        return "invalid"
    return "flight" if abs(p["means"].get("vertical_speed_mps", 0.0)) < 1.0 else "dive"


STYLE = {"flight": dict(ls="-", lw=2.0), "dive": dict(ls=":", lw=2.0), "invalid": dict(ls="--", lw=1.2, color="0.6")}


def draw_classes(ax, x, y, classes, color, label):
    """One line per run of equal class (solid: flight, dotted: dive, grey dashed: model invalid)."""
    start = 0
    seen = set()
    for i in range(1, len(x) + 1):
        if i == len(x) or classes[i] != classes[start]:
            c = classes[start]
            st = dict(STYLE[c])
            st.setdefault("color", color)
            lab = f"{label}: {c}" if (c not in seen) else None
            seen.add(c)
            j = min(i + 1, len(x))  # overlap one point so the runs join
            ax.plot(x[start:j], y[start:j], label=lab, **st)
            start = i


def tail_study(out: Path, max_angle: float, reuse: bool = False):
    out.mkdir(parents=True, exist_ok=True)
    cfg = with_values(Config(), {"tail.enabled": True})
    results = {}
    for name, level in (("level", True), ("fixed_42deg", False)):
        if reuse and (out / f"branch_{name}.json").exists():
            results[name] = json.loads((out / f"branch_{name}.json").read_text())
        else:
            
            t0 = time.perf_counter()
            br = bird_branch(cfg, "tail.opening_angle_deg", 0.0, max_angle, level=level,
                             bounds=(20.0, 90.0) if level else None)
            results[name] = br.to_dict()
            results[name]["script_wall_s"] = time.perf_counter() - t0
        branch_validity(cfg, results[name])
        atomic_write_json(out / f"branch_{name}.json", results[name])

    fig, axes = plt.subplots(1, 3, figsize=(18, 5.2))
    summary = {}
    for k, (name, d) in enumerate(results.items()):
        pts = d["points"]
        beta = np.array([p["parameter"] for p in pts])
        m1 = np.array([abs(complex(*p["multipliers"][0])) for p in pts])
        W = np.array([p["means"].get("vertical_speed_mps", np.nan) for p in pts])
        cls = [point_class(p) for p in pts]
        draw_classes(axes[0], beta, m1, cls, f"C{k}", name)
        draw_classes(axes[1], beta, W, cls, f"C{k}", name)
        for sp in d.get("special_points", []):
            i = sp["between"][0]
            mk = {"fold": "*", "neimark_sacker": "D", "period_doubling": "s"}.get(sp["kind"], "o")
            axes[0].plot(sp["parameter"], m1[i], mk, ms=12, color="k", mfc="none" if sp["kind"] != "fold" else "gold",
                         zorder=5, label=f"{name}: {sp['kind'].replace('_', '-')} β = {sp['parameter']:.2f}, "
                                         f"θ(0) = {np.degrees(sp['x0'][3]):.0f} deg")
            axes[1].plot(sp["parameter"], W[i], mk, ms=12, color="k", mfc="none" if sp["kind"] != "fold" else "gold",
                         zorder=5)
        axes[0].plot(beta[-1], m1[-1], "|", ms=16, mew=2.5, color=f"C{k}")
        axes[1].plot(beta[-1], W[-1], "|", ms=16, mew=2.5, color=f"C{k}")
        if name == "level":
            amp = np.array([p["free_values"][AMP] for p in pts])
            draw_classes(axes[2], beta, amp, cls, "C0", "level flight")
            axes[2].axhline(90.0, color="k", lw=0.8, ls="-.", label="amplitude bound 90 deg (branch end)")
            axes[2].plot(beta[-1], amp[-1], "|", ms=16, mew=2.5, color="C0")
        flight = [i for i, c in enumerate(cls) if c == "flight"]
        kmin = min(flight, key=lambda i: m1[i]) if flight else None
        summary[name] = {
            "beta_range_deg": [float(beta.min()), float(beta.max())], "end_reason": d["end_reason"],
            "end_message": d["end_message"], "m1_at_0": float(m1[0]),
            "min_m1_in_flight": float(m1[kmin]) if kmin is not None else None,
            "beta_at_min_m1_in_flight": float(beta[kmin]) if kmin is not None else None,
            "stable_anywhere": bool(m1.min() < 1), "stable_in_flight": bool(kmin is not None and m1[kmin] < 1),
            "points": len(pts), "flight_points": len(flight), "dive_points": cls.count("dive"),
            "invalid_points": cls.count("invalid"),
            "valid_beta_range_deg": ([float(beta[[i for i, c in enumerate(cls) if c != "invalid"]].min()),
                                      float(beta[[i for i, c in enumerate(cls) if c != "invalid"]].max())]
                                     if cls.count("invalid") < len(cls) else None),
            "first_invalid": (dict(beta_deg=float(beta[cls.index("invalid")]),
                                   reasons=pts[cls.index("invalid")]["validity"]["reasons"])
                              if "invalid" in cls else None),
        }
    axes[0].axhline(1, color="k", lw=0.8)
    axes[0].set(xlabel="tail opening angle β [deg]", ylabel="largest multiplier modulus |Λ1|",
                title="expanding multiplier against the tail opening angle")
    axes[0].legend(fontsize=7, loc="lower left")
    axes[1].axhline(0, color="k", lw=0.8)
    axes[1].axhline(-1, color="0.5", lw=0.8, ls=":")
    axes[1].axhspan(-1e3, -1, color="tab:red", alpha=0.06)
    axes[1].set_ylim(min(-2, np.nanmin([p["means"].get("vertical_speed_mps", 0) for d in results.values()
                                        for p in d["points"]]) * 1.05), 2)
    axes[1].text(0.5, -1.5, "dive region: mean W < -1 m/s", fontsize=8, color="tab:red", va="top")
    axes[1].set(xlabel="tail opening angle β [deg]", ylabel="mean vertical speed W [m/s] (+ climbing)",
                title="mean vertical speed: the fixed-amplitude branch dives")
    axes[2].set(xlabel="tail opening angle β [deg]", ylabel="level-flight flapping amplitude [deg]",
                title="amplitude needed for level flight")
    axes[2].legend(fontsize=8, loc="upper left")
    fig.suptitle("The tail (continuation in its opening angle). Solid: flight (model valid, |mean W| < 1 m/s); "
                 "dotted: dive (mean W < -1 m/s); grey dashed: model not valid (birdocp.bird.validity); | : branch end",
                 fontsize=10.5)
    save(fig, out / "tail.png")

    lines = ["# The tail: continuation in its opening angle\n",
             "Flight = the model is valid on the cycle (birdocp.bird.validity, default thresholds) and it is not a "
             "dive (|mean W| < 1 m/s).\n",
             "| family | β range [deg] | end | \\|Λ1\\| at β = 0 | min \\|Λ1\\| in flight | points: flight / dive / "
             "model invalid | first invalid point | special points | stable anywhere | stable in flight |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, d in results.items():
        s = summary[name]
        pts = d["points"]
        sp = "; ".join(f"{q['kind']} at β = {q['parameter']:.3f} (mean W "
                       f"{pts[q['between'][0]]['means'].get('vertical_speed_mps', float('nan')):.1f} m/s, θ(0) "
                       f"{np.degrees(q['x0'][3]):.0f} deg, model "
                       f"{'valid' if pts[q['between'][0]]['validity']['valid'] else 'not valid'})"
                       for q in d.get("special_points", [])) or "none"
        fi = s["first_invalid"]
        lines.append(f"| {name} | {s['beta_range_deg'][0]:.2f} - {s['beta_range_deg'][1]:.2f} | {d['end_reason']} | "
                     f"{s['m1_at_0']:.4f} | "
                     + (f"{s['min_m1_in_flight']:.4f} (β = {s['beta_at_min_m1_in_flight']:.2f})" if s["min_m1_in_flight"]
                        is not None else "-")
                     + f" | {s['flight_points']} / {s['dive_points']} / {s['invalid_points']} | "
                     + (f"β = {fi['beta_deg']:.2f}: {'; '.join(fi['reasons'])}" if fi else "none")
                     + f" | {sp} | {'yes' if s['stable_anywhere'] else 'no'} | {'yes' if s['stable_in_flight'] else 'no'} |")
    atomic_write_text(out / "table.md", "\n".join(lines) + "\n")
    atomic_write_json(out / "summary.json", summary)
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--skip-tail", action="store_true")
    ap.add_argument("--skip-optimum", action="store_true")
    ap.add_argument("--tail-max-deg", type=float, default=60.0)
    ap.add_argument("--reuse", action="store_true", help="redraw the tail study from its branch files")
    ap.add_argument("--reuse-optimum", action="store_true",
                    help="take the optimum from results/stability_optimum/result.json (validity re-evaluated, "
                         "table and figure redrawn) instead of optimising again (~6 min)")
    ap.add_argument("--out", default="results", metavar="DIR",
                    help="root folder: writes DIR/stability_optimum and DIR/tail (default results)")
    args = ap.parse_args()
    root = Path(args.out)
    if not args.skip_optimum:
        stability_optimum(root / "stability_optimum", reuse=args.reuse_optimum)
        print((root / "stability_optimum" / "table.md").read_text())
    if not args.skip_tail:
        tail_study(root / "tail", args.tail_max_deg, reuse=args.reuse)
        print((root / "tail" / "table.md").read_text())


if __name__ == "__main__":
    main()
