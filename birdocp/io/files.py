"""Atomic writing for the layers above the engine: files, folders and run folders appear whole.

The mechanism (:mod:`birdocp.engine.atomic`, standard library only, so that the engine's disk caches
use it too) is re-exported here: :func:`atomic_target` (one file), :func:`atomic_folder` (a folder
as a whole, e.g. ``export-c``), :func:`staged_files` (several files into a run folder, the last
one marking the set complete) and :func:`signals_deferred`. The helpers below write bytes, text and
JSON through :func:`atomic_target`.
"""

from __future__ import annotations

import json
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

# The one JSON convention of every result (complex as [re, im], NaN/inf as null): a standard-library
# module of the engine, one of io's two imports from another layer (declared in pyproject.toml).
from birdocp.engine.results import to_jsonable
# The one atomic write (standard library only; the engine's caches use it too), declared likewise.
from birdocp.engine.atomic import atomic_folder, atomic_target, signals_deferred, staged_files, umask_mode

__all__ = ["atomic_target", "atomic_folder", "staged_files", "signals_deferred", "umask_mode",
           "atomic_write_bytes", "atomic_write_text", "atomic_write_json", "dataclass_to_dict", "to_jsonable"]


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (:func:`atomic_target`).

    Parameters
    ----------
    path : str or Path
        File to write; it appears whole or not at all.
    data : bytes
        Content of the file.

    Returns
    -------
    None
    """
    with atomic_target(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
        File to write; it appears whole or not at all.
    text : str
        Content of the file, encoded as UTF-8.

    Returns
    -------
    None
    """
    atomic_write_bytes(path, text.encode("utf-8"))


def dataclass_to_dict(obj: Any) -> dict:
    """Nested plain dict of a dataclass (nested dataclasses as dicts, tuples as lists).

    Parameters
    ----------
    obj : dataclass instance or dict
        Object to convert; a dict is returned as it is.

    Returns
    -------
    dict
        Field name to value.
    """
    if isinstance(obj, dict):
        return obj
    out = {}
    for f in fields(obj):
        v = getattr(obj, f.name)
        out[f.name] = dataclass_to_dict(v) if is_dataclass(v) else (list(v) if isinstance(v, tuple) else v)
    return out


def atomic_write_json(path: str | Path, obj: Any) -> None:
    """Write ``obj`` as indented JSON atomically (complex as [re, im], NaN/inf as null).

    Parameters
    ----------
    path : str or Path
        File to write; it appears whole or not at all.
    obj : Any
        Value to write, converted by :func:`to_jsonable`.

    Returns
    -------
    None
    """
    atomic_write_text(path, json.dumps(to_jsonable(obj), indent=1) + "\n")
