"""Lateral-directional stability of the flapping ibis: the six-degree-of-freedom cycle and its lateral
Floquet multipliers at the paper's gait and in level flight, over the stability margin (the wing-root
position of Experiment 3) and over the roll inertia, which the planar model does not need and which
is an estimate (docs/studies/lateral.md).

Every row carries the cycle's model validity; invalid rows are drawn dashed and grey. Writes
result.json, table.md and lateral_margin.png.

    python scripts/lateral_study.py --out results/lateral
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.engine.results import to_jsonable
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.studies.lateral import lateral_trim
from birdocp.studies.lateral_sensitivity import LATERAL_SENSITIVITY_KEYS, lateral_sensitivities
from script_common import parse_with_out, script_parser

ROOT_AHEAD_CM = tuple(np.round(np.arange(2.0, 8.01, 0.5), 2))
"""Wing-root positions [cm ahead of G] of the fixed-amplitude sweep (the paper's range is 3.5-6.5 cm)."""
LEVEL_ROOT_AHEAD_CM = (2.0, 2.5, 3.0, 3.5, 4.0, 4.25, 4.5, 4.6, 4.7, 4.8, 4.9, 5.0, 5.1, 5.2, 5.3, 5.4, 5.5, 5.6,
                       5.7)
"""Root positions of the level-flight sweep: the planar level branch (Experiment 3) needs the amplitude
to change by about 30 deg per cm ahead of 5 cm and reaches the 70 deg bound at 5.76 cm."""
ROLL_INERTIA_KGM2 = (0.0015, 0.005, 0.011, 0.02, 0.03)
"""Roll inertias of the inertia sweep: the body alone (massless wings) up to about three times the default."""


def row(res, **extra) -> dict:
    """One table row: the labelled multipliers, validity and enough of the cycle to re-solve it."""
    d = res.to_dict()
    modes = {m["label"]: m for m in d["lateral_modes"]}
    out = {**extra, "success": d["success"], "status": d["status"], "max_residual": d["max_residual"],
           "amplitude_deg": d["amplitude_deg"], "x0": d["x0"], "valid": bool(d["validity"] and d["validity"]["valid"]),
           "validity": d["validity"], "longitudinal_multipliers": d["longitudinal_multipliers"],
           "lateral_multipliers": d["lateral_multipliers"], "lateral_modes": d["lateral_modes"],
           "heading_multiplier": d["heading_multiplier"], "coupling_max": d["coupling_max"],
           "lateral_stable": d["lateral_stable"], "stable": d["stable"],
           "mean_forward_speed_mps": d["mean_forward_speed_mps"]}
    out["spiral_modulus"] = abs(complex(*modes["spiral"]["multiplier"])) if "spiral" in modes else None
    return out


def margin_sweep(level: bool) -> list[dict]:
    """Trims over ROOT_AHEAD_CM (LEVEL_ROOT_AHEAD_CM in level flight), outwards from the reference root (5 cm) in both directions, each
    from the previous converged cycle (state and, in level flight, amplitude)."""
    rows, grid = {}, LEVEL_ROOT_AHEAD_CM if level else ROOT_AHEAD_CM
    for half in ([c for c in grid if c >= 5.0], [c for c in grid if c < 5.0][::-1]):
        guess, amp = None, Config().gait.shoulder_flap.amplitude_deg
        for cm in half:
            cfg = with_values(Config(), {"wing.root_ahead_m": cm / 100, "gait.shoulder_flap.amplitude_deg": amp})
            res = lateral_trim(cfg, level=level, x_guess=guess)
            if res.success:
                guess, amp = res.cycle.x0, res.amplitude_deg
            rows[cm] = row(res, root_ahead_cm=float(cm))
            print(f"  {'level' if level else 'A=42'} root {cm:4.1f} cm: {rows[cm]['status']}, "
                  f"lateral {np.round(np.abs(res.lateral_multipliers), 4)}", flush=True)
    return [rows[c] for c in grid]


def inertia_sweep() -> list[dict]:
    rows = []
    for ixx in ROLL_INERTIA_KGM2:
        res = lateral_trim(with_values(Config(), {"model.roll_inertia_kgm2": ixx}))
        rows.append(row(res, roll_inertia_kgm2=ixx))
    return rows


def sensitivities(res, cfg) -> list[dict]:
    """Exact d|Lambda|/d(parameter) of every mode at the paper's gait, per unit of each parameter."""
    rows = []
    for r in lateral_sensitivities(res, cfg, LATERAL_SENSITIVITY_KEYS):
        per = {}
        for lab, d in zip(r["labels"], r["d_moduli"]):
            per.setdefault(lab, float(d))  # a complex pair shares one modulus derivative
        lam = [abs(z) for z, lab in zip(r["multipliers"], r["labels"]) if lab == "longitudinal"]
        i1 = [i for i, lab in enumerate(r["labels"]) if lab == "longitudinal"][int(np.argmax(lam))]
        per["longitudinal_largest"] = float(r["d_moduli"][i1])
        per.pop("longitudinal", None)
        rows.append({"parameter": r["parameter"], "d_modulus_per_unit": per})
    return rows


def fmt_mult(m) -> str:
    re_, im = m
    return f"{re_:.4f}" if abs(im) < 1e-12 else f"{re_:.4f} ± {abs(im):.4f}i"


def table(res: dict) -> str:
    lines = ["# Lateral multipliers of the flapping ibis (six degrees of freedom)", "",
             f"Roll inertia {res['inertia']['roll_inertia_kgm2']} kg m², yaw {res['inertia']['yaw_inertia_kgm2']} kg m² "
             "(estimates, docs/studies/lateral.md); 5 shooting points, 148 RK4 steps. Beats: wingbeats to double "
             "(negative: to halve).", ""]
    for key, title in (("paper_gait", "Paper's gait (A = 42 deg)"), ("level", "Level flight")):
        r = res[key]
        lines += [f"## {title}: amplitude {r['amplitude_deg']:.4f} deg, {'valid' if r['valid'] else 'NOT valid'}", "",
                  "| mode | multiplier | modulus | beats | dominant |", "|---|---|---|---|---|"]
        for m in r["lateral_modes"]:
            mod = abs(complex(*m["multiplier"]))
            lines.append(f"| {m['label']} | {fmt_mult(m['multiplier'])} | {mod:.4f} | {m['beats_to_double']:.3g} "
                         f"| {m['dominant_state']} |")
        lines += [f"| heading | {r['heading_multiplier']:.12g} | | | psi |", "",
                  f"Longitudinal: {', '.join(fmt_mult(m) for m in r['longitudinal_multipliers'])}; "
                  f"coupling max {r['coupling_max']:.1e}.", ""]
    for key, title, col in (("margin_fixed", "Margin sweep, A = 42 deg", "root_ahead_cm"),
                            ("margin_level", "Margin sweep, level flight", "root_ahead_cm"),
                            ("roll_inertia", "Roll inertia sweep (paper's gait)", "roll_inertia_kgm2")):
        lines += [f"## {title}", "", f"| {col} | status | valid | A [deg] | lateral moduli | spiral | lateral stable |",
                  "|---|---|---|---|---|---|---|"]
        for r in res[key]:
            mods = ", ".join(f"{abs(complex(*m)):.4f}" for m in r["lateral_multipliers"])
            sp = f"{r['spiral_modulus']:.4f}" if r["spiral_modulus"] is not None else "-"
            lines.append(f"| {r[col]} | {r['status']} | {'yes' if r['valid'] else 'NO'} | {r['amplitude_deg']:.3f} "
                         f"| {mods} | {sp} | {r['lateral_stable']} |")
        lines.append("")
    if res.get("sensitivities"):
        labs = ["longitudinal_largest", "spiral", "dutch_roll_like", "roll_subsidence"]
        lines += ["## Exact sensitivities at the paper's gait (d|Λ| per unit of the parameter: deg or kg m²)", "",
                  "| parameter | " + " | ".join(labs) + " |", "|---|" + "---|" * len(labs)]
        for r in res["sensitivities"]:
            d = r["d_modulus_per_unit"]
            lines.append(f"| {r['parameter']} | " + " | ".join(
                f"{d[k]:+.4g}" if d.get(k) is not None else "-" for k in labs) + " |")
        lines += ["", f"(second-order AD through the RK4 period map, {res['sensitivities_wall_s']:.1f} s; the "
                  "heading's multiplier stays 1.)", ""]
    lines.append(f"Wall time {res['wall_s']:.1f} s (margin sweeps: A = 42 deg {res['margin_fixed_wall_s']:.1f} s, "
                 f"level {res['margin_level_wall_s']:.1f} s; the machine was shared).")
    return "\n".join(lines) + "\n"


def figure(res: dict, path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4))
    for ax, key, title in ((axes[0], "margin_fixed", "A = 42 deg"), (axes[1], "margin_level", "level flight")):
        rows = [r for r in res[key] if r["success"]]
        x = np.array([r["root_ahead_cm"] for r in rows])
        ok = np.array([r["valid"] for r in rows])
        series = {"longitudinal |Λ1|": [max(abs(complex(*m)) for m in r["longitudinal_multipliers"]) for r in rows],
                  "spiral": [r["spiral_modulus"] for r in rows],
                  "Dutch-roll-like pair": [next((abs(complex(*m["multiplier"])) for m in r["lateral_modes"]
                                                 if m["label"] == "dutch_roll_like"), np.nan) for r in rows]}
        for (name, y), c in zip(series.items(), ("C0", "C3", "C2")):
            y = np.array([np.nan if v is None else v for v in y], float)
            ax.plot(np.where(ok, x, np.nan), np.where(ok, y, np.nan), "-o", color=c, ms=3, label=name)
            ax.plot(np.where(~ok, x, np.nan), np.where(~ok, y, np.nan), "--o", color="0.6", ms=3)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.axvspan(3.5, 6.5, color="0.92", zorder=0)
        ax.set_xlabel("wing root ahead of G [cm] (paper's range shaded)")
        ax.set_ylabel("|multiplier|")
        ax.set_title(f"{title}: grey dashed = model not valid")
        ax.legend(fontsize=8)
    rows = res["roll_inertia"]
    x = [r["roll_inertia_kgm2"] for r in rows]
    for label, c in (("spiral", "C3"), ("dutch_roll_like", "C2"), ("roll_subsidence", "C1"), ("lateral_real", "C4")):
        pts = [(xi, abs(complex(*m["multiplier"]))) for xi, r in zip(x, rows) for m in r["lateral_modes"]
               if m["label"] == label]
        if pts:
            axes[2].semilogx(*zip(*pts), "o", color=c, label=label.replace("_", " "))
    axes[2].set_xticks(x, [f"{v:g}" for v in x])
    axes[2].minorticks_off()
    axes[2].axhline(1.0, color="k", lw=0.8)
    axes[2].axvline(res["inertia"]["roll_inertia_kgm2"], color="0.5", ls=":", label="default")
    axes[2].set_xlabel("roll inertia I_xx [kg m²] (A = 42 deg)")
    axes[2].set_ylabel("|lateral multiplier|")
    axes[2].set_title("lateral modes against the roll inertia")
    axes[2].legend(fontsize=8)
    fig.suptitle("Lateral Floquet multipliers of the flapping ibis (6 DOF); |Λ| > 1 unstable, heading's 1 left out")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral")
    ap.add_argument("--replot", action="store_true", help="redraw the figure and table from --out/result.json")
    args, out = parse_with_out(ap, argv)
    if args.replot:
        import json

        res = json.loads((out / "result.json").read_text())
        atomic_write_text(out / "table.md", table(res))
        figure(res, out / "lateral_margin.png")
        return
    t0 = time.perf_counter()
    cfg = Config()
    paper, lev = lateral_trim(cfg), lateral_trim(cfg, level=True)
    res = {"inertia": paper.to_dict()["inertia"], "paper_gait": row(paper), "level": row(lev)}
    print("paper gait and level flight done", flush=True)
    t1 = time.perf_counter()
    res["sensitivities"] = sensitivities(paper, cfg)
    res["sensitivities_wall_s"] = time.perf_counter() - t1
    for key, lev in (("margin_fixed", False), ("margin_level", True)):
        t1 = time.perf_counter()
        res[key] = margin_sweep(lev)
        res[f"{key}_wall_s"] = time.perf_counter() - t1
    res["roll_inertia"] = inertia_sweep()
    res["wall_s"] = time.perf_counter() - t0
    atomic_write_json(out / "result.json", to_jsonable(res))
    atomic_write_text(out / "table.md", table(res))
    figure(res, out / "lateral_margin.png")
    print(f"wrote {out} in {res['wall_s']:.1f} s")


if __name__ == "__main__":
    main()
