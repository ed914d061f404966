"""Shared pieces of every CLI command: exit codes, the common options, configuration resolution
(defaults <- CONFIG <- --set <- dedicated flags), output helpers, the trim table and the run-folder
context manager :func:`run_folder` (claim, solver noise, clean-up, one JSON object, exit codes).

Every command module in :mod:`birdocp.cli` builds on these; none of them is private.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Sequence

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.bird.keys import AMPLITUDE_KEY, ROOT_AHEAD_KEY, resolve_key
from birdocp.cli.tables import (fmt_num, format_trim_table, growth_text, one_line, pairs, real_part,  # noqa: F401
                                validity_notes, validity_word)
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
# Parser

class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (still exit code 2) that reads negative numbers in scientific
    notation (``--time -1e-3``, ``--to -3.25e1``) as values: argparse's own pattern knows only ``-1``
    and ``-0.5`` and took them for unknown options."""

    NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = self.NEGATIVE_NUMBER  # the attribute argparse consults

    def error(self, message: str):  # noqa: D401 - argparse API
        hint = f"see '{self.prog} --help'"
        self.exit(EXIT_BAD_INPUT, f"{PROG}: error: {one_line(message)}; {hint}\n")


def common_options() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(add_help=False)
    g = p.add_argument_group("configuration (defaults <- CONFIG <- --set <- dedicated flags)")
    g.add_argument("config", nargs="?", metavar="CONFIG",
                   help="TOML configuration file (start one with 'birdocp config > bird.toml')")
    g.add_argument("--amplitude", type=float, metavar="DEG",
                   help=f"flapping amplitude in degrees (sets {AMPLITUDE_KEY})")
    g.add_argument("--root-ahead", type=float, metavar="M",
                   help=f"distance of the wing root ahead of the centre of mass in metres (sets {ROOT_AHEAD_KEY})")
    g.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="sets",
                   help="set a dotted config key, e.g. --set aero.circulation=relaxed (repeatable; "
                        "the value is read as TOML, bare words are strings)")
    o = p.add_argument_group("output")
    o.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")
    o.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    o.add_argument("--verbose", action="store_true",
                   help="show the solvers' own warnings (CasADi 'NaN detected', ...) on the terminal instead of "
                        "writing them to the run folder's solver.log")
    o.add_argument("--quiet", action="store_true",
                   help="no progress bar on stderr (there is none anyway when stderr is not a terminal)")
    return p


def add_run_command(sub, common: argparse.ArgumentParser, name: str, func, *, help: str,
                    description: str) -> argparse.ArgumentParser:
    """The subparser of a command that writes a run folder: the common options, ``--out DIR`` and
    ``func(args, command_line) -> exit code`` as its handler; the command adds its own options."""
    p = sub.add_parser(name, parents=[common], help=help, description=description)
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty)")
    p.set_defaults(func=func)
    return p


def add_free_gait_options(p: argparse.ArgumentParser, *, free_help: str, default_bounds: str) -> None:
    """``--free KEY`` (repeatable), ``--bounds KEY=LO:HI`` (repeatable; default ``default_bounds``) and
    ``--climb-rate MPS`` of the gait optimisations."""
    p.add_argument("--free", action="append", metavar="KEY", help=free_help)
    add_bounds_option(p, f"bounds of a free parameter (joint limits; repeatable, LO < HI; default: {default_bounds})")
    p.add_argument("--climb-rate", type=float, default=0.0, metavar="MPS", help="mean vertical speed (default 0)")


