"""The one atomic write of the package: outputs appear whole or not at all.

Every file or folder birdocp writes is first written under a temporary name beside its target
(same folder, so the same file system) and then renamed into place; an interrupt (Ctrl-C,
SIGTERM), a full disk (``ENOSPC``), a file-size limit (``EFBIG``) or any other exception before
the rename leaves the target as it was (absent, or the earlier complete version) and removes the
temporary copy. Three shapes of output, one mechanism:

* :func:`atomic_target` -- one file: yields a temporary path, renamed over the target;
* :func:`atomic_folder` -- a folder of files as a whole (``export-c``, the graph cache's entries):
  yields a temporary sibling folder that takes the target's place in one step (an atomic exchange
  where the platform has it, Linux ``renameat2``; elsewhere two renames with signals held back);
* :func:`staged_files` -- several files into a folder that exists and holds other things (a run
  folder: ``config.toml``, ``arrays.npz``, ``result.json``): all are written completely into a
  hidden staging folder inside it, then moved into place one after the other with SIGINT and
  SIGTERM held back (:func:`signals_deferred`), the file named last (``result.json``) last.

Temporary names start with a dot and end in ``.tmp`` (``.old`` for an earlier folder on its way
out); only SIGKILL or a power cut can leave one behind.

The :mod:`birdocp.io.files` module re-exports these for the layers above the engine; the engine's
own disk caches (:mod:`birdocp.engine.graphcache`, :mod:`birdocp.engine.datastore`) use them
directly. Standard library only.
"""
from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import shutil
import signal
import sys
import tempfile
import threading
from pathlib import Path
from typing import Callable, Iterable, Iterator

__all__ = ["umask_mode", "signals_deferred", "atomic_target", "atomic_folder", "staged_files", "fsync_file"]

_DEFERRED = tuple(s for s in (getattr(signal, "SIGINT", None), getattr(signal, "SIGTERM", None)) if s)


def umask_mode(directory: bool = False) -> int:
    """The mode a new file (or folder) gets under the process umask, e.g. 0o644 (0o755).

    Parameters
    ----------
    directory : bool
        The mode of a folder instead of a file.

    Returns
    -------
    int
    """
    umask = os.umask(0)
    os.umask(umask)
    return (0o777 if directory else 0o666) & ~umask


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back while the body runs (a short sequence of renames, a clean-up,
    that must not be cut in the middle); a signal that arrived meanwhile is acted on, once, when the
    body ends (its handler called: ``KeyboardInterrupt`` for Ctrl-C).

    The Python-level handlers are swapped for a recorder (blocking the signal with
    ``pthread_sigmask`` would not do: the kernel hands a process-wide signal to any thread that does
    not block it, CasADi's and the progress bar's included). Outside the main thread, where Python
    allows no handler change and delivers no signal, the body simply runs.

    Yields
    ------
    None
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    saved = {}
    for signum in _DEFERRED:
        with contextlib.suppress(ValueError, OSError, TypeError):
            handler = signal.getsignal(signum)
            if handler in (signal.SIG_IGN, None):
                continue  # ignored (or not set from Python) stays so
            saved[signum] = handler
            signal.signal(signum, lambda n, frame: caught.append(n))
    try:
        yield
    finally:
        for signum, handler in saved.items():
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(signum, handler)
        if caught:
            handler = saved[caught[0]]
            if callable(handler):
                handler(caught[0], None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), caught[0])  # the default action (terminate)


def fsync_file(path: str | Path) -> None:
    """Flush ``path``'s data to the disk (a full disk is seen here at the latest, as ``OSError``).

    Parameters
    ----------
    path : str or Path
        File to flush.
    """
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _discard(path: str | Path) -> None:
    """Remove a temporary file or folder; never raises, and a second Ctrl-C cannot cut it short."""
    with signals_deferred():
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                os.unlink(path)


@contextlib.contextmanager
def atomic_target(path: str | Path, suffix: str = ".tmp") -> Iterator[str]:
    """Yield a temporary path in the target's folder; when the body ends normally the file there is
    flushed to disk, given ordinary permissions and renamed over ``path``; on any exception (also
    ``KeyboardInterrupt``) it is removed and ``path`` is untouched.

    Parameters
    ----------
    path : str or Path
        Target file.
    suffix : str
        Suffix of the temporary file's name.

    Yields
    ------
    str
        Temporary path to write.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        fsync_file(tmp)
        os.chmod(tmp, umask_mode())  # mkstemp creates 0600
        os.replace(tmp, path)
    except BaseException:
        _discard(tmp)
        raise


def _exchange(a: Path, b: Path) -> bool:
    """Swap two folders in one step (Linux ``renameat2(RENAME_EXCHANGE)``); False where unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EPERM):
        return False  # old kernel or a file system without exchange: the two-rename path
    raise OSError(err, os.strerror(err), str(b))


