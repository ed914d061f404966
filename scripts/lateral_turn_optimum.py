"""The most stable gait in a steady level turn vs in straight level flight, in six degrees of freedom:
optimize-stability with ``model.degrees_of_freedom = 6`` (the largest of the eight heading-free
multipliers minimised, the heading's structural 1 left out). Writes ``OUT/result.json``,
``OUT/table.md`` and ``OUT/turn_optimum.png`` (default OUT: results/lateral/turn_optimum).

* straight flight: the symmetric gait, the default keys and bounds of optimize-stability;
* the turn: the same keys and two per-side offsets of the right wing (shoulder incidence offset and
  flapping amplitude, ``--bounds``-like ranges below) free, the heading change per wingbeat held at
  ``--turn-rate`` (default 5 deg per beat, positive to the right): the cycle is the turn's 8
  heading-free states (:mod:`birdocp.studies.turn_cycle`), verified by a 6-DOF trim from scratch
  (multiple shooting, configured initial guess) at the optimal gait.

Both on ``--steps`` RK4 steps per period (default 32, the optimisers' coarse grid; no fine stage), each
with the exact validity of its optimal cycle (both wings, sideslip); ``--valid`` adds the validity
limits as constraints.

The turn is found by continuation in the turn rate (``--turn-steps N``): from the straight optimum's
gait, the straight optimum again (its stage 0), then the turn rate held at k/N of its target, k = 1..N,
each solve from the last optimum; ``--max-iter`` IPOPT iterations per solve.

    python scripts/lateral_turn_optimum.py [--out DIR] [--turn-rate DEG] [--steps N] [--turn-steps N]
                                           [--max-iter N] [--valid]
"""

import functools
import time
from pathlib import Path

import numpy as np

from script_common import parse_with_out, script_parser

from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
SIX = {"model.degrees_of_freedom": 6}
SIDE_FREE = {"gait.right_offset.shoulder_incidence.offset_deg": (-2.0, 2.0),
             "gait.right_offset.shoulder_flap.amplitude_deg": (-5.0, 5.0)}


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def optimum(turn: float | None, steps: int, max_iter: int, valid: bool, turn_steps: int = 0,
            start: dict | None = None) -> dict:
    """optimize_stability in six degrees of freedom (straight: default keys; turn: with SIDE_FREE and the
    heading change held, by continuation in the turn rate over ``turn_steps`` steps, from the gait
    ``start``), as its JSON."""
    from birdocp.studies.optimize import DEFAULT_FREE, optimize_stability

    free = dict(DEFAULT_FREE) | (SIDE_FREE if turn is not None else {})
    tag = "turn" if turn is not None else "straight"
    res = optimize_stability(with_values(Config(), SIX | (start or {})), free, steps_per_period=steps, coarse_steps=None,
                             max_iter=max_iter, valid=valid, turn_deg_per_beat=turn, turn_steps=turn_steps,
                             progress=lambda s: log(f"  {tag}:", s))
    d = res.to_dict()
    d["free_keys"] = list(free)
    return d


def turn_trajectory(d: dict, steps: int) -> dict:
    """Bank and heading over one beat of the turn's optimal cycle (a 6-DOF trim at the optimal gait from
    the optimum's state, then the 9 states integrated with the heading)."""
    from birdocp.bird.sixdof import sixdof_model
    from birdocp.studies.lateral import heading_trajectory, lateral_trim

    cfg = with_values(Config(), SIX | d["free"] | {"gait.shoulder_flap.amplitude_deg": d["amplitude_deg"]})
    tr = lateral_trim(cfg, x_guess=list(d["x0"][:8]) + [0.0], points=5, steps_per_period=steps)
    t, X = heading_trajectory(sixdof_model(cfg), tr.cycle, steps)
    return {"t_s": np.asarray(t).tolist(), "phi_deg": np.degrees(X[:, 6]).tolist(),
            "psi_deg": np.degrees(X[:, 8]).tolist(), "theta_deg": np.degrees(X[:, 7]).tolist()}


