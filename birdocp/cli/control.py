"""``birdocp control``: design the wingbeat-to-wingbeat (or N-updates-per-beat) feedback at a cycle."""

from __future__ import annotations

import argparse

import math
import sys
import time

from birdocp.bird.config import ConfigError
from birdocp.cli import common as cli


HELP = "design the feedback of the gait that stabilises the cycle (periodic LQR on the exact linearised wingbeat map)"

DESCRIPTION = """Trim the configured gait (or --level flight), linearise the wingbeat map exactly with respect to the
state and to gait parameters held over each of N intervals of the beat, and design the periodic discrete LQR (Bryson
weights: 1 m/s, 1 m/s, 1 rad/s, 5 deg; 5 deg per joint). Reports open- and closed-loop multipliers, the gain and each
control's ability to stabilise the cycle alone. Needs scipy (pip install 'birdocp[control]')."""
"""The text of ``birdocp control --help`` (argparse joins the lines)."""


def register(sub, common) -> None:
    """Add ``control`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = cli.add_run_command(sub, common, "control", cmd_control, help=HELP,
                            description=DESCRIPTION)
    p.add_argument("--level", action="store_true", help="control the level-flight cycle (amplitude solved first)")
    p.add_argument("--controls", nargs="+", metavar="KEY",
                   help="gait keys corrected by the feedback (default: gait.shoulder_incidence.offset_deg "
                        "gait.shoulder_flap.amplitude_deg gait.shoulder_sweep.offset_deg; aliases incidence, "
                        "amplitude, sweep; with model.degrees_of_freedom = 6: per-side keys "
                        "gait.right_offset.<joint>.<field>, default right_/left_amplitude, _sweep, _incidence)")
    p.add_argument("--updates-per-beat", type=int, default=1, metavar="N",
                   help="corrections per wingbeat (1 = wingbeat to wingbeat; must divide the RK4 steps)")
    p.add_argument("--limit-deg", type=float, default=None, metavar="DEG",
                   help="joint range of each control around its cycle value, used by 'simulate' to saturate "
                        "(default 15)")


def cmd_control(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp control``.

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
    from birdocp.bird.config import dumps
    from birdocp.studies.control import DEFAULT_CONTROLS, resolve_controls

    t0 = time.perf_counter()
    cfg = cli.resolve_config(args)
    if cfg.model.degrees_of_freedom == 6:  # per-side controls on the 8-state map
        return _cmd_lateral_control(args, command_line, cfg, t0)
    controls = resolve_controls(args.controls if args.controls is not None else DEFAULT_CONTROLS)
    N, limit = _check_options(args, cfg)
    with cli.run_folder(args, "control", command_line) as run:
        with run.solving():
            from birdocp.studies.control import design_controller, reference_cycle

            base = reference_cycle(cfg, args.level)
        head = {"requested_config": dumps(cfg), "level": bool(args.level), "controls": controls,
                "updates_per_beat": N, "run_dir": str(run.dir)}
        if not base.success:
            result = {"success": False, "status": base.status, "message": base.message, **head}
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("the cycle did not converge", base.status, base.max_residual, base.message)
        import numpy as np

        with run.solving():
            try:
                ctl = design_controller(base, controls, N, limit_deg=limit)
                body, message = ctl.to_dict(), ""
            except (np.linalg.LinAlgError, ValueError) as exc:
                ctl, (body, message) = None, _failure_body(exc, controls)
        result = {**head, **body, "message": message or body["message"], "amplitude_deg": base.amplitude_deg,
                  "mean_forward_speed_mps": base.mean_forward_speed_mps,
                  "mean_vertical_speed_mps": base.mean_vertical_speed_mps,
                  "wall_s": {"total": time.perf_counter() - t0}}
        return finish(args, run, base.cfg, result, ctl)


def finish(args, run, cfg, result: dict, ctl) -> int:
    """Draw the multipliers (when a controller exists), write the run, print it (JSON or table) and
    return the exit code: not converged when no stabilising feedback was found.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (``json``).
    run : Run
        The run folder.
    cfg : Config
        Resolved configuration.
    result : dict
        JSON-able result.
    ctl : controller or None
        The feedback found (None: none).

    Returns
    -------
    int
        Exit code.
    """
    if ctl is not None:
        from birdocp.plots.control import plot_multipliers

        result["figure"] = str(plot_multipliers(result, run.dir / "multipliers.png"))
    run.write(cfg, result)
    if args.json:
        run.output(result, None)
    else:
        _print_table(result)
    if not result["success"]:
        print(f"{cli.PROG}: {result['message']}; result written to {run.dir}", file=sys.stderr)
        return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK


def _failure_body(exc: Exception, controls) -> tuple[dict, str]:
    """(result body, message) when no stabilising feedback exists: the closed loop is the open loop,
    with each control's analysis when the design got that far."""
    body = {"success": False, "status": "not_stabilised"}
    message = f"no stabilising feedback through {', '.join(controls)}: {cli.one_line(exc)}"
    wm, per = getattr(exc, "wingbeat_map", None), getattr(exc, "per_control", None)
    if wm is not None and per is not None:
        from birdocp.engine.floquet import complex_pairs

        ol = complex_pairs(wm.multipliers)
        body.update(controls=list(wm.controls), open_loop_multipliers=ol, closed_loop_multipliers=ol,
                    controllable={r["control"]: r["stabilisable"] for r in per}, per_control=per)
    return body, message


