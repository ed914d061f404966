"""One interface for running independent jobs: serial, local processes, or a Dask distributed cluster.

``executor.map(fn, items)`` returns ``[fn(item) for item in items]`` in the order of ``items``,
whatever the backend; ``fn`` and the items must be picklable (module-level functions) for the
process and Dask backends. Each job runs in a fresh interpreter state as far as results go: the
engine's graph caches only save time, they never change numbers, so a job's result does not depend
on which worker ran it or what ran there before.

* :class:`SerialExecutor` (default): in this process, one after another.
* :class:`ProcessExecutor` (``--jobs N``): ``concurrent.futures.ProcessPoolExecutor`` with the
  ``spawn`` start method (no fork of a process holding CasADi/IPOPT state); each worker builds the
  model once and reuses it for the jobs it runs.
* :class:`DaskExecutor` (``--scheduler ADDRESS``): ``distributed.Client(ADDRESS).map`` (needs the
  ``cluster`` extra: ``pip install birdocp[cluster]``); the workers need birdocp installed.

``get_executor(jobs=None, scheduler=None)`` picks one from the CLI options.
"""
from __future__ import annotations

from typing import Callable, Iterable

__all__ = ["Executor", "SerialExecutor", "ProcessExecutor", "DaskExecutor", "get_executor"]


class Executor:
    """Runs one function over many items and returns the results in order (the contract of every
    executor: serial, local processes, Dask distributed). Use as a context manager to release it."""

    name = "executor"

    def map(self, fn: Callable, items: Iterable) -> list:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def describe(self) -> dict:
        return {"executor": self.name}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class SerialExecutor(Executor):
    """Runs the items one after the other in this process."""

    name = "serial"

    def map(self, fn, items):
        return [fn(x) for x in items]


class ProcessExecutor(Executor):
    """Runs the items in ``jobs`` spawned worker processes (each builds its model once)."""

    name = "processes"

    def __init__(self, jobs: int):
        if int(jobs) < 1:
            raise ValueError(f"jobs must be >= 1, got {jobs!r}")
        self.jobs = int(jobs)
        self._pool = None

    def _get(self):
        if self._pool is None:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=mp.get_context("spawn"))
        return self._pool

    def map(self, fn, items):
        items = list(items)
        if not items:
            return []
        return list(self._get().map(fn, items))

    def close(self):
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def describe(self):
        return {"executor": self.name, "jobs": self.jobs}


class DaskExecutor(Executor):
    """``client``: a ``distributed.Client``, or ``address``: a scheduler address (a Client is made and
    closed with the executor)."""

    name = "dask"

    def __init__(self, address: str | None = None, client=None):
        if client is None and not address:
            raise ValueError("DaskExecutor needs a scheduler address or a Client")
        try:
            import distributed  # noqa: F401
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("the Dask executor needs 'distributed': pip install 'birdocp[cluster]'") from e
        self.address = address
        self._client = client
        self._own = client is None

    def _get(self):
        if self._client is None:
            from distributed import Client

            self._client = Client(self.address)
        return self._client

    def map(self, fn, items):
        items = list(items)
        if not items:
            return []
        c = self._get()
        futures = c.map(fn, items, pure=False)
        return c.gather(futures)

    def close(self):
        if self._own and self._client is not None:
            self._client.close()
            self._client = None

    def describe(self):
        return {"executor": self.name, "scheduler": self.address or str(getattr(self._client, "scheduler", ""))}


def get_executor(jobs: int | None = None, scheduler: str | None = None) -> Executor:
    """Serial by default; processes with ``jobs > 1``; Dask with a ``scheduler`` address."""
    if scheduler:
        return DaskExecutor(address=scheduler)
    if jobs is not None and int(jobs) > 1:
        return ProcessExecutor(int(jobs))
    if jobs is not None and int(jobs) < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs!r}")
    return SerialExecutor()
