"""``birdocp forces``: body-frame loads and the state derivative at one state and time."""

from __future__ import annotations

import argparse
import math
import sys

from birdocp.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, PROG, context_of, finite_values, noise_summary, print_json,
                                resolve_config, solver_noise)
from birdocp.io.errors import ConfigError


def register(sub, common) -> None:
    """Add ``forces`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("forces", parents=[common], help="body-frame loads and state derivative at one state and time",
                       description="Evaluate the model once: body-frame loads (x' forward, z' down, "
                                   "pitching moment nose-up positive) and the state derivative. Non-finite "
                                   "loads (the model is singular there) are a failure: exit 1.")
    p.add_argument("--state", nargs="+", type=float, required=True, metavar="X",
                   help="the state: u w q theta (body-frame velocities u, w [m/s], pitch rate q [rad/s], pitch "
                        "angle theta [rad]); with model.degrees_of_freedom = 6 the nine u v w p q r phi theta psi "
                        "(v [m/s] right, roll and yaw rates p, r [rad/s], bank phi and heading psi [rad])")
    p.add_argument("--time", type=float, required=True, metavar="T", help="time in the flapping cycle [s]")
    p.set_defaults(func=cmd_forces)


def cmd_forces(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp forces``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the command.
    command_line : list of str
        The command line, recorded in the provenance of the result.

    Returns
    -------
    int
        Exit code: 0 success, 1 the computation failed or its output could not be written, 2 bad input.
    """
    state = finite_values("--state", args.state)
    (t,) = finite_values("--time", [args.time])
    cfg = resolve_config(args)
    six = cfg.model.degrees_of_freedom == 6
    if len(state) != (9 if six else 4):
        raise ConfigError("--state", f"takes {'9 values u v w p q r phi theta psi' if six else '4 values u w q theta'}"
                                     f" (model.degrees_of_freedom = {6 if six else 4}), got {len(state)}")
    if six:
        return _six_dof(args, state, t, cfg)

    import numpy as np

    from birdocp.bird.model import get_model

    with solver_noise(None, getattr(args, "verbose", False)) as noise:
        model = get_model(cfg)
        out = model.evaluate(state, t)
    res = {
        "Fx_N": float(np.asarray(out["Fx_N"], dtype=float).reshape(-1)[0]),
        "Fz_N": float(np.asarray(out["Fz_N"], dtype=float).reshape(-1)[0]),
        "My_Nm": float(np.asarray(out["My_Nm"], dtype=float).reshape(-1)[0]),
        "xdot": [float(v) for v in np.asarray(out["xdot"], dtype=float).reshape(-1)],
    }
    finite = all(math.isfinite(v) for v in [res["Fx_N"], res["Fz_N"], res["My_Nm"], *res["xdot"]])
    if not finite:  # never reported as a success
        bad = [k for k in ("Fx_N", "Fz_N", "My_Nm") if not math.isfinite(res[k])]
        bad += ["xdot"] if not all(math.isfinite(v) for v in res["xdot"]) else []
        message = (f"non-finite {', '.join(bad)} at u = {state[0]:g} m/s, w = {state[1]:g} m/s, "
                   f"q = {state[2]:g} rad/s, theta = {state[3]:g} rad, t = {t:g} s (overflow or a singular "
                   "state of the model)")
        if args.json:
            print_json(dict(res, success=False, status="non_finite", message=message), context_of(args))
        warn = noise_summary(noise)
        print(f"{PROG}: forces: {message}{warn}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if args.json:
        # the four documented keys, success and status
        print_json(dict(res, success=True, status="ok"), context_of(args))
        return EXIT_OK
    u, w, q, th = state
    xd = res["xdot"] + [float("nan")] * (4 - len(res["xdot"]))
    rows = [
        ("state", f"u = {u:g} m/s, w = {w:g} m/s, q = {q:g} rad/s, theta = {th:g} rad"),
        ("time", f"t = {t:g} s"),
        ("", ""),
        ("body-frame loads", "(x' forward, z' down, pitching moment nose-up positive)"),
        ("  Fx", f"{res['Fx_N']: .6g} N"),
        ("  Fz", f"{res['Fz_N']: .6g} N"),
        ("  My", f"{res['My_Nm']: .6g} N m"),
        ("state derivative", ""),
        ("  du/dt", f"{xd[0]: .6g} m/s^2"),
        ("  dw/dt", f"{xd[1]: .6g} m/s^2"),
        ("  dq/dt", f"{xd[2]: .6g} rad/s^2"),
        ("  dtheta/dt", f"{xd[3]: .6g} rad/s"),
    ]
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}".rstrip() for k, v in rows))
    return EXIT_OK


SIX_DOF_ROWS = (("  Fx", "Fx_N", "N"), ("  Fy", "Fy_N", "N"), ("  Fz", "Fz_N", "N"), ("  Mx (roll L)", "Mx_Nm", "N m"),
                ("  My (pitch M)", "My_Nm", "N m"), ("  Mz (yaw N)", "Mz_Nm", "N m"))
SIX_DOF_RATES = (("du/dt", "m/s^2"), ("dv/dt", "m/s^2"), ("dw/dt", "m/s^2"), ("dp/dt", "rad/s^2"), ("dq/dt", "rad/s^2"),
                 ("dr/dt", "rad/s^2"), ("dphi/dt", "rad/s"), ("dtheta/dt", "rad/s"), ("dpsi/dt", "rad/s"))


def _six_dof(args: argparse.Namespace, state: list[float], t: float, cfg) -> int:
    """``forces`` with ``model.degrees_of_freedom = 6``: the six body-axis loads and the 9-state derivative
    (:meth:`birdocp.bird.sixdof.SixDofModel.evaluate`); JSON keys Fx_N, Fy_N, Fz_N, Mx_Nm, My_Nm, Mz_Nm,
    xdot (9), state_names, degrees_of_freedom, success, status."""
    from birdocp.bird.config import param_vector
    from birdocp.bird.sides import side_vector
    from birdocp.bird.sixdof import STATE_NAMES, LateralInertia, sixdof_model

    with solver_noise(None, getattr(args, "verbose", False)) as noise:
        six = sixdof_model(cfg)
        p6 = six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg) if six.sides else None)
        res = six.evaluate(state, t, p6)
    res |= {"state_names": list(STATE_NAMES), "degrees_of_freedom": 6}
    loads = [res[k] for _, k, _ in SIX_DOF_ROWS]
    if not all(math.isfinite(v) for v in loads + res["xdot"]):
        message = (f"non-finite loads or state derivative at the state ({', '.join(f'{v:g}' for v in state)}), "
                   f"t = {t:g} s (overflow or a singular state of the model)")
        if args.json:
            print_json(dict(res, success=False, status="non_finite", message=message), context_of(args))
        print(f"{PROG}: forces: {message}{noise_summary(noise)}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    if args.json:
        print_json(dict(res, success=True, status="ok"), context_of(args))
        return EXIT_OK
    rows = [("state", ", ".join(f"{n} = {v:g}" for n, v in zip(STATE_NAMES, state))), ("time", f"t = {t:g} s"),
            ("", ""), ("body-axis loads", "(x' forward, y' right, z' down; about G: roll right wing down, pitch "
                                          "nose up, yaw nose right positive)")]
    rows += [(label, f"{res[k]: .6g} {unit}") for label, k, unit in SIX_DOF_ROWS]
    rows += [("state derivative", "")] + [(f"  {n}", f"{v: .6g} {u}") for (n, u), v in zip(SIX_DOF_RATES, res["xdot"])]
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}".rstrip() for k, v in rows))
    return EXIT_OK
