"""Command-line interface: the parser, the entry point and the registry of command modules.

Every command lives in its own module of :mod:`birdocp.cli` (``forces``, ``trim``, ``export_c``,
``level``, ``sweep``, ``continue_``, ``plot``, ``sensitivity``, ``optimize_stability``,
``control``, ``simulate``, ``animate``, ``config_cmd``) on the shared pieces of :mod:`birdocp.cli.common`, whose :func:`run_folder` holds the
one run-folder pattern (claim the folder exclusively before computing, solver noise to its log,
atomic writes, clean-up on failure).

Configuration resolution (one helper, :func:`resolve_config`, used by every subcommand)::

    defaults  <-  CONFIG file  <-  --set KEY=VALUE ...  <-  dedicated flags (--amplitude, --points, ...)

The ``--set`` assignments and the dedicated flags are applied together in one step, so they may be
given in any order and e.g. ``--set solve.points=4 --steps 150`` is checked as a whole. The
configuration is fully validated before the model is imported or built.

Exit codes: 0 success; 1 the computation failed (did not converge, diverged; the result is still
written) or its output could not be written (a full disk, a file-size limit: one line, nothing
partial kept); 2 bad input (one line on stderr naming the key at fault, nothing written); 3 internal
error (one line naming a log file that holds the traceback, see
:func:`birdocp.cli.streams.error_log_dir`); 130
interrupted. With ``--json`` exactly one JSON object is printed on every exit except bad input. The
exit code never depends on stdout: a closed stdout or a reader that went away (EPIPE) ends the
printing, not the command (:class:`birdocp.cli.streams.SafeStdout`).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import signal
import sys
import warnings
import traceback
from typing import Sequence

try:
    from birdocp.engine import interrupts
    from birdocp.io.errors import ConfigError
    from birdocp.cli.common import (
        EXIT_BAD_INPUT,
        EXIT_INTERNAL,
        EXIT_INTERRUPTED,
        EXIT_NOT_CONVERGED,
        EXIT_OK,
        PROG,
        Context,
        Parser,
        common_options,
        config_message,
        failure_json,
        one_line,
        print_json,
        resolve_config,
    )
    from birdocp.cli.streams import guarded_stdout, open_std_streams, tolerant_encodings, write_error_log
except KeyboardInterrupt:  # Ctrl-C while the command starts up: the same exit as later on
    if "--json" in sys.argv[1:]:
        sys.stdout.write('{"success": false, "status": "interrupted", "message": "interrupted (Ctrl-C)", '
                         '"run_dir": null}\n')
    sys.stderr.write("birdocp: interrupted\n")
    raise SystemExit(130) from None

__all__ = ["main", "build_parser", "resolve_config", "EXIT_OK", "EXIT_NOT_CONVERGED", "EXIT_BAD_INPUT",
           "COMMAND_MODULES"]

COMMAND_MODULES = (
    "birdocp.cli.forces",
    "birdocp.cli.trim",
    "birdocp.cli.export_c",
    "birdocp.cli.level",
    "birdocp.cli.sweep",
    "birdocp.cli.continue_",
    "birdocp.cli.plot",
    "birdocp.cli.sensitivity",
    "birdocp.cli.optimize_stability",
    "birdocp.cli.control",
    "birdocp.cli.simulate",
    "birdocp.cli.animate",
    "birdocp.cli.config_cmd",
    "birdocp.cli.gait",
)
"""Modules that add subcommands, in the order of ``birdocp --help``: each defines
``register(sub, common)`` (``sub`` the subparsers action, ``common`` the parent parser with the
configuration and output options) and sets ``func(args, command_line) -> exit code`` on its parsers.
Add a new command by adding its module here."""


def build_parser() -> argparse.ArgumentParser:
    """The ``birdocp`` argument parser with every command registered.

    Returns
    -------
    argparse.ArgumentParser
    """
    from birdocp import __version__

    parser = Parser(
        prog=PROG,
        description="Trimmed periodic flapping flight of a bird and its Floquet stability.",
        epilog="Exit codes: 0 ok, 1 the computation failed (result written) or a full disk, 2 bad input, "
               "3 internal error (traceback in a log file, see docs/troubleshooting.md), 130 interrupted. "
               "Run 'birdocp COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=Parser)
    common = common_options()
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub, common)
    return parser


def _json_failure(args, ctx: Context, status: str, message: str, argv: Sequence[str] = ()) -> None:
    """The one JSON object of a --json run that ended without printing its own (before the arguments
    were parsed, ``--json`` in ``argv`` decides)."""
    wanted = getattr(args, "json", False) if args is not None else "--json" in argv
    if wanted and not ctx.json_printed:
        with contextlib.suppress(Exception):
            print_json(failure_json(status, message, ctx), ctx)


def _one_line_warning(message, category, filename, lineno, file=None, line=None):  # noqa: ARG001
    text = one_line(message)
    text = text[len(PROG) + 2:] if text.startswith(f"{PROG}: ") else text
    print(f"{PROG}: warning: {text}", file=sys.stderr if file is None else file)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script passes it to ``sys.exit``).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name (None: ``sys.argv[1:]``, run as the program).

    Returns
    -------
    int
        Exit code.
    """
    as_program = argv is None  # the console script or python -m birdocp (not a call from Python)
    argv = sys.argv[1:] if argv is None else list(argv)
    if as_program:
        open_std_streams()  # a closed stdout (>&-) is os.devnull, not a descriptor a file may take
        tolerant_encodings()  # PYTHONIOENCODING=ascii and a non-ASCII path: escapes, not a traceback
        # figures are files: the command line draws with Agg whatever MPLBACKEND says (a GUI backend
        # or a misspelt one would fail only when the first figure is drawn, after the computation)
        os.environ["MPLBACKEND"] = "Agg"
        # warnings as one line each ("birdocp: warning: ..."), not Python's file, line and source
        warnings.showwarning = _one_line_warning
    old_handler = signal.getsignal(signal.SIGINT)
    try:
        with guarded_stdout(redirect_fd=as_program):
            return _main(argv, as_program)
    except KeyboardInterrupt:  # a second Ctrl-C while the first one was being reported
        return EXIT_INTERRUPTED
    finally:
        with contextlib.suppress(ValueError, TypeError):
            # the command is over: a Ctrl-C now would only turn a finished run into a traceback
            signal.signal(signal.SIGINT, signal.SIG_IGN if as_program else old_handler)
        with contextlib.suppress(KeyboardInterrupt):
            interrupts.check()  # clear a late flag (the exit code already says it)


