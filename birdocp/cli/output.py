"""The output half of every CLI command: exit codes, the one JSON object, solver noise, and the run-folder
context manager :func:`run_folder` (claim, solver noise, clean-up, exit codes).

Split from :mod:`birdocp.cli.common` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

from birdocp.cli.tables import fmt_num, one_line
from birdocp.engine.solver_log import LOG_ENV, NoiseFilter

PROG = "birdocp"
EXIT_OK = 0
EXIT_NOT_CONVERGED = 1
"""The computation failed (did not converge, diverged; result written) or its output could not be
written (full disk, file-size limit)."""
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 3
"""An unexpected error (a bug): one line naming the log file that holds the traceback."""
EXIT_INTERRUPTED = 130


# ---------------------------------------------------------------------------------------------
# Output helpers

@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send everything written to stdout (Python and C level, e.g. IPOPT) to stderr meanwhile.

    Yields
    ------
    None
    """
    sys.stdout.flush()
    saved = None
    try:
        saved = os.dup(1)
        os.dup2(2, 1)
    except OSError:
        saved = None
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        with contextlib.suppress(Exception):
            sys.stdout.flush()
            sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def add_plot_flag(p) -> None:
    """``--plot``: draw the cycle's figures in the run folder too (the command draws none by default,
    so that it imports no plotting library; ``birdocp plot RUN_DIR`` draws them later).

    Parameters
    ----------
    p : argparse.ArgumentParser
        Parser of the command.
    """
    p.add_argument("--plot", action="store_true",
                   help="also draw power.png (power over the wingbeat) in the run folder; without it "
                        "`birdocp plot RUN_DIR` draws the figures later")


def power_figure(arrays, run_dir: Path, args=None) -> None:
    """power.png (power over the wingbeat) in the run folder, when the power outputs exist and
    ``args.plot`` (:func:`add_plot_flag`) asks for it.

    Parameters
    ----------
    arrays : dict or None
        Arrays of the result (``power_t_s`` and ``power_<name>`` [W]).
    run_dir : Path
        The run folder.
    args : argparse.Namespace, optional
        Parsed arguments (None: draw whenever the outputs exist).
    """
    if args is not None and not getattr(args, "plot", False):
        return
    if arrays and "power_t_s" in arrays:
        with stdout_to_stderr():
            from birdocp.plots.energetics import plot_power

            plot_power(arrays, Path(run_dir) / "power.png")


def record_result(run_dir: Path, cfg, result: dict, command_line: list[str], command: str) -> None:
    """Record ``run_dir`` in ``result`` and write the run folder (configuration, result.json).

    Parameters
    ----------
    run_dir : Path
        The run folder.
    cfg : Config
        Resolved configuration.
    result : dict
        JSON-able result; ``run_dir`` is added to it.
    command_line : list of str
        The command line, recorded in the provenance.
    command : str
        Name of the command.
    """
    from birdocp.io.runs import write_run

    result["run_dir"] = str(run_dir)
    write_run(run_dir, cfg, result, None, command_line, command=command)


@dataclass
class Context:
    """What one run of the command line carries from the entry point to its end, passed explicitly
    (``args.context``, set by :func:`birdocp.cli.main.main` for every command; :func:`context_of`):

    command_line:  the command as typed (``birdocp trim ...``), for the run folder's provenance.
    json_printed:  the command's one JSON object was printed (a failure after it prints none).
    run_dir:       the run folder that was kept (named by an interrupt or a failure), else None.
    """

    command_line: list[str]
    json_printed: bool = False
    run_dir: Path | None = None


def context_of(args: argparse.Namespace | None) -> Context:
    """The :class:`Context` of a parsed command line (``args.context``); one is made and attached
    when the namespace was built without the entry point (a command called from Python).

    Parameters
    ----------
    args : argparse.Namespace or None
        Parsed arguments.

    Returns
    -------
    Context
    """
    ctx = getattr(args, "context", None)
    if ctx is None:
        ctx = Context([PROG])
        if args is not None:
            args.context = ctx
    return ctx


def print_json(obj: Any, ctx: Context) -> None:
    """Print ``obj`` as the command's one JSON object (complex as [re, im], NaN/inf as null) and
    record in ``ctx`` that it was printed.

    Parameters
    ----------
    obj : Any
        JSON-able value.
    ctx : Context
        Context of the command.
    """
    from birdocp.io.files import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(obj)) + "\n")
    sys.stdout.flush()
    ctx.json_printed = True


