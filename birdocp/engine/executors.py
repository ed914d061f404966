"""One interface for running independent jobs: serial, local processes, or a Dask distributed cluster.

``executor.map(fn, items, on_result=None)`` returns ``[fn(item) for item in items]`` in the order of
``items``, whatever the backend (``on_result(index, result)`` is called as each job finishes); ``fn`` and the items must be picklable (module-level functions) for the
process and Dask backends. Each job runs in a fresh interpreter state as far as results go: the
engine's graph caches only save time, they never change numbers, so a job's result does not depend
on which worker ran it or what ran there before.

* :class:`SerialExecutor` (default): in this process, one after another.
* :class:`ProcessExecutor` (``--jobs N``): a ``multiprocessing`` pool with the ``spawn`` start
  method (no fork of a process holding CasADi/IPOPT state); each worker builds the model once and
  reuses it for the jobs it runs. Workers ignore SIGINT: on Ctrl-C the parent terminates them (and
  on Linux they get SIGTERM when the parent dies), so no worker outlives the command.
* :class:`DaskExecutor` (``--scheduler ADDRESS``): ``distributed.Client(ADDRESS).map`` (needs the
  ``cluster`` extra: ``pip install birdocp[cluster]``); the workers need birdocp installed.

``get_executor(jobs=None, scheduler=None)`` picks one from the CLI options.
"""
from __future__ import annotations

import threading
from typing import Callable, Iterable

__all__ = ["Executor", "SerialExecutor", "ProcessExecutor", "DaskExecutor", "get_executor"]


class Executor:
    """Runs one function over many items and returns the results in order (the contract of every
    executor: serial, local processes, Dask distributed). Use as a context manager to release it."""

    name = "executor"

    def map(self, fn: Callable, items: Iterable, on_result: Callable | None = None) -> list:
        """``[fn(item) for item in items]``; ``on_result(index, result)`` is called in this process as
        each job finishes (in any order), e.g. to write it to disk before the others are done.

        Parameters
        ----------
        fn : callable
            Job (picklable for process and Dask executors).
        items : iterable
            Arguments, one per job.
        on_result : callable, optional
            ``on_result(index, result)``.

        Returns
        -------
        list
            Results in the order of ``items``.
        """
        raise NotImplementedError

    def start(self) -> "Executor":
        """Make the workers ready now rather than at the first :meth:`map` (nothing to do for most
        executors): their start-up cost is then paid here.

        Returns
        -------
        Executor
            ``self``.
        """
        return self

    def close(self) -> None:
        pass

    def terminate(self) -> None:
        """Stop at once: jobs not started are dropped, running ones are killed (Ctrl-C)."""
        self.close()

    def describe(self) -> dict:
        """What the results record about the executor.

        Returns
        -------
        dict
        """
        return {"executor": self.name}

    def __enter__(self):
        return self

    def __exit__(self, exc_type, *exc):
        if exc_type is not None and not issubclass(exc_type, Exception):  # KeyboardInterrupt, SystemExit
            self.terminate()
        else:
            self.close()
        return False


class SerialExecutor(Executor):
    """Runs the items one after the other in this process."""

    name = "serial"

    def map(self, fn, items, on_result=None):
        """Parameters
        ----------
        fn : callable
            Job.
        items : iterable
            Arguments, one per job.
        on_result : callable, optional
            ``on_result(index, result)``.

        Returns
        -------
        list
            Results in the order of ``items``.
        """
        out = []
        for i, x in enumerate(items):
            out.append(fn(x))
            if on_result is not None:
                on_result(i, out[-1])
        return out


def _call_indexed(job):
    fn, i, x = job
    return i, fn(x)


def _worker_init() -> None:
    """In each worker: Ctrl-C is the parent's business (it terminates the pool, so a worker never
    dies half-way through writing its result), and on Linux the worker is sent SIGTERM when the parent
    dies (even by SIGKILL), so no orphan goes on computing."""
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from birdocp.engine.solver_log import install_from_env

    install_from_env()  # CasADi's warnings to the parent's solver log, if it names one
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):  # pragma: no cover - no prctl
            pass


def _pool_in_own_thread(jobs: int):
    """A spawn pool of ``jobs`` workers started by a daemon thread that then waits for the returned event:
    the workers' parent-death signal fires when that thread ends (the event set, or the process gone).
    Interrupted while the pool starts (Ctrl-C), the owner thread terminates it once started.

    Returns
    -------
    tuple
        ``(pool, event)``: set the event once the pool is closed.
    """
    import multiprocessing as mp

    box: dict = {}
    ready, done = threading.Event(), threading.Event()

    def own() -> None:
        try:
            box["pool"] = mp.get_context("spawn").Pool(jobs, initializer=_worker_init)
        except BaseException as e:  # noqa: BLE001 - re-raised in the calling thread
            box["error"] = e
            ready.set()
            return
        ready.set()
        done.wait()
        if box.get("abandoned"):
            box["pool"].terminate()

    threading.Thread(target=own, name="birdocp-pool-owner", daemon=True).start()
    try:
        ready.wait()
    except BaseException:
        box["abandoned"] = True
        done.set()
        raise
    if "error" in box:
        raise box["error"]
    return box["pool"], done


