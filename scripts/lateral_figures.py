"""Figures of the lateral modes over the wingbeat and the 3-D animation of a perturbed flight, for the
paper's gait trimmed in six degrees of freedom.

    python scripts/lateral_figures.py --out results/lateral/modes --gif results/animation/lateral_3d.gif

writes one PNG per lateral Floquet mode (``lateral_mode_<label>.png``), ``modes.json`` (the
multipliers, their labels, beats to double/halve, the check ``monodromy_error`` of the stepped
state-transition matrices and the cycle's validity) and the GIF: the flight from the cycle's start
with its bank disturbed by ``--bank-deg`` over ``--wingbeats`` wingbeats.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from script_common import parse_with_out, script_parser  # noqa: E402

from birdocp.io.files import atomic_write_json  # noqa: E402
from birdocp.bird.config import Config, with_values  # noqa: E402
from birdocp.plots.animation_lateral import save_lateral_animation  # noqa: E402
from birdocp.plots.lateral import plot_lateral_modes  # noqa: E402
from birdocp.studies.lateral import lateral_trim  # noqa: E402
from birdocp.studies.lateral_modes import lateral_mode_histories  # noqa: E402
from birdocp.studies.lateral_motion import lateral_motion, perturbed_flight  # noqa: E402


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/modes")
    ap.add_argument("--gif", default="results/animation/lateral_3d.gif", help="the animation ('' for none)")
    ap.add_argument("--bank-deg", type=float, default=15.0)
    ap.add_argument("--wingbeats", type=int, default=6)
    ap.add_argument("--frames", type=int, default=16, help="frames per wingbeat")
    args, out = parse_with_out(ap, argv)
    cfg = with_values(Config(), {"model.degrees_of_freedom": 6})
    res = lateral_trim(cfg)
    if not res.success:
        raise SystemExit(f"the 6-DOF trim did not converge: {res.cycle.message}")
    valid = bool(res.validity.valid) if res.validity is not None else None
    note = {True: "the model holds on this cycle", False: "the model does NOT hold on this cycle "
            "(validity limits exceeded)", None: None}[valid]
    h = lateral_mode_histories(res, cfg)
    figs = plot_lateral_modes(h, out, note)
    info = {"monodromy_error": h["monodromy_error"], "valid": valid, "period_s": h["period_s"],
            "steps_per_period": int(res.cycle.method["steps_per_period"]), "figures": [f.name for f in figs],
            "modes": [{"label": m["label"], "multiplier": [m["multiplier"].real, m["multiplier"].imag],
                       "modulus": abs(m["multiplier"]), "beats_to_double": m["beats_to_double"]} for m in h["modes"]]}
    atomic_write_json(out / "modes.json", info)
    print(json.dumps(info, indent=1))
    if args.gif:
        per = max(1, -(-96 // args.frames))
        fl = perturbed_flight(cfg, res.cycle.x0, res.cycle.p, args.bank_deg, args.wingbeats,
                              steps_per_period=per * args.frames)
        mo = lateral_motion(cfg, fl, np.arange(0, per * args.frames * args.wingbeats + 1, per), res.cycle.p)
        title = (f"6 DOF, the paper's gait: the trimmed cycle with its bank disturbed by {args.bank_deg:+g} deg, "
                 f"{args.wingbeats} wingbeats" + ("" if valid else " (the model does not hold on this cycle)"))
        save_lateral_animation(mo, fl, args.gif, fps=8, title=title)
        X = fl["x"]
        print(f"wrote {args.gif}: bank {np.degrees(X[0, 6]):+.1f} -> {np.degrees(X[-1, 6]):+.1f} deg, heading "
              f"{np.degrees(X[-1, 8]):+.1f} deg, pitch {np.degrees(X[0, 7]):+.1f} -> {np.degrees(X[-1, 7]):+.1f} deg")


if __name__ == "__main__":
    main()