def finish_result(result: dict, command: str, t_start: float, run_dir: Path) -> None:
    """The solver's own total wall time becomes ``wall_s[command]``; ``wall_s.total`` is the whole
    command's; ``run_dir`` is recorded.

    Parameters
    ----------
    result : dict
        JSON-able result, changed in place.
    command : str
        Name of the command.
    t_start : float
        ``time.perf_counter()`` at the start of the command [s].
    run_dir : Path
        The run folder.
    """
    wall = result.get("wall_s")
    wall = dict(wall) if isinstance(wall, dict) else ({} if wall is None else {command: wall})
    if "total" in wall:
        wall[command] = wall.pop("total")
    wall["total"] = time.perf_counter() - t_start
    result["wall_s"] = wall
    result["run_dir"] = str(run_dir)




# ---------------------------------------------------------------------------------------------
# Solver noise and run folders

SOLVER_LOG = "solver.log"
"""File of a run folder that receives the solvers' own warnings (unless --verbose)."""

def noise_summary(noise: NoiseFilter | None) -> str:
    """'' or '; 12 solver warnings (first: ...) in DIR/solver.log' (warnings of worker processes,
    which append to the same log, included).

    Parameters
    ----------
    noise : NoiseFilter or None
        Filter of the solve (None with ``--verbose``).

    Returns
    -------
    str
    """
    if noise is None:
        return ""
    count, first = noise.count, noise.first
    if noise.log_path is not None and noise.log_path.is_file():
        with contextlib.suppress(OSError):
            lines = noise.log_path.read_text(encoding="utf-8", errors="replace").splitlines()
            count, first = len(lines), (lines[0] if lines else first)
    if not count:
        return ""
    first = one_line(first or "")
    first = first[first.find("WARNING"):] if "WARNING" in first else first
    where = f" in {noise.log_path}" if noise.log_path is not None else " (--verbose shows them)"
    return f"; {count} solver warning{'s' if count != 1 else ''} ({first[:100]}){where}"


@contextlib.contextmanager
def solver_noise(log_path: Path | None, verbose: bool = False) -> Iterator[NoiseFilter | None]:
    """While the body runs: stdout (Python and C level) goes to stderr (stdout is for the result
    only), and unless ``verbose`` CasADi's warning lines go to ``log_path`` (created when the first
    one arrives) instead of the terminal, also those of worker processes started meanwhile
    (:data:`birdocp.engine.solver_log.LOG_ENV`). Yields the filter (None with ``verbose``).

    Parameters
    ----------
    log_path : Path or None
        The solver log.
    verbose : bool
        Leave CasADi's warnings on the terminal.

    Yields
    ------
    NoiseFilter or None
    """
    with stdout_to_stderr():
        if verbose:
            yield None
            return
        filt = NoiseFilter(sys.stderr, log_path)
        saved = sys.stderr
        saved_env = os.environ.get(LOG_ENV)
        sys.stderr = filt
        if log_path is not None:
            os.environ[LOG_ENV] = str(Path(log_path).resolve())
        else:
            os.environ.pop(LOG_ENV, None)
        try:
            with contextlib.redirect_stdout(filt):
                yield filt
        finally:
            sys.stderr = saved
            filt.close()
            if saved_env is None:
                os.environ.pop(LOG_ENV, None)
            else:
                os.environ[LOG_ENV] = saved_env


class Run:
    """The run folder of one command (from :func:`run_folder`).

    dir:     the claimed folder.
    noise:   the :class:`NoiseFilter` of the solve (None with --verbose).
    """

    def __init__(self, args: argparse.Namespace, command: str, run_dir: Path, command_line: list[str]):
        self.args, self.command, self.dir, self.command_line = args, command, run_dir, command_line
        self.ctx = context_of(args)
        self.noise: NoiseFilter | None = None
        self._verbose = bool(getattr(args, "verbose", False))

    @contextlib.contextmanager
    def solving(self) -> Iterator[None]:
        """Around the computation: solver noise to the run folder's log (see :func:`solver_noise`)."""
        with solver_noise(self.dir / SOLVER_LOG, self._verbose) as filt:
            self.noise = filt
            yield

    def write(self, cfg, result: dict, arrays: dict | None = None) -> Path:
        """config.toml, arrays.npz (if any) and result.json (with provenance, written last), atomically."""
        from birdocp.io.runs import write_run

        return write_run(self.dir, cfg, result, arrays, self.command_line, command=self.command)

    def output(self, result: dict, table: str | None) -> None:
        """Print the result: the one JSON object with --json, else the table."""
        if getattr(self.args, "json", False):
            print_json(result, self.ctx)
        elif table is not None:
            print(table)

    def fail(self, what: str, status: Any, residual: Any, message: Any) -> int:
        """One line on stderr for a failed solve (status, residual, folder); returns exit code 1."""
        warn = noise_summary(self.noise)
        print(f"{PROG}: {what} (status: {one_line(status)}, last residual: {fmt_num(residual, '.3e')}): "
              f"{one_line(message)}; result written to {self.dir}{warn}", file=sys.stderr)
        return EXIT_NOT_CONVERGED


