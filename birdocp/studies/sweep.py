"""Families of trims (or level-flight solves) along one parameter, warm-started from neighbour to neighbour.

``sweep(cfg, key, values)`` solves one limit cycle per value of ``key`` (any
:data:`birdocp.bird.config.PARAM_NAMES` key or an alias such as ``amplitude``), in the given order; each
point starts from the last *successful* point's shooting points (``warm=True``). With ``level=True``
each point is a :func:`birdocp.studies.level.level` solve (by default the flapping amplitude free, mean
vertical speed 0) with ``key`` swept.

Run folder (``out_dir``), written as the sweep goes (every file atomically)::

    config.toml            the base configuration
    points/point-0003.json one file per solved point, written as soon as it is solved: the table row,
                           the full trim result, the parameter vector (enough to warm-start from),
                           ``config_sha256`` of the point's configuration and its ``settings``
    sweep.json             the sweep definition and all rows so far (rewritten after each point)
    sweep.csv              the same rows as a CSV table
    result.json            written last (with provenance): the sweep is complete

``resume=True`` reads the point files of ``out_dir`` and solves only the missing points, warm-starting
from the points on disk, so the table is the one of an uninterrupted run (up to wall times). A resume
with another definition than sweep.json's is refused, and every point's own configuration hash is
compared with its configuration in the resumed sweep (also when sweep.json is truncated or damaged):
a point of another configuration is refused, never reported (:mod:`birdocp.io.resume`, the mechanism
``continue`` resumes with too).
A failed point is recorded (``success`` false) and the sweep goes on.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from birdocp.bird.config import Config, ConfigError, to_dict, with_values
from birdocp.bird.validity import VALIDITY_COLUMNS, validity_columns
from birdocp.io.files import atomic_write_json, atomic_write_text, to_jsonable
from birdocp.io import resume as resume_io
from birdocp.io.inputs import read_json_file
from birdocp.io.provenance import config_hash
from birdocp.io.progress import progress_bar
from birdocp.studies.level import AMPLITUDE_KEY, resolve_key

__all__ = ["sweep", "sweep_values", "read_points", "CSV_COLUMNS", "row_of", "grid_sweep", "GRID_COLUMNS",
           "SIX_DOF_COLUMNS"]

N_MULT = 4
CSV_COLUMNS = (
    ["index", "key", "value", "success", "status", "stable"]
    + [f"multiplier{k}_{part}" for k in range(N_MULT) for part in ("re", "im")]
    + [f"modulus{k}" for k in range(N_MULT)]
    + ["mean_forward_speed_mps", "mean_vertical_speed_mps", "mean_speed_norm_mps", "flight_path_angle_deg",
       "amplitude_deg", "free_key", "free_value", "iterations", "max_residual", "wall_s", "warm_from"]
    + list(VALIDITY_COLUMNS)
)

SIX_DOF_COLUMNS = (["lateral_stable"] + [f"lateral_modulus{k}" for k in range(4)]
                   + [f"longitudinal_modulus{k}" for k in range(4)] + ["spiral_modulus", "coupling_max"])
"""Columns added to the table of a six-degree-of-freedom family (``model.degrees_of_freedom = 6``):
the lateral verdict (the heading's multiplier 1 excluded), the moduli of the lateral (v, p, r, phi) and
longitudinal (u, w, q, theta) multipliers (largest first), the spiral mode's modulus and the largest
longitudinal-lateral coupling entry of the monodromy. The rows' JSON also hold ``multipliers`` (all
nine), ``lateral_multipliers``, ``longitudinal_multipliers``, ``heading_multiplier`` and the labelled
``lateral_modes``."""


MAX_SWEEP_POINTS = 10000
"""At most this many values in one sweep (a larger count is almost always a step in the wrong unit)."""


def sweep_values(start: float, stop: float, step: float) -> list[float]:
    """``start, start +- step, ...`` and ``stop`` itself (direction from the signs; step > 0).

    The end is always included: when ``|stop - start|`` is not a multiple of ``step`` the last
    interval is shorter than ``step``. A step larger than a non-empty range is refused
    (:class:`ConfigError` on ``--by``): it would solve the two ends only, which is rarely what was
    meant (e.g. a step in centimetres for a parameter in metres).

    Parameters
    ----------
    start, stop, step : float
        Range and step (step > 0).

    Returns
    -------
    list of float
    """
    for name, v in (("--from", start), ("--to", stop), ("--by", step)):
        if not math.isfinite(v):
            raise ConfigError(name, f"must be finite, got {v!r}")
    if not step > 0:
        raise ConfigError("--by", f"must be positive, got {step!r}")
    span = abs(stop - start)
    if span > 0 and step > span * (1 + 1e-9):
        raise ConfigError("--by", f"{step:g} is larger than the range {start:g} .. {stop:g} (width {span:g}); "
                                    f"give a step <= {span:g}")
    n = int(math.floor(span / step + 1e-9))
    if n + 1 > MAX_SWEEP_POINTS:
        raise ConfigError("--by", f"{n + 1} points from {start:g} to {stop:g}; at most {MAX_SWEEP_POINTS}: "
                                    "use a larger step")
    sign = 1.0 if stop >= start else -1.0
    values = [float(np.round(start + sign * k * step, 12)) for k in range(n + 1)]
    if abs(values[-1] - stop) > 1e-9 * max(step, abs(stop)):
        values.append(float(stop))  # the end is inclusive, also off the step grid
    return values


@dataclass
class _WarmStart:
    """The part of a OrbitResult the engine reads for a warm start (rebuilt from a point file)."""

    p: np.ndarray
    shooting_points: np.ndarray
    x0: np.ndarray


def _warm_from_point(point: dict):
    r = point.get("result") or {}
    try:
        return _WarmStart(np.asarray(point["p"], float), np.asarray(r["shooting_points"], float),
                          np.asarray(r["x0"], float))
    except (KeyError, TypeError, ValueError):
        return None


def _pair_list(v):
    return v if isinstance(v, list) else []


def row_of(index: int, key: str, value: float, d: dict, free_key: str | None, warm_from) -> dict:
    """The table row of a solved point (``d``: TrimResult.to_dict()): the :data:`CSV_COLUMNS` (the
    validity's verdict and key numbers flat, :data:`birdocp.bird.validity.VALIDITY_COLUMNS`) and the
    object ``validity`` (``valid``, ``reasons`` and the measured numbers).

    Parameters
    ----------
    index : int
        Index of the point.
    key : str
        Swept key.
    value : float
        Swept value.
    d : dict
        ``TrimResult.to_dict()``.
    free_key : str or None
        Key solved with a level condition.
    warm_from : int or None
        Index of the point it was warm-started from.

    Returns
    -------
    dict
    """
    mults = _pair_list(d.get("multipliers"))
    moduli = _pair_list(d.get("moduli"))
    U, W = d.get("mean_forward_speed_mps"), d.get("mean_vertical_speed_mps")
    row = {"index": index, "key": key, "value": value, "success": bool(d.get("success")),
           "status": d.get("status"), "stable": d.get("stable")}
    for k in range(N_MULT):
        m = mults[k] if k < len(mults) else [None, None]
        row[f"multiplier{k}_re"], row[f"multiplier{k}_im"] = m[0], m[1]
    for k in range(N_MULT):
        row[f"modulus{k}"] = moduli[k] if k < len(moduli) else None
    row["mean_forward_speed_mps"] = U
    row["mean_vertical_speed_mps"] = W
    row["mean_speed_norm_mps"] = math.hypot(U, W) if U is not None and W is not None else None
    row["flight_path_angle_deg"] = d.get("flight_path_angle_deg")
    row["amplitude_deg"] = d.get("amplitude_deg")
    fv = d.get("free_values") or {}
    row["free_key"] = free_key
    row["free_value"] = fv.get(free_key) if free_key else None
    row["iterations"] = d.get("iterations")
    row["max_residual"] = d.get("max_residual")
    row["wall_s"] = (d.get("wall_s") or {}).get("total")
    row["warm_from"] = warm_from
    v = d.get("validity") or {}
    row.update(validity_columns(v))
    row["validity"] = {k: x for k, x in v.items() if k != "thresholds"} or None
    if "lateral_multipliers" in d:
        row.update(_six_dof_columns(d))
    return row


def _six_dof_columns(d: dict) -> dict:
    """The :data:`SIX_DOF_COLUMNS` and the multiplier lists of a 6-DOF result's JSON ``d``."""
    out = {k: d.get(k) for k in ("lateral_stable", "coupling_max") + _SIX_DOF_LISTS}
    for name in ("lateral", "longitudinal"):
        mods = [math.hypot(*m) for m in _pair_list(d.get(f"{name}_multipliers"))]
        for k in range(4):
            out[f"{name}_modulus{k}"] = mods[k] if k < len(mods) else None
    spiral = [m for m in d.get("lateral_modes") or [] if m.get("label") == "spiral"]
    out["spiral_modulus"] = math.hypot(*spiral[0]["multiplier"]) if spiral else None
    return out


_SIX_DOF_LISTS = ("multipliers", "lateral_multipliers", "longitudinal_multipliers", "heading_multiplier",
                  "lateral_modes")


def _columns_of(cfg: Config, base=None) -> list[str]:
    """The CSV columns of a family of ``cfg`` (the 6-DOF columns appended with six degrees of freedom)."""
    base = list(CSV_COLUMNS if base is None else base)
    return base + SIX_DOF_COLUMNS if cfg.model.degrees_of_freedom == 6 else base


def _csv_text(rows: list[dict], columns=None) -> str:
    """The table as CSV (floats written with repr, so they read back exactly; None as empty)."""
    columns = CSV_COLUMNS if columns is None else columns
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else (repr(r[k]) if isinstance(r[k], float) else r[k]))
                    for k in columns})
    return buf.getvalue()


