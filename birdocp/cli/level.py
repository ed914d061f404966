"""``birdocp level``: level (or climbing) flight with the flapping amplitude (or --free KEY) solved for."""

from __future__ import annotations

import argparse
import time

from birdocp.bird.config import ConfigError
from birdocp.bird.keys import AMPLITUDE_BOUNDS_DEG, AMPLITUDE_KEY
from birdocp.cli.common import (add_bounds_option, add_plot_flag, bounds_of, compiled_requested, power_figure, EXIT_OK,
                                config_message, finish_result, finite_values, fmt_num, format_trim_table,
                                resolve_config, run_folder)
from birdocp.cli.trim import solve_shortcuts


def level_options(p: argparse.ArgumentParser, in_sweep: bool) -> None:
    """--free, --climb-rate, --constrain, --target, --bounds.

    Parameters
    ----------
    p : argparse.ArgumentParser
        Parser of the command.
    in_sweep : bool
        The options belong to ``sweep --level`` (the group's title says so).
    """
    g = p.add_argument_group("level flight" + (" (with --level)" if in_sweep else ""))
    g.add_argument("--free", metavar="KEY",
                   help="parameter solved for: a dotted model parameter key or an alias (amplitude, "
                        "root_ahead_m); default amplitude (gait.shoulder_flap.amplitude_deg)")
    g.add_argument("--climb-rate", type=float, metavar="MPS",
                   help="target mean vertical speed in m/s, positive climbing (default 0: level flight)")
    g.add_argument("--constrain", metavar="MEAN",
                   help="condition: vertical_speed_mps (default; target --climb-rate), forward_speed_mps or "
                        "flight_path_angle_deg (target --target)")
    g.add_argument("--target", type=float, metavar="VALUE",
                   help="target of --constrain forward_speed_mps [m/s] or flight_path_angle_deg [deg]")
    lo, hi = AMPLITUDE_BOUNDS_DEG
    add_bounds_option(g, f"bounds of the free parameter, KEY its key or alias (default: amplitude={lo:g}:{hi:g} deg, "
                         "the configured value +-30 for other _deg keys, root_ahead_m=-0.2:0.3 m; required "
                         "otherwise)")


