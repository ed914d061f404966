"""The stall-aware section (aero.section = "stall") in six degrees of freedom, measured: the paper's
symmetric gait against the planar stall cycle (x0, multipliers, coupling) with its lateral modes beside
the linear section's, and an asymmetric turn with its mirror image (left and right offsets swapped).

Writes result.json and table.md to --out (default results/lateral/stall); the numbers of
docs/studies/lateral.md (the stall-aware section in six degrees of freedom) come from here.

    python scripts/lateral_stall.py --out results/lateral/stall
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL
from script_common import parse_with_out, script_parser, write_result

SIX = {"model.degrees_of_freedom": 6}
STALL = {"aero.section": "stall"}
TURN = {"gait.right_offset.shoulder_flap.amplitude_deg": 1.0, "gait.right_offset.shoulder_sweep.offset_deg": -1.0,
        "gait.left_offset.shoulder_incidence.offset_deg": 0.5}
MIRRORED = {k.replace("right_", "X_").replace("left_", "right_").replace("X_", "left_"): v for k, v in TURN.items()}
FLIP = np.array([1, -1, 1, -1, 1, -1, -1, 1, -1.0])


def _modes(res) -> list:
    return [{"label": m["label"], "multiplier": [m["multiplier"].real, m["multiplier"].imag],
             "modulus": abs(m["multiplier"]), "beats_to_double": m["beats_to_double"]} for m in res.lateral_modes]


def symmetric(method: dict) -> dict:
    """The paper's gait with the stall section in 6 DOF against the planar stall trim, and the linear
    section's 6-DOF lateral modes beside it."""
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.trim import trim

    six = lateral_trim(with_values(Config(), {**SIX, **STALL}), **method)
    planar = trim(with_values(Config(), STALL), **method)
    linear = lateral_trim(with_values(Config(), SIX), **method)
    x0 = np.asarray(six.cycle.x0)
    return {"success": six.success and planar.success and linear.success, "max_residual": six.cycle.max_residual,
            "max_abs_x0_diff": float(np.abs(x0[list(LONGITUDINAL)] - planar.x0).max()),
            "max_abs_lateral_x0": float(np.abs(x0[list(LATERAL)]).max()),
            "max_abs_multiplier_diff": float(np.abs(np.sort_complex(six.longitudinal_multipliers)
                                                    - np.sort_complex(planar.multipliers)).max()),
            "coupling_max": six.coupling_max, "heading_multiplier": six.heading_multiplier,
            "longitudinal_moduli": np.abs(six.longitudinal_multipliers).tolist(),
            "modes": _modes(six), "linear_modes": _modes(linear), "valid": bool(six.validity.valid),
            "stalled_fraction": six.validity.to_dict()["stalled_fraction"],
            "separated_fraction": six.validity.to_dict().get("separated_fraction")}


def turn(method: dict) -> dict:
    """The asymmetric gait with the stall section and its mirror image."""
    from birdocp.bird.sixdof import sixdof_model
    from birdocp.studies.lateral import heading_trajectory, lateral_trim

    ca_, cb_ = (with_values(Config(), {**SIX, **STALL, **o}) for o in (TURN, MIRRORED))
    a, free = lateral_trim(ca_, **method), lateral_trim(cb_, **method)
    # the mirror image of a's cycle solves the mirrored gait: start there (from the symmetric start the
    # mirrored gait's solve may reach another of its cycles, reported as ``independent``)
    b = lateral_trim(cb_, x_guess=list(FLIP[:8] * np.asarray(a.cycle.x0)) + [0.0], **method)
    _, Xa = heading_trajectory(sixdof_model(ca_), a.cycle)
    _, Xb = heading_trajectory(sixdof_model(cb_), b.cycle)
    scale = np.abs(Xa).max(axis=0) + 1e-3
    va, vb = a.validity.to_dict(), b.validity.to_dict()
    return {"success": a.success and b.success, "max_residual": a.cycle.max_residual,
            "heading_change_deg": a.heading_change_deg, "phi0_rad": float(a.cycle.x0[6]),
            "mirror_max_rel_state_diff": float(np.abs((Xb - Xa * FLIP) / scale).max()),
            "mirror_heading_sum_deg": a.heading_change_deg + b.heading_change_deg,
            "mirror_moduli_diff": float(np.max(np.abs(np.sort(np.abs(a.multipliers)) - np.sort(np.abs(b.multipliers))))),
            "moduli": np.sort(np.abs(a.multipliers))[::-1].tolist(), "modes": _modes(a), "valid": bool(va["valid"]),
            "stalled_fraction_left": va["stalled_fraction_left"], "stalled_fraction_right": va["stalled_fraction_right"],
            "mirrored_stalled_fraction_left": vb["stalled_fraction_left"],
            "mirrored_stalled_fraction_right": vb["stalled_fraction_right"],
            "independent": {"success": free.success, "heading_change_deg": free.heading_change_deg,
                            "phi0_rad": float(free.cycle.x0[6]), "valid": bool(free.validity.valid),
                            "moduli": np.sort(np.abs(free.multipliers))[::-1].tolist(),
                            "stalled_fraction_left": free.validity.to_dict()["stalled_fraction_left"],
                            "stalled_fraction_right": free.validity.to_dict()["stalled_fraction_right"]}}


