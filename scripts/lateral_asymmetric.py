"""The six-degree-of-freedom model features of an asymmetric gait, measured: the validity of the turn
over both wings and its modes labelled by eigenvector content, the mirror check (left and right
offsets swapped), wing masses with the asymmetric gait in vacuum (momentum and angular momentum), a
short continuation in one wing's sweep offset, a vertical gust on the symmetric cycle against the planar
simulation, and the symmetric cycle with the optional drag against the planar one.

Writes result.json and table.md to --out (default results/lateral/asymmetric); the numbers of
docs/studies/lateral.md (asymmetric gaits) come from here.

    python scripts/lateral_asymmetric.py --out results/lateral/asymmetric
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.bird.sixdof import LONGITUDINAL
from script_common import parse_with_out, script_parser, write_result

SIX = {"model.degrees_of_freedom": 6}
TURN = {"gait.right_offset.shoulder_flap.amplitude_deg": 1.0, "gait.right_offset.shoulder_sweep.offset_deg": -1.0}
MIRRORED = {k.replace("right_offset", "left_offset"): v for k, v in TURN.items()}
MASSES = {"wing.mass_kg": 0.086, "tail.opening_angle_deg": 20.0,
          "gait.right_offset.shoulder_flap.amplitude_deg": 6.0, "gait.right_offset.shoulder_sweep.offset_deg": -4.0,
          "gait.left_offset.elbow_flex.offset_deg": 5.0}
DRAG = {"drag.body_drag_coefficient": 0.1, "drag.profile_drag_coefficient": 0.014}


def _modes(res) -> list:
    return [{"label": m["label"], "multiplier": [m["multiplier"].real, m["multiplier"].imag],
             "modulus": abs(m["multiplier"]), "beats_to_double": m["beats_to_double"],
             "lateral_share": m["lateral_share"]} for m in res.lateral_modes]


def turn() -> dict:
    """The asymmetric turn and its mirror image (default grid)."""
    from birdocp.studies.lateral import lateral_trim

    a, b = lateral_trim(with_values(Config(), {**SIX, **TURN})), lateral_trim(with_values(Config(), {**SIX, **MIRRORED}))
    va, vb = a.validity.to_dict(), b.validity.to_dict()
    keys = ("valid", "stalled_fraction", "stalled_fraction_left", "stalled_fraction_right", "max_sideslip_deg",
            "max_abs_bank_deg", "max_airflow_body_angle_deg", "alpha_eff_min_deg", "alpha_eff_max_deg")
    return {"success": a.success and b.success, "max_residual": a.cycle.max_residual,
            "heading_change_deg": a.heading_change_deg, "phi0_rad": float(a.cycle.x0[6]),
            "validity": {k: va[k] for k in keys}, "mirrored_validity": {k: vb[k] for k in keys},
            "modes": _modes(a), "longitudinal_moduli": np.abs(a.longitudinal_multipliers).tolist(),
            "coupling_max": a.coupling_max,
            "mirror_heading_sum_deg": a.heading_change_deg + b.heading_change_deg,
            "mirror_moduli_diff": float(np.max(np.abs(np.sort(np.abs(a.multipliers)) - np.sort(np.abs(b.multipliers)))))}


def vacuum() -> dict:
    from birdocp.studies.lateral_checks import vacuum_drift

    r = vacuum_drift(with_values(Config(), {**SIX, **MASSES}), (50, 100, 200), one_wing=False)
    return {"steps_per_beat": r["steps_per_beat"], "drift": r["drift"], "ratios": r["ratios"],
            "initial_angular_momentum_kgm2ps": r["initial"][3:]}


def branch() -> dict:
    from birdocp.studies.branch import bird_branch

    br = bird_branch(with_values(Config(), SIX), "gait.right_offset.shoulder_sweep.offset_deg", 0.0, -2.0,
                     max_points=8)
    return {"end_reason": br.end_reason, "offset_deg": [p.parameter for p in br.points],
            "phi0_rad": [float(p.x0[6]) for p in br.points], "valid": [p.validity["valid"] for p in br.points],
            "stalled_fraction_left": [p.validity["stalled_fraction_left"] for p in br.points],
            "stalled_fraction_right": [p.validity["stalled_fraction_right"] for p in br.points],
            "lateral_moduli": [[float(np.hypot(*m)) for m in ms] for ms in br.settings["lateral_multipliers"]]}


def gust() -> dict:
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.lateral_control import sides_parameters
    from birdocp.studies.lateral_simulate import simulate_lateral
    from birdocp.studies.simulate import Gust, simulate

    cfg = with_values(Config(), SIX)
    res = lateral_trim(cfg)
    steps, x0 = int(res.cycle.method["steps_per_period"]), np.asarray(res.cycle.x0)
    g = [Gust("vertical", 3.0, 1.0)]
    six = simulate_lateral(cfg, x0, sides_parameters(res.cycle.p), 4, steps_per_period=steps, gusts=g)
    planar = simulate(Config(), x0[list(LONGITUDINAL)], 4, steps_per_period=steps, gusts=g)
    scale = np.abs(planar.states).max(axis=0)
    return {"success": six.success, "status": six.status, "beats": 4, "gust_mps": 3.0,
            "max_rel_diff_longitudinal": float(np.abs((six.states[:, list(LONGITUDINAL)] - planar.states) / scale).max()),
            "max_abs_lateral": float(np.abs(six.states[:, [1, 3, 5, 6, 8]]).max()),
            "max_stalled_fraction_per_beat": six.max_stalled_fraction,
            "planar_max_stalled_fraction_per_beat": planar.max_stalled_fraction}


def drag() -> dict:
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), DRAG)
    a, b = lateral_trim(with_values(cfg, SIX)), trim(cfg)
    return {"success": a.success and b.success,
            "max_abs_x0_diff": float(np.abs(np.asarray(a.cycle.x0)[list(LONGITUDINAL)] - b.cycle.x0).max()),
            "max_abs_multiplier_diff": float(np.abs(np.sort_complex(a.longitudinal_multipliers)
                                                    - np.sort_complex(b.multipliers)).max()),
            "longitudinal_moduli": np.abs(a.longitudinal_multipliers).tolist(),
            "lateral_moduli": np.abs(a.lateral_multipliers).tolist(), "valid": a.validity.valid,
            "coupling_max": a.coupling_max}


def table(r: dict) -> str:
    t, v = r["turn"], r["turn"]["validity"]
    rows = "\n".join(f"| {m['label']} | {m['modulus']:.4f} | {m['lateral_share']:.4f} | {m['beats_to_double']:.3g} |"
                     for m in t["modes"])
    return f"""# Asymmetric gait in six degrees of freedom (measured by scripts/lateral_asymmetric.py)

