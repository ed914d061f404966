"""The command line's standard streams and its internal-error log.

* :class:`SafeStdout` / :func:`guarded_stdout`: the exit code never depends on stdout (a closed
  stdout, a pipe whose reader exited, a full disk under ``> file``: the printing ends, the command
  goes on);
* :func:`open_std_streams`: a closed stdin, stdout or stderr becomes ``os.devnull``;
* :func:`tolerant_encodings`: characters the streams' encoding cannot hold are escaped;
* :func:`error_log_dir` / :func:`write_error_log`: where the traceback of an internal error (exit 3)
  is written.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path
from typing import Iterator, Sequence

from birdocp.cli.common import PROG

__all__ = ["SafeStdout", "guarded_stdout", "open_std_streams", "tolerant_encodings", "error_log_dir",
           "write_error_log", "LOG_DIR_ENV"]

LOG_DIR_ENV = "BIRDOCP_LOG_DIR"
"""Environment variable: the folder of the internal-error logs (see :func:`error_log_dir`)."""


class SafeStdout:
    """``sys.stdout`` while a command runs: when the reader goes away (a closed stdout ``>&-``, a
    pipe whose reader exited: ``EPIPE``, a full disk under ``> file``) the printing ends and the
    command goes on, so its exit code is the computation's own and its result is still written to
    the run folder. File descriptor 1 then points at ``os.devnull`` (so that neither C code nor
    the interpreter's exit flush fails on it), and one warning goes to stderr (none for a pipe whose
    reader exited: ``birdocp config | head -1`` is ordinary use)."""

    def __init__(self, stream, redirect_fd: bool = True):
        self._stream = stream
        self.lost = stream is None
        self._redirect_fd = redirect_fd  # False when called from Python (a test's capture owns fd 1)

    def _lose(self, exc: BaseException | None) -> None:
        if not self.lost and exc is not None and not isinstance(exc, BrokenPipeError):  # EPIPE: as `| head`
            why = getattr(exc, "strerror", None) or type(exc).__name__
            with contextlib.suppress(Exception):
                print(f"{PROG}: warning: stdout is gone ({why}); the command goes on, its result is in "
                      "its run folder", file=sys.stderr)
        self.lost = True
        if not self._redirect_fd:
            return
        with contextlib.suppress(OSError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.close(devnull)

    def write(self, text: str) -> int:
        if not self.lost:
            try:
                return self._stream.write(text)
            except (OSError, ValueError, AttributeError) as exc:
                self._lose(exc)
        return len(text)

    def flush(self) -> None:
        if not self.lost:
            try:
                self._stream.flush()
            except (OSError, ValueError, AttributeError) as exc:
                self._lose(exc)

    def isatty(self) -> bool:
        return False if self.lost else bool(self._stream.isatty())

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def guarded_stdout(redirect_fd: bool = True) -> Iterator[SafeStdout]:
    """``sys.stdout`` replaced by a :class:`SafeStdout` while the body runs (restored after);
    ``redirect_fd``: point descriptor 1 at ``os.devnull`` once stdout is gone (the program does,
    a call from Python does not).

    Parameters
    ----------
    redirect_fd : bool
        Point descriptor 1 at ``os.devnull`` once stdout is gone.

    Yields
    ------
    SafeStdout
    """
    saved = sys.stdout
    guard = SafeStdout(saved, redirect_fd)
    sys.stdout = guard
    try:
        yield guard
    finally:
        if sys.stdout is guard:
            sys.stdout = saved
        if guard.lost and saved is not None:
            with contextlib.suppress(Exception):
                saved.flush()  # fd 1 is os.devnull now: the buffered rest goes nowhere, quietly


def open_std_streams() -> None:
    """A closed stdin, stdout or stderr (``>&-``) becomes ``os.devnull``, so that no file the
    command opens takes its descriptor (a lock file receiving the output) and every print works."""
    for fd, name, mode in ((0, "stdin", os.O_RDONLY), (1, "stdout", os.O_WRONLY), (2, "stderr", os.O_WRONLY)):
        try:
            os.fstat(fd)
            continue
        except OSError:
            pass
        with contextlib.suppress(OSError):
            new = os.open(os.devnull, mode)
            if new != fd:
                os.dup2(new, fd)
                os.close(new)
            if getattr(sys, name) is None:
                setattr(sys, name, open(fd, "r" if fd == 0 else "w", closefd=False))


def tolerant_encodings() -> None:
    """stdout and stderr keep their encoding (``PYTHONIOENCODING``, the locale) but write characters
    it cannot encode as escapes (``\\u00e9``) instead of failing: a path or a name in a message
    never ends a command."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError, OSError):
            stream.reconfigure(errors="backslashreplace")


def error_log_dir() -> Path:
    """Folder of the internal-error logs: ``$BIRDOCP_LOG_DIR``, else ``$XDG_STATE_HOME/birdocp/logs``
    (default ``~/.local/state/birdocp/logs``).

    Returns
    -------
    Path
    """
    env = os.environ.get(LOG_DIR_ENV)
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "birdocp" / "logs"


def write_error_log(exc: BaseException, command_line: Sequence[str]) -> Path | None:
    """Write the traceback of ``exc`` (with the command line and versions) to a new file in
    :func:`error_log_dir` (the system's temporary folder if that cannot be written); returns its
    path, or None when nothing could be written.

    Parameters
    ----------
    exc : BaseException
        The error.
    command_line : sequence of str
        The command line.

    Returns
    -------
    Path or None
    """
    import platform
    import tempfile
    import traceback

    from birdocp import __version__

    text = (f"command: {' '.join(command_line)}\nbirdocp {__version__}, Python {platform.python_version()}, "
            f"{platform.platform()}\ntime: {time.strftime('%Y-%m-%dT%H:%M:%S%z')}\n\n"
            + "".join(traceback.format_exception(type(exc), exc, exc.__traceback__)))
    name = f"error-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.log"
    for folder in (error_log_dir(), Path(tempfile.gettempdir())):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / name
            with open(path, "x", encoding="utf-8", errors="backslashreplace") as fh:
                fh.write(text)
            return path
        except OSError:
            continue
    return None
