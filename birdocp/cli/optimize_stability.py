"""``birdocp optimize-stability``: the gait within bounds that minimises the largest multiplier."""

from __future__ import annotations

import argparse

from birdocp.bird.config import require_body_states
import math
import sys

from birdocp.bird.config import ConfigError
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.bird.validity import validity_text
from birdocp.cli import common as cli
from birdocp.cli.sensitivity import check_key


HELP = "the gait within bounds that minimises the largest multiplier of level flight"

DESCRIPTION = """Minimise the largest Floquet multiplier modulus of a level-flight cycle over free gait parameters
within bounds (Jury conditions on the monodromy's characteristic polynomial), then verify with numpy eigenvalues and a
trim from scratch at the optimum. Default: reduced space (IPOPT over the gait parameters and r, the level cycle solved
at every iterate, exact gradients), as optimize-gait."""
"""The text of ``birdocp optimize-stability --help`` (argparse joins the lines)."""


def register(sub, common) -> None:
    """Add ``optimize-stability`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = cli.add_run_command(sub, common, "optimize-stability", cmd_optimize, help=HELP,
                            description=DESCRIPTION)
    cli.add_free_gait_options(p, free_help="free parameter (repeatable; default: shoulder incidence and sweep "
                                           "offsets and amplitudes)",
                              default_bounds="birdocp.studies.optimize.DEFAULT_FREE")
    p.add_argument("--max-iter", type=int, default=400, metavar="N",
                   help="IPOPT iterations at most, per stage (default 400; the result says whether it converged)")
    p.add_argument("--method", choices=("reduced", "full"), default="reduced",
                   help="reduced: IPOPT over the gait parameters and r, the level cycle eliminated (default); "
                        "full: the full-space single-shooting NLP (state, parameters, amplitude, r)")
    add_valid_flag(p)
    p.add_argument("--turn-rate", type=float, default=None, metavar="DEG",
                   help="six degrees of freedom: hold the heading change per wingbeat at DEG (a steady turn, "
                        "positive to the right); free per-side offsets (--free gait.right_offset.KEY) to reach it")
    p.add_argument("--threads", type=int, default=2, metavar="N",
                   help="threads evaluating the finite-difference Hessian's points (reduced method; default 2; "
                        "the result does not depend on it)")


def add_valid_flag(p: argparse.ArgumentParser) -> None:
    """``--valid``: the limits of ``[validity]`` as smooth constraints of the optimiser.

    Parameters
    ----------
    p : argparse.ArgumentParser
        Parser of the command.
    """
    p.add_argument("--valid", action="store_true",
                   help="constrain the cycle to where the model holds: every limit of [validity] (stalled "
                        "span-time share, minimum forward speed, |pitch|, airflow-to-body angle) as a smooth "
                        "constraint (tighten with --set validity.KEY=VALUE); JSON adds validity_constraints")


def validity_lines(result: dict) -> list[str]:
    """Table lines of a result's ``validity_constraints`` (none without ``--valid``).

    Parameters
    ----------
    result : dict
        JSON-able result of the optimisation.

    Returns
    -------
    list of str
    """
    vc = result.get("validity_constraints") or {}
    lines = []
    for k, c in vc.items():
        op = "<=" if c.get("kind") == "max" else ">="
        tight = "" if c.get("bound_used") == c.get("bound") else f" (held {op} {cli.fmt_num(c.get('bound_used'), '.5g')})"
        lines.append(f"  validity limit {k:28s} smooth {cli.fmt_num(c.get('smooth'), '.5g'):>9s}  exact "
                     f"{cli.fmt_num(c.get('exact'), '.5g'):>9s}  {op} {c.get('bound'):g}{tight}"
                     f"{'  ACTIVE' if c.get('active') else ''}")
    return lines


def six_dof_lines(result: dict) -> list[str]:
    """Table lines of a six-degree-of-freedom optimum: the longitudinal and lateral multipliers and
    radii (none for a planar one).

    Parameters
    ----------
    result : dict
        JSON-able result of the optimisation.

    Returns
    -------
    list of str
    """
    if result.get("degrees_of_freedom") != 6:
        return []
    pairs = lambda z: ", ".join(f"{a:.5f}{b:+.5f}j" for a, b in z)  # noqa: E731
    check = result.get("verification") or {}
    return [f"  six degrees of freedom (symmetric gait; the heading's multiplier 1 left out): longitudinal radius "
            f"{cli.fmt_num(result.get('longitudinal_radius'), '.6f')}, lateral radius "
            f"{cli.fmt_num(result.get('lateral_radius'), '.6f')}",
            "    longitudinal: " + pairs(result.get("longitudinal_multipliers") or []),
            "    lateral:      " + pairs(result.get("lateral_multipliers") or [])] + \
        (["    lateral modes (6-DOF trim at the optimum): " + ", ".join(
            f"{m['label']} {abs(complex(*m['multiplier'])):.5f}" for m in check["trim_lateral_modes"])]
         if check.get("trim_lateral_modes") else [])


def invalid_failure(res, result: dict, run_dir) -> str | None:
    """The failure line when ``--valid`` was asked for and the optimum's exact verdict is not valid.

    Parameters
    ----------
    res : optimisation result
        Result of the optimiser.
    result : dict
        Its JSON-able form (``validity``).
    run_dir : Path
        The run folder, named by the line.

    Returns
    -------
    str or None
        None when ``--valid`` was not asked for or the optimum is valid.
    """
    v = result.get("validity") or {}
    if v.get("valid"):
        return None
    rounds = len(result.get("validity_rounds") or [])
    return (f"{cli.PROG}: the optimum is NOT VALID after {rounds} validity round(s) "
            f"({'; '.join(v.get('reasons') or ['not checked'])}); result written to {run_dir}")


def _free_with_bounds(args: argparse.Namespace, defaults: dict) -> dict:
    """key -> (lo, hi) from ``--free KEY`` (default: the keys of ``defaults``) and ``--bounds KEY=LO:HI``
    (default: ``defaults``' range); ConfigError (exit 2) on an unknown key or a malformed range."""
    from birdocp.bird.sides import SIDE_PARAM_NAMES  # per-side offsets: six degrees of freedom (checked later)

    keys = [k if k in SIDE_PARAM_NAMES else check_key(k, "--free") for k in (args.free or [])] or list(defaults)
    bounds = cli.parse_bounds(args.bounds)
    free = {}
    for k in keys:
        if k == AMPLITUDE_KEY:
            raise ConfigError("--free", f"{k} is solved for level flight at every iterate; free other keys")
        if k in bounds:
            free[k] = bounds[k]
        elif k in defaults:
            free[k] = defaults[k]
        else:
            raise ConfigError("--bounds", f"'{k}' has no default range; give --bounds {k}=LO:HI")
    for k in bounds:
        if k not in free:
            raise ConfigError("--bounds", f"'{k}' is not free; add --free {k}")
    return free


def checked_free(args: argparse.Namespace, cfg, defaults: dict, objective: str = "stability") -> dict:
    """:func:`_free_with_bounds`, then every free key checked against the model before any run folder
    exists (:func:`birdocp.studies.optimize.check_free_keys`: not the amplitude, not reshaping the
    wing in the arm frame, the configured value inside its bounds); ConfigError (exit 2) otherwise.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (``free``, ``bounds``).
    cfg : Config
        Resolved configuration.
    defaults : dict
        Default free keys and bounds of the command.
    objective : str
        The command's objective: a turn (six degrees of freedom with per-side offsets set or free, or
        ``--turn-rate``) takes the power objectives, not with Wagner's section.

    Returns
    -------
    dict
        Free model key to (lo, hi).
    """
    from birdocp.studies.gait import check_free_bounds
    from birdocp.studies.optimize import check_free_keys

    from birdocp.studies.turn_cycle import check_turn, is_turn

    free = _free_with_bounds(args, defaults)
    check_free_bounds(cfg, free)  # everything that needs no model, before building it
    turn_rate = getattr(args, "turn_rate", None)
    turn = is_turn(cfg, free, turn_rate)
    check_turn(cfg, objective, turn_rate, turn)
    with cli.stdout_to_stderr():
        from birdocp.bird.model import get_model

        check_free_keys(get_model(cfg), cfg, free)
    return free


def cmd_optimize(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp optimize-stability``.

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
    from birdocp.studies.optimize import DEFAULT_FREE, optimize_stability

    cfg = cli.resolve_config(args)
    if args.method == "full":  # before any computation: exit 2
        require_body_states(cfg, "optimize-stability --method full", "use the reduced method (drop --method full)")
    if not math.isfinite(args.climb_rate):
        raise ConfigError("--climb-rate", f"must be finite, got {args.climb_rate}")
    if not 1 <= args.max_iter <= 100000:
        raise ConfigError("--max-iter", f"must be an integer in [1, 100000], got {args.max_iter}")
    if not 1 <= args.threads <= 64:
        raise ConfigError("--threads", f"must be an integer in [1, 64], got {args.threads}")
    free = checked_free(args, cfg, DEFAULT_FREE)
    with cli.run_folder(args, "optimize-stability", command_line) as run:
        from birdocp.io.progress import progress_callback

        say, bar = progress_callback("optimize-stability", args.quiet)
        with run.solving(), bar:
            res = optimize_stability(cfg, free, climb_rate_mps=args.climb_rate, max_iter=args.max_iter, progress=say,
                                     method=args.method, threads=args.threads, valid=args.valid,
                                     turn_deg_per_beat=args.turn_rate)
        result = res.to_dict()
        result["run_dir"] = str(run.dir)
        run.write(res.cfg or cfg, result)
        if args.json:
            cli.print_json(result, cli.context_of(args))
        else:
            _print_table(res, result, run.dir)
        if not res.success:
            warn = cli.noise_summary(run.noise)
            print(f"{cli.PROG}: optimisation did not converge (status {res.status}, {residuals(res)}); result "
                  f"written to {run.dir}{warn}", file=sys.stderr)
            return cli.EXIT_NOT_CONVERGED
        bad = invalid_failure(res, result, run.dir) if args.valid else None
        if bad:
            print(bad, file=sys.stderr)
            return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK


def residuals(res) -> str:
    """'KKT residual 2.16e+00, constraint violation 0.00e+00' of an optimisation result (what the
    failure line reports as its residual).

    Parameters
    ----------
    res : optimisation result
        With ``kkt_residual`` and ``constraint_violation``.

    Returns
    -------
    str
    """
    return (f"KKT residual {cli.fmt_num(getattr(res, 'kkt_residual', None), '.2e')}, "
            f"constraint violation {cli.fmt_num(getattr(res, 'constraint_violation', None), '.2e')}")


def _print_table(res, result: dict, run_dir) -> None:
    kkt = f", KKT residual {res.kkt_residual:.2e}" if res.kkt_residual is not None else ""
    print(f"optimize-stability: {'converged' if res.success else 'NOT converged'} ({res.status}), "
          f"{res.iterations} iterations, {res.wall_s.get('total', 0):.1f} s ({res.method} space){kkt}")
    valid = bool((result.get("validity") or {}).get("valid"))
    print(f"  largest multiplier modulus {max(abs(res.multipliers)):.6f} (start {max(abs(res.start_multipliers)):.6f}); "
          f"{'STABLE' if res.stable else 'UNSTABLE'} level{'' if valid else ' cycle (the model is NOT VALID on it)'}"
          f"{' flight' if valid else ''} at amplitude {res.amplitude_deg:.4f} deg")
    for k, v in res.free.items():
        lo, hi = res.bounds[k]
        at = " (at a bound)" if min(abs(v - lo), abs(v - hi)) < 1e-6 else ""
        print(f"  {k:40s} {v:+10.4f}   in [{lo:g}, {hi:g}]{at}")
    print("  multipliers: " + ", ".join(f"{z.real:.5f}{z.imag:+.5f}j" for z in res.multipliers))
    for line in six_dof_lines(result):
        print(line)
    v = res.verification
    if v:
        print(f"  check: trim at the optimum {'converged' if v.get('trim_success') else 'FAILED'}, "
              f"multipliers differ by {v.get('max_multiplier_difference')}, "
              f"mean W {v.get('trim_mean_vertical_speed_mps')}")
    print(f"  model validity of the optimal cycle: {validity_text(result.get('validity'))}")
    for line in validity_lines(result):
        print(line)
    print(f"  written to {run_dir}")
