"""Experiment 2 of the paper: level flight and the flapping-amplitude sweep (Python API).

* level-flight amplitude (mean vertical speed 0, the amplitude a decision variable of one NLP) with
  (a) the default model (exact circulation, exact kinematic velocity) and
  (b) the reference implementation's model (relaxed circulation, backward-difference velocity);
  the paper places level flight at 43.47 deg;
* the sweep 40 .. 46 deg, step 0.5, warm-started from neighbour to neighbour (default model);
* figures: speeds.png, multipliers.png, trajectories.png (flight path over one period in the vertical
  plane for 42 deg, the level amplitude and 44 deg, integrating U = u cos(theta) + w sin(theta) and
  W = u sin(theta) - w cos(theta)); result.json and table.md.

    python scripts/experiment2.py --out results/experiment2
"""

from __future__ import annotations

import functools
import math
import shutil
import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.studies.level import level
from birdocp.studies.trim import trim
from birdocp.studies.sweep import sweep, sweep_values
from script_common import Beside, parse_with_out, script_parser

AMP = "gait.shoulder_flap.amplitude_deg"
RELAXED = {"aero.circulation": "relaxed", "aero.kinematic_velocity": "backward-difference"}
PAPER_LEVEL_DEG = 43.47


def level_summary(r, wall) -> dict:
    d = r.to_dict()
    return {"success": d["success"], "status": d["status"], "amplitude_deg": r.amplitude_deg,
            "iterations": d["iterations"], "wall_s": wall, "wall_phases_s": d["wall_s"],
            "max_residual": d["max_residual"], "mean_vertical_speed_mps": d["mean_vertical_speed_mps"],
            "mean_forward_speed_mps": d["mean_forward_speed_mps"],
            "flight_path_angle_deg": d["flight_path_angle_deg"], "multipliers": d["multipliers"],
            "moduli": d["moduli"], "x0": d["x0"], "validity": d["validity"]}


def _cm(z_m: float) -> str:
    s = f"{100 * z_m:+.2f}"
    return "0.00" if s in ("+0.00", "-0.00") else s


def flight_path(r):
    """Inertial position (x forward, z up) over one period from U and W along the RK4 trajectory."""
    t = np.asarray(r.trajectory_t)
    X = np.asarray(r.trajectory_x)
    u, w, th = X[:, 0], X[:, 1], X[:, 3]
    U = u * np.cos(th) + w * np.sin(th)
    W = u * np.sin(th) - w * np.cos(th)
    dt = np.diff(t)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (U[1:] + U[:-1]) * dt)])
    z = np.concatenate([[0.0], np.cumsum(0.5 * (W[1:] + W[:-1]) * dt)])
    return t - t[0], x, z


def level_job(name: str, compiled: bool = False) -> dict:
    """Level flight of one model variant, solved twice (the repeat: the cost without the one-off graph
    build); the summary dict (runs in a worker process with ``--jobs 2``)."""
    over = RELAXED if name == "relaxed_backward_difference" else {}
    c = with_values(Config(), over) if over else Config()
    t = time.perf_counter()
    r = level(c, compiled=compiled)
    wall = time.perf_counter() - t
    t = time.perf_counter()
    r2 = level(c, compiled=compiled)
    wall2 = time.perf_counter() - t
    s = level_summary(r, wall)
    s["repeat_wall_s"] = wall2
    s["repeat_iterations"] = r2.iterations
    s["repeat_amplitude_deg"] = r2.amplitude_deg
    print(f"level ({name}): A = {r.amplitude_deg:.6f} deg, {r.iterations} it, {wall:.1f} s "
          f"(repeat {wall2:.1f} s), mean W {r.mean_vertical_speed_mps:.2e}", flush=True)
    return {"result": r if name == "default" else None, "summary": s}