class ProcessExecutor(Executor):
    """Runs the items in ``jobs`` spawned worker processes (each builds its model once). The workers are
    started by the first :meth:`map` (or :meth:`start`) from a thread of the executor's own, which lives
    until :meth:`close` or :meth:`terminate`: the workers stop when the process ends (Linux parent-death
    signal), never because the thread that first mapped has ended, so any thread may map."""

    name = "processes"

    def __init__(self, jobs: int):
        if int(jobs) < 1:
            raise ValueError(f"jobs must be >= 1, got {jobs!r}")
        self.jobs = int(jobs)
        self._pool = None
        self._owner_done = None
        self._lock = threading.Lock()

    def _get(self):
        with self._lock:
            if self._pool is None:
                self._pool, self._owner_done = _pool_in_own_thread(self.jobs)
            return self._pool

    def start(self):
        """Returns
        -------
        ProcessExecutor
            ``self``.
        """
        self._get()
        return self

    def map(self, fn, items, on_result=None):
        """Parameters
        ----------
        fn : callable
            Job (picklable).
        items : iterable
            Arguments, one per job.
        on_result : callable, optional
            ``on_result(index, result)``.

        Returns
        -------
        list
            Results in the order of ``items``.
        """
        items = list(items)
        if not items:
            return []
        results = [None] * len(items)
        try:
            for i, r in self._get().imap_unordered(_call_indexed, [(fn, i, x) for i, x in enumerate(items)]):
                results[i] = r
                if on_result is not None:
                    on_result(i, r)
        except BaseException:
            self.terminate()  # a failed or interrupted map leaves no worker running
            raise
        return results

    def close(self):
        """Close the pool and wait for its workers.

        Returns
        -------
        None
        """
        self._stop(lambda pool: pool.close())

    def terminate(self):
        """Returns
        -------
        None
        """
        self._stop(lambda pool: pool.terminate())

    def _stop(self, end) -> None:
        """``end(pool)`` (close or terminate), wait for the workers, and release the owner thread."""
        if self._pool is not None:
            pool, self._pool = self._pool, None
            try:
                end(pool)
                pool.join()
            finally:
                self._owner_done.set()

    def describe(self):
        """What the results record about the executor (its name and worker count).

        Returns
        -------
        dict
        """
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

    def start(self):
        """Connect to the scheduler now (an unreachable address raises here, before any job).

        Returns
        -------
        DaskExecutor
            ``self``.
        """
        self._get()
        return self

    def _get(self):
        if self._client is None:
            from distributed import Client

            self._client = Client(self.address)
        return self._client

    def map(self, fn, items, on_result=None):
        """Parameters
        ----------
        fn : callable
            Job (picklable).
        items : iterable
            Arguments, one per job.
        on_result : callable, optional
            ``on_result(index, result)``.

        Returns
        -------
        list
            Results in the order of ``items``.
        """
        items = list(items)
        if not items:
            return []
        c = self._get()
        futures = c.map(fn, items, pure=False)
        try:
            if on_result is not None:
                from distributed import as_completed

                index = {f.key: i for i, f in enumerate(futures)}
                for f in as_completed(futures):
                    on_result(index[f.key], f.result())
            return c.gather(futures)
        except BaseException:
            c.cancel(futures)  # Ctrl-C or a failed job: nothing left running on the cluster
            raise

    def close(self):
        """Close the client when this executor made it (a client passed in stays open).

        Returns
        -------
        None
        """
        if self._own and self._client is not None:
            self._client.close()
            self._client = None

    def describe(self):
        """What the results record about the executor (its name and scheduler).

        Returns
        -------
        dict
        """
        return {"executor": self.name, "scheduler": self.address or str(getattr(self._client, "scheduler", ""))}


def get_executor(jobs: int | None = None, scheduler: str | None = None) -> Executor:
    """Serial by default; processes with ``jobs > 1``; Dask with a ``scheduler`` address.

    Parameters
    ----------
    jobs : int, optional
        Local worker processes (None or 1: serial).
    scheduler : str, optional
        Address of a Dask distributed scheduler (needs the ``cluster`` extra).

    Returns
    -------
    Executor
        Runs independent jobs (``map``) and says how (``describe``).
    """
    if scheduler:
        return DaskExecutor(address=scheduler)
    if jobs is not None and int(jobs) > 1:
        return ProcessExecutor(int(jobs))
    if jobs is not None and int(jobs) < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs!r}")
    return SerialExecutor()
