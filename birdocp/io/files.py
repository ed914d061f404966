"""Atomic file writing: a temporary file in the same folder, flushed, then renamed over the target."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

# The one JSON convention of every result (complex as [re, im], NaN/inf as null): a standard-library
# module of the engine, the only import of io from another layer (declared in pyproject.toml).
from birdocp.engine.results import to_jsonable


def umask_mode() -> int:
    """The mode a new file gets under the process umask (0o666 & ~umask), e.g. 0o644."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextlib.contextmanager
def atomic_target(path: str | Path, suffix: str = ".tmp"):
    """Yield a temporary path in the target's folder; on success it is renamed over ``path`` (with
    ordinary permissions), on any exception it is removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, umask_mode())  # mkstemp creates 0600
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    with atomic_target(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def dataclass_to_dict(obj: Any) -> dict:
    """Nested plain dict of a dataclass (nested dataclasses as dicts, tuples as lists); a dict is
    returned as it is."""
    if isinstance(obj, dict):
        return obj
    out = {}
    for f in fields(obj):
        v = getattr(obj, f.name)
        out[f.name] = dataclass_to_dict(v) if is_dataclass(v) else (list(v) if isinstance(v, tuple) else v)
    return out


def atomic_write_json(path: str | Path, obj: Any) -> None:
    atomic_write_text(path, json.dumps(to_jsonable(obj), indent=1) + "\n")