Turn: right wing +1 deg flap amplitude, -1 deg sweep offset (default grid). Heading change
{t['heading_change_deg']:.4f} deg per beat, phi(0) {t['phi0_rad']:.4f} rad, residual {t['max_residual']:.1e}.
Validity: valid {v['valid']}, stalled share left {v['stalled_fraction_left']:.4f}, right
{v['stalled_fraction_right']:.4f}, max sideslip {v['max_sideslip_deg']:.3f} deg, max bank {v['max_abs_bank_deg']:.2f} deg,
airflow-body angle {v['max_airflow_body_angle_deg']:.2f} deg. Coupling max {t['coupling_max']:.2e}.

| lateral mode | modulus | lateral share | beats to double |
|---|---|---|---|
{rows}

Longitudinal moduli: {', '.join(f'{x:.4f}' for x in t['longitudinal_moduli'])}.
Mirror: heading sum {t['mirror_heading_sum_deg']:.1e} deg, moduli diff {t['mirror_moduli_diff']:.1e}.

Vacuum, wing masses with the asymmetric gait: drift {', '.join(f'{x:.2e}' for x in r['vacuum']['drift'])} at
{r['vacuum']['steps_per_beat']} RK4 steps per beat (ratios {', '.join(f'{x:.2f}' for x in r['vacuum']['ratios'])}).

Vertical gust 3 m/s on the symmetric cycle, 4 beats: 6-DOF vs planar max relative difference
{r['gust']['max_rel_diff_longitudinal']:.1e}, lateral states {r['gust']['max_abs_lateral']:.1e}, stalled share per beat
{r['gust']['max_stalled_fraction_per_beat']:.4f} (planar {r['gust']['planar_max_stalled_fraction_per_beat']:.4f}).

Drag on (C_Db 0.1, C_Dpro 0.014): 6-DOF vs planar cycle x0 {r['drag']['max_abs_x0_diff']:.1e}, multipliers
{r['drag']['max_abs_multiplier_diff']:.1e}; lateral moduli {', '.join(f'{x:.4f}' for x in r['drag']['lateral_moduli'])}.

Continuation in gait.right_offset.shoulder_sweep.offset_deg 0 -> -2: {len(r['branch']['offset_deg'])} points
({r['branch']['end_reason']}), phi(0) {r['branch']['phi0_rad'][0]:.1e} -> {r['branch']['phi0_rad'][-1]:.4f} rad.

Wall time {r['wall_s']:.0f} s.
"""


def main(argv=None) -> dict:
    ap = script_parser(__doc__, "results/lateral/asymmetric")
    _, out = parse_with_out(ap, argv)
    t0 = time.perf_counter()
    res = {"turn": turn(), "vacuum": vacuum(), "branch": branch(), "gust": gust(), "drag": drag()}
    res["wall_s"] = time.perf_counter() - t0
    write_result(out, res, table(res))
    return res


if __name__ == "__main__":
    main()
