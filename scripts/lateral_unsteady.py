"""Wagner's unsteady section and dynamic stall in six degrees of freedom, measured: the paper's
symmetric gait (amplitude 42 deg) trimmed in 6 DOF with ``aero.unsteady = "wagner"``, ``aero.section =
"dynamic-stall"`` and both, each against the planar cycle of the same model (x0 with the aerodynamic
states, the longitudinal multipliers against the planar monodromy's symmetric block, the coupling of the
longitudinal and lateral blocks, the heading multiplier), with the lateral body modes (roll, spiral,
Dutch roll), the largest antisymmetric aerodynamic multiplier and the validity of every cycle, beside
the quasi-steady linear section's 6-DOF modes.

Writes result.json and table.md to --out (default results/lateral/unsteady); the numbers of
docs/studies/lateral.md (unsteady and dynamic-stall sections in six degrees of freedom) come from here.

    python scripts/lateral_unsteady.py --out results/lateral/unsteady
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL
from script_common import parse_with_out, script_parser, write_result

SIX = {"model.degrees_of_freedom": 6}
CASES = {"quasi_steady": {}, "wagner": {"aero.unsteady": "wagner"}, "dynamic_stall": {"aero.section": "dynamic-stall"},
         "wagner_dynamic_stall": {"aero.unsteady": "wagner", "aero.section": "dynamic-stall"}}


def _modes(res) -> list:
    return [{"label": m["label"], "multiplier": [m["multiplier"].real, m["multiplier"].imag],
             "modulus": abs(m["multiplier"]), "beats_to_double": m["beats_to_double"],
             "body_share": m.get("body_share")} for m in res.lateral_modes]


def _planar_symmetric_multipliers(planar) -> np.ndarray:
    """The planar cycle's multipliers of its symmetric block (body states and the symmetric parts of the
    aerodynamic states), from its monodromy in the mirror basis."""
    from birdocp.studies.lateral_aero import mirror_basis, split_indices

    n_air = len(planar.x0) - 4
    if not n_air:
        return np.asarray(planar.multipliers)
    M = np.asarray(planar.cycle.monodromy)
    B = mirror_basis(4, n_air)
    lon, _ = split_indices(range(4), (), 4, n_air)
    return np.linalg.eigvals((B @ M @ B.T)[np.ix_(lon, lon)])


def case(name: str, overrides: dict, method: dict, start=None) -> dict:
    """One model at the paper's gait: the 6-DOF cycle against the planar one, the lateral modes;
    ``start``: a planar body state (u, w, q, theta) to start both from (the aerodynamic states on the
    quasi-steady manifold there)."""
    from birdocp.bird.sixdof import embed_planar_state
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.trim import trim

    t0 = time.perf_counter()
    six = lateral_trim(with_values(Config(), {**SIX, **overrides}),
                       x_guess=None if start is None else embed_planar_state(start), **method)
    t1 = time.perf_counter()
    planar = trim(with_values(Config(), overrides), x_guess=start, **method)
    x0, xp = np.asarray(six.cycle.x0), np.asarray(planar.x0)
    lon6 = np.concatenate([x0[list(LONGITUDINAL)], x0[9:]])
    pm = _planar_symmetric_multipliers(planar) if planar.success else None
    aero = [m for m in six.lateral_modes if m["label"] == "aerodynamic"]
    v = six.validity.to_dict() if six.validity is not None else None
    return {"case": name, "overrides": overrides, "start": None if start is None else [float(v) for v in start],
            "x0_body_planar": xp[:4].tolist(), "success": bool(six.success and planar.success),
            "max_residual": six.cycle.max_residual, "n_states": int(x0.size),
            "max_abs_x0_diff": float(np.abs(lon6 - xp).max()), "max_abs_lateral_x0": float(np.abs(x0[list(LATERAL)]).max()),
            "max_abs_multiplier_diff": None if pm is None else float(np.abs(np.sort_complex(six.longitudinal_multipliers)
                                                                            - np.sort_complex(pm)).max()),
            "coupling_max": six.coupling_max, "heading_multiplier": six.heading_multiplier,
            "lambda1": float(np.abs(six.longitudinal_multipliers).max()) if six.success else None,
            "modes": [m for m in _modes(six) if m["label"] != "aerodynamic"],
            "aerodynamic_modes_largest": sorted([m for m in _modes(six) if m["label"] == "aerodynamic"],
                                                key=lambda m: -m["modulus"])[:4],
            "largest_antisymmetric_aero_modulus": max((abs(m["multiplier"]) for m in aero), default=None),
            "lateral_stable": six.lateral_stable, "valid": bool(v and v["valid"]), "validity": v,
            "wall_s_6dof": t1 - t0, "wall_s_planar": time.perf_counter() - t1}


def _e(v) -> str:
    return "—" if v is None else f"{v:.1e}"


def _f(v) -> str:
    return "—" if v is None else f"{v:.4f}"


def table(r: dict) -> str:
    rows = ["| case | states | \\|Λ1\\| | roll | spiral | Dutch roll | largest antisym. aero | x0 vs planar | "
            "multipliers vs planar | coupling | valid |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for c in r["cases"]:
        lab = {}
        for m in c["modes"]:
            lab.setdefault(m["label"], m)
        roll, spiral, dutch = (lab.get(k) for k in ("roll_subsidence", "spiral", "dutch_roll_like"))
        dr = "—" if dutch is None else f"{dutch['modulus']:.4f} ({dutch['multiplier'][0]:.4f} ± {abs(dutch['multiplier'][1]):.4f}i)"
        aero = c["largest_antisymmetric_aero_modulus"]
        rows.append(f"| {c['case']} | {c['n_states']} | {_f(c['lambda1'])} | "
                    f"{'—' if roll is None else format(roll['modulus'], '.2e')} | "
                    f"{'—' if spiral is None else format(spiral['modulus'], '.4f')} | {dr} | "
                    f"{'—' if aero is None else format(aero, '.4f')} | {c['max_abs_x0_diff']:.1e} | "
                    f"{_e(c['max_abs_multiplier_diff'])} | {c['coupling_max']:.1e} | {c['valid']} |")
    return (f"# Unsteady and dynamic-stall sections in six degrees of freedom (measured by scripts/lateral_unsteady.py)\n\n"
            f"Paper's gait (amplitude 42 deg, symmetric), {r['method']['points']} shooting points, "
            f"{r['method']['steps_per_period']} RK4 steps per period. Moduli of the lateral body modes; \\|Λ1\\| the "
            "largest longitudinal modulus; 'vs planar' the largest difference from the planar cycle of the same model "
            "(x0 with the aerodynamic states; longitudinal multipliers against the planar monodromy's symmetric "
            "block); coupling the largest entry between the longitudinal and lateral blocks in the mirror basis.\n\n"
            + "\n".join(rows) + f"\n\nWall time {r['wall_s']:.0f} s.\n")


def main(argv=None) -> dict:
    ap = script_parser(__doc__, "results/lateral/unsteady")
    ap.add_argument("--points", type=int, default=5, help="shooting points (default %(default)s)")
    ap.add_argument("--steps", type=int, default=148, help="RK4 steps per period (default %(default)s)")
    args, out = parse_with_out(ap, argv)
    method = {"points": args.points, "steps_per_period": args.steps}
    t0 = time.perf_counter()
    res = {"method": method, "cases": []}
    for k, v in CASES.items():  # both sections with Wagner start from the Wagner cycle (as scripts/aero_study.py)
        start = res["cases"][1]["x0_body_planar"] if k == "wagner_dynamic_stall" else None
        res["cases"].append(case(k, v, method, start))
    res["wall_s"] = time.perf_counter() - t0
    write_result(out, res, table(res))
    return res


if __name__ == "__main__":
    main()
