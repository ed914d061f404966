"""Wings with mass (issue 18): does wing inertia stabilise or destabilise the ibis, and by how much?

Families, each from massless wings to a wing-mass fraction (both wings / whole bird, M = 1.2 kg held)
of 15 %, the mass distributed as in docs/studies/inertia.md, mass distribution:

* ``fixed``: the paper's reference cycle (amplitude 42 deg), pseudo-arclength continuation in
  ``wing.mass_kg`` with the wing root 5 cm ahead of G_b (the body's own centre of mass);
* ``level``: level flight held (mean W = 0, the amplitude an unknown), the same continuation;
* ``fixed_held_com`` / ``level_held_com``: warm-started sweeps in which the wing root is placed so
  that the shoulder stays 5 cm ahead of the cycle-mean centre of mass of the whole bird
  (:func:`birdocp.studies.inertia.hold_mean_com_root`): the wings' inertial forces and moments
  without the static shift of the mean centre of mass;
* stability margin: level-flight continuation in SM (paper range -32.5 .. -17.5 %) at the realistic
  wing mass 0.086 kg per wing (14.3 %, van den Berg & Rayner 1995) against massless wings.

Writes results/inertia/: result.json, table.md, fraction.png, moduli.png, margin.png, power.png.

    python scripts/inertia_study.py --out results/inertia
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.studies.branch import bird_branch, sm_percent
from birdocp.studies.inertia import (config_with_wing_mass, cycle_summary, hold_mean_com_root, mean_com_offset_m,
                                     stability_margin_mean_com_percent, wing_mass_of_fraction)
from birdocp.studies.level import level
from birdocp.studies.trim import trim
from script_common import parse_with_out, script_parser

M_TOTAL = 1.2
ROOT_REF = 0.05
CHORD = 0.2
REALISTIC_WING_KG = 0.086
AMP = "gait.shoulder_flap.amplitude_deg"
ROOT = "wing.root_ahead_m"
MAX_FRACTION = 0.15


def _moduli(mults):
    return [float(abs(complex(*m))) for m in mults]


def _row(cfg, fraction, x0, p, mults, means, root, amplitude, extra=None):
    s = cycle_summary(cfg, x0, p)
    lam = [complex(*m) for m in mults]
    out = {"wing_mass_fraction_percent": 100.0 * fraction, "wing_mass_kg": wing_mass_of_fraction(fraction, M_TOTAL),
           "root_ahead_m": float(root), "amplitude_deg": float(amplitude),
           "multipliers": [[v.real, v.imag] for v in lam], "moduli": _moduli(mults),
           "largest_modulus": float(abs(lam[0])), "doubling_time_s": float(0.25 / np.log(abs(lam[0]))),
           "mean_forward_speed_mps": float(means.get("forward_speed_mps", np.nan)),
           "mean_vertical_speed_mps": float(means.get("vertical_speed_mps", np.nan)),
           "x0": [float(v) for v in x0], **s}
    out["stability_margin_mean_com_percent"] = stability_margin_mean_com_percent(root, s["mean_com_ahead_of_G_m"], CHORD)
    out.update(extra or {})
    return out


def branch_family(level_flight: bool) -> tuple[list, float]:
    t0 = time.perf_counter()
    cfg = config_with_wing_mass(Config(), 0.0)
    br = bird_branch(cfg, "wing.mass_kg", 0.0, wing_mass_of_fraction(MAX_FRACTION, M_TOTAL), level=level_flight,
                     step=0.01, max_dparam=0.01)
    rows = []
    for pt in br.points:
        fr = 2 * pt.parameter / M_TOTAL
        c = config_with_wing_mass(Config(), fr)
        p = np.asarray(pt.p, float)
        rows.append(_row(c, fr, pt.x0, p, pt.multipliers, pt.means, p[PARAM_NAMES.index(ROOT)],
                         p[PARAM_NAMES.index(AMP)]))
    return rows, time.perf_counter() - t0, br.end_reason


def held_family(level_flight: bool, fractions) -> tuple[list, float]:
    t0 = time.perf_counter()
    rows, prev, amp = [], None, 42.0
    for fr in fractions:
        c = config_with_wing_mass(Config(), fr)
        root, res, it = ROOT_REF, None, 0
        for it in range(1, 6):
            p = np.asarray(get_p(c, root, amp))
            new_root = hold_mean_com_root(c, ROOT_REF, p)
            ci = with_values(c, {ROOT: new_root, AMP: amp})
            res = level(ci, warm_start=prev) if level_flight else trim(ci, warm_start=prev)
            if not res.success:
                raise RuntimeError(f"held-CoM {'level' if level_flight else 'trim'} failed at {fr}: {res.status}")
            amp_new = res.amplitude_deg
            done = abs(new_root - root) < 1e-7 and abs(amp_new - amp) < 1e-6
            root, amp = new_root, amp_new
            if done or not level_flight:  # at fixed gait the mean C does not depend on the root
                break
        prev = res
        rows.append(_row(c, fr, res.x0, res.cycle.p, [[v.real, v.imag] for v in res.multipliers],
                         res.cycle.means, root, amp, {"fixed_point_iterations": it}))
    return rows, time.perf_counter() - t0


def get_p(cfg, root, amp):
    from birdocp.bird.config import param_vector

    return param_vector(with_values(cfg, {ROOT: root, AMP: amp}))


def margin_family(wing_kg: float) -> tuple[list, float]:
    t0 = time.perf_counter()
    cfg = with_values(Config(), {"wing.mass_kg": wing_kg, "wing.inertial_terms": True})
    rows = []
    for to_sm in (-32.5, -17.5):
        br = bird_branch(cfg, "stability_margin", -25.0, to_sm, level=True, step=0.5, max_dparam=1.0,
                         max_dstate=1.5)
        pts = br.points if to_sm > -25 else list(reversed(br.points))[:-1]
        half = []
        for pt in pts:
            p = np.asarray(pt.p, float)
            xc, zc = mean_com_offset_m(cfg, p)
            half.append({"stability_margin_percent": sm_percent(pt.parameter, CHORD),
                         "stability_margin_mean_com_percent": stability_margin_mean_com_percent(pt.parameter, xc, CHORD),
                         "root_ahead_m": pt.parameter, "amplitude_deg": float(p[PARAM_NAMES.index(AMP)]),
                         "moduli": pt.moduli, "largest_modulus": pt.moduli[0], "stable": bool(pt.stable),
                         "mean_forward_speed_mps": pt.means.get("forward_speed_mps"),
                         "mean_com_ahead_of_G_m": xc, "mean_com_below_G_m": zc, "end_reason": br.end_reason})
        rows = half + rows if to_sm < -25 else rows + half
    rows.sort(key=lambda r: r["stability_margin_percent"])
    return rows, time.perf_counter() - t0


def figures(res, out: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fam = res["families"]
    style = {"fixed": ("C0", "-", "A = 42 deg, root 5 cm ahead of G_b"),
             "level": ("C1", "-", "level flight, root 5 cm ahead of G_b"),
             "fixed_held_com": ("C0", "--", "A = 42 deg, root 5 cm ahead of mean C"),
             "level_held_com": ("C1", "--", "level flight, root 5 cm ahead of mean C")}
    fig, ax = plt.subplots(2, 2, figsize=(11, 8), constrained_layout=True)
    for k, (col, ls, lab) in style.items():
        rows = fam[k]["points"]
        f = [r["wing_mass_fraction_percent"] for r in rows]
        ax[0, 0].plot(f, [r["largest_modulus"] for r in rows], ls, color=col, marker=".", label=lab)
        if k.startswith("level"):
            ax[0, 1].plot(f, [r["amplitude_deg"] for r in rows], ls, color=col, marker=".", label=lab)
        ax[1, 0].plot(f, [r["mean_pitch_deg"] for r in rows], ls, color=col, marker=".", label=lab)
        ax[1, 1].plot(f, [r["pitch_oscillation_amplitude_deg"] for r in rows], ls, color=col, marker=".", label=lab)
    for a in ax.ravel():
        a.axvline(100 * 2 * REALISTIC_WING_KG / M_TOTAL, color="0.6", lw=0.8, ls=":")
        a.set_xlabel("wing-mass fraction, both wings / whole bird [%]")
        a.grid(alpha=0.3)
    ax[0, 0].set_ylabel("largest Floquet multiplier modulus |Λ1|")
    ax[0, 0].set_title("instability (|Λ1| > 1 unstable)")
    ax[0, 1].set_ylabel("level-flight flapping amplitude [deg]")
    ax[0, 1].set_title("level flight: amplitude needed")
    ax[1, 0].set_ylabel("period-mean pitch θ [deg]")
    ax[1, 0].set_title("mean pitch attitude")
    ax[1, 1].set_ylabel("pitch oscillation amplitude (max-min)/2 [deg]")
    ax[1, 1].set_title("pitch oscillation over the wingbeat")
    ax[0, 0].legend(fontsize=8)
    fig.suptitle("Northern bald ibis with wing mass (dotted line: 0.086 kg per wing, van den Berg & Rayner 1995)")
    fig.savefig(out / "fraction.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True, sharey=True)
    for a, k in zip(ax, ("fixed", "level")):
        rows = fam[k]["points"]
        f = [r["wing_mass_fraction_percent"] for r in rows]
        Mo = np.array([r["moduli"] for r in rows])
        for j, lab in enumerate(("|Λ1|", "|Λ2|", "|Λ3|", "|Λ4|")):
            a.plot(f, Mo[:, j], marker=".", ls="-" if j != 2 else "--", label=lab)
        a.axhline(1.0, color="k", lw=0.8)
        a.set_xlabel("wing-mass fraction [%]")
        a.set_title(style[k][2])
        a.grid(alpha=0.3)
    ax[0].set_ylabel("Floquet multiplier modulus")
    ax[0].legend(loc="center", bbox_to_anchor=(0.5, 0.35), ncol=4)
    fig.savefig(out / "moduli.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for k, col, lab in (("massless", "k", "massless wings"), ("realistic", "C3", "wings 0.086 kg each")):
        rows = res["margin"][k]["points"]
        ax[0].plot([r["stability_margin_percent"] for r in rows], [r["largest_modulus"] for r in rows], "-", color=col,
                   marker=".", label=lab + " (SM from G_b)")
        if k == "realistic":
            ax[0].plot([r["stability_margin_mean_com_percent"] for r in rows], [r["largest_modulus"] for r in rows],
                       "--", color=col, label=lab + " (SM from mean C)")
        ax[1].plot([r["stability_margin_percent"] for r in rows], [r["amplitude_deg"] for r in rows], "-", color=col,
                   marker=".", label=lab)
    ax[0].axhline(1.0, color="0.5", lw=0.8)
    ax[0].set(xlabel="stability margin SM [%]", ylabel="largest multiplier modulus |Λ1|",
              title="level flight: instability against SM")
    ax[1].set(xlabel="stability margin SM (from G_b) [%]", ylabel="level-flight amplitude [deg]",
              title="level flight: amplitude against SM")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.savefig(out / "margin.png", dpi=110)
    plt.close(fig)

    h = res["power_history"]
    fig, ax = plt.subplots(figsize=(8, 4.2), constrained_layout=True)
    ax.plot(h["t_s"], h["inertial_power_W"], label="inertial power dT_rel/dt")
    ax.plot(h["t_s"], h["shoulder_inertial_power_W"], label="shoulder power on the wing masses P_in + P_grav")
    ax2 = ax.twinx()
    ax2.plot(h["t_s"], h["wing_relative_kinetic_energy_J"], color="C2", ls="--", label="T_rel (right axis)")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("time in the wingbeat [s]")
    ax.set_ylabel("power [W]")
    ax2.set_ylabel("wings' kinetic energy relative to the body T_rel [J]")
    ax.set_title("Level flight, wings 0.086 kg each: powers of the wing masses over one beat")
    lines = ax.get_legend_handles_labels()
    l2 = ax2.get_legend_handles_labels()
    ax.legend(lines[0] + l2[0], lines[1] + l2[1], fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    fig.savefig(out / "power.png", dpi=110)
    plt.close(fig)
    return ["fraction.png", "moduli.png", "margin.png", "power.png"]


def table(res) -> str:
    lines = ["# Wings with mass: continuation in the wing-mass fraction", "",
             "M = 1.2 kg held; fraction = both wings / whole bird. Λ1 is the largest multiplier (unstable > 1);",
             "θ̄ the period-mean pitch, Δθ half the peak-to-peak pitch oscillation; P̄_sh,in the period mean of",
             "the shoulder power on the wing masses; P⁺ the mean positive part of dT_rel/dt.", ""]
    for k, fam in res["families"].items():
        lines += [f"## {k}: {fam['label']}", "",
                  "| fraction [%] | wing [kg] | root [cm] | A [deg] | abs Λ1 | abs Λ2 | abs Λ4 | θ̄ [deg] | Δθ [deg] "
                  "| U [m/s] | SM from mean C [%] | P̄_sh,in [W] | P⁺ [W] |",
                  "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in fam["points"]:
            lines.append(f"| {r['wing_mass_fraction_percent']:.2f} | {r['wing_mass_kg']:.4f} | {100 * r['root_ahead_m']:.3f} "
                         f"| {r['amplitude_deg']:.3f} | {r['moduli'][0]:.4f} | {r['moduli'][1]:.4f} | {r['moduli'][3]:.4f} "
                         f"| {r['mean_pitch_deg']:.3f} | {r['pitch_oscillation_amplitude_deg']:.4f} "
                         f"| {r['mean_forward_speed_mps']:.3f} | {r['stability_margin_mean_com_percent']:.2f} "
                         f"| {r['mean_shoulder_inertial_power_W']:+.3f} | {r['mean_positive_inertial_power_W']:.3f} |")
        lines.append("")
    lines += ["## Level flight against the stability margin", "",
              "| wings | SM from G_b [%] | SM from mean C [%] | A [deg] | abs Λ1 | U [m/s] |", "|---|---:|---:|---:|---:|---:|"]
    for k, fam in res["margin"].items():
        for r in fam["points"]:
            lines.append(f"| {k} | {r['stability_margin_percent']:.2f} | {r['stability_margin_mean_com_percent']:.2f} "
                         f"| {r['amplitude_deg']:.3f} | {r['largest_modulus']:.4f} | {r['mean_forward_speed_mps']:.3f} |")
    lines += ["", "## Answer", ""] + [f"- {s}" for s in res["answer"]]
    return "\n".join(lines) + "\n"


def main():
    ap = script_parser(__doc__, "results/inertia")
    ap.add_argument("--replot", action="store_true", help="redraw the figures and table from --out/result.json")
    a, out = parse_with_out(ap)
    if a.replot:
        import json

        res = json.loads((out / "result.json").read_text())
        figures(res, out)
        atomic_write_text(out / "table.md", table(res))
        return
    t0 = time.perf_counter()
    fams, walls = {}, {}
    labels = {"fixed": "A = 42 deg, root 5 cm ahead of G_b (continuation)",
              "level": "level flight, root 5 cm ahead of G_b (continuation)",
              "fixed_held_com": "A = 42 deg, root 5 cm ahead of the mean centre of mass (sweep)",
              "level_held_com": "level flight, root 5 cm ahead of the mean centre of mass (sweep)"}
    for k, lev in (("fixed", False), ("level", True)):
        rows, wall, end = branch_family(lev)
        fams[k] = {"label": labels[k], "points": rows, "end_reason": end}
        walls[k] = wall
        print(f"{k}: {len(rows)} points, {wall:.1f} s", flush=True)
    fractions = np.linspace(0.0, MAX_FRACTION, 11)
    for k, lev in (("fixed_held_com", False), ("level_held_com", True)):
        rows, wall = held_family(lev, fractions)
        fams[k] = {"label": labels[k], "points": rows}
        walls[k] = wall
        print(f"{k}: {len(rows)} points, {wall:.1f} s", flush=True)
    margin = {}
    for k, kg in (("massless", 0.0), ("realistic", REALISTIC_WING_KG)):
        rows, wall = margin_family(kg)
        margin[k] = {"wing_mass_kg": kg, "points": rows}
        walls[f"margin_{k}"] = wall
        print(f"margin {k}: {len(rows)} points, {wall:.1f} s", flush=True)

    # the realistic level cycle: powers over one beat
    cr = with_values(Config(), {"wing.mass_kg": REALISTIC_WING_KG})
    lv = level(cr)
    lv0 = level(Config())
    wp = lv.wing_power
    hist = {k: [float(v) for v in np.asarray(wp[k])] for k in ("t_s", "inertial_power_W", "shoulder_inertial_power_W",
                                                              "wing_relative_kinetic_energy_J")}

    def at(rows, frac_pct):
        f = np.array([r["wing_mass_fraction_percent"] for r in rows])
        return {key: float(np.interp(frac_pct, f, [r[key] for r in rows]))
                for key in ("largest_modulus", "amplitude_deg", "mean_pitch_deg", "pitch_oscillation_amplitude_deg",
                            "doubling_time_s", "mean_forward_speed_mps")}

    real_pct = 100 * 2 * REALISTIC_WING_KG / M_TOTAL
    summary = {k: {"massless": at(v["points"], 0.0), "realistic": at(v["points"], real_pct),
                   "max_fraction": at(v["points"], 100 * MAX_FRACTION)} for k, v in fams.items()}
    for s in summary.values():
        s["relative_change_largest_modulus_realistic"] = s["realistic"]["largest_modulus"] / s["massless"]["largest_modulus"] - 1
    lm = {k: (min(r["largest_modulus"] for r in v["points"]), max(r["largest_modulus"] for r in v["points"]))
          for k, v in margin.items()}
    answer = [
        f"Level flight (root 5 cm ahead of G_b): |Λ1| {summary['level']['massless']['largest_modulus']:.4f} massless -> "
        f"{summary['level']['realistic']['largest_modulus']:.4f} at {real_pct:.1f} % "
        f"({100 * summary['level']['relative_change_largest_modulus_realistic']:+.2f} %); doubling time "
        f"{summary['level']['massless']['doubling_time_s']:.3f} -> {summary['level']['realistic']['doubling_time_s']:.3f} s; "
        f"level amplitude {summary['level']['massless']['amplitude_deg']:.2f} -> {summary['level']['realistic']['amplitude_deg']:.2f} deg.",
        f"Same with the mean centre of mass held 5 cm behind the shoulder: |Λ1| "
        f"{summary['level_held_com']['massless']['largest_modulus']:.4f} -> {summary['level_held_com']['realistic']['largest_modulus']:.4f} "
        f"({100 * summary['level_held_com']['relative_change_largest_modulus_realistic']:+.2f} %).",
        f"Reference gait A = 42 deg: |Λ1| {summary['fixed']['massless']['largest_modulus']:.4f} -> "
        f"{summary['fixed']['realistic']['largest_modulus']:.4f} ({100 * summary['fixed']['relative_change_largest_modulus_realistic']:+.2f} %); "
        f"held mean C: {100 * summary['fixed_held_com']['relative_change_largest_modulus_realistic']:+.2f} %.",
        f"Level flight against SM -32.5..-17.5 %: |Λ1| in [{lm['massless'][0]:.4f}, {lm['massless'][1]:.4f}] massless, "
        f"[{lm['realistic'][0]:.4f}, {lm['realistic'][1]:.4f}] with 0.086 kg wings; stable anywhere: "
        f"{any(r['stable'] for v in margin.values() for r in v['points'])}.",
        f"Inertial power at 0.086 kg (level): dT_rel/dt peaks at {wp['peak_inertial_power_W']:.2f} W, its positive part "
        f"averages {wp['mean_positive_inertial_power_W']:.2f} W; the shoulder's power on the wing masses averages "
        f"{wp['mean_shoulder_inertial_power_W']:+.3f} W.",
    ]
    res = {"families": fams, "margin": margin, "summary": summary, "answer": answer, "power_history": hist,
           "level_realistic": {"amplitude_deg": lv.amplitude_deg, "multipliers": [[v.real, v.imag] for v in lv.multipliers],
                               **{k: v for k, v in lv.wing_power_summary().items() if k != "wing_power_history"}},
           "level_massless": {"amplitude_deg": lv0.amplitude_deg,
                              "multipliers": [[v.real, v.imag] for v in lv0.multipliers]},
           "settings": {"total_mass_kg": M_TOTAL, "root_ref_m": ROOT_REF, "chord_m": CHORD, "points": 5,
                        "steps_per_period": 148, "realistic_wing_mass_kg": REALISTIC_WING_KG},
           "wall_s": dict(walls, total=time.perf_counter() - t0)}
    res["figures"] = figures(res, out)
    atomic_write_json(out / "result.json", res)
    atomic_write_text(out / "table.md", table(res))
    print("\n".join(answer))


if __name__ == "__main__":
    main()