def bounds_text(text: str) -> str:
    """The argparse type of ``--bounds``: ``KEY=LO:HI`` (checked later by :func:`parse_bounds`). The
    form ``--bounds LO HI`` of earlier versions is refused here, while the command line is parsed
    (its second number would otherwise be taken for the CONFIG file), with one line naming the new form."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not KEY=LO:HI: '--bounds LO HI' is now '--bounds KEY=LO:HI', e.g. --bounds amplitude=20:70")
    return text


def add_bounds_option(g, help: str) -> None:
    """The one ``--bounds KEY=LO:HI`` option (repeatable) of every command that takes bounds."""
    g.add_argument("--bounds", action="append", type=bounds_text, metavar="KEY=LO:HI", help=help)


def parse_bounds(texts: Sequence[str] | None) -> dict[str, tuple[float, float]]:
    """{model key: (lo, hi)} from ``--bounds KEY=LO:HI`` texts: KEY a dotted key or an alias
    (:func:`birdocp.bird.keys.resolve_key`), LO < HI finite; ConfigError on ``--bounds`` otherwise."""
    bounds = {}
    for text in texts or []:
        try:
            key, rng = text.split("=", 1)
            lo, hi = (float(v) for v in rng.split(":"))
        except ValueError:
            raise ConfigError("--bounds", f"expected KEY=LO:HI, got '{text}'") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ConfigError("--bounds", f"need finite LO < HI, got '{text}'")
        bounds[resolve_key(key.strip(), "--bounds")] = (lo, hi)
    return bounds


def bounds_of(texts: Sequence[str] | None, key: str) -> tuple[float, float] | None:
    """The bounds ``--bounds`` gives the one free parameter ``key`` (None: not given); bounds of any
    other key are a ConfigError naming the free one."""
    bounds = parse_bounds(texts)
    for k in bounds:
        if k != key:
            raise ConfigError("--bounds", f"'{k}' is not the free parameter; give --bounds {key}=LO:HI")
    return bounds.get(key)


def add_compiled_flag(g) -> None:
    """``--compiled``: pass ``compiled=True`` to the solves (``BIRDOCP_COMPILED=1`` in the environment
    is a shorthand for it, see :func:`compiled_requested`)."""
    g.add_argument("--compiled", action="store_true",
                   help="use the state RHS and the data's post compiled to C (the same numbers; compiled once, "
                        "~15 s, and cached in $BIRDOCP_CACHE or ~/.cache/birdocp; falls back to the interpreted "
                        "path with a warning if compilation fails; BIRDOCP_COMPILED=1 is a shorthand)")


COMPILED_ENV = "BIRDOCP_COMPILED"
"""Environment variable that is a shorthand for ``--compiled`` on the command line (1/on/yes/true).
The library never reads it: the Python API takes ``compiled=``."""


def compiled_requested(args: argparse.Namespace) -> bool:
    """``compiled=`` of the command's solves: ``--compiled`` or ``$BIRDOCP_COMPILED`` on."""
    env = os.environ.get(COMPILED_ENV, "").strip().lower() in ("1", "on", "yes", "true")
    return bool(getattr(args, "compiled", False)) or env


# ---------------------------------------------------------------------------------------------
# Configuration

def config_message(exc: ConfigError) -> str:
    """The message of a ConfigError without its ``"key: "`` prefix."""
    text = str(exc)
    prefix = f"{exc.key}: "
    return text[len(prefix):] if exc.key and text.startswith(prefix) else text


def load_config_file(path_text: str) -> C.Config:
    """The configuration in the CONFIG file: a regular file (a FIFO, device or folder is refused
    without opening it), at most :data:`birdocp.io.inputs.MAX_TEXT_BYTES`, UTF-8 TOML (a byte-order
    mark is dropped); each problem is a ConfigError naming the file."""
    from birdocp.io.inputs import file_problem, read_input_text

    path = Path(path_text)
    if file_problem(path) == "does not exist":
        raise ConfigError("CONFIG", f"file '{path}' does not exist; give the path of a TOML file "
                                    "(write one with 'birdocp config > bird.toml')")
    text = read_input_text(path, "CONFIG", what=f"'{path}'")
    try:
        return C.loads(text)
    except ConfigError as exc:
        if not exc.key:  # not valid TOML
            raise ConfigError(str(path), config_message(exc)) from None
        raise ConfigError(exc.key, f"{config_message(exc)} (in {path})") from None


