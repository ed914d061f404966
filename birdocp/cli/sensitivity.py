"""``birdocp sensitivity``: exact derivatives of the Floquet multipliers, ranked."""

from __future__ import annotations

import argparse
import time

from birdocp.bird.config import ConfigError
from birdocp.bird.keys import AMPLITUDE_KEY, resolve_key
from birdocp.bird.validity import validity_text
from birdocp.cli import common as cli


HELP = "exact derivatives of the Floquet multipliers with respect to gait and morphology parameters, ranked"

DESCRIPTION = """Trim the configured gait and rank the parameters by the exact derivative of the expanding
multiplier's modulus (the change of the cycle included), per degree or per cm. --level holds level flight: the
amplitude is first solved for level flight and re-solved along every parameter direction."""
"""The text of ``birdocp sensitivity --help`` (argparse joins the lines)."""


def register(sub, common) -> None:
    """Add ``sensitivity`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = cli.add_run_command(sub, common, "sensitivity", cmd_sensitivity, help=HELP,
                            description=DESCRIPTION)
    p.add_argument("--param", action="append", metavar="KEY",
                   help="parameter to differentiate (repeatable; default: every gait joint and the morphology)")
    p.add_argument("--level", action="store_true", help="hold level flight (amplitude re-solved)")
    p.add_argument("--top", type=int, default=15, metavar="N", help="rows to print (default 15)")


def check_key(key: str, flag: str) -> str:
    """The model parameter ``key`` names (a dotted key or an alias: amplitude, root_ahead_m), else a
    ConfigError on ``flag`` with a suggestion and the kinds of keys there are.

    Parameters
    ----------
    key : str
        Dotted key or alias.
    flag : str
        Flag named by the error.

    Returns
    -------
    str
        The dotted model key.
    """
    return resolve_key(key, flag)


def cmd_sensitivity(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp sensitivity``.

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
    t0 = time.perf_counter()
    cfg = cli.resolve_config(args)
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.cli.six_dof import run_six_dof_sensitivity

        return run_six_dof_sensitivity(args, command_line, cfg, t0)
    params = list(dict.fromkeys(check_key(k, "--param") for k in (args.param or []))) or None
    if args.level and AMPLITUDE_KEY in (params or []):  # it would be dropped: the result had no row for it
        raise ConfigError("--param", f"{AMPLITUDE_KEY} is re-solved for level flight with --level, not a "
                                     "parameter: drop it from --param (or drop --level)")
    if args.top < 1:
        raise ConfigError("--top", f"must be >= 1, got {args.top}")
    with cli.run_folder(args, "sensitivity", command_line) as run:
        with run.solving():
            from birdocp.bird.config import with_values
            from birdocp.studies.sensitivity import multiplier_sensitivities
            from birdocp.studies.trim import trim

            if args.level:
                from birdocp.studies.level import level

                lv = level(cfg)
                base = trim(with_values(cfg, {"gait.shoulder_flap.amplitude_deg": lv.amplitude_deg}),
                            warm_start=lv) if lv.success else lv
            else:
                base = trim(cfg)
        if not base.success:
            result = {"success": False, "status": base.status, "message": base.message,
                      "max_residual": getattr(base, "max_residual", None),
                      "wall_s": {"total": time.perf_counter() - t0}, "run_dir": str(run.dir)}
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("sensitivity: the cycle did not converge", base.status, result["max_residual"],
                            base.message)
        with run.solving():
            s = multiplier_sensitivities(base, params, hold_level=args.level)
        result = {"success": True, "status": base.status, "amplitude_deg": base.amplitude_deg, **s.to_dict(),
                  "validity": base.validity.to_dict(),
                  "wall_s": {"total": time.perf_counter() - t0}, "run_dir": str(run.dir)}
        run.write(base.cfg, result)
        run.output(result, None if args.json else _table(s, base, args, result, run.dir))
    return cli.EXIT_OK


def _table(s, base, args, result, run_dir) -> str:
    lam = s.multipliers[0]
    lines = [f"sensitivity of the expanding multiplier {lam.real:.6f} (|.| = {abs(lam):.6f}) at amplitude "
             f"{base.amplitude_deg:.4f} deg{' (level flight held)' if args.level else ''}; per unit of the parameter:"]
    head = f"  {'parameter':42s} {'d|L1|':>11s} {'dL1 (re, im)':>24s} {'d mean W [m/s]':>15s}"
    if args.level:
        head += f" {'dA [deg]':>10s}"
    lines.append(head)
    for row in s.ranked()[:args.top]:
        line = (f"  {row['parameter'] + ' /' + row['unit']:42s} {row['d_modulus_per_unit']:+11.3e} "
                f"{row['d_multiplier_per_unit'][0]:+11.3e} {row['d_multiplier_per_unit'][1]:+11.3e}j "
                f"{row['d_mean_vertical_speed_mps_per_unit']:+15.3e}")
        if args.level:
            line += f" {row['d_amplitude_deg_per_unit']:+10.3e}"
        lines.append(line)
    lines.append(f"  model validity of the cycle: {validity_text(result['validity'])}")
    lines.append(f"  ({len(s.parameters)} parameters, {result['wall_s']['total']:.1f} s; written to {run_dir})")
    return "\n".join(lines)
