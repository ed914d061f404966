"""``birdocp forces``: body-frame loads and the state derivative at one state and time."""

from __future__ import annotations

import argparse
import math
import sys

from birdocp.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, PROG, context_of, finite_values, noise_summary, print_json,
                                resolve_config, solver_noise)


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
    p.add_argument("--state", nargs=4, type=float, required=True, metavar=("U", "W", "Q", "THETA"),
                   help="body-frame velocities u, w [m/s], pitch rate q [rad/s], pitch angle theta [rad]")
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
