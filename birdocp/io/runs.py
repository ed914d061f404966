"""Run folders: one fresh folder per command run, written atomically.

Layout of a run folder::

    runs/20250101-120000-trim-3fa9c2/
        config.toml   the resolved configuration (load it back with ``birdocp.bird.config.load``)
        arrays.npz    numeric arrays of the result (trajectory, monodromy, ...), if any
        result.json   the result dict plus ``provenance``; written last, so its presence means the
                      run folder is complete

The three files are written completely into a hidden staging folder inside the run folder and then
moved into place together, result.json last, with Ctrl-C held back meanwhile
(:func:`birdocp.io.files.staged_files`): an interrupt, a full disk or a file-size limit leaves
either the earlier files or the new complete set, never a mix or a truncated file.
"""

from __future__ import annotations

import atexit
import contextlib
import errno
import os
import re
import secrets
import socket
import tempfile
import time
from pathlib import Path
from typing import IO, Any, Iterator

from birdocp.io.errors import ConfigError

__all__ = [
    "DEFAULT_BASE", "RUN_FILES", "LOCK_NAME", "new_run_dir", "claim_out_dir", "release_out_dir", "held_lock",
    "check_out_path", "check_out_file", "check_writable", "lock_folder", "folder_entries", "RunLock", "is_run_dir", "write_run", "atomic_file",
    "read_result",
]

DEFAULT_BASE = Path("runs")
RUN_FILES = ("config.toml", "arrays.npz", "result.json")


