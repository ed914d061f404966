"""Beyond the paper: the most stable level-flight gait within bounds. Writes OUT/stability_optimum/
(JSON, table.md, figure; ``--out OUT``, default ``results``). The tail: scripts/tail_study.py.

    python scripts/stability_study.py            # ~6.5 min on 2 cores
    python scripts/stability_study.py --reuse-optimum   # the stored result: validity, table, figure
"""

import json
import time
from pathlib import Path

import casadi as ca
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import JOINT_NAMES, Config, get_value, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.bird.kinematics import joint_angles
from birdocp.studies.optimize import COARSE_STEPS, optimize_stability
from script_common import parse_with_out, script_parser


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


def stability_optimum(out: Path, reuse: bool = False, method: str = "reduced"):
    """The optimum (``reuse``: the stored result.json, whose cycle gets its validity by re-integrating
    one period from its x0; the optimisation itself takes ~6 min). ``method``: the optimiser
    (:func:`optimize_stability`'s ``method``, "reduced" by default; the committed result.json was
    written by the full-space one, "full", before the reduced optimiser became the default: see
    docs/reproducibility.md)."""
    out.mkdir(parents=True, exist_ok=True)
    from birdocp.bird.validity import periodic_validity
    from birdocp.studies.level import level

    if reuse and (out / "result.json").exists():
        d = json.loads((out / "result.json").read_text())
        d["validity_source"] = "re-evaluation of the stored optimal cycle (one RK4 period from x0, 148 steps)"
    else:
        t0 = time.perf_counter()
        res = optimize_stability(Config(), progress=True, method=method)
        d = res.to_dict()
        d["script_wall_s"] = time.perf_counter() - t0
        d["validity_source"] = "optimize_stability"
        d["coarse_steps"] = COARSE_STEPS[method]  # the method's coarse grid (RK4 steps per period)
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
            f"IPOPT ({d.get('method', 'full')} method): {d['status']}, {d['iterations']} iterations (coarse "
            f"{d.get('coarse_steps', 48)}-step grid, then 148 steps), "
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


def main(argv=None):
    ap = script_parser(__doc__, "results")
    ap.add_argument("--reuse-optimum", action="store_true",
                    help="take the optimum from OUT/stability_optimum/result.json (validity re-evaluated, "
                         "table and figure redrawn) instead of optimising again (~6 min)")
    ap.add_argument("--method", choices=("reduced", "full"), default="reduced",
                    help="the optimiser: 'reduced' (the level cycle eliminated; default, as optimize-stability) "
                         "or 'full' (the full-space NLP that wrote the committed result.json)")
    args, out = parse_with_out(ap, argv)
    stability_optimum(out / "stability_optimum", reuse=args.reuse_optimum, method=args.method)
    print((out / "stability_optimum" / "table.md").read_text())


if __name__ == "__main__":
    main()
