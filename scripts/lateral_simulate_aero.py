"""Lateral feedback and many-beat simulation of the six-degree-of-freedom ibis with aerodynamic states
(``aero.unsteady = "wagner"``, ``aero.section = "dynamic-stall"``) beside the quasi-steady section, at
the paper's gait (A = 42 deg) on one grid: the periodic LQR of the six per-side controls designed on the
full wingbeat map (8 body states, heading excluded, and the aerodynamic states) and applied on the 8
body states (the aerodynamic columns folded through the quasi-steady manifold's slope), and the
nonlinear response to a 2 m/s side-gust pulse and to a 0.1 rad bank perturbation, open and closed loop
(the cases of scripts/lateral_control_study.py).

Writes result.json and table.md to --out (default results/lateral/simulate_aero); the numbers of
docs/studies/lateral.md (simulation and feedback with aerodynamic states) come from here.

    python scripts/lateral_simulate_aero.py --out results/lateral/simulate_aero
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.studies.lateral_simulate import SideGust, simulate_lateral
from script_common import parse_with_out, script_parser, write_result

BEATS = 24
"""Wingbeats of every simulation (6 s at 4 Hz)."""
SIDE_GUST = SideGust(amplitude_mps=2.0, length_beats=1.0, start_beats=1.0, shape="pulse")
"""A 2 m/s side-wind pulse one beat long, starting after one beat."""
ROLL_RAD = 0.1
"""Initial bank perturbation [rad]."""
CASES = {"quasi_steady": {}, "wagner": {"aero.unsteady": "wagner"}, "dynamic_stall": {"aero.section": "dynamic-stall"}}


def _summary(sim) -> dict:
    d = sim.to_dict()
    return {k: d[k] for k in ("status", "message", "peak_deviation", "final_deviation", "beats_to_recover",
                              "max_abs_bank_deg", "final_heading_deg", "max_abs_east_drift_m", "saturated",
                              "max_stalled_fraction_per_beat", "control_range")}


def case(name: str, overrides: dict, method: dict) -> dict:
    """One section model: its 6-DOF cycle, the controller, the four responses."""
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.lateral_control import design_lateral_controller, sides_parameters

    cfg = with_values(Config(), {"model.degrees_of_freedom": 6, **overrides})
    t0 = time.perf_counter()
    res = lateral_trim(cfg, **method)
    assert res.success, res.cycle.message
    t1 = time.perf_counter()
    ctl = design_lateral_controller(res, cfg)
    d = ctl.to_dict()
    t2 = time.perf_counter()
    p, steps = sides_parameters(res.cycle.p), method["steps_per_period"]
    dx = np.zeros(9)
    dx[6] = ROLL_RAD
    runs = {}
    for what, kw in {"side_gust": {"side_gust": SIDE_GUST}, "roll": {"perturbation": dx}}.items():
        for loop, c in (("open", None), ("closed", ctl)):
            runs[f"{what}_{loop}"] = _summary(simulate_lateral(cfg, res.cycle.x0, p, BEATS, steps_per_period=steps,
                                                               controller=c, **kw))
    v = res.validity.to_dict() if res.validity is not None else None
    out = {"case": name, "overrides": overrides, "n_states": len(res.cycle.x0), "max_residual": res.cycle.max_residual,
           "valid": bool(v and v["valid"]), "cycle_multipliers": res.to_dict()["multipliers"],
           "open_loop_spectral_radius": d["open_loop_spectral_radius"],
           "closed_loop_spectral_radius": d["closed_loop_spectral_radius"],
           "full_state_spectral_radius": d.get("full_state_spectral_radius"),
           "aero_states": d.get("aero_states", 0), "beats_to_reduce_100x": d["beats_to_reduce_100x"],
           "gain": d["gain"], "state_names": d["state_names"], "controls": d["controls"], "responses": runs,
           "wall_s": {"trim": t1 - t0, "design": t2 - t1, "simulations": time.perf_counter() - t2}}
    print(f"{name}: open rho {out['open_loop_spectral_radius']:.4f} -> closed {out['closed_loop_spectral_radius']:.4f} "
          f"(full-state {out['full_state_spectral_radius']}); {out['wall_s']}", flush=True)
    return out


def _g(v, fmt=".3g") -> str:
    return "—" if v is None else format(v, fmt)


def table(r: dict) -> str:
    rows = ["| case | states | open-loop ρ | closed loop ρ (body gains) | full-state gains ρ |",
            "|---|---|---|---|---|"]
    for c in r["cases"]:
        rows.append(f"| {c['case']} | {c['n_states']} | {c['open_loop_spectral_radius']:.4f} | "
                    f"{c['closed_loop_spectral_radius']:.4f} | {_g(c['full_state_spectral_radius'], '.4f')} |")
    resp = ["| case | response | status | peak bank [deg] | final heading [deg] | largest east drift [m] | "
            "final deviation | beats to recover |", "|---|---|---|---|---|---|---|---|"]
    for c in r["cases"]:
        for k, s in c["responses"].items():
            resp.append(f"| {c['case']} | {k.replace('_', ' ')} | {s['status']} | {_g(s['max_abs_bank_deg'])} | "
                        f"{_g(s['final_heading_deg'])} | {_g(s['max_abs_east_drift_m'])} | {_g(s['final_deviation'])} | "
                        f"{_g(s['beats_to_recover'])} |")
    return ("# Lateral feedback with aerodynamic states (measured by scripts/lateral_simulate_aero.py)\n\n"
            f"Paper's gait (A = 42 deg, symmetric), {r['method']['points']} shooting points, "
            f"{r['method']['steps_per_period']} RK4 steps per period; six per-side controls, Bryson weights, the LQR "
            "designed on the full map (no weight on the aerodynamic states) and applied on the 8 body states. "
            f"Responses over {BEATS} beats: a 2 m/s side-gust pulse (1 beat) and a 0.1 rad bank perturbation.\n\n"
            + "\n".join(rows) + "\n\n" + "\n".join(resp) + f"\n\nWall time {r['wall_s']:.0f} s.\n")


def main(argv=None) -> dict:
    ap = script_parser(__doc__, "results/lateral/simulate_aero")
    ap.add_argument("--points", type=int, default=3, help="shooting points (default %(default)s)")
    ap.add_argument("--steps", type=int, default=48, help="RK4 steps per period (default %(default)s)")
    args, out = parse_with_out(ap, argv)
    method = {"points": args.points, "steps_per_period": args.steps}
    t0 = time.perf_counter()
    res = {"method": method, "cases": [case(k, v, method) for k, v in CASES.items()]}
    res["wall_s"] = time.perf_counter() - t0
    write_result(out, res, table(res))
    return res


if __name__ == "__main__":
    main()