@contextlib.contextmanager
def run_folder(args: argparse.Namespace, command: str, command_line: list[str], *,
               out: str | None = None, resume_file: str | None = None,
               scaffold: Sequence[str] = ()) -> Iterator[Run]:
    """The one run-folder pattern of every command that writes results.

    1. Claim the folder before any computation: ``--out DIR`` (validated and locked exclusively, see
       :func:`birdocp.io.runs.claim_out_dir`; ``resume_file``: an earlier run holding this file may
       be continued) or a new ``runs/<time>-<command>-<id>/``. Anything wrong with the location is a
       :class:`ConfigError` (exit 2), and nothing is created.
    2. The body computes inside ``run.solving()`` (solver noise to ``solver.log``) and writes with
       ``run.write`` (atomic files, result.json last) or its own atomic writers.
    3. On any exception (bad input found late, error, Ctrl-C) a folder that got no result is
       removed again: new files named in ``scaffold`` (written before the first result, e.g. a
       sweep's definition), the solver log and empty sub-folders do not count as results (a
       non-empty sub-folder, e.g. a sweep's points/, does); the folder
       itself only goes if this run created it. What was finished stays. The lock is released on
       every exit.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (``out``, ``verbose``).
    command : str
        Name of the command.
    command_line : list of str
        The command line, recorded in the provenance.
    out : str, optional
        Folder to claim instead of ``args.out``.
    resume_file : str, optional
        File of an earlier run that may be continued.
    scaffold : sequence of str
        Files written before the first result.

    Yields
    ------
    Run
    """
    from birdocp.io.runs import claim_out_dir, folder_entries, held_lock, new_run_dir, release_out_dir

    out = getattr(args, "out", None) if out is None else out
    if out is not None:  # --out '' is refused by claim_out_dir, not taken for no --out
        run_dir = claim_out_dir(out, command, resume_file=resume_file)
        lock = held_lock(run_dir)
        created = bool(lock and lock.created)
        before = set(folder_entries(run_dir))
    else:
        run_dir = new_run_dir(None, command)
        created, before = True, set()
    run = Run(args, command, run_dir, command_line)
    run.ctx.run_dir = run_dir
    try:
        yield run
    except BaseException:
        from birdocp.io.files import signals_deferred

        with signals_deferred(), contextlib.suppress(OSError):  # a second Ctrl-C waits for the clean-up
            if _remove_if_empty(run_dir, before, {SOLVER_LOG, *scaffold}, created):
                run.ctx.run_dir = None
        raise
    finally:
        release_out_dir(run_dir)


def _remove_if_empty(run_dir: Path, before: set, scaffold: set, created: bool) -> bool:
    """Remove what this run added to ``run_dir`` when none of it is a result; True if it did."""
    from birdocp.io.runs import folder_entries, release_out_dir

    new = set(folder_entries(run_dir)) - before
    # a result: a non-empty sub-folder (points/, rows/) or a file that is not scaffold
    results = [n for n in new if (any((run_dir / n).iterdir()) if (run_dir / n).is_dir() else n not in scaffold)]
    if results:
        return False
    for n in new:
        path = run_dir / n
        if path.is_dir():
            path.rmdir()
        else:
            path.unlink()
    release_out_dir(run_dir)
    if created and not folder_entries(run_dir):
        run_dir.rmdir()
    return True


def failure_json(status: str, message: str, ctx: Context) -> dict:
    """The one JSON object of a command that ended without its own (interrupt, internal error).

    Parameters
    ----------
    status : str
        Status of the failure (e.g. "interrupted").
    message : str
        One line saying what happened.
    ctx : Context
        Context of the command (its run folder).

    Returns
    -------
    dict
        ``success`` (False), ``status``, ``message`` and ``run_dir``.
    """
    return {"success": False, "status": status, "message": message,
            "run_dir": str(ctx.run_dir) if ctx.run_dir is not None else None}
