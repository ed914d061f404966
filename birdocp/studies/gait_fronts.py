"""Fronts of gait optima: the stability-power Pareto front (:func:`stability_pareto`, sequential or in
parallel chains through :mod:`birdocp.studies.pareto`) and the power curve over valid gaits
(:func:`valid_power_curve`); each point one :func:`birdocp.studies.gait.optimize_gait`. Importable from
:mod:`birdocp.studies.gait` too."""
from __future__ import annotations

import math

import numpy as np

from birdocp.bird.config import Config
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.studies.gait import optimize_gait
from birdocp.studies.power_curves import curve_optima

__all__ = ["stability_pareto", "valid_power_curve"]


def stability_pareto(cfg: Config | None, speed_mps: float, bounds, *, free: dict | None = None,
                     start: dict | None = None, x_guess=None, objective: str = "power",
                     steps_per_period: int | None = None, max_halvings: int = 4, progress=None,
                     executor=None, anchors=(), start_bound: float | None = None, **options) -> list[dict]:
    """The Pareto front of minimum ``objective`` in level flight at ``speed_mps`` against the bound R
    on every multiplier's modulus: one :func:`optimize_gait` per R in ``bounds`` (in the given order,
    normally from loose to tight), each started from the previous optimum (gait, amplitude and cycle).

    A failed point is retried from the last optimum with a smaller step: the bound halfway between the
    last successful R and the failed one is inserted first (at most ``max_halvings`` times in a row).
    Returns one row per bound tried (inserted ones included, ``"inserted": True``), each with
    ``bound``, ``success``, ``status``, ``objective_value``, ``largest_modulus``, ``free``,
    ``amplitude_deg``, ``x0``, ``iterations``, ``kkt_residual``, ``wall_s`` and the verification's
    ``power_difference_W``, ``validity``, ``valid`` and ``validity_constraints``. ``options`` go to
    :func:`optimize_gait` (e.g. ``valid=True``: the front over valid cycles).

    With an ``executor`` (:mod:`birdocp.engine.executors`: processes or Dask) the points are solved in
    parallel waves, each from its nearest solved neighbour (:func:`birdocp.studies.pareto.pareto_parallel`;
    ``anchors``: known solutions such as the most stable gait, ``start_bound``: the start's largest
    modulus); no halving then, one row per bound.

    Parameters
    ----------
    cfg : Config or None
        The configuration (None: the paper's reference case).
    speed_mps : float
        Mean forward speed held [m/s].
    bounds : sequence of float
        The bounds R on every multiplier's modulus, in the order tried.
    free : dict, optional
        Gait key -> (lo, hi) (default :data:`birdocp.studies.gait.DEFAULT_GAIT_FREE`).
    start : dict, optional
        Gait values of the first start.
    x_guess : array_like (4,), optional
        State at t = 0 of the start's level cycle, if known.
    objective : str
        The objective of :func:`optimize_gait`.
    steps_per_period : int, optional
        RK4 steps per period.
    max_halvings : int
        Inserted bounds in a row after failures.
    progress : callable, optional
        ``progress(text)``, one line per point.
    executor : Executor, optional
        Solve the points in parallel waves (processes or Dask), each from its nearest solved
        neighbour (:func:`birdocp.studies.pareto.pareto_parallel`); no halving then, one row per bound.
    anchors : sequence
        Known solutions to start points from (with ``executor``).
    start_bound : float, optional
        The start's largest modulus (with ``executor``).
    **options
        Passed to :func:`optimize_gait`.

    Returns
    -------
    list of dict
        One row per bound tried (inserted ones included, ``"inserted": True``), each with ``bound``,
        ``success``, ``status``, ``objective_value``, ``largest_modulus``, ``free``, ``amplitude_deg``,
        ``x0``, ``iterations``, ``kkt_residual``, ``wall_s`` and the verification's
        ``power_difference_W``, ``validity``, ``valid`` and ``validity_constraints``.
    """
    if executor is not None:
        from birdocp.studies.pareto import pareto_parallel

        return pareto_parallel(executor, optimize_gait, cfg, speed_mps, bounds, free=free, start=start, x_guess=x_guess,
                               start_bound=start_bound, anchors=anchors, objective=objective,
                               steps_per_period=steps_per_period, progress=progress, **options)
    return _pareto_sequential(cfg, speed_mps, bounds, free, start, x_guess, objective, steps_per_period,
                              max_halvings, progress, options)


