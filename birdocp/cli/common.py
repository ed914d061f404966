"""Shared pieces of every CLI command: the common options and configuration resolution (defaults <-
CONFIG <- --set <- dedicated flags); it re-exports the trim table (:mod:`birdocp.cli.tables`), the exit
codes, output helpers and the run-folder context manager :func:`run_folder` (:mod:`birdocp.cli.output`).

Every command module in :mod:`birdocp.cli` builds on these; none of them is private.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from pathlib import Path
from typing import Any, Sequence

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.bird.keys import AMPLITUDE_KEY, ROOT_AHEAD_KEY, resolve_key
from birdocp.cli.tables import (fmt_num, format_trim_table, growth_text, one_line, pairs, real_part,  # noqa: F401
                                validity_notes, validity_word)
# The output half (exit codes, JSON, solver noise, run folders) lives in birdocp.cli.output; every
# command reaches it through this module as before.
from birdocp.cli.output import (  # noqa: F401
    Context, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_NOT_CONVERGED, EXIT_OK, PROG, Run,
    add_plot_flag, context_of, failure_json, finish_result, noise_summary, power_figure, print_json,
    record_result, run_folder, solver_noise, stdout_to_stderr)


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
    """The parent parser of the options every model command shares (CONFIG, ``--set``, dedicated flags).

    Returns
    -------
    argparse.ArgumentParser
        Parser without help, for ``parents=``.
    """
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
    ``func(args, command_line) -> exit code`` as its handler; the command adds its own options.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options (:func:`common_options`).
    name : str
        Name of the command.
    func : callable
        Handler of the command.
    help, description : str
        Texts of the command's help.

    Returns
    -------
    argparse.ArgumentParser
    """
    p = sub.add_parser(name, parents=[common], help=help, description=description)
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty)")
    p.set_defaults(func=func)
    return p


def add_free_gait_options(p: argparse.ArgumentParser, *, free_help: str, default_bounds: str) -> None:
    """``--free KEY`` (repeatable), ``--bounds KEY=LO:HI`` (repeatable; default ``default_bounds``) and
    ``--climb-rate MPS`` of the gait optimisations.

    Parameters
    ----------
    p : argparse.ArgumentParser
        Parser of the command.
    free_help : str
        Help text of ``--free``.
    default_bounds : str
        The default bounds, as named in the help of ``--bounds``.
    """
    p.add_argument("--free", action="append", metavar="KEY", help=free_help)
    add_bounds_option(p, f"bounds of a free parameter (joint limits; repeatable, LO < HI; default: {default_bounds})")
    p.add_argument("--climb-rate", type=float, default=0.0, metavar="MPS", help="mean vertical speed (default 0)")