def _put_in_place(new: Path, path: Path, replace: bool) -> None:
    """Rename folder ``new`` to ``path``; an existing ``path`` is replaced as a whole (``replace``)
    or kept (``FileExistsError``). Called with signals held back."""
    try:
        os.rename(new, path)  # path absent or an empty folder: one rename
        return
    except OSError as exc:
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST) or not replace:
            if exc.errno in (errno.ENOTEMPTY, errno.EEXIST):
                raise FileExistsError(exc.errno, "the folder exists", str(path)) from None
            raise
    if _exchange(new, path):
        _discard(new)  # now the earlier folder
        return
    old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".old"))
    os.rename(path, old / "d")
    try:
        os.rename(new, path)
    except BaseException:
        os.rename(old / "d", path)  # put the earlier folder back
        _discard(old)
        raise
    _discard(old)


@contextlib.contextmanager
def atomic_folder(path: str | Path, *, replace: bool = True,
                  carry: Callable[[str], bool] | None = None) -> Iterator[Path]:
    """Yield a new temporary folder beside ``path``; when the body ends normally its files are
    flushed to disk and the folder takes ``path``'s place as a whole.

    On any exception (also ``KeyboardInterrupt`` or a full disk) the temporary folder is removed
    and ``path`` is left as it was: absent, or the earlier folder, complete.

    Parameters
    ----------
    path : str or Path
        The folder to write.
    replace : bool
        An existing non-empty ``path`` is replaced (the earlier folder removed); with False it is
        kept and ``FileExistsError`` raised (first writer wins, as a cache wants).
    carry : callable, optional
        ``carry(name) -> bool`` for each entry of the earlier folder: True to keep it in the new one
        (hard-linked, or copied across file systems, before the swap), e.g. a user's own files.

    Yields
    ------
    Path
        The temporary folder to write into.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
    try:
        yield tmp
        for f in tmp.rglob("*"):
            if f.is_file() and not f.is_symlink():
                fsync_file(f)
        if carry is not None and path.is_dir():
            _carry_over(path, tmp, carry)
        os.chmod(tmp, umask_mode(directory=True))  # mkdtemp creates 0700
        with signals_deferred():
            _put_in_place(tmp, path, replace)
    except BaseException:
        _discard(tmp)
        raise


def _carry_over(old: Path, new: Path, carry: Callable[[str], bool]) -> None:
    for name in os.listdir(old):
        if not carry(name) or os.path.lexists(new / name):
            continue
        src, dst = old / name, new / name
        if src.is_dir() and not src.is_symlink():
            shutil.copytree(src, dst, symlinks=True, copy_function=_link_or_copy)
        else:
            _link_or_copy(src, dst)


def _link_or_copy(src, dst) -> None:
    try:
        os.link(src, dst, follow_symlinks=False)
    except OSError:
        shutil.copy2(src, dst, follow_symlinks=False)


@contextlib.contextmanager
def staged_files(folder: str | Path, last: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a hidden staging folder inside ``folder``; when the body ends normally every file
    written into it is flushed to disk and moved into ``folder`` (replacing files of the same name),
    the names in ``last`` after the others, all with SIGINT/SIGTERM held back. On any exception the
    staging folder is removed and ``folder`` is untouched.

    For several files that belong together in a folder that holds other things too (a run folder):
    a reader sees none of them or all of them (the one named last marks the set complete).

    Parameters
    ----------
    folder : str or Path
        Existing folder the files go to.
    last : iterable of str
        Names moved last (e.g. the file that marks the set complete).

    Yields
    ------
    Path
        The staging folder to write into.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(dir=folder, prefix=".stage-", suffix=".tmp"))
    last = list(last)
    try:
        yield stage
        names = sorted(os.listdir(stage), key=lambda n: (n in last, last.index(n) if n in last else 0, n))
        for name in names:
            fsync_file(stage / name)
            os.chmod(stage / name, umask_mode())
        with signals_deferred():
            for name in names:
                os.replace(stage / name, folder / name)
            os.rmdir(stage)
    except BaseException:
        _discard(stage)
        raise
