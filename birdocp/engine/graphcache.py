"""On-disk cache of built CasADi Functions (CasADi's own serialisation), shared by processes.

Building a large SX graph (the bird's wing geometry: ~0.7 s) costs more than reading it back
(``Function.deserialize``: ~0.1 s for 180k instructions), so a new process loads the graphs that an
earlier one built. An *entry* is a folder ``<cache_dir>/graphs/<kind>-<hash>/`` holding one file per
Function (``<name>.casadi``, the text of ``Function.serialize()``) and ``manifest.json``:

* ``key``: everything the caller says changes the graphs (for the bird: a hash of the model's source
  files, the structural configuration, the birdocp and CasADi versions); the folder name is a hash of
  it, and the manifest's key must equal the requested key **exactly**, so a foreign entry (a hash
  collision, a hand-copied folder) is never used;
* ``files``: per Function its size and SHA-256; a file is hashed when it is read and deserialised
  only if it matches, so a truncated or garbled file is detected, the entry removed and the caller
  rebuilds (``load`` returns None, or :class:`CacheMiss` from :meth:`Entry.function`);
* ``meta``: small JSON data the caller stores beside the graphs.

Writes are atomic and safe with concurrent processes (:func:`birdocp.engine.atomic.atomic_folder`):
an entry is written completely into a private temporary folder inside the cache folder and renamed
into place in one ``os.rename``; if another process got there first the rename fails and the copy
is discarded (both built the same graphs). An interrupt while writing removes the temporary folder.
Readers never see a partial entry. At most :data:`MAX_ENTRIES` entries of a kind are kept (the least
recently used are removed when a new one is stored).

Location: ``$BIRDOCP_CACHE`` or ``$XDG_CACHE_HOME/birdocp`` (default ``~/.cache/birdocp``), the folder
the compiled RHS (:mod:`birdocp.export.compiled`) uses too. Disable with ``BIRDOCP_GRAPH_CACHE=0``
(or ``off``/``no``/``false``); :func:`enabled`. Failures to write (read-only or full disk) are
silent: the cache only ever saves time, it never changes a number (a deserialised Function evaluates
the same instructions as the one that was serialised: results are bit-identical).
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
from pathlib import Path

import casadi as ca

from birdocp.engine.atomic import atomic_folder
from birdocp.engine.lazy import signature

__all__ = ["FORMAT", "MAX_ENTRIES", "CacheMiss", "Entry", "cache_dir", "enabled", "key_digest",
           "source_digest", "load", "store", "clear", "remove_oldest"]

FORMAT = 1
"""Version of the entry layout (part of every key)."""

MAX_ENTRIES = 6
"""Entries kept per kind (the bird model's entry is ~50 MB)."""

_OFF = ("0", "off", "no", "false")


class CacheMiss(RuntimeError):
    """A cached Function could not be used (missing, checksum mismatch, deserialisation error)."""


def cache_dir() -> Path:
    """``$BIRDOCP_CACHE``, else ``$XDG_CACHE_HOME/birdocp``, else ``~/.cache/birdocp``.

    Returns
    -------
    Path
        The cache folder (not created here).
    """
    env = os.environ.get("BIRDOCP_CACHE")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "birdocp"


def enabled() -> bool:
    """False when ``$BIRDOCP_GRAPH_CACHE`` is ``0``/``off``/``no``/``false``.

    Returns
    -------
    bool
    """
    return os.environ.get("BIRDOCP_GRAPH_CACHE", "1").strip().lower() not in _OFF


def source_digest(paths) -> str:
    """SHA-256 over the names and contents of ``paths`` (sorted by name).

    Parameters
    ----------
    paths : iterable of Path
        Files to hash.

    Returns
    -------
    str
        Hexadecimal digest.
    """
    h = hashlib.sha256()
    for p in sorted(Path(p) for p in paths):
        h.update(p.name.encode())
        h.update(b"\0")
        h.update(p.read_bytes())
        h.update(b"\0")
    return h.hexdigest()


def key_digest(key: dict) -> str:
    """Hash of a key dict (JSON with sorted keys; the format version and CasADi version included).

    Parameters
    ----------
    key : dict
        JSON-able key.

    Returns
    -------
    str
        24 hexadecimal digits.
    """
    return hashlib.sha256(_canonical(key).encode()).hexdigest()[:24]


def _canonical(key: dict) -> str:
    full = dict(key, _format=FORMAT, _casadi=ca.__version__)
    return json.dumps(full, sort_keys=True, default=repr)


def _root(directory) -> Path:
    return (Path(directory) if directory is not None else cache_dir()) / "graphs"


def _folder(kind: str, key: dict, directory) -> Path:
    return _root(directory) / f"{kind}-{key_digest(key)}"


class Entry:
    """A cache entry that passed the manifest check; Functions are read (and checked) on demand."""

    def __init__(self, folder: Path, manifest: dict):
        self.folder = folder
        self.manifest = manifest
        self.meta = manifest.get("meta", {})
        self.load_s = 0.0

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.manifest["files"])

    def signature(self, name: str) -> dict | None:
        """The stored signature of ``name`` (:func:`birdocp.engine.lazy.signature`), or None.

        Parameters
        ----------
        name : str
            Function name.

        Returns
        -------
        dict or None
        """
        info = self.manifest["files"].get(name) or {}
        sig = info.get("signature")
        return sig if isinstance(sig, dict) and {"name", "size_in", "size_out"} <= set(sig) else None

    def function(self, name: str) -> ca.Function:
        """The Function ``name``; raises :class:`CacheMiss` (and removes the entry) if its file is
        missing, has the wrong size or checksum, or does not deserialise.

        Parameters
        ----------
        name : str
            Function name.

        Returns
        -------
        casadi.Function
        """
        t = time.perf_counter()
        info = self.manifest["files"].get(name)
        if info is None:
            raise CacheMiss(f"{name!r} not in the cache entry {self.folder.name}")
        try:
            data = (self.folder / f"{name}.casadi").read_bytes()
        except OSError as e:
            self.discard()
            raise CacheMiss(f"{name}: {e}") from e
        if len(data) != info["size"] or hashlib.sha256(data).hexdigest() != info["sha256"]:
            self.discard()
            raise CacheMiss(f"{name}: checksum mismatch in {self.folder}")
        try:
            f = ca.Function.deserialize(data.decode("ascii"))
        except Exception as e:  # a valid checksum of a file CasADi cannot read: foreign
            self.discard()
            raise CacheMiss(f"{name}: {e}") from e
        self.load_s += time.perf_counter() - t
        return f

    def discard(self) -> None:
        """Remove the entry (another process may already have done so)."""
        _remove(self.folder)