def read_points(out_dir: str | Path) -> dict[int, dict]:
    """Point files of a sweep folder by index (:func:`birdocp.io.resume.read_points`: unreadable files
    are ignored: they will be re-solved).

    Parameters
    ----------
    out_dir : str or Path
        Sweep folder.

    Returns
    -------
    dict of int to dict
    """
    return resume_io.read_points(out_dir)


def _point_settings(spec: dict) -> dict:
    """What besides its configuration decides a point's result (stored in every point file)."""
    return {k: spec[k] for k in ("level", "level_options", "method_over")}


class _Progress:
    """The sweep's progress bar (:func:`birdocp.io.progress.progress_bar`): one step per point."""

    def __init__(self, total: int, enabled: bool, label: str):
        self.bar = progress_bar(total, label, quiet=not enabled)
        self.total, self.done = total, 0

    def show(self, done: int, text: str, solved_now: bool = False):
        if done > self.done:
            self.bar.update(done - self.done)
            self.done = done
        self.bar.set_postfix_str(text)
        if done >= self.total:
            self.bar.close()


def sweep(cfg: Config | None, key: str, values: Sequence[float], *, level: bool = False, warm: bool = True,
          out_dir: str | Path | None = None, resume: bool = False, progress: bool = True,
          level_options: dict | None = None, compiled: bool = False, **method_over) -> list[dict]:
    """Solve one limit cycle per value of ``key``; returns the table rows (see :data:`CSV_COLUMNS`).

    Parameters
    ----------
    cfg : Config or None
        The configuration (None: the paper's reference case).
    key : str
        The swept parameter: a dotted key of :data:`PARAM_NAMES` or an alias (``amplitude``,
        ``root_ahead_m``).
    values : sequence of float
        The values of ``key``, solved in this order (:func:`sweep_values` makes an evenly spaced list).
    level : bool
        Each point a :func:`birdocp.studies.level.level` solve (``level_options`` passed on: ``free``,
        ``bounds``, ``climb_rate_mps``, ``constrain``, ``target``).
    warm : bool
        Warm-start each point from the last successful one (else from the config's guess).
    out_dir : str or Path, optional
        Run folder to write as the sweep goes (None: nothing written).
    resume : bool
        Reuse the points found in ``out_dir`` (same key, values and configuration).
    progress : bool
        Draw a progress bar on stderr when it is a terminal.
    level_options : dict, optional
        Keyword arguments of :func:`~birdocp.studies.level.level` for ``level=True``.
    compiled : bool
        Solve with the RHS and data compiled to C (:func:`birdocp.studies.trim.solver_ode`; the same
        numbers, faster).
    **method_over
        Overrides of :class:`~birdocp.engine.method.OrbitMethod`.

    Returns
    -------
    list of dict
        One row per value (the columns of :data:`CSV_COLUMNS`, with the point's validity).
    """
    cfg = cfg or Config()
    key = resolve_key(key, "key")
    values = _checked_values(values)
    level_options = dict(level_options or {})
    free_key = resolve_key(level_options.get("free", AMPLITUDE_KEY), "free") if level else None
    if level and free_key == key:
        raise ConfigError("key", f"'{key}' is the free parameter of the level-flight solve; sweep another "
                                 "parameter (or sweep without --level)")
    cfgs = [with_values(cfg, {key: v}) for v in values]  # validates every value before solving
    if cfg.model.degrees_of_freedom == 6 and level:
        from birdocp.studies.lateral_options import level_keywords

        level_keywords(level_options)  # refused before anything is written

    out = Path(out_dir) if out_dir is not None else None
    spec = {"key": key, "values": values, "level": bool(level), "warm": bool(warm),
            "level_options": to_jsonable(level_options), "method_over": to_jsonable(method_over),
            "config": to_dict(cfg)}
    done = _claim_sweep_folder(out, spec, cfg, cfgs, resume) if out is not None else {}
    rows: list[dict | None] = [done[i]["row"] if i in done else None for i in range(len(values))]
    bar = _Progress(len(values), progress, f"sweep {key}" + (" (level)" if level else ""))
    solve = _point_solver(level, level_options, compiled, method_over)
    _flush_sweep(out, spec, rows, len(values), _columns_of(cfg))
    last_ok = None  # (index, warm start object)
    for i, (v, cfg_i) in enumerate(zip(values, cfgs)):
        if i in done:
            ws = _warm_from_point(done[i]) if done[i]["row"].get("success") else None
            last_ok = (i, ws) if ws is not None else last_ok
            bar.show(i + 1, f"{v:g} (on disk)")
            continue
        bar.show(i, f"solving {v:g}")
        warm_from = last_ok if (warm and last_ok is not None) else (None, None)
        res, row = solve(cfg_i, i, key, v, free_key, warm_from)
        rows[i] = row
        last_ok = (i, res.cycle) if res.success else last_ok
        if out is not None:
            point = {"row": row, "p": [float(x) for x in np.asarray(res.cycle.p)], "result": res.result}
            resume_io.write_point(out, i, point, config_hash(cfg_i), _point_settings(spec))
        _flush_sweep(out, spec, rows, len(values), _columns_of(cfg))
        bar.show(i + 1, f"{v:g} {'ok' if res.success else 'FAILED'} {row['iterations']} it "
                        f"{row['wall_s']:.1f} s", solved_now=True)
    return [r for r in rows if r is not None]


