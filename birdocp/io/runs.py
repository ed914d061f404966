"""Run folders: one fresh folder per command run, written atomically.

Layout of a run folder::

    runs/20250101-120000-trim-3fa9c2/
        config.toml   the resolved configuration (load it back with ``birdocp.bird.config.load``)
        arrays.npz    numeric arrays of the result (trajectory, monodromy, ...), if any
        result.json   the result dict plus ``provenance``; written last, so its presence means the
                      run folder is complete

Every file is written to a temporary file in the same folder and renamed over its target, so a
reader (or a crash) never sees a half-written file.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import tempfile
import time
from pathlib import Path
from typing import IO, Any, Iterator

from birdocp.io.errors import ConfigError

__all__ = [
    "DEFAULT_BASE", "RUN_FILES", "new_run_dir", "claim_out_dir", "is_run_dir", "write_run",
    "atomic_file", "read_result",
]

DEFAULT_BASE = Path("runs")
RUN_FILES = ("config.toml", "arrays.npz", "result.json")


def _slug(command: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", command).strip("-")
    return slug or "run"


def new_run_dir(base: str | Path | None, command: str) -> Path:
    """Create and return a new, unique folder ``base/YYYYmmdd-HHMMSS-<command>-<random>``.

    The folder is created with ``mkdir(exist_ok=False)``, so two runs (even concurrent ones, in
    the same second) never share a folder.
    """
    base = DEFAULT_BASE if base is None else Path(base)
    if base.exists() and not base.is_dir():
        raise ConfigError(str(base), "the runs folder is an existing file; remove it or pass --out DIR")
    base.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    for _ in range(100):
        path = base / f"{stamp}-{_slug(command)}-{secrets.token_hex(3)}"
        try:
            path.mkdir(exist_ok=False)
        except FileExistsError:
            continue
        return path
    raise RuntimeError(f"could not create a unique run folder in {base}")  # pragma: no cover


def read_result(run_dir: str | Path) -> dict | None:
    """The result.json of a run folder, or None if absent or unreadable."""
    try:
        return json.loads((Path(run_dir) / "result.json").read_text())
    except (OSError, ValueError):
        return None


def is_run_dir(path: str | Path, command: str | None = None) -> bool:
    """Whether ``path`` is a complete run folder (of ``command`` when given).

    Helper for a future ``--resume``: a run folder is complete when its result.json exists.
    """
    result = read_result(path)
    if not isinstance(result, dict):
        return False
    if command is None:
        return True
    prov = result.get("provenance") or {}
    return isinstance(prov, dict) and prov.get("command") == command


def claim_out_dir(out: str | Path, command: str) -> Path:
    """Use ``--out DIR`` as the run folder: created if missing, accepted if an empty folder.

    Anything else is refused with a :class:`ConfigError` on ``--out`` (the CLI exits 2).
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise ConfigError("--out", f"'{path}' is an existing file; give a new or empty folder")
    if path.is_dir():
        if any(path.iterdir()):
            if is_run_dir(path, command):
                raise ConfigError("--out", f"'{path}' holds a previous '{command}' run and resuming is not "
                                  "supported yet; give a new folder or remove it")
            raise ConfigError("--out", f"folder '{path}' is not empty; give a new or empty folder")
        return path
    try:
        path.mkdir(parents=True, exist_ok=False)
    except FileExistsError:  # created concurrently: re-check it
        return claim_out_dir(path, command)
    except OSError as exc:
        raise ConfigError("--out", f"cannot create folder '{path}': {exc.strerror or exc}") from None
    return path


@contextlib.contextmanager
def atomic_file(path: str | Path) -> Iterator[IO[bytes]]:
    """Binary file handle on a temporary file next to ``path``, renamed over ``path`` on success.

    If the body raises, the temporary file is removed and ``path`` is left untouched.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _write_npz(path: Path, arrays: dict[str, Any]) -> None:
    import numpy as np

    with atomic_file(path) as fh:
        np.savez(fh, **{str(k): np.asarray(v) for k, v in arrays.items()})


def write_run(run_dir: str | Path, cfg, result_dict: dict, arrays: dict | None,
              command_line: list[str] | None, *, command: str | None = None,
              wall_s: Any = None) -> Path:
    """Write ``config.toml``, ``arrays.npz`` (if ``arrays``) and ``result.json`` into ``run_dir``.

    ``result.json`` holds ``result_dict`` plus ``provenance`` (see :mod:`birdocp.io.provenance`) and is
    written last. ``wall_s`` defaults to ``result_dict["wall_s"]``. Returns the result.json path.
    """
    import tomli_w

    from birdocp.io.files import atomic_write_json, atomic_write_text, dataclass_to_dict
    from birdocp.io.provenance import provenance

    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(run_dir / "config.toml", tomli_w.dumps(dataclass_to_dict(cfg)))
    if arrays:
        _write_npz(run_dir / "arrays.npz", arrays)
    if wall_s is None:
        wall_s = result_dict.get("wall_s")
    prov = provenance(cfg, command_line, wall_s)
    prov["command"] = command
    out = dict(result_dict)
    out["provenance"] = prov
    atomic_write_json(run_dir / "result.json", out)
    return run_dir / "result.json"
