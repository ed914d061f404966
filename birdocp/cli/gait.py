"""CLI command ``optimize-gait``: the energy-optimal level-flight gait (registered by cli.main)."""

from __future__ import annotations

import argparse

import math
import sys

from birdocp.bird.config import ConfigError
from birdocp.cli import common as cli


HELP = "the gait that minimises mean power (or cost of transport) in level flight at a speed"

DESCRIPTION = """Minimise the mean mechanical power (or the cost of transport, or the positive-work power) of level
flight at a given mean forward speed over free gait parameters within bounds, optionally with every Floquet multiplier
inside the circle of radius R. Reduced space: IPOPT over the gait parameters, the periodic cycle and the flapping
amplitude solved for level flight at every iterate, exact gradients by the implicit function theorem. Verified by a
trim at the optimum."""
"""The text of ``birdocp optimize-gait --help`` (argparse joins the lines)."""


def register(sub, common) -> None:
    """Add ``optimize-gait`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = cli.add_run_command(sub, common, "optimize-gait", cmd_optimize_gait, help=HELP,
                            description=DESCRIPTION)
    p.add_argument("--objective", choices=("power", "cost-of-transport", "positive-power"), default="power",
                   help="mean mechanical power [W] (default), cost of transport P/(m g U), or the smoothed "
                        "mean positive-work power [W]")
    p.add_argument("--speed", type=float, required=True, metavar="MPS",
                   help="mean forward speed of the level flight [m/s], held by the first free key")
    cli.add_free_gait_options(p, free_help="free gait parameter (repeatable; default: shoulder incidence and sweep "
                                           "offsets and amplitudes; the first one also brings the start gait to "
                                           "--speed)",
                              default_bounds="birdocp.studies.gait.DEFAULT_GAIT_FREE")
    p.add_argument("--max-multiplier", type=float, default=None, metavar="R",
                   help="stability constraint: every Floquet multiplier modulus <= R (default: none)")
    from birdocp.cli.optimize_stability import add_valid_flag

    add_valid_flag(p)
    p.add_argument("--turn-rate", type=float, default=None, metavar="DEG",
                   help="six degrees of freedom: hold the heading change per wingbeat at DEG (a steady turn, "
                        "positive to the right); free per-side offsets (--free gait.right_offset.KEY) to reach it")


def cmd_optimize_gait(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp optimize-gait``.

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
    from birdocp.bird.validity import validity_text
    from birdocp.cli.optimize_stability import checked_free, invalid_failure, residuals, six_dof_lines, validity_lines
    from birdocp.studies.gait import DEFAULT_GAIT_FREE, optimize_gait

    cfg = cli.resolve_config(args)
    if not (math.isfinite(args.speed) and args.speed > 0):
        raise ConfigError("--speed", f"must be a positive speed in m/s, got {args.speed}")
    if args.max_multiplier is not None and not (math.isfinite(args.max_multiplier) and args.max_multiplier > 0):
        raise ConfigError("--max-multiplier", f"must be a positive number, got {args.max_multiplier}")
    if not math.isfinite(args.climb_rate):
        raise ConfigError("--climb-rate", f"must be finite, got {args.climb_rate}")
    free = checked_free(args, cfg, DEFAULT_GAIT_FREE, args.objective)
    with cli.run_folder(args, "optimize-gait", command_line) as run:
        run_dir = run.dir
        with run.solving():
            res = optimize_gait(cfg, free, objective=args.objective, speed_mps=args.speed,
                                max_multiplier=args.max_multiplier, climb_rate_mps=args.climb_rate,
                                valid=args.valid, turn_deg_per_beat=args.turn_rate)
        result = res.to_dict()
        cli.record_result(run_dir, res.cfg or cfg, result, command_line, "optimize-gait")
        if args.json:
            cli.print_json(result, cli.context_of(args))
        else:
            unit = " W" if args.objective != "cost-of-transport" else ""
            print(f"optimize-gait: {'converged' if res.success else 'NOT converged'} ({res.status}), "
                  f"{res.iterations} iterations, {res.wall_s.get('total', float('nan')):.1f} s")
            print(f"  {args.objective}: {cli.fmt_num(result['objective_value'], '.6g')}{unit} (configured gait at "
                  f"{args.speed:g} m/s: {cli.fmt_num(result['start_objective_value'], '.6g')}{unit}); KKT residual "
                  f"{cli.fmt_num(res.kkt_residual, '.2e')}")
            for k, v in res.free.items():
                lo, hi = res.bounds[k]
                at = " (at a bound)" if min(abs(v - lo), abs(v - hi)) < 1e-6 else ""
                print(f"  {k:40s} {v:+10.4f}   in [{lo:g}, {hi:g}]{at}   (start {res.start_free.get(k, float('nan')):+.4f})")
            print(f"  flapping amplitude {res.amplitude_deg:.4f} deg; mean forward speed "
                  f"{cli.fmt_num(result['mean_forward_speed_mps'], '.6g')} m/s")
            valid = bool((result.get("validity") or {}).get("valid"))
            print("  multipliers: " + ", ".join(f"{z.real:.5f}{z.imag:+.5f}j" for z in res.multipliers)
                  + f"  ({'STABLE' if res.largest_modulus < 1 else 'UNSTABLE'}"
                  + ("" if valid else "; the model is NOT VALID on this cycle") + ")")
            for line in six_dof_lines(result):
                print(line)
            print(f"  model validity of the optimal cycle: {validity_text(result.get('validity'))}")
            for line in validity_lines(result):
                print(line)
            for line in _power_lines(result):
                print(line)
            v = res.verification
            if v:
                ok = v.get("trim_success")
                print(f"  check: trim at the optimum {'converged' if ok else 'FAILED'}"
                      + (f", power differs by {cli.fmt_num(v.get('power_difference_W'), '.2e')} W, multipliers by "
                         f"{cli.fmt_num(v.get('max_multiplier_difference'), '.2e')}" if ok else ""))
            print(f"  written to {run_dir}")
        if not res.success:
            print(f"{cli.PROG}: optimisation did not converge (status {res.status}, {residuals(res)}: "
                  f"{cli.one_line(res.message)}); result written to {run_dir}", file=sys.stderr)
            return cli.EXIT_NOT_CONVERGED
        bad = invalid_failure(res, result, run_dir) if args.valid else None
        if bad:
            print(bad, file=sys.stderr)
            return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK


def _power_lines(result: dict) -> list[str]:
    """The per-wing shoulder powers of a six-degree-of-freedom turn (none otherwise)."""
    if "mean_right_shoulder_power_W" not in result:
        return []
    return [f"  shoulder power: right wing {cli.fmt_num(result['mean_right_shoulder_power_W'], '.6g')} W, left wing "
            f"{cli.fmt_num(result['mean_left_shoulder_power_W'], '.6g')} W (positive work "
            f"{cli.fmt_num(result.get('mean_right_positive_power_W'), '.6g')} W, "
            f"{cli.fmt_num(result.get('mean_left_positive_power_W'), '.6g')} W); heading change "
            f"{cli.fmt_num(result.get('heading_change_deg'), '.4g')} deg per wingbeat"]