def _checked_values(values) -> list[float]:
    values = [float(v) for v in values]
    if not values:
        raise ConfigError("values", "no values to sweep")
    for v in values:
        if not math.isfinite(v):
            raise ConfigError("values", f"must be finite, got {v!r}")
    return values


def _claim_sweep_folder(out: Path, spec: dict, cfg: Config, cfgs: list, resume: bool) -> dict[int, dict]:
    """Create ``out`` (config.toml) and return the points kept from an earlier run (``resume``); a
    folder that holds a sweep without ``resume`` is a ConfigError."""
    values = spec["values"]
    out.mkdir(parents=True, exist_ok=True)
    old, damaged = resume_io.read_index(out / "sweep.json")
    done: dict[int, dict] = {}
    if resume:
        if old is not None:
            resume_io.check_index(old, spec, out, "sweep")
        done = resume_io.kept_points(out, lambda i: config_hash(cfgs[i]), _point_settings(spec), old is not None,
                                     match=lambda i, p: i < len(values) and p["row"].get("value") == values[i])
    elif old is not None or damaged or read_points(out):
        raise ConfigError("--out", f"'{out}' already holds a sweep; pass resume=True (--resume) or a new folder")
    from birdocp.bird.config import dumps
    atomic_write_text(out / "config.toml", dumps(cfg))
    return done