def figure(d: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
    th = np.linspace(0, 2 * np.pi, 200)
    a.plot(np.cos(th), np.sin(th), color="0.6", lw=0.8)
    for key, mark, label in (("straight", "o", "straight flight"), ("turn", "x", f"turn {d['turn_rate_deg_per_beat']:g} deg/beat")):
        o = d[key]
        z = np.array([complex(*p) for p in o["multipliers"]])
        valid = "valid" if (o.get("validity") or {}).get("valid") else "NOT valid"
        a.plot(z.real, z.imag, mark, ms=8, mfc="none" if mark == "o" else None,
               label=f"{label}: max |Λ| = {max(o['moduli']):.4f} ({valid})")
    a.set_aspect("equal")
    a.set_xlabel("Re Λ")
    a.set_ylabel("Im Λ")
    a.set_title("the eight heading-free multipliers at each optimum")
    a.legend(fontsize=8, loc="lower left")
    tj = d["turn_trajectory"]
    b.plot(tj["t_s"], tj["phi_deg"], label="bank φ [deg]")
    b.plot(tj["t_s"], tj["theta_deg"], label="pitch θ [deg]")
    b.plot(tj["t_s"], tj["psi_deg"], label="heading ψ − ψ(0) [deg]")
    b.set_xlabel("time in the wingbeat [s]")
    b.set_title("the optimal turn over one wingbeat")
    b.legend(fontsize=8)
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _pairs(z) -> str:
    return ", ".join(f"{a:.4f}{b:+.4f}j" if abs(b) > 1e-12 else f"{a:.4f}" for a, b in z)


def table(d: dict) -> str:
    s, t = d["straight"], d["turn"]
    v = lambda r: "valid" if (r.get("validity") or {}).get("valid") else "**NOT valid**: " + "; ".join(  # noqa: E731
        (r.get("validity") or {}).get("reasons") or ["not checked"])
    keys = t["free_keys"]
    val = lambda r, k: f"{r['free'][k]:.4f}" if k in r["free"] else "0 (symmetric)"  # noqa: E731
    rows = [f"| flapping amplitude [deg] | {s['amplitude_deg']:.4f} | {t['amplitude_deg']:.4f} |"]
    rows += [f"| {k} {list(t['bounds'][k])} | {val(s, k)} | {val(t, k)} |" for k in keys]
    rows += [f"| heading change per beat [deg] | {s.get('heading_change_deg', 0.0):.4f} | {t['heading_change_deg']:.4f} |",
             f"| turn rate [deg/s] | {s.get('turn_rate_degps', 0.0):.4f} | {t['turn_rate_degps']:.4f} |",
             f"| longitudinal multipliers | {_pairs(s['longitudinal_multipliers'])} | {_pairs(t['longitudinal_multipliers'])} |",
             f"| lateral multipliers | {_pairs(s['lateral_multipliers'])} | {_pairs(t['lateral_multipliers'])} |",
             f"| IPOPT's r | {s['radius']:.5f} | {t['radius']:.5f} |",
             f"| largest modulus of the eight | {max(s['moduli']):.5f} | {max(t['moduli']):.5f} |",
             f"| model validity | {v(s)} | {v(t)} |"]
    run = lambda o: (f"{o['status']}, {o['iterations']} iterations, {o['wall_s'].get('total', float('nan')):.0f} s, "  # noqa: E731
                     f"KKT residual {o.get('kkt_residual')}")
    ver = t.get("verification") or {}
    return "\n".join([
        f"# The most stable gait in a steady turn of {d['turn_rate_deg_per_beat']:g} deg per wingbeat vs straight "
        f"flight (six degrees of freedom, {d['steps_per_period']} RK4 steps per period)", "",
        "| quantity | straight flight (symmetric gait) | turn |", "|---|---|---|", *rows, "",
        f"Straight: {run(s)}. Turn: {run(t)}.", "",
        f"Turn check: a 6-DOF trim from {ver.get('trim_from')} at the optimal gait converges ({ver.get('trim_success')}), "
        f"its eight multipliers within {ver.get('max_multiplier_difference')} of the optimiser's, its heading change "
        f"{ver.get('trim_heading_change_deg')} deg per beat (difference {ver.get('heading_change_difference_deg')}).", ""])


def main(argv=None) -> None:
    ap = script_parser(__doc__, str(ROOT / "results" / "lateral" / "turn_optimum"))
    ap.add_argument("--turn-rate", type=float, default=5.0, help="heading change per wingbeat held [deg]")
    ap.add_argument("--steps", type=int, default=32, help="RK4 steps per period (default %(default)s)")
    ap.add_argument("--max-iter", type=int, default=30, help="IPOPT iterations per solve (default %(default)s)")
    ap.add_argument("--turn-steps", type=int, default=5,
                    help="continuation in the turn rate: the straight optimum, then k/N of the turn rate, "
                         "k = 1..N, each from the last optimum (default %(default)s)")
    ap.add_argument("--valid", action="store_true", help="the limits of [validity] as constraints")
    args, out = parse_with_out(ap, argv)
    t0 = time.perf_counter()
    d = {"problem": "optimize_stability, model.degrees_of_freedom = 6, default keys and bounds; the turn also "
                    "frees " + ", ".join(f"{k} {list(b)}" for k, b in SIDE_FREE.items()),
         "turn_rate_deg_per_beat": args.turn_rate, "steps_per_period": args.steps, "valid": bool(args.valid),
         "turn_steps": args.turn_steps, "max_iter_per_solve": args.max_iter}
    job = functools.partial(optimum, steps=args.steps, max_iter=args.max_iter, valid=args.valid)
    log("straight flight")
    d["straight"] = job(None)
    log(f"  {d['straight']['status']}: r* {d['straight']['radius']:.5f}")
    log(f"turn of {args.turn_rate} deg per beat, from the straight optimum's gait")
    bounds = d["straight"]["bounds"]  # an interior-point optimum lies on an active bound only to ~1e-6
    start = {k: float(np.clip(v, *bounds[k])) for k, v in d["straight"]["free"].items()}
    start["gait.shoulder_flap.amplitude_deg"] = d["straight"]["amplitude_deg"]
    d["turn"] = job(args.turn_rate, turn_steps=args.turn_steps, start=start)
    log(f"  {d['turn']['status']}: r* {d['turn']['radius']:.5f}")
    d["turn_trajectory"] = turn_trajectory(d["turn"], args.steps)
    d["script_wall_s"] = time.perf_counter() - t0
    atomic_write_json(out / "result.json", d)
    atomic_write_text(out / "table.md", table(d))
    figure(d, out / "turn_optimum.png")
    log("written", out)


if __name__ == "__main__":
    main()