def table(r: dict) -> str:
    s, t = r["symmetric"], r["turn"]

    def modes(ms):
        return ", ".join(f"{m['label']} {m['modulus']:.4f}" for m in ms)

    return f"""# The stall-aware section in six degrees of freedom (measured by scripts/lateral_stall.py)

Grid: {r['method']['points']} shooting points, {r['method']['steps_per_period']} RK4 steps per period.

Paper's gait (symmetric), aero.section = "stall": 6-DOF vs planar stall cycle x0 {s['max_abs_x0_diff']:.1e},
lateral x0 {s['max_abs_lateral_x0']:.1e}, multipliers {s['max_abs_multiplier_diff']:.1e}; coupling {s['coupling_max']:.1e},
heading multiplier {s['heading_multiplier']:.12g}; residual {s['max_residual']:.1e}. Valid {s['valid']}, stalled share
{s['stalled_fraction']:.4f}, separated share {s['separated_fraction']:.4f}.
Longitudinal moduli: {', '.join(f'{x:.4f}' for x in s['longitudinal_moduli'])}.
Lateral modes, stall: {modes(s['modes'])}.
Lateral modes, linear section: {modes(s['linear_modes'])}.

Turn (right wing +1 deg flap amplitude, -1 deg sweep offset, left wing +0.5 deg incidence), stall section:
heading change {t['heading_change_deg']:.4f} deg per beat, phi(0) {t['phi0_rad']:.4f} rad, residual
{t['max_residual']:.1e}, valid {t['valid']} (stalled share left {t['stalled_fraction_left']:.4f}, right
{t['stalled_fraction_right']:.4f}). Moduli: {', '.join(f'{x:.4f}' for x in t['moduli'])}.
Mirror (offsets swapped, solved from the mirror image of the cycle): states {t['mirror_max_rel_state_diff']:.1e}
relative, heading sum {t['mirror_heading_sum_deg']:.1e} deg, moduli {t['mirror_moduli_diff']:.1e}; stalled shares
left/right of the mirror {t['mirrored_stalled_fraction_left']:.4f}/{t['mirrored_stalled_fraction_right']:.4f}.
The mirrored gait solved from the symmetric start instead: heading change
{t['independent']['heading_change_deg']:.4f} deg per beat, phi(0) {t['independent']['phi0_rad']:.4f} rad, valid
{t['independent']['valid']} (stalled share left {t['independent']['stalled_fraction_left']:.4f}, right
{t['independent']['stalled_fraction_right']:.4f}), moduli {', '.join(f'{x:.4f}' for x in t['independent']['moduli'])}.

Wall time {r['wall_s']:.0f} s.
"""


def main(argv=None) -> dict:
    ap = script_parser(__doc__, "results/lateral/stall")
    ap.add_argument("--points", type=int, default=5, help="shooting points (default %(default)s)")
    ap.add_argument("--steps", type=int, default=148, help="RK4 steps per period (default %(default)s)")
    args, out = parse_with_out(ap, argv)
    method = {"points": args.points, "steps_per_period": args.steps}
    t0 = time.perf_counter()
    res = {"method": method, "symmetric": symmetric(method), "turn": turn(method)}
    res["wall_s"] = time.perf_counter() - t0
    write_result(out, res, table(res))
    return res


if __name__ == "__main__":
    main()