def _check_options(args: argparse.Namespace, cfg) -> tuple[int, float]:
    """(N, limit_deg) of ``--updates-per-beat`` and ``--limit-deg``, checked before any computation
    (with scipy's presence): ConfigError naming the option."""
    from birdocp.studies.control import DEFAULT_LIMIT_DEG

    N = args.updates_per_beat
    steps = cfg.solve.steps_per_period
    if N < 1:
        raise ConfigError("--updates-per-beat", f"must be >= 1, got {N}")
    if steps % N:
        raise ConfigError("--updates-per-beat", f"must divide the RK4 steps per period ({steps}), got {N}; "
                                                "change N or --set solve.steps_per_period")
    limit = DEFAULT_LIMIT_DEG if args.limit_deg is None else args.limit_deg
    if not (math.isfinite(limit) and limit > 0):
        raise ConfigError("--limit-deg", f"must be a positive number of degrees, got {limit}")
    try:
        import scipy  # noqa: F401
    except ImportError:
        raise ConfigError("scipy", "birdocp control needs scipy: pip install 'birdocp[control]'") from None
    return N, limit


def _print_table(r: dict) -> None:
    """The human-readable summary of a control result (planar or six degrees of freedom)."""
    if "gain" not in r:  # no controller (a failure carries the multipliers and per-control analysis only)
        print(f"control: {r['status']}: {r['message']}")
        return
    print(f"control: {r['status']} with {len(r['controls'])} control(s), {r['updates_per_beat']} update(s) per beat, "
          f"at amplitude {r['amplitude_deg']:.4f} deg{' (level flight)' if r['level'] else ''}")
    print(f"  spectral radius open loop {r['open_loop_spectral_radius']:.6f} -> closed loop "
          f"{r['closed_loop_spectral_radius']:.6f}"
          + (f" (deviation / 100 in {r['beats_to_reduce_100x']:.1f} beats)" if r["beats_to_reduce_100x"] else ""))
    print("  closed-loop multipliers: " + ", ".join(cli.fmt_num(z, ".5f") for z in r["closed_loop_multipliers"]))
    print(f"  gain of the first update [{r['gain_units']}]:")
    names = [n.split("_")[0] for n in r.get("state_names") or ("u", "w", "q", "theta")]
    wid = max([42] + [len(k) for k in r["controls"]])
    print(f"    {'control':{wid}s} " + " ".join(f"{n:>9s}" for n in names))
    for key, row in zip(r["controls"], r["gain"]):
        print(f"    {key:{wid}s} " + " ".join(f"{v:+9.3f}" for v in row))
    print("  each control alone:")
    print(f"    {'control':{wid}s} {'stabilisable':>12s} {'|w1 B|/deg':>11s} {'min effort':>11s} {'LQR rho':>8s}")
    for row in r["per_control"]:
        eff = row["min_effort_per_unit_mode"]
        rho = row["lqr_spectral_radius"]
        print(f"    {row['control']:{wid}s} {str(row['stabilisable']):>12s} {row['modal_input_per_unit']:11.4g} "
              f"{cli.fmt_num(eff, '.4g'):>11s} {cli.fmt_num(rho, '.4f'):>8s}")
    from birdocp.bird.validity import validity_text

    print(f"  model validity of the cycle controlled: {validity_text(r.get('cycle_validity'))}")
    print(f"  written to {r['run_dir']}")


def _cmd_lateral_control(args: argparse.Namespace, command_line: list[str], cfg, t0: float) -> int:
    """``birdocp control`` with a 6-DOF configuration: one run folder (result.json with the gains
    (N, m, 8), multipliers.png); the exit code."""
    import numpy as np

    from birdocp.bird.config import dumps
    from birdocp.studies.lateral_control import LATERAL_CONTROLS, resolve_lateral_controls

    controls = resolve_lateral_controls(args.controls if args.controls is not None else LATERAL_CONTROLS)
    N, limit = _check_options(args, cfg)
    with cli.run_folder(args, "control", command_line) as run:
        with run.solving():
            from birdocp.studies.lateral_control import design_lateral_controller, lateral_reference_cycle

            base, cycle_cfg = lateral_reference_cycle(cfg, args.level)
        head = {"requested_config": dumps(cfg), "level": bool(args.level), "controls": controls,
                "updates_per_beat": N, "run_dir": str(run.dir), "degrees_of_freedom": 6}
        if not base.success:
            c = base.cycle
            result = {"success": False, "status": c.status, "message": c.message, **head}
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("the cycle did not converge", c.status, c.max_residual, c.message)
        with run.solving():
            try:
                ctl = design_lateral_controller(base, cycle_cfg, controls, N, limit_deg=limit)
                body, message = ctl.to_dict(), ""
            except (np.linalg.LinAlgError, ValueError) as exc:
                ctl, (body, message) = None, _failure_body(exc, controls)
        result = {**head, **body, "message": message or body["message"], "amplitude_deg": base.amplitude_deg,
                  "mean_forward_speed_mps": base.mean_forward_speed_mps,
                  "mean_vertical_speed_mps": base.mean_vertical_speed_mps, "cycle_symmetric": base.symmetric,
                  "cycle_multipliers": base.to_dict()["multipliers"], "wall_s": {"total": time.perf_counter() - t0}}
        return finish(args, run, cycle_cfg, result, ctl)