def _slug(command: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", command).strip("-")
    return slug or "run"


LOCK_NAME = ".birdocp.lock"
"""Lock file of a claimed run folder: created with ``O_EXCL`` (and held with ``flock`` where the
platform has it, so the lock of a killed run is recognised as stale); removed when the run ends."""


def _os_reason(exc: OSError) -> str:
    if exc.errno == errno.ENAMETOOLONG:
        return "the name is too long for the file system"
    if exc.errno in (errno.EROFS,):
        return "the file system is read-only"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return "permission denied (the folder is read-only)"
    if exc.errno == errno.ELOOP:
        return "too many levels of symbolic links"
    if exc.errno == errno.ENOSPC:
        return "no space left on the device"
    return exc.strerror or str(exc)


def check_out_path(path: str | Path, flag: str = "--out") -> Path:
    """Refuse (:class:`ConfigError` on ``flag``) an output location that cannot be a run folder.

    Checked without creating anything: a dangling symbolic link, a name longer than the file system
    allows, an existing file, a path through a file, and a nearest existing folder that this process
    cannot write into. The final word is the atomic create of :func:`claim_out_dir`, which maps any
    remaining ``OSError`` to a ``ConfigError`` too.

    Parameters
    ----------
    path : str or Path
        The output folder asked for.
    flag : str
        Flag named by the error.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    text = os.fspath(path)
    if not text.strip() or "\x00" in text:  # Path("") would be the current folder
        raise ConfigError(flag, f"{text!r} is not a usable path; give a folder name")
    path = Path(path)
    if os.path.islink(path) and not os.path.exists(path):
        raise ConfigError(flag, f"'{path}' is a dangling symbolic link (to '{os.readlink(path)}'); remove it or "
                            "give another folder")
    # the nearest existing ancestor: where the folder would be created
    anc = path
    missing = []
    while not os.path.lexists(anc):
        missing.append(anc.name)
        if anc.parent == anc:
            break
        anc = anc.parent
    if os.path.islink(anc) and not os.path.exists(anc):
        raise ConfigError(flag, f"'{anc}' (in '{path}') is a dangling symbolic link; remove it or give another folder")
    try:
        name_max = os.pathconf(anc if os.path.isdir(anc) else anc.parent, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        name_max = 255
    for part in path.parts:
        if len(os.fsencode(part)) > name_max:
            raise ConfigError(flag, f"'{part[:40]}...' is {len(os.fsencode(part))} bytes long; the file system "
                                f"allows {name_max} per name")
    if len(os.fsencode(os.path.abspath(path))) + 64 > 4096:
        raise ConfigError(flag, "the path is too long for the file system")
    if path.exists() and not path.is_dir():
        raise ConfigError(flag, f"'{path}' is an existing file; give a new or empty folder")
    if not os.path.isdir(anc):
        raise ConfigError(flag, f"'{anc}' is a file, so '{path}' cannot be created; give another folder")
    if missing and not os.access(anc, os.W_OK | os.X_OK):
        raise ConfigError(flag, f"cannot create '{path}': '{anc}' is read-only; give another folder")
    if not missing and not os.access(path, os.W_OK | os.X_OK):
        raise ConfigError(flag, f"'{path}' is read-only; give a writable folder")
    return path


def check_writable(folder: str | Path, flag: str) -> None:
    """Refuse (:class:`ConfigError` on ``flag``) a folder this process cannot create files in, by
    creating and removing an empty probe file: only a real write tells a read-only file system or a
    full inode table (permission bits do not stop root).

    Parameters
    ----------
    folder : str or Path
        Existing folder to probe.
    flag : str
        Flag named by the error.
    """
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".birdocp-probe-")
    except OSError as exc:
        raise ConfigError(flag, f"cannot write into '{folder}': {_os_reason(exc)}; give another location") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(probe)


def check_out_file(path: str | Path, flag: str = "--out", suffixes: tuple[str, ...] = ()) -> Path:
    """Refuse (:class:`ConfigError` on ``flag``) an output *file* that cannot be written, before any
    computation: a name with a suffix not in ``suffixes``, an existing folder or special file (FIFO,
    device, socket), a missing or non-folder parent, a parent that cannot be written into
    (:func:`check_writable`). The file itself is then written atomically.

    Parameters
    ----------
    path : str or Path
        The output file asked for.
    flag : str
        Flag named by the error.
    suffixes : tuple of str
        Accepted lower-case suffixes with the dot (e.g. ``(".gif", ".mp4")``); empty: any.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    text = os.fspath(path)
    if not text.strip() or "\x00" in text:
        raise ConfigError(flag, f"{text!r} is not a usable file name")
    path = Path(path)
    if suffixes and path.suffix.lower() not in suffixes:
        raise ConfigError(flag, f"'{path.name}': the file must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise ConfigError(flag, f"'{path}' is a folder; give a file name")
    if os.path.lexists(path) and not (path.is_file() or os.path.islink(path)):
        raise ConfigError(flag, f"'{path}' exists and is not a regular file (a FIFO, device or socket); "
                                "give another name")
    if not path.parent.is_dir():
        raise ConfigError(flag, f"folder '{path.parent}' does not exist")
    check_writable(path.parent, flag)
    return path


class RunLock:
    """The lock of a claimed run folder (see :data:`LOCK_NAME`). ``created``: the folder did not exist
    before the claim (so an unused one may be removed again)."""

    def __init__(self, folder: Path, fd: int, created: bool):
        self.folder, self.fd, self.created = folder, fd, created
        self.path = folder / LOCK_NAME

    def release(self) -> None:
        """Remove the lock file (if it is still this lock's) and close it; idempotent."""
        if self.fd is None:
            return
        with contextlib.suppress(OSError):
            if os.stat(self.path).st_ino == os.fstat(self.fd).st_ino:
                os.unlink(self.path)
        with contextlib.suppress(OSError):
            os.close(self.fd)
        self.fd = None
        _HELD.pop(str(self.folder), None)


_HELD: dict[str, RunLock] = {}


def _release_all() -> None:
    for lock in list(_HELD.values()):
        lock.release()


atexit.register(_release_all)


def _try_flock(fd: int) -> bool:
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    except OSError:  # file system without flock: the O_EXCL create alone decides
        return True
    return True


def _holder(lock_path: Path) -> str:
    with contextlib.suppress(OSError, ValueError):
        text = lock_path.read_text().split()
        return f" (process {text[0]} on {text[1]})" if len(text) >= 2 else ""
    return ""


def lock_folder(folder: str | Path, flag: str = "--out", created: bool = False) -> RunLock:
    """Take the lock of ``folder`` (which exists): an ``O_EXCL`` create of its lock file, held with
    ``flock``. A lock file whose ``flock`` can be taken belongs to a run that died (SIGKILL, power
    loss): it is taken over. Raises :class:`ConfigError` when another live run holds the folder.

    Parameters
    ----------
    folder : str or Path
        Existing folder to lock.
    flag : str
        Flag named by the error.
    created : bool
        The caller created the folder just now (an unused one may be removed again on release).

    Returns
    -------
    RunLock
        The held lock.
    """
    folder = Path(folder)
    lock_path = folder / LOCK_NAME
    for _ in range(20):
        try:
            fd = os.open(lock_path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            try:
                fd = os.open(lock_path, os.O_RDWR)
            except FileNotFoundError:  # released meanwhile: try again
                continue
            except OSError as exc:
                raise ConfigError(flag, f"cannot lock '{folder}': {_os_reason(exc)}") from None
            has_flock = True
            try:
                import fcntl  # noqa: F401
            except ImportError:  # pragma: no cover - not POSIX: a lock file is never stale
                has_flock = False
            if not has_flock or not _try_flock(fd):
                os.close(fd)
                raise ConfigError(flag, f"'{folder}' is in use by another birdocp run{_holder(lock_path)}; "
                                    "give another folder (or wait for that run to end)")
        except OSError as exc:
            raise ConfigError(flag, f"cannot write into '{folder}': {_os_reason(exc)}; give another folder") from None
        else:
            if not _try_flock(fd):  # pragma: no cover - a fresh file: only a racing taker can hold it
                os.close(fd)
                raise ConfigError(flag, f"'{folder}' is in use by another birdocp run; give another folder")
        # the file we hold must still be the lock file (not one its owner just removed)
        try:
            same = os.stat(lock_path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if not same:
            os.close(fd)
            continue
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()} {socket.gethostname()}\n".encode())
        lock = RunLock(folder, fd, created)
        _HELD[str(folder)] = lock
        return lock
    raise ConfigError(flag, f"could not lock '{folder}' (its lock file keeps changing); give another folder")


def release_out_dir(folder: str | Path) -> None:
    """Release the lock taken by :func:`claim_out_dir` (also released when the process exits).

    Parameters
    ----------
    folder : str or Path
        Run folder claimed by :func:`claim_out_dir`; a folder without a lock of this process is ignored.
    """
    lock = _HELD.get(str(Path(folder)))
    if lock is not None:
        lock.release()


def held_lock(folder: str | Path) -> RunLock | None:
    """The lock this process holds on ``folder``, if any.

    Parameters
    ----------
    folder : str or Path
        Run folder.

    Returns
    -------
    RunLock or None
    """
    return _HELD.get(str(Path(folder)))


def folder_entries(folder: str | Path) -> list[str]:
    """Names in ``folder`` other than the lock file.

    Parameters
    ----------
    folder : str or Path
        Existing folder.

    Returns
    -------
    list of str
    """
    return [n for n in os.listdir(folder) if n != LOCK_NAME]


def new_run_dir(base: str | Path | None, command: str) -> Path:
    """Create and return a new, unique folder ``base/YYYYmmdd-HHMMSS-<command>-<random>``.

    The folder is created with ``mkdir(exist_ok=False)``, so two runs (even concurrent ones, in
    the same second) never share a folder. A ``base`` that cannot be written is a
    :class:`ConfigError` on ``--out`` (the CLI exits 2 before any computation).

    Parameters
    ----------
    base : str or Path or None
        Folder of the run folders (None: :data:`DEFAULT_BASE`).
    command : str
        Name of the command, part of the folder's name.

    Returns
    -------
    Path
        The new, empty folder.
    """
    base = DEFAULT_BASE if base is None else Path(base)
    if base.exists() and not base.is_dir():
        raise ConfigError(str(base), "the runs folder is an existing file; remove it or pass --out DIR")
    if os.path.islink(base) and not os.path.exists(base):
        raise ConfigError("--out", f"the runs folder '{base}' is a dangling symbolic link; fix it or pass --out DIR")
    try:
        base.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError("--out", f"cannot create the runs folder '{base}': {_os_reason(exc)}; "
                                   "pass --out DIR") from None
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for _ in range(100):
        path = base / f"{stamp}-{_slug(command)}-{secrets.token_hex(3)}"
        try:
            path.mkdir(exist_ok=False)
        except FileExistsError:
            continue
        except OSError as exc:
            raise ConfigError("--out", f"cannot create a run folder in '{base}': {_os_reason(exc)}; "
                                       "pass --out DIR") from None
        return path
    raise RuntimeError(f"could not create a unique run folder in {base}")  # pragma: no cover


def read_result(run_dir: str | Path) -> dict | None:
    """The result.json of a run folder, or None if absent, unreadable or not a regular file (read by
    :func:`birdocp.io.inputs.read_json_file`: a FIFO is never opened). Commands that use a run
    folder read it with :func:`birdocp.io.inputs.read_run`, which says what is wrong.

    Parameters
    ----------
    run_dir : str or Path
        Run folder.

    Returns
    -------
    dict or None
        The parsed result.json.
    """
    from birdocp.io.inputs import read_json_file

    try:
        return read_json_file(Path(run_dir) / "result.json", "RUN_DIR")
    except ConfigError:
        return None


def is_run_dir(path: str | Path, command: str | None = None) -> bool:
    """Whether ``path`` is a complete run folder (of ``command`` when given).

    A run folder is complete when its result.json exists.

    Parameters
    ----------
    path : str or Path
        Folder to look at.
    command : str, optional
        Only a run of this command (``provenance.command``) counts.

    Returns
    -------
    bool
    """
    result = read_result(path)
    if not isinstance(result, dict):
        return False
    if command is None:
        return True
    prov = result.get("provenance") or {}
    return isinstance(prov, dict) and prov.get("command") == command


def claim_out_dir(out: str | Path, command: str, *, resume_file: str | None = None,
                  flag: str = "--out") -> Path:
    """Use ``--out DIR`` as the run folder, exclusively: created if missing, accepted if empty.

    The claim is atomic: the folder's lock file (:data:`LOCK_NAME`) is created with ``O_EXCL`` and
    held until :func:`release_out_dir` or the end of the process, so of two runs started together
    with the same folder exactly one gets it. ``resume_file``: the folder may also hold an earlier
    run that has this file (``sweep.json`` for ``sweep --resume``).

    Anything else is refused with a :class:`ConfigError` on ``flag`` (the CLI exits 2), before any
    computation: a file, a non-empty folder, a folder in use by another run, a dangling symbolic
    link, a name too long for the file system, a read-only location.

    Parameters
    ----------
    out : str or Path
        The folder asked for.
    command : str
        Name of the command (for the messages).
    resume_file : str, optional
        File name that marks an earlier run of this command the folder may hold.
    flag : str
        Flag named by the error.

    Returns
    -------
    Path
        The claimed folder, locked by this process.
    """
    path = check_out_path(out, flag)
    created = False
    if not path.is_dir():
        try:
            path.mkdir(parents=True, exist_ok=False)
            created = True
        except FileExistsError:  # created concurrently: the lock decides
            pass
        except OSError as exc:
            raise ConfigError(flag, f"cannot create folder '{path}': {_os_reason(exc)}") from None
    if not path.is_dir():
        raise ConfigError(flag, f"'{path}' is an existing file; give a new or empty folder")
    lock = lock_folder(path, flag, created)
    try:
        entries = folder_entries(path)
    except OSError as exc:
        lock.release()
        raise ConfigError(flag, f"cannot read folder '{path}': {_os_reason(exc)}") from None
    if entries and not (resume_file and resume_file in entries):
        lock.release()
        if resume_file:
            raise ConfigError(flag, f"'{path}' holds no {resume_file} to resume from")
        if is_run_dir(path, command):
            raise ConfigError(flag, f"'{path}' holds a previous '{command}' run and resuming is not "
                              "supported yet; give a new folder or remove it")
        raise ConfigError(flag, f"folder '{path}' is not empty; give a new or empty folder")
    return path


@contextlib.contextmanager
def atomic_file(path: str | Path) -> Iterator[IO[bytes]]:
    """Binary file handle on a temporary file next to ``path``, renamed over ``path`` on success
    (:func:`birdocp.io.files.atomic_target`). If the body raises, ``path`` is left untouched.

    Parameters
    ----------
    path : str or Path
        File to write.

    Yields
    ------
    file object
        Binary handle to write the content into.
    """
    from birdocp.io.files import atomic_target

    with atomic_target(path) as tmp, open(tmp, "wb") as fh:
        yield fh


def _write_npz(path: Path, arrays: dict[str, Any]) -> None:
    import numpy as np

    with open(path, "wb") as fh:
        np.savez(fh, **{str(k): np.asarray(v) for k, v in arrays.items()})


def write_run(run_dir: str | Path, cfg, result_dict: dict, arrays: dict | None,
              command_line: list[str] | None, *, command: str | None = None,
              wall_s: Any = None) -> Path:
    """Write ``config.toml``, ``arrays.npz`` (if ``arrays``) and ``result.json`` into ``run_dir``.

    ``result.json`` holds ``result_dict`` plus ``provenance`` (see :mod:`birdocp.io.provenance`) and is
    written last. ``wall_s`` defaults to ``result_dict["wall_s"]``. Returns the result.json path.

    Parameters
    ----------
    run_dir : str or Path
        Existing run folder.
    cfg : Config
        Resolved configuration of the run (written as config.toml and into the provenance).
    result_dict : dict
        JSON-able result.
    arrays : dict of str to ndarray or None
        Arrays for arrays.npz; None: no arrays.npz.
    command_line : list of str or None
        Command line of the run (None from the Python API).
    command : str, optional
        Name of the command, stored as ``provenance.command``.
    wall_s : float, optional
        Wall time of the run [s] (default: ``result_dict["wall_s"]``).

    Returns
    -------
    Path
        The path of result.json.
    """
    import json

    import tomli_w

    from birdocp.io.files import dataclass_to_dict, staged_files, to_jsonable
    from birdocp.io.provenance import provenance

    run_dir = Path(run_dir)
    if wall_s is None:
        wall_s = result_dict.get("wall_s")
    prov = provenance(cfg, command_line, wall_s)
    prov["command"] = command
    out = dict(result_dict)
    out["provenance"] = prov
    # all files complete in a staging folder first, then moved in with result.json last: a full disk
    # or an interrupt leaves the earlier files (or none), never config.toml without result.json
    with staged_files(run_dir, last=("result.json",)) as stage:
        (stage / "config.toml").write_text(tomli_w.dumps(dataclass_to_dict(cfg)), encoding="utf-8")
        if arrays:
            _write_npz(stage / "arrays.npz", arrays)
        (stage / "result.json").write_text(json.dumps(to_jsonable(out), indent=1) + "\n", encoding="utf-8")
    return run_dir / "result.json"