def parse_assignment(assignment: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--set``, the value parsed as by :func:`birdocp.bird.config.set_value`."""
    if "=" not in assignment:
        raise ConfigError("--set", f"'{assignment}' is not KEY=VALUE; e.g. --set aero.circulation=relaxed")
    key, text = assignment.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError("--set", f"missing key in '{assignment}'; expected KEY=VALUE, e.g. body.mass_kg=1.3")
    return key, C.parse_scalar(text.strip())


def flag_values(args: argparse.Namespace) -> list[tuple[str, str, Any]]:
    """(flag, dotted key, value) of the dedicated flags that were given."""
    table = [
        ("--amplitude", AMPLITUDE_KEY, "amplitude"),
        ("--root-ahead", ROOT_AHEAD_KEY, "root_ahead"),
        ("--points", "solve.points", "points"),
        ("--steps", "solve.steps_per_period", "steps"),
        ("--solver", "solve.solver", "solver"),
        ("--derivatives", "solve.derivatives", "derivatives"),
        ("--max-iter", "solve.max_iter", "solve_max_iter"),
        ("--tol", "solve.tol", "solve_tol"),
    ]
    return [(flag, key, getattr(args, attr)) for flag, key, attr in table
            if getattr(args, attr, None) is not None]


def resolve_config(args: argparse.Namespace) -> C.Config:
    """The validated configuration: defaults <- CONFIG file <- --set <- dedicated flags."""
    cfg = load_config_file(args.config) if getattr(args, "config", None) else C.Config()
    values: dict[str, Any] = {}
    for assignment in getattr(args, "sets", None) or []:
        key, value = parse_assignment(assignment)
        values[key] = value
    flags = flag_values(args)
    by_key = {}
    for flag, key, value in flags:
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(key, f"must be finite, got {value!r} (from {flag})")
        values[key] = value
        by_key[key] = flag
    if values:
        try:
            cfg = C.with_values(cfg, values)
        except ConfigError as exc:
            if exc.key in by_key:
                raise ConfigError(exc.key, f"{config_message(exc)} (from {by_key[exc.key]})") from None
            raise
    return cfg


def finite_values(name: str, values: Sequence[float]) -> list[float]:
    for v in values:
        if not math.isfinite(v):
            raise ConfigError(name, f"must be finite numbers, got {v!r}")
    return [float(v) for v in values]


# ---------------------------------------------------------------------------------------------
# Output helpers

@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send everything written to stdout (Python and C level, e.g. IPOPT) to stderr meanwhile."""
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
    so that it imports no plotting library; ``birdocp plot RUN_DIR`` draws them later)."""
    p.add_argument("--plot", action="store_true",
                   help="also draw power.png (power over the wingbeat) in the run folder; without it "
                        "`birdocp plot RUN_DIR` draws the figures later")


def power_figure(arrays, run_dir: Path, args=None) -> None:
    """power.png (power over the wingbeat) in the run folder, when the power outputs exist and
    ``args.plot`` (:func:`add_plot_flag`) asks for it."""
    if args is not None and not getattr(args, "plot", False):
        return
    if arrays and "power_t_s" in arrays:
        with stdout_to_stderr():
            from birdocp.plots.energetics import plot_power

            plot_power(arrays, Path(run_dir) / "power.png")


def record_result(run_dir: Path, cfg, result: dict, command_line: list[str], command: str) -> None:
    """Record ``run_dir`` in ``result`` and write the run folder (configuration, result.json)."""
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
    when the namespace was built without the entry point (a command called from Python)."""
    ctx = getattr(args, "context", None)
    if ctx is None:
        ctx = Context([PROG])
        if args is not None:
            args.context = ctx
    return ctx


def print_json(obj: Any, ctx: Context) -> None:
    """Print ``obj`` as the command's one JSON object (complex as [re, im], NaN/inf as null) and
    record in ``ctx`` that it was printed."""
    from birdocp.io.files import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(obj)) + "\n")
    sys.stdout.flush()
    ctx.json_printed = True


def finish_result(result: dict, command: str, t_start: float, run_dir: Path) -> None:
    """The solver's own total wall time becomes ``wall_s[command]``; ``wall_s.total`` is the whole
    command's; ``run_dir`` is recorded."""
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
    which append to the same log, included)."""
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
    (:data:`birdocp.engine.solver_log.LOG_ENV`). Yields the filter (None with ``verbose``)."""
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
    """The one JSON object of a command that ended without its own (interrupt, internal error)."""
    return {"success": False, "status": status, "message": message,
            "run_dir": str(ctx.run_dir) if ctx.run_dir is not None else None}
