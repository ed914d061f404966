"""On-disk store of numeric arrays that are expensive to compute and depend on a few numbers only.

The engine keeps here the values of an ODE's ``pre(t, p)`` on a stage-time grid (see
:class:`birdocp.engine.ode.ODE`, ``graph_key``): for the bird, the wing's shape in the
arm frame at the 2N+1 RK4 stage times, 0.2 s to evaluate and the same in every process that flies
the same wing. A later process reads it back in about a millisecond.

One file per array, ``<cache_dir>/data/<kind>-<digest>.npz``, holding the array, the full key it was
computed for (as text) and the SHA-256 of the array's bytes. A file is used only if its key equals
the requested key exactly and the checksum matches; a truncated, garbled or foreign file is removed
and the array recomputed (never trusted). Writes go to a temporary file renamed into place
(:func:`birdocp.engine.atomic.atomic_target`: atomic, safe with parallel processes, removed on an
interrupt). At most :data:`MAX_FILES` files are kept (least recently used
removed). The folder is the graph cache's (:func:`birdocp.engine.graphcache.cache_dir`), and the
store is off when the graph cache is off (``BIRDOCP_GRAPH_CACHE=0``). Failures to write are silent:
the store only saves time, it never changes a number (the stored doubles are the computed ones).
"""
from __future__ import annotations

import hashlib
import json
import os
import time
import zipfile
from pathlib import Path

import numpy as np

from birdocp.engine import graphcache
from birdocp.engine.atomic import atomic_target

__all__ = ["MAX_FILES", "load", "store", "clear", "folder"]

MAX_FILES = 64
"""Files kept in the store (the bird's pre grid is about 0.5 MB)."""


def folder(directory=None) -> Path:
    """The store's folder: ``<cache_dir>/data``.

    Parameters
    ----------
    directory : str or Path, optional
        Cache folder (default: :func:`birdocp.engine.graphcache.cache_dir`).

    Returns
    -------
    Path
    """
    return (Path(directory) if directory is not None else graphcache.cache_dir()) / "data"


def _text(key: dict) -> str:
    return json.dumps(key, sort_keys=True, default=repr)


def _path(kind: str, key: dict, directory) -> Path:
    return folder(directory) / f"{kind}-{hashlib.sha256(_text(key).encode()).hexdigest()[:32]}.npz"


def load(kind: str, key: dict, directory=None) -> np.ndarray | None:
    """The array stored for ``(kind, key)``, or None (absent, store disabled, or a file that fails the
    key or checksum test: such a file is removed).

    Parameters
    ----------
    kind : str
        Kind of array.
    key : dict
        JSON-able key.
    directory : str or Path, optional
        Cache folder.

    Returns
    -------
    ndarray or None
    """
    if not graphcache.enabled():
        return None
    path = _path(kind, key, directory)
    try:
        with np.load(path, allow_pickle=False) as z:
            values = np.array(z["values"])
            stored_key = str(z["key"])
            digest = str(z["sha256"])
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        _remove(path)
        return None
    if stored_key != _text(key) or hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest() != digest:
        _remove(path)
        return None
    try:
        os.utime(path)  # least recently used goes first
    except OSError:
        pass
    return values


def store(kind: str, key: dict, values, directory=None) -> Path | None:
    """Write ``values`` for ``(kind, key)``; returns the file, or None (disabled or not writable).

    Parameters
    ----------
    kind : str
        Kind of array.
    key : dict
        JSON-able key.
    values : array_like
        Array to store.
    directory : str or Path, optional
        Cache folder.

    Returns
    -------
    Path or None
    """
    if not graphcache.enabled():
        return None
    values = np.ascontiguousarray(np.asarray(values, float))
    path = _path(kind, key, directory)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_target(path, suffix=".tmp") as tmp, open(tmp, "wb") as fh:  # removed on any exception
            np.savez(fh, values=values, key=np.array(_text(key)),
                     sha256=np.array(hashlib.sha256(values.tobytes()).hexdigest()))
    except OSError:
        return None
    _prune(path.parent, keep=path)
    return path


def _remove(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


def _prune(root: Path, keep: Path) -> None:
    now = time.time()
    files = []
    for f in root.iterdir():
        try:
            st = f.stat()
        except OSError:
            continue
        if f.name.startswith("."):
            if now - st.st_mtime > 3600:  # a temporary file left by a killed process (SIGKILL)
                _remove(f)
            continue
        if f.suffix == ".npz":
            files.append((st.st_mtime, f))
    graphcache.remove_oldest(files, MAX_FILES, keep, _remove)


def clear(directory=None) -> int:
    """Remove every stored array; returns how many files were removed.

    Parameters
    ----------
    directory : str or Path, optional
        Cache folder.

    Returns
    -------
    int
    """
    root = folder(directory)
    files = list(root.glob("*.npz")) if root.exists() else []
    for f in files:
        _remove(f)
    return len(files)