def _bounds_text(text: str) -> str:
    """The argparse type of ``--bounds``: ``KEY=LO:HI`` (checked later by :func:`parse_bounds`). The
    form ``--bounds LO HI`` of earlier versions is refused here, while the command line is parsed
    (its second number would otherwise be taken for the CONFIG file), with one line naming the new form."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(
            f"'{text}' is not KEY=LO:HI: '--bounds LO HI' is now '--bounds KEY=LO:HI', e.g. --bounds amplitude=20:70")
    return text


def add_bounds_option(g, help: str) -> None:
    """The one ``--bounds KEY=LO:HI`` option (repeatable) of every command that takes bounds.

    Parameters
    ----------
    g : argparse.ArgumentParser or argument group
        Where the option goes.
    help : str
        Help text of the option.
    """
    g.add_argument("--bounds", action="append", type=_bounds_text, metavar="KEY=LO:HI", help=help)


def parse_bounds(texts: Sequence[str] | None) -> dict[str, tuple[float, float]]:
    """{model key: (lo, hi)} from ``--bounds KEY=LO:HI`` texts: KEY a dotted key or an alias
    (:func:`birdocp.bird.keys.resolve_key`) or a per-side offset ``gait.right_offset.*`` /
    ``gait.left_offset.*``, LO < HI finite; ConfigError on ``--bounds`` otherwise.

    Parameters
    ----------
    texts : sequence of str or None
        The ``--bounds`` values.

    Returns
    -------
    dict of str to (float, float)
    """
    bounds = {}
    for text in texts or []:
        try:
            key, rng = text.split("=", 1)
            lo, hi = (float(v) for v in rng.split(":"))
        except ValueError:
            raise ConfigError("--bounds", f"expected KEY=LO:HI, got '{text}'") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ConfigError("--bounds", f"need finite LO < HI, got '{text}'")
        key = key.strip()  # a per-side offset (six degrees of freedom) is a key of its own
        bounds[key if key in C.SIDE_KEYS else resolve_key(key, "--bounds")] = (lo, hi)
    return bounds


def bounds_of(texts: Sequence[str] | None, key: str) -> tuple[float, float] | None:
    """The bounds ``--bounds`` gives the one free parameter ``key`` (None: not given); bounds of any
    other key are a ConfigError naming the free one.

    Parameters
    ----------
    texts : sequence of str or None
        The ``--bounds`` values.
    key : str
        The free parameter's model key.

    Returns
    -------
    (float, float) or None
    """
    bounds = parse_bounds(texts)
    for k in bounds:
        if k != key:
            raise ConfigError("--bounds", f"'{k}' is not the free parameter; give --bounds {key}=LO:HI")
    return bounds.get(key)


def add_compiled_flag(g) -> None:
    """``--compiled``: pass ``compiled=True`` to the solves (``BIRDOCP_COMPILED=1`` in the environment
    is a shorthand for it, see :func:`compiled_requested`).

    Parameters
    ----------
    g : argparse.ArgumentParser or argument group
        Where the flag goes.
    """
    g.add_argument("--compiled", action="store_true",
                   help="use the state RHS and the data's post compiled to C (the same numbers; compiled once, "
                        "~15 s, and cached in $BIRDOCP_CACHE or ~/.cache/birdocp; falls back to the interpreted "
                        "path with a warning if compilation fails; BIRDOCP_COMPILED=1 is a shorthand)")


COMPILED_ENV = "BIRDOCP_COMPILED"
"""Environment variable that is a shorthand for ``--compiled`` on the command line (1/on/yes/true).
The library never reads it: the Python API takes ``compiled=``."""


def compiled_requested(args: argparse.Namespace) -> bool:
    """``compiled=`` of the command's solves: ``--compiled`` or ``$BIRDOCP_COMPILED`` on.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the command.

    Returns
    -------
    bool
    """
    env = os.environ.get(COMPILED_ENV, "").strip().lower() in ("1", "on", "yes", "true")
    return bool(getattr(args, "compiled", False)) or env


# ---------------------------------------------------------------------------------------------
# Configuration

def config_message(exc: ConfigError) -> str:
    """The message of a ConfigError without its ``"key: "`` prefix.

    Parameters
    ----------
    exc : ConfigError
        The error.

    Returns
    -------
    str
    """
    text = str(exc)
    prefix = f"{exc.key}: "
    return text[len(prefix):] if exc.key and text.startswith(prefix) else text


def _load_config_file(path_text: str) -> C.Config:
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


def _parse_assignment(assignment: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--set``, the value parsed as by :func:`birdocp.bird.config.set_value`."""
    if "=" not in assignment:
        raise ConfigError("--set", f"'{assignment}' is not KEY=VALUE; e.g. --set aero.circulation=relaxed")
    key, text = assignment.split("=", 1)
    key = key.strip()
    if not key:
        raise ConfigError("--set", f"missing key in '{assignment}'; expected KEY=VALUE, e.g. body.mass_kg=1.3")
    return key, C.parse_scalar(text.strip())


def _flag_values(args: argparse.Namespace) -> list[tuple[str, str, Any]]:
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
    """The validated configuration: defaults <- CONFIG file <- --set <- dedicated flags.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the command (``config``, ``sets`` and the dedicated flags).

    Returns
    -------
    Config
    """
    cfg = _load_config_file(args.config) if getattr(args, "config", None) else C.Config()
    values: dict[str, Any] = {}
    for assignment in getattr(args, "sets", None) or []:
        key, value = _parse_assignment(assignment)
        values[key] = value
    flags = _flag_values(args)
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
    """The values of option ``name`` as floats, each finite (else a :class:`ConfigError` on ``name``).

    Parameters
    ----------
    name : str
        The option (e.g. ``--state``).
    values : sequence of float
        Its values.

    Returns
    -------
    list of float
    """
    for v in values:
        if not math.isfinite(v):
            raise ConfigError(name, f"must be finite numbers, got {v!r}")
    return [float(v) for v in values]