def _flush_sweep(out: Path | None, spec: dict, rows: list, n: int, columns=None) -> None:
    """sweep.json and sweep.csv (``columns``, default :data:`CSV_COLUMNS`) with the rows solved so far."""
    if out is None:
        return
    table = [r for r in rows if r is not None]
    atomic_write_json(out / "sweep.json", dict(spec, points=table, complete=len(table) == n))
    atomic_write_text(out / "sweep.csv", _csv_text(table, columns))


@dataclass
class _Solved:
    """One solved point: its verdict, its cycle (the next point's warm start) and its result dict."""

    success: bool
    cycle: object
    result: dict


def _point_solver(level: bool, level_options: dict, compiled: bool, method_over: dict):
    """``solve(cfg_i, i, key, v, free_key, (warm_from, warm_start)) -> (_Solved, row)``: one point
    of a sweep, a trim or a level solve, timed."""
    from birdocp.studies.level import level as level_solve  # the model and the engine: after the input checks
    from birdocp.studies.trim import trim

    def solve(cfg_i, i, key, v, free_key, warm):
        warm_from, ws = warm
        t = time.perf_counter()
        if cfg_i.model.degrees_of_freedom == 6:  # the 6-DOF trim or level solve (birdocp.studies.lateral)
            from birdocp.studies.lateral import solve_point

            res = solve_point(cfg_i, level=level, level_options=level_options, warm_start=ws, **method_over)
        elif level:
            res = level_solve(cfg_i, warm_start=ws, compiled=compiled, **level_options, **method_over)
        else:
            res = trim(cfg_i, warm_start=ws, compiled=compiled, **method_over)
        d = res.to_dict()
        d.setdefault("wall_s", {})["total"] = time.perf_counter() - t
        return _Solved(bool(res.success), res.cycle, d), row_of(i, key, v, d, free_key, warm_from)

    return solve


