"""Lateral feedback of the flapping ibis in six degrees of freedom: the periodic LQR of per-side gait
corrections (each wing's amplitude, sweep and incidence offsets) on the exact 8-state wingbeat map
(heading excluded), at the paper's gait (A = 42 deg) and in level flight, and the nonlinear response
to a side gust and to a roll perturbation, open and closed loop.

Writes result.json (gains, open- and closed-loop multipliers, each control alone, the simulations'
summaries), table.md, multipliers.png, side_gust.png and roll.png.

    python scripts/lateral_control_study.py --out results/lateral/control
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.engine.results import to_jsonable
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.plots.lateral_simulation import plot_lateral_simulation
from birdocp.studies.lateral_control import design_lateral_controller, lateral_reference_cycle, sides_parameters
from birdocp.studies.lateral_simulate import SideGust, simulate_lateral
from script_common import parse_with_out, script_parser

BEATS = 24
"""Wingbeats of every simulation (6 s at 4 Hz)."""
SIDE_GUST = SideGust(amplitude_mps=2.0, length_beats=1.0, start_beats=1.0, shape="pulse")
"""A 2 m/s side-wind pulse one beat long (about 4.4 m of the path), starting after one beat."""
ROLL_RAD = 0.1
"""Initial bank perturbation [rad] (5.7 deg, right wing down)."""


def design(cfg, level: bool) -> tuple:
    """(cycle, its configuration, controller, summary dict) at the paper's gait or in level flight."""
    t0 = time.perf_counter()
    res, ccfg = lateral_reference_cycle(cfg, level)
    assert res.success, res.cycle.message
    ctl = design_lateral_controller(res, ccfg)
    d = ctl.to_dict()
    keep = ("controls", "gain", "gain_units", "state_names", "open_loop_multipliers", "closed_loop_multipliers",
            "open_loop_spectral_radius", "closed_loop_spectral_radius", "beats_to_reduce_100x", "per_control",
            "cycle_x0", "cycle_valid", "cycle_validity", "limits")
    summary = {k: d[k] for k in keep}
    summary.update(amplitude_deg=res.amplitude_deg, cycle_max_residual=res.cycle.max_residual,
                   cycle_multipliers=res.to_dict()["multipliers"], lateral_modes=res.to_dict()["lateral_modes"],
                   wall_s=time.perf_counter() - t0)
    print(f"{'level' if level else 'A=42'}: open rho {d['open_loop_spectral_radius']:.4f} -> closed "
          f"{d['closed_loop_spectral_radius']:.4f} ({summary['wall_s']:.0f} s)")
    return res, ccfg, ctl, summary


def responses(res, ccfg, ctl, out) -> dict:
    """Side gust and roll perturbation, open and closed loop: summaries, and the two figures."""
    p = sides_parameters(res.cycle.p)
    steps = int(res.cycle.method["steps_per_period"])
    dx = np.zeros(9)
    dx[6] = ROLL_RAD
    cases = {"side_gust": {"side_gust": SIDE_GUST}, "roll": {"perturbation": dx}}
    found = {}
    for name, kw in cases.items():
        runs = {}
        for loop, c in (("open loop", None), ("closed loop", ctl)):
            s = simulate_lateral(ccfg, res.cycle.x0, p, BEATS, steps_per_period=steps, controller=c, **kw)
            d = s.to_dict()
            found[f"{name}, {loop}"] = {k: d[k] for k in (
                "status", "message", "success", "saturated", "deviation_per_beat", "peak_deviation", "peak_beat",
                "final_deviation", "beats_to_recover", "max_abs_bank_deg", "final_heading_deg", "max_abs_east_drift_m",
                "control_range", "min_air_forward_speed_mps", "max_airflow_body_angle_deg", "side_gust", "perturbation",
                "distance_per_beat_m")}
            runs[loop] = dict(s.arrays(), control_keys=s.control_keys)
            print(f"  {name}, {loop}: {s.status}, final deviation {d['final_deviation']:.3g}, peak bank "
                  f"{d['max_abs_bank_deg']:.3g} deg")
        title = ("side gust: 2 m/s pulse, 1 beat" if name == "side_gust" else f"roll perturbation {ROLL_RAD} rad") \
            + f" (paper gait A = 42 deg, {BEATS} beats)"
        plot_lateral_simulation(runs, out / f"{name}.png", title)
    return found


def multipliers_figure(designs: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(designs), figsize=(5 * len(designs), 5))
    t = np.linspace(0, 2 * np.pi, 400)
    for ax, (name, d) in zip(np.atleast_1d(axes), designs.items()):
        ax.plot(np.cos(t), np.sin(t), "k-", lw=0.8)
        for key, mark, label in (("open_loop_multipliers", "x", "open loop"), ("closed_loop_multipliers", "o",
                                                                              "closed loop (LQR)")):
            z = np.array(d[key], float)
            ax.plot(z[:, 0], z[:, 1], mark, ms=9, mfc="none", label=label)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_title(f"{name}: A = {d['amplitude_deg']:.2f} deg, model "
                     f"{'valid' if d['cycle_valid'] else 'NOT valid'} on the cycle", fontsize=10)
        ax.set_xlabel("Re")
        ax.set_ylabel("Im")
        ax.legend(fontsize=8, loc="lower left")
    fig.suptitle("8-state wingbeat map of the 6-DOF ibis (heading excluded), per-side amplitude/sweep/incidence")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(res: dict) -> str:
    lines = ["| cycle | amplitude [deg] | valid | open-loop rho | closed-loop rho | beats to /100 |", "|---" * 6 + "|"]
    for name, d in res["designs"].items():
        lines.append(f"| {name} | {d['amplitude_deg']:.3f} | {d['cycle_valid']} | {d['open_loop_spectral_radius']:.4f} "
                     f"| {d['closed_loop_spectral_radius']:.4f} | {d['beats_to_reduce_100x']:.1f} |")
    lines += ["", "| response | status | peak bank [deg] | final heading [deg] | max east drift [m] | "
                  "deviation at the last beat simulated | saturated |", "|---" * 7 + "|"]
    for name, r in res["responses"].items():
        lines.append(f"| {name} | {r['status']} | {r['max_abs_bank_deg']:.2f} | {r['final_heading_deg']:.2f} | "
                     f"{r['max_abs_east_drift_m']:.2f} | {r['final_deviation']:.3g} | {r['saturated']} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/control")
    args, out = parse_with_out(ap, argv)
    cfg = with_values(Config(), {"model.degrees_of_freedom": 6})
    t0 = time.perf_counter()
    designs, found = {}, {}
    for name, level in (("paper gait", False), ("level flight", True)):
        res, ccfg, ctl, summary = design(cfg, level)
        designs[name] = summary
        if not level:
            found = responses(res, ccfg, ctl, out)
    result = {"designs": designs, "responses": found, "beats": BEATS, "wall_s": time.perf_counter() - t0,
              "note": "heading psi excluded from the map and the controller (its multiplier is 1 open and closed loop)"}
    atomic_write_json(out / "result.json", to_jsonable(result))
    atomic_write_text(out / "table.md", table(result))
    multipliers_figure(designs, out / "multipliers.png")
    print(table(result))


if __name__ == "__main__":
    main()