def main() -> None:
    ap = script_parser(__doc__, "results/experiment2")
    ap.add_argument("--jobs", type=int, default=2,
                    help="processes (default 2: the relaxed model's level flight runs in a worker while "
                         "this process solves the default model and the sweep; 1: all in this process)")
    args, out = parse_with_out(ap)
    if args.jobs < 1:
        ap.error(f"--jobs must be >= 1, got {args.jobs}")
    cfg = Config()
    res: dict = {"paper": {"level_amplitude_deg": PAPER_LEVEL_DEG,
                           "statements": ["level flight at A = 43.47 deg",
                                          "mean vertical speed nearly linear in A over 40-46 deg",
                                          "the multipliers change only slightly with A"]}}

    # --- level flight, two model variants (the relaxed one in a worker process when jobs > 1: it
    # depends on nothing below, and its model's graphs are its own)
    relaxed = Beside(functools.partial(level_job, compiled=args.compiled), "relaxed_backward_difference", args.jobs)
    default = level_job("default", args.compiled)
    res["level"] = None  # filled below, when the worker is done (keeps the key order of result.json)
    r_level = default["result"]
    a_level = r_level.amplitude_deg

    # --- the sweep (default model)
    values = sweep_values(40.0, 46.0, 0.5)
    sweep_dir = out / "sweep"
    if sweep_dir.exists():
        shutil.rmtree(sweep_dir)
    t = time.perf_counter()
    rows = sweep(cfg, AMP, values, out_dir=sweep_dir, compiled=args.compiled)
    sweep_wall = time.perf_counter() - t
    A = np.array([r["value"] for r in rows])
    U = np.array([r["mean_forward_speed_mps"] for r in rows])
    W = np.array([r["mean_vertical_speed_mps"] for r in rows])
    beta = np.array([r["flight_path_angle_deg"] for r in rows])
    mods = np.array([[r[f"modulus{k}"] for k in range(4)] for r in rows])
    mre = np.array([[r[f"multiplier{k}_re"] for k in range(4)] for r in rows])
    mim = np.array([[r[f"multiplier{k}_im"] for k in range(4)] for r in rows])
    fit = np.polyfit(A, W, 1)
    lin_dev = float(np.max(np.abs(np.polyval(fit, A) - W)))
    a_zero_interp = float(np.interp(0.0, W, A)) if np.all(np.diff(W) > 0) else float("nan")
    res["sweep"] = {
        "values_deg": values, "success": [r["success"] for r in rows],
        "iterations": [r["iterations"] for r in rows], "wall_s_per_point": [r["wall_s"] for r in rows],
        "wall_s_total": sweep_wall,
        "mean_vertical_speed_linear_fit": {"slope_mps_per_deg": float(fit[0]), "intercept_mps": float(fit[1]),
                                           "max_deviation_mps": lin_dev},
        "level_amplitude_from_linear_interpolation_deg": a_zero_interp,
        "largest_modulus_range": [float(mods[:, 0].min()), float(mods[:, 0].max())],
        "all_valid": all(r["valid"] for r in rows),
        "rows": rows,
    }
    print(f"sweep: {len(rows)} points, {sum(r['success'] for r in rows)} converged, "
          f"{sum(r['iterations'] for r in rows)} iterations, {sweep_wall:.1f} s", flush=True)

    # --- trajectories
    c42 = with_values(cfg, {AMP: 42.0})
    c44 = with_values(cfg, {AMP: 44.0})
    r42 = trim(c42, warm_start=r_level, compiled=args.compiled)
    r44 = trim(c44, warm_start=r_level, compiled=args.compiled)
    paths = {}
    for lab, r in (("A = 42 deg (descending)", r42), (f"A = {a_level:.2f} deg (level)", r_level),
                   ("A = 44 deg (climbing)", r44)):
        tt, xx, zz = flight_path(r)
        paths[lab] = (tt, xx, zz, r)
    res["trajectories"] = {lab: {"amplitude_deg": v[3].amplitude_deg, "horizontal_distance_m": float(v[1][-1]),
                                 "height_change_m": float(v[2][-1]),
                                 "height_range_m": float(v[2].max() - v[2].min()),
                                 "success": bool(v[3].success)} for lab, v in paths.items()}

    # --- the relaxed model's level flight (from the worker)
    levels = {"default": (r_level, default["summary"]),
              "relaxed_backward_difference": (None, relaxed.result()["summary"])}
    res["level"] = {k: v[1] for k, v in levels.items()}

    # --- figures (matplotlib imported here only: the worker process never draws)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"descending": "tab:red", "level": "tab:green", "climbing": "tab:blue"}

    fig, ax = plt.subplots(2, 2, figsize=(10, 7), sharex=True)
    spec = [(ax[0, 0], U, "mean horizontal speed $\\bar U$ [m/s]"),
            (ax[0, 1], W, "mean vertical speed $\\bar W$ [m/s] (+ climbing)"),
            (ax[1, 0], np.hypot(U, W), "mean speed norm $\\sqrt{\\bar U^2+\\bar W^2}$ [m/s]"),
            (ax[1, 1], beta, "flight path angle $\\beta$ [deg] (+ climbing)")]
    lv = {"U": r_level.mean_forward_speed_mps, "W": r_level.mean_vertical_speed_mps}
    lvals = [lv["U"], lv["W"], math.hypot(lv["U"], lv["W"]), r_level.flight_path_angle_deg]
    for (a, y, lab), yl in zip(spec, lvals):
        a.plot(A, y, "o-", ms=4, color="tab:blue", label="sweep (trims)")
        a.axvline(a_level, color="tab:green", ls="--", lw=1)
        a.plot([a_level], [yl], "*", ms=13, color="tab:green", label=f"level flight, A = {a_level:.3f} deg")
        a.axvline(PAPER_LEVEL_DEG, color="0.5", ls=":", lw=1, label=f"paper level, {PAPER_LEVEL_DEG} deg")
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    for a in (ax[0, 1], ax[1, 1]):
        a.axhline(0, color="k", lw=0.6)
    ax[1, 0].set_xlabel("shoulder flapping amplitude A [deg]")
    ax[1, 1].set_xlabel("shoulder flapping amplitude A [deg]")
    ax[0, 0].legend(fontsize=8, loc="upper left")
    fig.suptitle("Experiment 2: mean flight speeds against the flapping amplitude (default model)")
    fig.tight_layout()
    fig.savefig(out / "speeds.png", dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(1, 3, figsize=(14, 4.4))
    labels = ["$\\lambda_1$ (expanding)", "$\\lambda_{2}$", "$\\lambda_{3}$", "$\\lambda_4$"]
    mk = ["o", "s", "^", "v"]
    for k in (0, 1, 3):
        lab = labels[k] if k != 1 else "$\\lambda_{2,3}$ (complex pair)"
        ax[0].plot(A, mods[:, k], mk[k] + "-", ms=4, label=lab)
    ax[0].axhline(1, color="k", lw=0.8)
    ax[0].set_ylabel("modulus $|\\lambda|$")
    ax[0].set_title("moduli")
    pair = "$\\lambda_{2,3}$"
    for k, c in ((0, "tab:blue"), (1, "tab:orange"), (3, "tab:red")):
        ax[1].plot(A, mre[:, k], mk[k] + "-", ms=4, color=c, label="Re " + (labels[k] if k != 1 else pair))
    ax[1].plot(A, mim[:, 1], "s--", ms=4, color="tab:orange", mfc="none", label="$\\pm$Im $\\lambda_{2,3}$")
    ax[1].plot(A, mim[:, 2], "s--", ms=4, color="tab:orange", mfc="none")
    ax[1].axhline(0, color="k", lw=0.6)
    ax[1].set_title("real and imaginary parts")
    ax[2].plot(A, mods[:, 0], "o-", ms=5, color="tab:blue")
    ax[2].set_title("zoom: expanding multiplier $\\lambda_1$ (real)")
    ax[2].set_ylabel("$\\lambda_1$")
    ax[2].ticklabel_format(useOffset=False)
    for a in ax:
        a.axvline(a_level, color="tab:green", ls="--", lw=1, label=f"level, {a_level:.2f} deg")
        a.set_xlabel("shoulder flapping amplitude A [deg]")
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8, loc="lower right", bbox_to_anchor=(1.0, 0.1))
    ax[1].legend(fontsize=7.5, loc="center", bbox_to_anchor=(0.5, 0.5), ncol=2)
    fig.suptitle("Experiment 2: Floquet multipliers against the flapping amplitude (default model)")
    fig.tight_layout()
    fig.savefig(out / "multipliers.png", dpi=130)
    plt.close(fig)

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.6))
    for lab, (tt, xx, zz, r) in paths.items():
        col = next(c for k, c in colors.items() if k in lab)
        ax[0].plot(xx, 100 * zz, color=col, label=lab)
        ax[0].plot(xx[-1], 100 * zz[-1], "o", color=col, ms=4)
        # ten wingbeats by periodicity: position after k periods = k * (displacement over one)
        n = 10
        X10 = np.concatenate([xx[:-1] + k * xx[-1] for k in range(n)] + [[n * xx[-1]]])
        Z10 = np.concatenate([zz[:-1] + k * zz[-1] for k in range(n)] + [[n * zz[-1]]])
        ax[1].plot(X10, 100 * Z10, color=col, label=lab)
    ax[0].set_title("one wingbeat (T = 0.25 s)")
    ax[1].set_title("ten wingbeats (the periodic motion repeated)")
    for a in ax:
        a.set_xlabel("horizontal distance [m]")
        a.set_ylabel("height change [cm]")
        a.axhline(0, color="k", lw=0.6)
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.suptitle("Flight path of the centre of mass in the vertical plane (vertical axis stretched)")
    fig.tight_layout()
    fig.savefig(out / "trajectories.png", dpi=130)
    plt.close(fig)

    atomic_write_json(out / "result.json", res)

    # --- table.md
    L = ["# Experiment 2: level flight and the amplitude sweep", "",
         "## Level flight (amplitude free, mean vertical speed = 0, one NLP)", "",
         "| model | A level [deg] | paper [deg] | iterations | wall [s] (first / repeat) | mean W [m/s] | mean U [m/s] | multipliers |",
         "|---|---|---|---|---|---|---|---|"]
    for name, (r, s) in levels.items():
        ms = ", ".join(f"{m[0]:.5f}{m[1]:+.5f}j" if abs(m[1]) > 0 else f"{m[0]:.5f}" for m in s["multipliers"])
        L.append(f"| {name} | {s['amplitude_deg']:.4f} | {PAPER_LEVEL_DEG} | {s['iterations']} | "
                 f"{s['wall_s']:.1f} / {s['repeat_wall_s']:.1f} | {s['mean_vertical_speed_mps']:.1e} | "
                 f"{s['mean_forward_speed_mps']:.4f} | {ms} |")
    L += ["", f"## Sweep 40-46 deg (default model, warm starts): {len(rows)} points, "
              f"{sum(r['iterations'] for r in rows)} iterations, {sweep_wall:.1f} s", "",
          "| A [deg] | ok | it | wall [s] | mean U [m/s] | mean W [m/s] | beta [deg] | lambda1 | lambda2,3 | |lambda2,3| | lambda4 "
          "| valid | max effective α [deg] | span-time beyond stall |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['value']:.1f} | {'yes' if r['success'] else 'NO'} | {r['iterations']} | {r['wall_s']:.2f} | "
                 f"{r['mean_forward_speed_mps']:.4f} | {r['mean_vertical_speed_mps']:+.5f} | "
                 f"{r['flight_path_angle_deg']:+.4f} | {r['multiplier0_re']:.5f} | "
                 f"{r['multiplier1_re']:.5f} ± {abs(r['multiplier1_im']):.5f}j | {r['modulus1']:.5f} | "
                 f"{r['multiplier3_re']:.5f} | {'yes' if r['valid'] else 'NO'} | {r['alpha_eff_max_abs_deg']:.1f} | "
                 f"{r['stalled_fraction']:.1%} |")
    L += ["", "## Against the paper", "",
          f"- Level flight: {levels['default'][1]['amplitude_deg']:.3f} deg (default model), "
          f"{levels['relaxed_backward_difference'][1]['amplitude_deg']:.3f} deg (relaxed circulation + "
          f"backward-difference velocity); paper 43.47 deg.",
          f"- Mean vertical speed against A: linear fit slope {fit[0]:.5f} m/s per deg, largest deviation "
          f"from the line {lin_dev:.1e} m/s over 40-46 deg (paper: nearly linear).",
          f"- Expanding multiplier from {mods[0, 0]:.4f} (40 deg) to {mods[-1, 0]:.4f} (46 deg); complex pair "
          f"modulus {mods[0, 1]:.4f} to {mods[-1, 1]:.4f} (paper: the multipliers change only slightly).",
          f"- Model validity (birdocp.bird.validity, default thresholds): every sweep point "
          f"{'valid' if res['sweep']['all_valid'] else 'NOT all valid'}; largest effective angle of attack "
          f"{rows[0]['alpha_eff_max_abs_deg']:.1f} deg at {rows[0]['value']:g} deg, {rows[-1]['alpha_eff_max_abs_deg']:.1f} deg "
          f"at {rows[-1]['value']:g} deg (faster flight, smaller angles), "
          f"span-time beyond the {cfg.validity.stall_angle_deg:g} deg stall angle "
          f"{min(r['stalled_fraction'] for r in rows):.1%} to {max(r['stalled_fraction'] for r in rows):.1%} "
          f"(the wingtips in the downstroke); level flight: "
          + "; ".join(f"{k} {'valid' if v[1]['validity']['valid'] else 'NOT valid'}" for k, v in levels.items()) + ".",
          "- Trajectories over one wingbeat: "
          + "; ".join(f"{lab}: {v['horizontal_distance_m']:.3f} m forward, {_cm(v['height_change_m'])} cm"
                      for lab, v in res["trajectories"].items()) + "."]
    atomic_write_text(out / "table.md", "\n".join(L) + "\n")
    print("\n".join(L))


if __name__ == "__main__":
    main()