# ----------------------------------------------------------------------------------------------
# Grids of lines through an executor (serial, local processes, Dask)

GRID_COLUMNS = ["row", "row_key", "row_value"] + [c for c in CSV_COLUMNS if c != "wall_s"]


def _grid_row(job: dict) -> dict:
    """One row of a grid: a warm-started line over ``key`` at ``row_key = row_value`` (run by an
    executor, possibly in another process or on another machine: everything comes in ``job``)."""
    from birdocp.bird.config import from_dict

    cfg = with_values(from_dict(job["config"]), {job["row_key"]: job["row_value"]})
    t = time.perf_counter()
    rows = sweep(cfg, job["key"], job["values"], level=job["level"], warm=job["warm"], out_dir=None,
                 progress=False, level_options=job["level_options"], compiled=job.get("compiled", False),
                 **job["method_over"])
    return {"row": job["row"], "rows": rows, "wall_s": time.perf_counter() - t}


def _row_path(out: Path, row: int) -> Path:
    return out / "rows" / f"row-{row:04d}.json"


def grid_sweep(cfg: Config | None, key: str, values: Sequence[float], row_key: str, row_values: Sequence[float], *,
               executor=None, level: bool = False, warm: bool = True, out_dir: str | Path | None = None,
               resume: bool = False, level_options: dict | None = None, compiled: bool = False,
               **method_over) -> list[dict]:
    """A grid ``row_key x key``: one warm-started line over ``values`` of ``key`` per value of
    ``row_key``, the rows independent jobs run by ``executor``.

    Written to ``out_dir``: ``grid.json`` (the definition) at the start; ``rows/row-0003.json`` as each
    row finishes (so an interrupted grid keeps its finished rows: ``resume=True`` solves only the
    missing ones); when all rows are done ``grid.json`` (definition + rows, ``complete: true``),
    ``grid.csv``, and ``timing.json`` (executor and wall times). ``grid.json`` and ``grid.csv`` hold no
    wall times, so they do not depend on the executor.

    Parameters
    ----------
    cfg : Config or None
        The configuration (None: the paper's reference case).
    key : str
        The parameter along each line (as in :func:`sweep`).
    values : sequence of float
        Its values.
    row_key : str
        The parameter that changes from row to row.
    row_values : sequence of float
        Its values, one line each.
    executor : Executor, optional
        Runs the rows (:func:`birdocp.engine.executors.get_executor`; default serial).
    level : bool
        Each point a level-flight solve.
    warm : bool
        Warm-start each point from its neighbour on the line.
    out_dir : str or Path, optional
        The run folder (None: nothing written).
    resume : bool
        Keep the finished rows found in ``out_dir``.
    level_options : dict, optional
        Keyword arguments of :func:`~birdocp.studies.level.level` for ``level=True``.
    compiled : bool
        Solve with the RHS and data compiled to C in every job (the same numbers, faster).
    **method_over
        Overrides of :class:`~birdocp.engine.method.OrbitMethod`.

    Returns
    -------
    list of dict
        The table rows (``GRID_COLUMNS``), row after row.
    """
    from birdocp.engine.executors import SerialExecutor

    cfg = cfg or Config()
    key = resolve_key(key, "key")
    row_key = resolve_key(row_key, "rows")
    if row_key == key:
        raise ConfigError("rows", "the row parameter must differ from the swept parameter")
    values, row_values = _grid_values(cfg, key, values, row_key, row_values)
    executor = executor or SerialExecutor()
    base = {"config": to_dict(cfg), "key": key, "values": values, "row_key": row_key, "level": bool(level),
            "warm": bool(warm), "level_options": dict(level_options or {}), "method_over": dict(method_over)}
    spec = to_jsonable(dict({k: base[k] for k in ("key", "values", "row_key", "level", "warm", "level_options",
                                                  "method_over", "config")}, row_values=row_values))
    jobs = [dict(base, row=i, row_value=v, compiled=bool(compiled)) for i, v in enumerate(row_values)]
    out = Path(out_dir) if out_dir is not None else None
    done = _claim_grid_folder(out, spec, resume) if out is not None else {}
    t = time.perf_counter()
    fresh = _run_rows(executor, [j for j in jobs if j["row"] not in done], out)
    wall = time.perf_counter() - t
    results = sorted(list(done.values()) + list(fresh), key=lambda r: r["row"])
    table = _grid_table(results, row_key, row_values)
    if out is not None:
        atomic_write_json(out / "grid.json", dict(spec, points=table, complete=True))
        atomic_write_text(out / "grid.csv", _csv_text(table, _columns_of(cfg, GRID_COLUMNS)))
        atomic_write_json(out / "timing.json", {**executor.describe(), "wall_s": wall,
                                                "row_wall_s": [r["wall_s"] for r in results],
                                                "rows_from_disk": sorted(done)})
    return table


