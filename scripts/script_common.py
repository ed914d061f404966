"""Shared start of the reproduction scripts (``python scripts/<name>.py``; this folder is on sys.path)."""
from __future__ import annotations

import argparse
import os
import threading
from pathlib import Path

from birdocp.io.files import atomic_write_json, atomic_write_text


def script_parser(doc: str, default_out: str, **kwargs) -> argparse.ArgumentParser:
    """The script's options: ``--out DIR`` (default ``default_out``) first; the script adds its own."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0], **kwargs)
    ap.add_argument("--out", default=default_out, help="output folder (default %(default)s)")
    ap.add_argument("--compiled", action="store_true", default=compiled_env(),
                    help="solve with the RHS and data compiled to C (compiled=True; the same numbers, faster; "
                         "BIRDOCP_COMPILED=1 is a shorthand); used by the scripts whose solves take it")
    return ap


def compiled_env() -> bool:
    """``$BIRDOCP_COMPILED`` on (1/on/yes/true): the default of the scripts' ``--compiled`` (the
    library itself never reads it: its functions take ``compiled=``)."""
    return os.environ.get("BIRDOCP_COMPILED", "").strip().lower() in ("1", "on", "yes", "true")


def parse_with_out(ap: argparse.ArgumentParser, argv=None) -> tuple[argparse.Namespace, Path]:
    """Parse the options and create the ``--out`` folder; (options, folder)."""
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    return args, out


def write_result(out: Path, result, table_md: str) -> None:
    """Write ``out/result.json`` (``result``) and ``out/table.md`` (``table_md``) atomically, then print
    the table: the common end of the scripts that make one result and its table."""
    atomic_write_json(out / "result.json", result)
    atomic_write_text(out / "table.md", table_md)
    print(table_md)


class Beside:
    """``fn(arg)`` in one worker process while this process goes on (``jobs > 1``), or in this process
    when :meth:`result` asks for it (``jobs == 1``). The worker is started at once (``start()``), so its
    start-up overlaps this process's work; an error in the job is raised again by :meth:`result`."""

    def __init__(self, fn, arg, jobs: int):
        self.fn, self.arg = fn, arg
        self._out: list = []
        self._error: BaseException | None = None
        self._ex = self._thread = None
        if jobs > 1:
            from birdocp.engine.executors import ProcessExecutor

            self._ex = ProcessExecutor(1).start()
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()

    def _run(self) -> None:
        try:
            self._out.extend(self._ex.map(self.fn, [self.arg]))
        except BaseException as e:  # noqa: BLE001 - handed to the main thread by result()
            self._error = e

    def result(self):
        """The job's return value (waits for the worker; runs the job here with ``jobs == 1``)."""
        if self._thread is None:
            return self.fn(self.arg)
        self._thread.join()
        self._ex.close()
        if self._error is not None:
            raise self._error
        return self._out[0]
