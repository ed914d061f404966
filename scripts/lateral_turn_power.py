"""The power-optimal gait of a steady level turn in six degrees of freedom, against straight flight at the
same speed: optimize-gait (objective: mean shoulder power of both wings, :mod:`birdocp.bird.sixdof_power`)
with the symmetric shoulder incidence and sweep offsets and the right wing's sweep offset free (in
``--side-bounds``), the heading change per wingbeat held at each of ``--turn-rates`` (0: straight flight,
where the optimum stays symmetric) and the mean forward speed at ``--speed``. Every turn is solved from the
configured gait and from the straight-flight optimum (the problem has local optima). Writes ``OUT/result.json``
and ``OUT/table.md`` (default OUT: results/lateral/turn_power).

Each optimum reports its power per wing, its eight heading-free multipliers, the exact validity of both
wings and the 6-DOF trim check at the optimal gait (multiple shooting from the configured initial guess).

    python scripts/lateral_turn_power.py [--out DIR] [--speed MPS] [--turn-rates DEG ...] [--steps N]
"""

import time
from pathlib import Path

from script_common import parse_with_out, script_parser

from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
SIX = {"model.degrees_of_freedom": 6}
RIGHT = "gait.right_offset.shoulder_sweep.offset_deg"
FREE = {"gait.shoulder_incidence.offset_deg": (0.0, 25.0), "gait.shoulder_sweep.offset_deg": (-30.0, -5.0)}
KEEP = ("success", "status", "message", "iterations", "objective_value", "start_objective_value", "free", "bounds",
        "amplitude_deg", "kkt_residual", "constraint_violation", "mean_shoulder_power_W", "mean_right_shoulder_power_W",
        "mean_left_shoulder_power_W", "mean_positive_power_W", "mean_right_positive_power_W",
        "mean_left_positive_power_W", "mean_aerodynamic_power_W", "mean_forward_speed_mps", "mean_vertical_speed_mps",
        "heading_change_deg", "turn_rate_degps", "multipliers", "longitudinal_radius", "lateral_radius",
        "lateral_modes", "validity", "verification", "wall_s", "active_bounds")


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def optimum(turn: float, speed: float, steps: int, side_bounds, start: dict | None = None) -> dict:
    """optimize_gait (power) of the turn of ``turn`` deg per beat at ``speed`` from the configured gait or
    ``start`` (gait values), its JSON's documented keys."""
    from birdocp.studies.gait import optimize_gait

    res = optimize_gait(with_values(Config(), SIX), FREE | {RIGHT: tuple(side_bounds)}, objective="power",
                        speed_mps=speed, steps_per_period=steps, turn_deg_per_beat=turn, start=start,
                        progress=lambda s: log("  ", s))
    d = res.to_dict()
    out = {k: d.get(k) for k in KEEP}
    out["x0"] = d.get("x0")
    return out


def table(d: dict) -> str:
    rows = []
    for o in d["optima"]:
        v = o["validity"] or {}
        free = o["free"] or {}
        rows.append(f"| {o['turn_deg_per_beat']:g} | {o['start']} | {o['heading_change_deg']:.4f} | {o['objective_value']:.5f} | "
                    f"{o['mean_right_shoulder_power_W']:.5f} | {o['mean_left_shoulder_power_W']:.5f} | "
                    f"{o['mean_aerodynamic_power_W']:.5f} | {o['mean_positive_power_W']:.4f} | {o['amplitude_deg']:.3f} | "
                    + " | ".join(f"{free.get(k, float('nan')):.4f}" for k in list(FREE) + [RIGHT])
                    + f" | {o['longitudinal_radius']:.4f}, {o['lateral_radius']:.4f} | "
                    f"{'valid' if v.get('valid') else '**NOT valid**: ' + '; '.join(v.get('reasons') or [])} | "
                    f"{o['status']}, {o['iterations']} it., KKT {o['kkt_residual']:.1e} |")
    ver = [f"{o['turn_deg_per_beat']:g} deg/beat from the {o['start']}: trim {'converged' if (o['verification'] or {}).get('trim_success') else 'FAILED'}, "
           f"multipliers within {(o['verification'] or {}).get('max_multiplier_difference')}, heading change "
           f"difference {(o['verification'] or {}).get('heading_change_difference_deg')} deg" for o in d["optima"]]
    return "\n".join([
        f"# The power-optimal level turn at {d['speed_mps']:g} m/s (six degrees of freedom, {d['steps_per_period']} "
        "RK4 steps per period)", "",
        "Objective: mean shoulder power of both wings (W); free: " + ", ".join(f"{k} {list(b)}" for k, b in d["free"].items())
        + "; the flapping amplitude solved for level flight.", "",
        "| turn held [deg/beat] | start | heading change [deg/beat] | power [W] | right wing [W] | left wing [W] | "
        "to the air [W] | positive work, both wings [W] | amplitude [deg] | incidence offset | sweep offset | "
        "right sweep offset | radii (long., lat.) | validity | IPOPT |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|", *rows, "",
        "6-DOF trim check at each optimum: " + "; ".join(ver) + ".", ""])


def main(argv=None) -> None:
    ap = script_parser(__doc__, str(ROOT / "results" / "lateral" / "turn_power"))
    ap.add_argument("--speed", type=float, default=15.0, help="mean forward speed held [m/s]")
    ap.add_argument("--turn-rates", type=float, nargs="+", default=[0.0, -1.0], help="heading changes per beat [deg]")
    ap.add_argument("--side-bounds", type=float, nargs=2, default=[-5.0, 5.0], help="bounds of the right sweep offset [deg]")
    ap.add_argument("--steps", type=int, default=32, help="RK4 steps per period (default %(default)s)")
    args, out = parse_with_out(ap, argv)
    t0 = time.perf_counter()
    d = {"problem": "optimize_gait, objective power (both shoulders), model.degrees_of_freedom = 6, level flight",
         "speed_mps": args.speed, "steps_per_period": args.steps,
         "free": {k: list(b) for k, b in (FREE | {RIGHT: tuple(args.side_bounds)}).items()}, "optima": []}
    straight = None  # the straight-flight optimum's gait: a second start of every turn (the problem has local optima)
    for turn in args.turn_rates:
        for name, start in [("configured gait", None)] + ([("straight optimum", straight)] if straight and turn else []):
            log(f"turn of {turn:g} deg per beat at {args.speed:g} m/s from the {name}")
            o = optimum(turn, args.speed, args.steps, args.side_bounds, start)
            o["turn_deg_per_beat"], o["start"] = turn, name
            d["optima"].append(o)
            log(f"  power {o['objective_value']:.6g} W (right {o['mean_right_shoulder_power_W']:.6g}, left "
                f"{o['mean_left_shoulder_power_W']:.6g}), {o['status']}")
            if turn == 0 and o["success"]:
                straight = dict(o["free"])
    d["wall_s"] = time.perf_counter() - t0
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "result.json", d)
    atomic_write_text(out / "table.md", table(d))
    log(f"written to {out}")


if __name__ == "__main__":
    main()
