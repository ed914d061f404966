"""CasADi's own warnings away from the terminal: a stream filter for ``sys.stderr``.

CasADi writes its warnings ("NaN detected for output g", one per failed evaluation, so a failed solve
can write many) through Python's ``sys.stderr`` as lines ``CasADi - <time> WARNING(...)``.
:class:`NoiseFilter` sends those lines to a log file and lets everything else through; a worker
process started with the environment variable :data:`LOG_ENV` naming a log file installs one itself
(:func:`install_from_env`), so the warnings of ``--jobs N`` workers land in the same file.
"""
from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path

__all__ = ["NoiseFilter", "LOG_ENV", "PREFIX", "install_from_env"]

LOG_ENV = "BIRDOCP_SOLVER_LOG"
"""Environment variable: the log file of CasADi's warnings for worker processes."""

PREFIX = "CasADi - "


class NoiseFilter:
    """A text stream in place of ``sys.stderr`` while a solver runs: CasADi's own warning lines
    (``CasADi - <time> WARNING(...)``: "NaN detected", "KeyboardInterruptException", ...) go to a log
    file (or, without one, are only counted); everything else (progress lines, messages) passes on to
    the terminal unchanged."""

    def __init__(self, terminal, log_path: Path | None):
        self.terminal, self.log_path = terminal, log_path
        self.count = 0
        self.first: str | None = None
        self._pending = ""
        self._log = None

    # the text-stream interface used by print() and CasADi's writer
    def write(self, text: str) -> int:
        """Pass ``text`` to the terminal, or count (and log) a CasADi warning line.

        Parameters
        ----------
        text : str
            Text written to the stream.

        Returns
        -------
        int
            ``len(text)``.
        """
        self._pending += text
        while self._pending:
            head = self._pending[:len(PREFIX)]
            if not PREFIX.startswith(head):  # not (the start of) a CasADi line: pass on
                self.terminal.write(self._pending)
                self._pending = ""
                break
            if "\n" not in self._pending:
                break  # wait for the rest of the line
            line, self._pending = self._pending.split("\n", 1)
            if line.startswith(PREFIX):
                self._to_log(line)
            else:
                self.terminal.write(line + "\n")
        return len(text)

    def _to_log(self, line: str) -> None:
        self.count += 1
        if self.first is None:
            self.first = line
        if self.log_path is None:
            return
        try:
            if self._log is None:
                self._log = open(self.log_path, "a", encoding="utf-8")
            self._log.write(line + "\n")
            self._log.flush()  # whole lines, at once: worker processes append to the same file
        except OSError:
            self.log_path = None

    def flush(self) -> None:
        with contextlib.suppress(Exception):
            self.terminal.flush()
        if self._log is not None:
            with contextlib.suppress(OSError):
                self._log.flush()

    def close(self) -> None:
        if self._pending:
            if self._pending.startswith(PREFIX):
                self._to_log(self._pending.rstrip("\n"))
            else:
                self.terminal.write(self._pending)
            self._pending = ""
        self.flush()
        if self._log is not None:
            with contextlib.suppress(OSError):
                self._log.close()
            self._log = None

    def isatty(self) -> bool:
        """Whether the terminal stream is a terminal.

        Returns
        -------
        bool
        """
        return self.terminal.isatty()

    def fileno(self) -> int:
        """The terminal stream's file descriptor.

        Returns
        -------
        int
        """
        return self.terminal.fileno()

    @property
    def encoding(self):
        return getattr(self.terminal, "encoding", "utf-8")


def install_from_env() -> NoiseFilter | None:
    """In a worker process: if :data:`LOG_ENV` names a file, route CasADi's warnings there.

    Returns
    -------
    NoiseFilter or None
    """
    path = os.environ.get(LOG_ENV)
    if not path:
        return None
    filt = NoiseFilter(sys.stderr, Path(path))
    sys.stderr = filt
    return filt
