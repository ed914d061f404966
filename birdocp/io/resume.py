"""Resumable studies: one index file and one file per finished point, and what a resume may keep.

The one mechanism of every study that resumes (``sweep``, its grids, ``continue``)::

    DIR/<index>.json           the study's definition (key, values or range, options, configuration)
    DIR/points/point-0003.json one finished point, written atomically as soon as it is finished, with
                               ``config_sha256`` (:func:`birdocp.io.provenance.config_hash` of the
                               configuration it was computed for) and ``settings`` (what else decides it)

A resume (:func:`check_index`, :func:`kept_points`) refuses another definition than the index file's,
and keeps a point only when its own ``config_sha256`` and ``settings`` are the ones the resumed study
would compute it with, also when the index file is truncated or damaged: a point of another
configuration is refused (:class:`ConfigError` on ``--resume``), never reported; a point written
before points carried the hash is kept only when the index file was intact and matched (else it is
computed again, with a warning). Every file is read through :mod:`birdocp.io.inputs` (a FIFO or
device is refused, never opened).
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any, Callable

from birdocp.io.errors import ConfigError
from birdocp.io.files import atomic_write_json, to_jsonable
from birdocp.io.inputs import file_problem, read_json_file

__all__ = ["POINTS_DIR", "point_path", "read_index", "check_index", "read_points", "write_point", "kept_points",
           "plain"]

POINTS_DIR = "points"


def plain(obj: Any) -> Any:
    """``obj`` as it reads back from JSON (tuples as lists, NaN as None): what a resume compares.

    Parameters
    ----------
    obj : Any
        JSON-able value (via :func:`to_jsonable`).

    Returns
    -------
    Any
        Lists, dicts, numbers, strings and None only.
    """
    return json.loads(json.dumps(to_jsonable(obj)))


def point_path(out: str | Path, index: int) -> Path:
    """``out/points/point-0003.json``.

    Parameters
    ----------
    out : str or Path
        Study folder.
    index : int
        Index of the point in the study.

    Returns
    -------
    Path
    """
    return Path(out) / POINTS_DIR / f"point-{index:04d}.json"


def read_index(path: str | Path, flag: str = "--resume") -> tuple[dict | None, bool]:
    """(definition, damaged) of a study's index file: (None, False) when absent, (None, True) when it
    does not parse (truncated, damaged); a FIFO, device or folder is a :class:`ConfigError` on ``flag``.

    Parameters
    ----------
    path : str or Path
        Index file of the study.
    flag : str
        Flag named by the error.

    Returns
    -------
    definition : dict or None
        The study's definition as written.
    damaged : bool
        The file exists but does not parse.
    """
    path = Path(path)
    if not os.path.lexists(path):
        return None, False
    problem = file_problem(path)
    if problem:
        raise ConfigError(flag, f"'{path}' {problem}")
    try:
        old = read_json_file(path, flag)
    except ConfigError:
        return None, True
    return (old, False) if isinstance(old, dict) else (None, True)


def check_index(old: dict, spec: dict, out: str | Path, what: str, flag: str = "--resume") -> None:
    """Refuse (:class:`ConfigError` on ``flag``) a resume whose definition ``spec`` differs from the
    index file's ``old`` (naming the differing keys).

    Parameters
    ----------
    old : dict
        Definition read from the index file.
    spec : dict
        Definition of the resumed study (its keys are compared as JSON).
    out : str or Path
        Study folder, for the message.
    what : str
        What the definition is, for the message (e.g. "sweep").
    flag : str
        Flag named by the error.
    """
    diff = [k for k in spec if json.dumps(plain(old.get(k))) != json.dumps(plain(spec[k]))]
    if diff:
        raise ConfigError(flag, f"the {what} in '{out}' differs in {', '.join(diff)}; resume with the same "
                                "arguments or use a new folder")


def _index_of(point: dict) -> int:
    if "index" in point:
        return int(point["index"])
    return int(point["row"]["index"])  # sweep points: the index is the table row's


def read_points(out: str | Path) -> dict[int, dict]:
    """The point files of ``out`` by index; unreadable or damaged ones are left out (computed again).

    Parameters
    ----------
    out : str or Path
        Study folder.

    Returns
    -------
    dict of int to dict
        Point index to the point as written by :func:`write_point`.
    """
    folder = Path(out) / POINTS_DIR
    found: dict[int, dict] = {}
    if not folder.is_dir():
        return found
    for f in sorted(folder.glob("point-*.json")):
        try:
            pt = read_json_file(f, "--resume")
            found[_index_of(pt)] = pt
        except (ConfigError, KeyError, TypeError, ValueError):
            continue
    return found


def write_point(out: str | Path, index: int, point: dict, config_sha256: str, settings: dict) -> None:
    """Write one finished point (atomically) with its configuration hash and settings.

    Parameters
    ----------
    out : str or Path
        Study folder (the file goes to its ``points/`` folder).
    index : int
        Index of the point in the study.
    point : dict
        The point's JSON-able result.
    config_sha256 : str
        Hash of the configuration the point was computed with.
    settings : dict
        What else decides the point (compared as JSON on resume).
    """
    atomic_write_json(point_path(out, index), dict(point, index=index, config_sha256=config_sha256,
                                                   settings=plain(settings)))


def kept_points(out: str | Path, config_sha256: Callable[[int], str], settings: dict, index_ok: bool,
                match: Callable[[int, dict], bool] = lambda i, p: True, flag: str = "--resume") -> dict[int, dict]:
    """The points of ``out`` a resume keeps (see the module's text).

    Parameters
    ----------
    out : str or Path
        Study folder.
    config_sha256 : callable
        ``config_sha256(index)``: the hash of the configuration the resumed study computes point
        ``index`` with.
    settings : dict
        What else decides a point (compared as JSON).
    index_ok : bool
        The index file was intact and matched the resumed definition.
    match : callable
        ``match(index, point)``: the point belongs at this index of the resumed study (e.g. the same
        swept value); points that do not are computed again.
    flag : str
        Flag named by errors.

    Returns
    -------
    dict of int to dict
        Point index to the kept point.
    """
    kept, unverified = {}, []
    settings = plain(settings)
    for i, p in sorted(read_points(out).items()):
        try:
            belongs = match(i, p)
        except (KeyError, TypeError, ValueError, IndexError):
            belongs = False
        if not belongs:
            continue
        stored = p.get("config_sha256")
        if stored is None:
            (kept.__setitem__(i, p) if index_ok else unverified.append(i))
            continue
        if stored != config_sha256(i) or p.get("settings") != settings:
            what = "configuration" if stored != config_sha256(i) else "settings"
            raise ConfigError(flag, f"'{out}': {POINTS_DIR}/{point_path(out, i).name} was computed for another "
                                    f"{what} (its config_sha256 or settings differ from this run's); resume with "
                                    "the same arguments or use a new folder")
        kept[i] = p
    if unverified:
        warnings.warn(f"{len(unverified)} point(s) in '{out}' carry no configuration hash and the index file is "
                      "damaged: they are computed again", stacklevel=2)
    return kept