def _pareto_sequential(cfg, speed_mps, bounds, free, start, x_guess, objective, steps_per_period, max_halvings,
                       progress, options) -> list[dict]:
    """:func:`stability_pareto` without an executor: each bound from the previous optimum, a failed
    one retried from halfway."""
    from birdocp.studies.pareto import pareto_row

    queue = [(float(R), False) for R in bounds]
    rows, last_R, halvings = [], None, 0
    while queue:
        R, inserted = queue[0]
        opt = optimize_gait(cfg, free, objective=objective, speed_mps=speed_mps, max_multiplier=R, start=start,
                            x_guess=x_guess, steps_per_period=steps_per_period, **options)
        row = pareto_row(R, opt, inserted)
        if progress:
            progress(f"Pareto R = {R:.5f}: {opt.status}, P {opt.objective_value:.5f}, |L1| "
                     f"{opt.largest_modulus:.5f}, {opt.iterations} iterations, "
                     f"{opt.wall_s.get('total', float('nan')):.1f} s")
        if opt.success:
            rows.append(row)
            queue.pop(0)
            start = dict(opt.free) | {AMPLITUDE_KEY: opt.amplitude_deg}
            x_guess, last_R, halvings = opt.x0, R, 0
        elif last_R is not None and halvings < max_halvings:
            rows.append(row)
            queue.insert(0, (0.5 * (last_R + R), True))
            halvings += 1
        else:
            rows.append(row)
            queue.pop(0)
            halvings = 0
    return rows


def valid_power_curve(executor, cfg, speeds, *, free=None, start=None, x_guess=None, start_speed=None,
                      progress=None, wave: int | None = None, **options) -> dict:
    """The power curve over valid gaits: at each speed the least-power level gait with every limit of
    ``[validity]`` a constraint (``optimize_gait(objective="power", valid=True)``), the speeds solved in
    parallel waves, each from its nearest solved speed (:func:`birdocp.studies.pareto.waves`).

    Parameters
    ----------
    executor : executor
        Runs the waves (:mod:`birdocp.engine.executors`).
    cfg : Config
        Configuration.
    speeds : sequence of float
        Mean forward speeds [m/s].
    free : dict, optional
        Free keys and bounds (default :data:`birdocp.studies.gait.DEFAULT_GAIT_FREE`).
    start, x_guess : optional
        A known solution's gait and cycle state at ``start_speed`` (default: the configured gait).
    start_speed : float, optional
        Speed of ``start`` [m/s].
    progress : callable, optional
        ``progress(text)`` after each speed.
    wave : int, optional
        Speeds solved at a time (default: the executor's worker count).
    **options
        Further keywords of :func:`optimize_gait`.

    Returns
    -------
    dict
        ``{"rows", "free", "minimum_power", "maximum_range", ...}`` as :func:`power_curve` (optima over
        the valid rows).
    """
    from birdocp.studies.pareto import power_point, waves

    options = {k: v for k, v in options.items() if k != "progress"} | {"valid": True}
    s0 = float(np.median(speeds)) if start_speed is None else float(start_speed)

    def job(U, nb):
        return {"optimize": optimize_gait, "cfg": cfg, "free": free, "speed_mps": float(U),
                "start": nb["start"] or None, "x_guess": nb["x_guess"], "options": options,
                "started_from": nb["label"]}

    def say(U, row):
        if progress:
            progress(f"valid power curve U = {U:.2f}: {row['status']}, P {row['objective_value']:.5f} W, valid "
                     f"{row['valid']}, {row['iterations']} iterations, {row['wall_s'].get('total', math.nan):.1f} s")
    rows = waves(executor, [float(U) for U in speeds], [(s0, None, start, x_guess)], job, power_point, say, wave)
    return {"rows": rows, "free": free} | curve_optima(rows)
