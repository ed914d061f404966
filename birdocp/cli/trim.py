"""``birdocp trim``: the trimmed periodic flight and its Floquet stability, in a run folder."""

from __future__ import annotations

import argparse
import time

from birdocp.bird.config_checks import SOLVE_SOLVERS
from birdocp.cli.common import (add_compiled_flag, add_plot_flag, compiled_requested, EXIT_OK, finish_result,
                                format_trim_table, power_figure, resolve_config, run_folder)


def solve_shortcuts(p: argparse.ArgumentParser) -> None:
    """--points, --steps, --solver, --derivatives, --max-iter, --tol (shorthands writing the solve.*
    keys, applied after --set) and --compiled (``compiled=True`` of the solves).

    Parameters
    ----------
    p : argparse.ArgumentParser
        Parser of the command.
    """
    s = p.add_argument_group("solve (shorthands for the solve.* keys of the configuration)")
    s.add_argument("--points", type=int, metavar="M", help="shooting points per period, closing point included (solve.points)")
    s.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period, a multiple of M-1 (solve.steps_per_period)")
    s.add_argument("--solver", choices=SOLVE_SOLVERS,
                   help="nonlinear solver (solve.solver; auto: newton-picard for a model with "
                        "aerodynamic states, ipopt otherwise)")
    s.add_argument("--derivatives", choices=("exact", "fd"), help="Jacobians by AD or finite differences (solve.derivatives)")
    s.add_argument("--max-iter", dest="solve_max_iter", type=int, metavar="N",
                   help="iteration limit of the limit-cycle solve (solve.max_iter, default 100)")
    s.add_argument("--tol", dest="solve_tol", type=float, metavar="TOL",
                   help="convergence tolerance of the limit-cycle solve, max-norm of the shooting residual "
                        "(solve.tol; default 0: 1e-10 for ipopt, 1e-5 for lm)")
    add_compiled_flag(s)


def register(sub, common) -> None:
    """Add ``trim`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("trim", parents=[common], help="find the trimmed periodic flight and its Floquet stability",
                       description="Find the periodic (trimmed) flapping flight by multiple shooting and its "
                                   "Floquet multipliers. Writes a run folder (config.toml, result.json, arrays.npz).")
    solve_shortcuts(p)
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-trim-<id>/")
    p.add_argument("--error-estimate", action="store_true",
                   help="add error_estimate to result.json: a re-solve on twice the RK4 steps and the solver's "
                        "tolerance (multipliers, x0, means)")
    add_plot_flag(p)
    p.set_defaults(func=cmd_trim)


def _last_residual(result: dict):
    """The max residual of a result, else the last of its residual history."""
    last = result.get("max_residual")
    hist = result.get("residual_history") or []
    return hist[-1] if last is None and hist else last


def cmd_trim(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp trim``.

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
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.cli.six_dof import run_six_dof

        return run_six_dof(args, "trim", command_line, cfg, {})
    with run_folder(args, "trim", command_line) as run:
        with run.solving():
            from birdocp.studies.trim import trim

            res = trim(cfg, compiled=compiled_requested(args),
                       **({"error_estimate": True} if args.error_estimate else {}))
            getattr(res, "energetics", None)  # computes the power outputs (result.json and the table)
            result = dict(res.to_dict())
            arrays = res.arrays() if hasattr(res, "arrays") else None
        finish_result(result, "trim", t_start, run.dir)
        run.write(cfg, result, arrays)
        power_figure(arrays, run.dir, args)  # only with --plot: `birdocp plot RUN_DIR` draws it later
        run.output(result, format_trim_table(result))
        if not res.success:
            return run.fail("trim did not converge", res.status, _last_residual(result), res.message)
    return EXIT_OK
