"""Beyond the paper: the most stable level-flight gait within bounds, the tail, and the ranked
sensitivities. Writes results/stability_optimum/ and results/tail/ (JSON, table.md, figures).

    python scripts/stability_study.py            # everything (~8 min on 2 cores: the optimum ~6.5 min)
    python scripts/stability_study.py --skip-tail
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


def stability_optimum(out: Path):
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    res = optimize_stability(Config(), progress=True)
    d = res.to_dict()
    d["script_wall_s"] = time.perf_counter() - t0
    from birdocp.studies.level import level
    lv = level(Config())
    d["paper_gait_level"] = {"amplitude_deg": lv.amplitude_deg,
                             "multipliers": [[float(z.real), float(z.imag)] for z in lv.multipliers]}
    atomic_write_json(out / "result.json", d)

    # table
    rows = ["| quantity | paper gait, level flight | optimum within the bounds |", "|---|---|---|",
            f"| flapping amplitude [deg] | {lv.amplitude_deg:.3f} | {res.amplitude_deg:.3f} |"]
    for k, (lo, hi) in res.bounds.items():
        rows.append(f"| {k} [{lo:g}, {hi:g}] | {get_value(Config(), k):.3f} | {res.free[k]:.3f}"
                    f"{' (bound)' if k in d['active_bounds'] else ''} |")
    fmt = lambda lam: ", ".join(f"{z.real:.4f}{z.imag:+.4f}j" if abs(z.imag) > 1e-12 else f"{z.real:.4f}" for z in lam)
    rows.append(f"| multipliers | {fmt(lv.multipliers)} | {fmt(res.multipliers)} |")
    rows.append(f"| largest modulus | {np.max(np.abs(lv.multipliers)):.4f} | {np.max(np.abs(res.multipliers)):.4f} |")
    v = res.verification
    other = ""
    if v.get("scratch_finds_another_cycle"):
        sm = [complex(*z) for z in v["scratch_trim_multipliers"]]
        other = (f" A trim from the default initial guess at the same gait converges to **another cycle** "
                 f"(x0 differs by {np.max(np.abs(np.array(v['scratch_trim_x0']) - res.x0)):.3f}), with multipliers "
                 f"{fmt(sm)} (largest modulus {max(abs(z) for z in sm):.4f}): two cycles coexist, a sign that the "
                 f"optimum lies next to a fold of cycles.")
    text = ("# The most stable level-flight gait within the default bounds\n\n" + "\n".join(rows) + "\n\n"
            f"IPOPT: {res.status}, {res.iterations} iterations (coarse 48-step grid, then 148 steps), "
            f"{res.wall_s.get('total', 0):.0f} s. Verification: multiple shooting (5 points) from the optimum's "
            f"state converges ({v.get('trim_success')}) to the same cycle (x0 within {v.get('trim_x0_difference'):.1e}) "
            f"and multipliers within {v.get('max_multiplier_difference'):.1e} (numpy eigenvalues), mean vertical "
            f"speed {v.get('trim_mean_vertical_speed_mps'):.1e} m/s; r - spectral radius = "
            f"{v.get('radius_minus_spectral_radius'):.1e}." + other + "\n\n"
            f"**A stable level-flight gait {'exists' if res.stable else 'does not exist'} within these bounds.**\n")
    atomic_write_text(out / "table.md", text)

    # figures: multipliers, joint angles over a wingbeat
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    ax = axes[0]
    unit_circle(ax)
    ax.plot(lv.multipliers.real, lv.multipliers.imag, "o", mfc="none", ms=9, label="paper gait, level flight")
    ax.plot(res.multipliers.real, res.multipliers.imag, "x", ms=9, mew=2, label="optimum")
    th = np.linspace(0, 2 * np.pi, 200)
    ax.plot(res.radius * np.cos(th), res.radius * np.sin(th), "--", lw=0.8, color="C1",
            label=f"optimal radius r = {res.radius:.3f}")
    ax.set_xlabel("Re Λ")
    ax.set_ylabel("Im Λ")
    ax.set_title("Floquet multipliers of level flight")
    ax.legend(loc="lower left", fontsize=8)
    ax = axes[1]
    cfg_best = res.cfg or Config()
    t, qa = joint_history(Config())
    _, qb = joint_history(cfg_best)
    for k, j in enumerate(("shoulder_incidence", "shoulder_flap", "shoulder_sweep")):
        ax.plot(t / t[-1], qa[j], "-", color=f"C{k}", lw=1, label=f"{j} (paper)")
        ax.plot(t / t[-1], qb[j], "--", color=f"C{k}", lw=2, label=f"{j} (optimum)")
    ax.set_xlabel("t / T")
    ax.set_ylabel("joint angle [deg]")
    ax.set_title("shoulder joint laws over one wingbeat")
    ax.legend(fontsize=7, ncol=2)
    fig.suptitle("Most stable level flight within the default gait bounds"
                 f" ({'stable' if res.stable else 'still unstable'}: largest |Λ| {np.max(np.abs(res.multipliers)):.3f})")
    save(fig, out / "optimum.png")
    return res


def tail_study(out: Path, max_angle: float, reuse: bool = False):
    out.mkdir(parents=True, exist_ok=True)
    cfg = with_values(Config(), {"tail.enabled": True})
    results = {}
    for name, level in (("level", True), ("fixed_42deg", False)):
        if reuse and (out / f"branch_{name}.json").exists():
            results[name] = json.loads((out / f"branch_{name}.json").read_text())
            continue
        t0 = time.perf_counter()
        br = bird_branch(cfg, "tail.opening_angle_deg", 0.0, max_angle, level=level,
                         bounds=(20.0, 90.0) if level else None)
        d = br.to_dict()
        d["script_wall_s"] = time.perf_counter() - t0
        atomic_write_json(out / f"branch_{name}.json", d)
        results[name] = d
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for k, (name, d) in enumerate(results.items()):
        beta = np.array([p["parameter"] for p in d["points"]])
        mods = np.array([[abs(complex(*z)) for z in p["multipliers"]] for p in d["points"]])
        axes[0].plot(beta, mods[:, 0], "-o", ms=3, color=f"C{k}", label=f"{name}: |Λ1|")
        axes[0].plot(beta, mods[:, 1:], "--", lw=0.8, color=f"C{k}")
        if name == "level":
            amp = [p["free_values"]["gait.shoulder_flap.amplitude_deg"] for p in d["points"]]
            axes[1].plot(beta, amp, "-o", ms=3, color="C0")
    axes[0].axhline(1, color="k", lw=0.8)
    axes[0].set_xlabel("tail opening angle β [deg]")
    axes[0].set_ylabel("|Λ| (dashed: the other three)")
    axes[0].set_title("Floquet multipliers' moduli against the tail opening angle")
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("tail opening angle β [deg]")
    axes[1].set_ylabel("level-flight amplitude [deg]")
    axes[1].set_title("flapping amplitude needed for level flight")
    save(fig, out / "tail.png")
    lines = ["# The tail: continuation in its opening angle\n",
             "Stable in flight = all |Λ| < 1 with |mean W| < 1 m/s and |θ(0)| < 45 deg (a cycle, not a dive).\n",
             "| family | β range [deg] | end | \\|Λ1\\| at β = 0 | min \\|Λ1\\| in flight | special points | stable anywhere | stable in flight |",
             "|---|---|---|---|---|---|---|---|"]
    for name, d in results.items():
        pts = d["points"]
        beta = [p["parameter"] for p in pts]
        m1 = [abs(complex(*p["multipliers"][0])) for p in pts]
        flight = [abs(p["means"].get("vertical_speed_mps", 0.0)) < 1.0 and abs(p["x0"][3]) < np.pi / 4 for p in pts]
        mf = [m for m, f in zip(m1, flight) if f]
        bf = [b for b, f in zip(beta, flight) if f]
        k = int(np.argmin(mf)) if mf else None
        sp = "; ".join(f"{q['kind']} at β = {q['parameter']:.3f} (mean W "
                       f"{pts[q['between'][0]]['means'].get('vertical_speed_mps', float('nan')):.1f} m/s, θ(0) "
                       f"{np.degrees(q['x0'][3]):.0f} deg)" for q in d.get("special_points", [])) or "none"
        lines.append(f"| {name} | {min(beta):.2f} - {max(beta):.2f} | {d['end_reason']} | {m1[0]:.4f} | "
                     + (f"{mf[k]:.4f} (β = {bf[k]:.2f})" if mf else "-") + f" | {sp} | "
                     f"{'yes' if min(m1) < 1 else 'no'} | {'yes' if mf and min(mf) < 1 else 'no'} |")
    atomic_write_text(out / "table.md", "\n".join(lines) + "\n")
    return results


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--skip-tail", action="store_true")
    ap.add_argument("--skip-optimum", action="store_true")
    ap.add_argument("--tail-max-deg", type=float, default=60.0)
    ap.add_argument("--reuse", action="store_true", help="redraw the tail study from its branch files")
    args = ap.parse_args()
    if not args.skip_optimum:
        stability_optimum(Path("results/stability_optimum"))
        print(open("results/stability_optimum/table.md").read())
    if not args.skip_tail:
        tail_study(Path("results/tail"), args.tail_max_deg, reuse=args.reuse)
        print(open("results/tail/table.md").read())


if __name__ == "__main__":
    main()