def _quiet_interrupts() -> None:
    """The command is ending with an error or an interrupt: a further Ctrl-C must not cut its report
    (the caller restores the handler)."""
    with contextlib.suppress(ValueError, TypeError):
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _main(argv: list[str], as_program: bool) -> int:
    command_line = [PROG, *argv]
    ctx = Context(command_line)  # passed to the command as args.context, and to the reports below
    debug = "--debug" in argv
    args = None
    try:
        interrupts.install()  # a Ctrl-C that CasADi swallows is still seen
        parser = build_parser()
        try:
            args, extra = parser.parse_known_args(argv)
            if extra:  # reported by the command's parser: the hint names its --help, not birdocp's
                sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
                sub.choices[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
        except SystemExit as exc:  # --help, --version, or a usage error (already printed)
            return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
        debug = args.debug
        args.context = ctx
        code = args.func(args, command_line)
        interrupts.check()
        return code
    except KeyboardInterrupt:
        _quiet_interrupts()
        return _interrupted(args, ctx, debug, argv)
    except ConfigError as exc:
        _quiet_interrupts()
        if interrupts.pending():
            return _interrupted(args, ctx, debug, argv)
        if debug:
            traceback.print_exc()
        msg = one_line(config_message(exc))
        print(f"{PROG}: error: {exc.key}: {msg}" if exc.key else f"{PROG}: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        _quiet_interrupts()
        if interrupts.pending():
            return _interrupted(args, ctx, debug, argv)
        if exc.errno not in WRITE_FAILURES:
            return _internal_error(exc, args, ctx, debug)
        return _write_failed(exc, args, ctx, debug)
    except Exception as exc:
        _quiet_interrupts()
        if interrupts.pending():  # CasADi turned the Ctrl-C into an exception of its own
            return _interrupted(args, ctx, debug, argv)
        return _internal_error(exc, args, ctx, debug)


WRITE_FAILURES = {errno.ENOSPC: "no space left on the device", errno.EFBIG: "the file is larger than allowed "
                  "(file-size limit)", getattr(errno, "EDQUOT", -1): "the disk quota is exhausted"}
"""OS errors that mean an output could not be written for lack of room: exit 1, one line."""


def _write_failed(exc: OSError, args, ctx: Context, debug: bool) -> int:
    if debug:
        traceback.print_exc()
    out = getattr(args, "out", None)
    where = f" {exc.filename}" if exc.filename else (f" the output (--out {out})" if out else " the output")
    kept = f"; finished results kept in {ctx.run_dir}" if ctx.run_dir is not None else ""
    msg = f"cannot write{where}: {WRITE_FAILURES[exc.errno]}; nothing partial was kept{kept}"
    print(f"{PROG}: error: {one_line(msg)}", file=sys.stderr)
    _json_failure(args, ctx, "write_failed", one_line(msg))
    return EXIT_NOT_CONVERGED


def _internal_error(exc: BaseException, args, ctx: Context, debug: bool) -> int:
    """One line naming the log file with the traceback (:func:`birdocp.cli.streams.write_error_log`)."""
    if debug:
        traceback.print_exc()
    log = write_error_log(exc, ctx.command_line)
    where = f"; the traceback is in {log}" if log is not None else "; rerun with --debug for the traceback"
    print(f"{PROG}: internal error: {type(exc).__name__}: {one_line(exc)}{where}", file=sys.stderr)
    _json_failure(args, ctx, "internal_error", f"{type(exc).__name__}: {one_line(exc)}")
    return EXIT_INTERNAL


def _interrupted(args, ctx: Context, debug: bool, argv: Sequence[str] = ()) -> int:
    with contextlib.suppress(KeyboardInterrupt):
        interrupts.check()  # clear the flag
    if debug:
        traceback.print_exc()
    kept = f" (finished results kept in {ctx.run_dir})" if ctx.run_dir is not None else ""
    print(f"{PROG}: interrupted{kept}", file=sys.stderr)
    _json_failure(args, ctx, "interrupted", "interrupted (Ctrl-C)", argv)
    return EXIT_INTERRUPTED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