def _remove(folder: Path) -> None:
    # rename first (atomic), then delete: a reader never sees a half-deleted entry under the real name
    tomb = folder.with_name(f".del-{folder.name}-{os.getpid()}-{time.monotonic_ns()}")
    try:
        os.rename(folder, tomb)
    except OSError:
        return
    shutil.rmtree(tomb, ignore_errors=True)


def load(kind: str, key: dict, directory=None) -> Entry | None:
    """The entry of ``kind`` for ``key``, or None (absent, disabled, unreadable or foreign manifest:
    a foreign or broken entry is removed).

    Parameters
    ----------
    kind : str
        Kind of entry.
    key : dict
        JSON-able key.
    directory : str or Path, optional
        Cache folder (default :func:`cache_dir`).

    Returns
    -------
    Entry or None
    """
    if not enabled():
        return None
    folder = _folder(kind, key, directory)
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        _remove(folder)
        return None
    if not isinstance(manifest, dict) or manifest.get("key") != json.loads(_canonical(key)) \
            or not isinstance(manifest.get("files"), dict):
        _remove(folder)
        return None
    try:
        os.utime(folder / "manifest.json")  # least recently used goes first
    except OSError:
        pass
    return Entry(folder, manifest)


def store(kind: str, key: dict, functions: dict, meta: dict | None = None, directory=None) -> Path | None:
    """Write ``functions`` (name -> Function) as the entry of ``kind`` for ``key``; returns its folder,
    or None when disabled or the write failed (never raises for I/O).

    Parameters
    ----------
    kind : str
        Kind of entry.
    key : dict
        JSON-able key.
    functions : dict of str to casadi.Function
        Functions to store.
    meta : dict, optional
        JSON-able data stored with them.
    directory : str or Path, optional
        Cache folder (default :func:`cache_dir`).

    Returns
    -------
    Path or None
    """
    if not enabled():
        return None
    root = _root(directory)
    folder = _folder(kind, key, directory)
    try:
        root.mkdir(parents=True, exist_ok=True)
        # the one atomic write: a temporary sibling folder renamed into place, removed on any
        # exception (Ctrl-C during a cold build included); the first process to store an entry wins
        with atomic_folder(folder, replace=False) as tmp:
            files = {}
            for name, f in functions.items():
                data = f.serialize().encode("ascii")
                (tmp / f"{name}.casadi").write_bytes(data)
                files[name] = {"size": len(data), "sha256": hashlib.sha256(data).hexdigest(),
                               "signature": signature(f)}
            manifest = {"key": json.loads(_canonical(key)), "files": files, "meta": meta or {},
                        "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
            (tmp / "manifest.json").write_text(json.dumps(manifest, indent=1))
    except FileExistsError:  # another process stored the entry first (the same graphs)
        return folder if (folder / "manifest.json").exists() else None
    except (OSError, UnicodeError):
        return None
    _prune(root, kind, keep=folder)
    return folder


def _prune(root: Path, kind: str, keep: Path) -> None:
    now = time.time()
    # left by killed processes (SIGKILL: nothing else leaves a temporary folder behind)
    for d in list(root.glob(".*.tmp")) + list(root.glob(".*.old")) + list(root.glob(".tmp-*")) + list(root.glob(".del-*")):
        try:
            if now - d.stat().st_mtime > 3600:
                shutil.rmtree(d, ignore_errors=True)
        except OSError:
            continue
    entries = []
    for d in root.glob(f"{kind}-*"):
        try:
            entries.append(((d / "manifest.json").stat().st_mtime, d))
        except OSError:
            continue
    remove_oldest(entries, MAX_ENTRIES, keep, _remove)


def remove_oldest(entries: list, n_kept: int, keep: Path, remove) -> None:
    """Keep the ``n_kept`` newest of ``entries`` (``(mtime, path)`` pairs) and pass the others to
    ``remove`` (the cache's policy, also the data store's); ``keep``, the entry just written, stays.

    Parameters
    ----------
    entries : list of (float, Path)
        Entries with their modification times.
    n_kept : int
        Number of entries kept.
    keep : Path
        Entry that stays in any case.
    remove : callable
        ``remove(path)``.
    """
    for _, path in sorted(entries, reverse=True)[n_kept:]:
        if path != keep:
            remove(path)


def clear(directory=None) -> int:
    """Remove every graph-cache entry; returns how many were removed.

    Parameters
    ----------
    directory : str or Path, optional
        Cache folder (default :func:`cache_dir`).

    Returns
    -------
    int
    """
    root = _root(directory)
    n = 0
    for d in list(root.glob("*-*")) if root.exists() else []:
        if d.is_dir() and not d.name.startswith("."):
            _remove(d)
            n += 1
    return n