def _run_rows(executor, todo: list[dict], out: Path | None) -> list[dict]:
    """The rows of ``todo`` run by ``executor``, each written to ``out/rows/`` as it finishes."""
    def keep(i: int, res: dict) -> None:
        if out is not None:
            atomic_write_json(_row_path(out, res["row"]), res)

    return executor.map(_grid_row, todo, on_result=keep) if todo else []


def _grid_values(cfg: Config, key: str, values, row_key: str, row_values) -> tuple[list[float], list[float]]:
    """Both value lists as floats, each value checked in ``cfg`` before any job starts."""
    values = [float(v) for v in values]
    row_values = [float(v) for v in row_values]
    if not values or not row_values:
        raise ConfigError("values", "no values to sweep")
    for v in row_values:
        with_values(cfg, {row_key: v})
    for v in values:
        with_values(cfg, {key: v})
    return values, row_values


def _claim_grid_folder(out: Path, spec: dict, resume: bool) -> dict[int, dict]:
    """Create ``out`` (grid.json, the definition) and return the finished rows of an earlier run
    (``resume``); a folder that holds a grid without ``resume`` is a ConfigError."""
    out.mkdir(parents=True, exist_ok=True)
    old, _ = resume_io.read_index(out / "grid.json")  # a damaged grid.json: every row solved again
    if old is not None and not resume:
        raise ConfigError("--out", f"'{out}' already holds a grid; pass resume=True (--resume) or a new folder")
    done: dict[int, dict] = {}
    if old is None:
        atomic_write_json(out / "grid.json", dict(spec, points=[], complete=False))
        return done
    resume_io.check_index(old, spec, out, "grid")
    for f in sorted((out / "rows").glob("row-*.json")) if (out / "rows").is_dir() else []:
        with contextlib.suppress(ConfigError, ValueError, KeyError, TypeError):
            r = read_json_file(f, "--resume")
            done[int(r["row"])] = r
    return done


def _grid_table(results: list[dict], row_key: str, row_values: list[float]) -> list[dict]:
    """The grid's table (:data:`GRID_COLUMNS` and each point's validity), row after row."""
    table = []
    for res in results:
        for r in res["rows"]:
            row = {"row": res["row"], "row_key": row_key, "row_value": row_values[res["row"]]}
            row.update({c: r.get(c) for c in CSV_COLUMNS if c != "wall_s"})
            row["validity"] = r.get("validity")
            row.update({k: r[k] for k in SIX_DOF_COLUMNS + list(_SIX_DOF_LISTS) if k in r})  # 6 DOF
            table.append(row)
    return table