def register(sub, common) -> None:
    """Add ``level`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("level", parents=[common], help="level (or climbing) flight: solve for the flapping amplitude",
                       description="Find the periodic flight with the flapping amplitude (or --free KEY) as an "
                                   "unknown such that the mean vertical speed is zero (or --climb-rate), in one "
                                   "NLP, and its Floquet multipliers. Writes a run folder like 'trim'.")
    level_options(p, False)
    solve_shortcuts(p)
    p.add_argument("--valid", action="store_true",
                   help="hold the result to the limits of [validity]: JSON adds validity_constraints (each "
                        "limit's smooth value, exact value, bound); exit 1 if the level cycle is not valid "
                        "(one free value and one condition leave no freedom to move it: set the gait with --set)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-level-<id>/")
    add_plot_flag(p)
    p.set_defaults(func=cmd_level)


LEVEL_FLAGS = (("--free", "free"), ("--climb-rate", "climb_rate"), ("--constrain", "constrain"),
               ("--target", "target"), ("--bounds", "bounds"))
"""The options of :func:`level_options` (flag, attribute): None when not given."""


def level_kwargs(args: argparse.Namespace, cfg) -> dict:
    """Checked keyword arguments of birdocp.studies.level.level from the level options (no model import).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (the level options).
    cfg : Config
        Resolved configuration.

    Returns
    -------
    dict
    """
    from birdocp.studies.level import default_bounds, resolve_constraint, resolve_key

    free = resolve_key("amplitude" if args.free is None else args.free, "--free")
    constrain = resolve_constraint("vertical_speed_mps" if args.constrain is None else args.constrain, "--constrain")
    (climb,) = finite_values("--climb-rate", [0.0 if args.climb_rate is None else args.climb_rate])
    kw: dict = {"free": free, "constrain": constrain, "climb_rate_mps": climb}
    if constrain != "vertical_speed_mps" and args.climb_rate is not None:
        raise ConfigError("--climb-rate", f"is the target of --constrain vertical_speed_mps (the default); "
                                          f"--constrain {constrain} holds --target instead: drop --climb-rate")
    if constrain == "vertical_speed_mps" and args.climb_rate is not None and args.target is not None:
        raise ConfigError("--target", "and --climb-rate both set the mean vertical speed; give one of them")
    if constrain != "vertical_speed_mps":
        if args.target is None:
            raise ConfigError("--target", f"--constrain {constrain} needs --target VALUE")
        (kw["target"],) = finite_values("--target", [args.target])
        if constrain == "forward_speed_mps" and not kw["target"] > 0:
            raise ConfigError("--target", f"the mean forward speed must be > 0 m/s, got {kw['target']!r}")
        if constrain == "flight_path_angle_deg" and not -89 < kw["target"] < 89:
            raise ConfigError("--target", f"flight path angle must lie in (-89, 89) deg, got {kw['target']!r}")
    elif args.target is not None:
        (kw["climb_rate_mps"],) = finite_values("--target", [args.target])
    bounds = bounds_of(args.bounds, free)
    if bounds is not None:
        kw["bounds"] = bounds
    else:
        try:
            default_bounds(cfg, free)
        except ConfigError as exc:
            raise ConfigError("--bounds", f"{config_message(exc)} (--bounds {free}=LO:HI)") from None
    return kw


def cmd_level(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp level``.

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
    t_start = time.perf_counter()
    cfg = resolve_config(args)
    kw = level_kwargs(args, cfg)
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.cli.six_dof import level_options, run_six_dof

        return run_six_dof(args, "level", command_line, cfg, level_options(kw))
    with run_folder(args, "level", command_line) as run:
        with run.solving():
            from birdocp.studies.level import level

            res = level(cfg, **kw, compiled=compiled_requested(args))
            getattr(res, "energetics", None)  # computes the power outputs (result.json and the table)
            result = dict(res.to_dict())
            arrays = res.arrays()
        free = kw["free"]
        result["free_key"] = free
        result["free_value"] = result.get("free_values", {}).get(free)
        result["constrain"] = kw["constrain"]
        result["target"] = kw.get("target", kw["climb_rate_mps"])
        if getattr(args, "valid", False):
            result["validity_constraints"] = _level_validity_constraints(cfg, res, result)
        finish_result(result, "level", t_start, run.dir)
        run.write(cfg, result, arrays)
        power_figure(arrays, run.dir, args)  # only with --plot: `birdocp plot RUN_DIR` draws it later
        table = format_trim_table(result).replace("trim:", "level:", 1)
        name = "amplitude A" if free == AMPLITUDE_KEY else free
        unit = " deg" if free.endswith("_deg") else " m" if free.endswith("_m") else ""
        head = [f"level flight: {name} = {fmt_num(result['free_value'], '.6f')}{unit} "
                f"(mean {kw['constrain']} = {fmt_num(result['target'], 'g')})"]
        if free != AMPLITUDE_KEY:
            head.append(f"amplitude: {fmt_num(result.get('amplitude_deg'), '.6f')} deg")
        run.output(result, "\n".join(head) + "\n" + table)
        if not res.success:
            return run.fail("level flight not found", res.status, result.get("max_residual"), res.message)
        if getattr(args, "valid", False) and not (result.get("validity") or {}).get("valid"):
            return run.fail("level flight found, but the model is NOT VALID on it (--valid)", res.status,
                            result.get("max_residual"), "; ".join((result.get("validity") or {}).get("reasons") or []))
    return EXIT_OK


def _level_validity_constraints(cfg, res, result: dict) -> dict:
    """The ``validity_constraints`` of a level cycle (``--valid``): per limit the smooth measure an
    optimiser with ``valid=True`` holds, the exact one and the bound
    (:func:`birdocp.studies.gait_validity.constraint_report`; ``active``: the smooth value at its bound)."""
    import numpy as np

    from birdocp.bird.config import with_values
    from birdocp.bird.validity_smooth import cycle_smooth_measures
    from birdocp.studies.gait_validity import constraint_report

    if not res.success or not np.all(np.isfinite(res.x0)):
        return {}
    vals = dict(result.get("free_values") or {})
    if result.get("amplitude_deg") is not None:
        vals[AMPLITUDE_KEY] = float(result["amplitude_deg"])
    solved = with_values(cfg, vals)
    steps = int(res.cycle.method["steps_per_period"])
    t0 = float(res.cycle.trajectory_t[0]) if len(res.cycle.trajectory_t) else 0.0
    smooth = cycle_smooth_measures(solved, res.x0, res.p, steps) if t0 == 0.0 else {}
    return constraint_report(cfg, smooth, result.get("validity") or {}, {})
