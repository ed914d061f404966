"""The stability-power Pareto front with its points solved in parallel (through an
:class:`birdocp.engine.executors.Executor`: local processes or a Dask cluster).

The points of the front (least ``objective`` with every multiplier inside the circle of radius R,
one per bound R) are independent NLPs; what links them is only the start. The bounds are split into
as many contiguous *chains* as the executor has workers (:func:`chains`); a worker traces its chain
away from the known solution nearest to it, each point from the one before (gait, amplitude and
cycle state), with no waiting for the other workers: the known ends are the unconstrained optimum
(``start``, at its own largest modulus ``start_bound``) and any ``anchors`` (e.g. the most stable
gait). Which point starts from which is fixed before any is solved, so the result does not depend
on timing. A point that fails is tried again in *waves* (:func:`waves`): each from its nearest
solved neighbour. Every point starting from a solved optimum is a warm IPOPT start
(:data:`birdocp.studies.gait_validity.WARM_IPOPT`: small barrier parameter, no push off the bounds;
``warm=False``: IPOPT's defaults).

Each job is one :func:`birdocp.studies.gait.optimize_gait` call in a worker (passed in as a
picklable module-level function: this module does not import the gait module, which calls it), so a job's result does not depend on which worker ran it; rows as :func:`birdocp.studies.gait_fronts.stability_pareto`'s, plus
``started_from`` (the bound of the neighbour it started from; None for the unconstrained start).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["pareto_parallel", "pareto_row", "solve_point", "waves", "chains", "run_chain", "power_point"]

from birdocp.bird.keys import AMPLITUDE_KEY  # noqa: E402


def pareto_row(R: float, opt, inserted: bool = False) -> dict:
    """The row of the front for one :class:`birdocp.studies.gait.GaitOptimum` at bound ``R``.

    Parameters
    ----------
    R : float
        Bound on the largest multiplier modulus.
    opt : GaitOptimum
        The optimum.
    inserted : bool
        The row was inserted between the requested bounds.

    Returns
    -------
    dict
    """
    return {"bound": R, "inserted": inserted, "success": bool(opt.success), "status": opt.status,
            "objective_value": opt.objective_value, "largest_modulus": opt.largest_modulus,
            "free": dict(opt.free), "amplitude_deg": opt.amplitude_deg,
            "x0": np.asarray(opt.x0, float).tolist(), "iterations": opt.iterations,
            "kkt_residual": opt.kkt_residual, "constraint_violation": opt.constraint_violation,
            "mean_forward_speed_mps": opt.mean_forward_speed_mps, "wall_s": dict(opt.wall_s),
            "verification_power_difference_W": opt.verification.get("power_difference_W"),
            "verification_trim_success": opt.verification.get("trim_success"),
            "validity": opt.validity, "valid": None if opt.validity is None else bool(opt.validity.get("valid")),
            "validity_constraints": opt.validity_constraints}


def solve_point(job: dict) -> dict:
    """One point of the front (a worker's job: picklable dict in, row out); ``job["warm"]`` and a
    solved neighbour (``started_from`` not None): a warm IPOPT start.

    Parameters
    ----------
    job : dict
        ``optimize``, ``cfg``, ``free``, ``objective``, ``speed_mps``, ``bound``, ``start``, ``x_guess``,
        ``steps_per_period``, ``options``, ``started_from`` and optionally ``warm``.

    Returns
    -------
    dict
        Row of :func:`pareto_row`.
    """
    options = dict(job["options"])
    if job.get("warm") and job["started_from"] is not None:
        from birdocp.studies.gait_validity import WARM_IPOPT

        options["ipopt_options"] = WARM_IPOPT | dict(options.get("ipopt_options") or {})
    opt = job["optimize"](job["cfg"], job["free"], objective=job["objective"], speed_mps=job["speed_mps"],
                          max_multiplier=job["bound"], start=job["start"], x_guess=job["x_guess"],
                          steps_per_period=job["steps_per_period"], **options)
    return pareto_row(job["bound"], opt) | {"started_from": job["started_from"]}


def pareto_parallel(executor, optimize, cfg, speed_mps: float, bounds, *, free=None, start=None, x_guess=None,
                    start_bound: float | None = None, anchors=(), objective: str = "power",
                    steps_per_period=None, progress=None, wave: int | None = None, warm: bool = True,
                    **options) -> list[dict]:
    """The front at the ``bounds`` R (see the module), solved in one chain of bounds per worker.

    Parameters
    ----------
    executor : executor
        Its ``map`` solves a wave.
    optimize : callable
        The optimiser (:func:`birdocp.studies.gait.optimize_gait`, module level: picklable).
    cfg : Config
        Configuration.
    speed_mps : float
        Mean forward speed [m/s].
    bounds : sequence of float
        Bounds R on the largest multiplier modulus.
    free : dict, optional
        Free keys and bounds.
    start, x_guess : optional
        The unconstrained optimum's gait and cycle state.
    start_bound : float, optional
        Largest modulus of ``start`` (default: above every bound).
    anchors : sequence of dict
        Rows of known solutions (``bound``, ``free``, ``amplitude_deg``, ``x0``).
    objective : str
        Objective of ``optimize``.
    steps_per_period : int, optional
        RK4 steps per period.
    progress : callable, optional
        ``progress(text)`` after each point.
    wave : int, optional
        Points solved at a time (default: the executor's worker count, else 2).
    warm : bool
        Warm IPOPT starts from the solved neighbour (see the module).
    **options
        Further keywords of ``optimize``.

    Returns
    -------
    list of dict
        One row per bound, in the order of ``bounds``.
    """
    options = {k: v for k, v in options.items() if k != "progress"}
    top = max(bounds) + 1.0 if start_bound is None else float(start_bound)
    seeds = [(top, None, start, x_guess)] + [(float(a["bound"]), float(a["bound"]), _gait(a), a["x0"]) for a in anchors]

    def job(R, nb):
        return {"optimize": optimize, "cfg": cfg, "free": free, "objective": objective, "speed_mps": speed_mps, "bound": R,
                "start": nb["start"] or None, "x_guess": nb["x_guess"], "steps_per_period": steps_per_period,
                "options": options, "started_from": nb["label"], "warm": bool(warm)}

    def say(R, row):
        if progress:
            progress(f"Pareto R = {R:.5f} (from {row['started_from']}): {row['status']}, objective "
                     f"{row['objective_value']:.5f}, |L1| {row['largest_modulus']:.5f}, valid {row['valid']}, "
                     f"{row['iterations']} iterations, {row['wall_s'].get('total', math.nan):.1f} s")
    return chains(executor, [float(R) for R in bounds], seeds, job, solve_point, say, wave)


def _gait(row: dict) -> dict:
    return dict(row["free"]) | {AMPLITUDE_KEY: float(row["amplitude_deg"])}


def waves(executor, values, seeds, make_job, fn, report=None, wave: int | None = None) -> list[dict]:
    """Solve one job per value of a scalar (a bound, a speed) in parallel waves, each from its nearest
    solved neighbour (see the module).

    Parameters
    ----------
    executor : executor
        Its ``map`` solves a wave.
    values : sequence of float
        The values.
    seeds : sequence of tuple
        Known solutions ``(value, label, start gait, x_guess)``.
    make_job : callable
        ``make_job(value, neighbour)`` (neighbour: ``{"label", "start", "x_guess"}``): the job of ``fn``.
    fn : callable
        ``fn(job)``: a row with ``success``, ``free``, ``amplitude_deg`` and ``x0``.
    report : callable, optional
        ``report(text)`` after each row.
    wave : int, optional
        Jobs at a time.

    Returns
    -------
    list of dict
        The rows in the order of ``values``.
    """
    n = int(wave or getattr(executor, "jobs", None) or 2)
    solved = [{"key": float(v), "label": lab, "start": dict(st or {}),
               "x_guess": None if x is None else np.asarray(x, float)} for v, lab, st, x in seeds]
    pending, rows, tried = list(values), {}, {}
    while pending:
        pending.sort(key=lambda v: abs(_nearest(v, solved)["key"] - v))
        batch = pending[:n]
        jobs = []
        for v in batch:
            nb = _nearest(v, solved)
            tried.setdefault(v, []).append(nb["key"])
            jobs.append(make_job(v, nb))
        for v, row in zip(batch, executor.map(fn, jobs)):
            rows[v] = row
            if report:
                report(v, row)
            if row["success"]:
                solved.append({"key": v, "label": v, "start": _gait(row), "x_guess": np.asarray(row["x0"], float)})
        for v in batch:
            pending.remove(v)
            if not rows[v]["success"] and _nearest(v, solved)["key"] not in tried[v]:
                pending.append(v)  # a nearer neighbour was solved since: once more from it
    return [rows[v] for v in values]


def chains(executor, values, seeds, make_job, fn, report=None, n: int | None = None) -> list[dict]:
    """As :func:`waves`, but the sorted values are split into ``n`` (default: the executor's worker
    count, else 2) contiguous chains, each traced by one job (:func:`run_chain`) from the end nearest
    to a seed, away from it, every point from the one before; no job waits for another. Values whose
    point failed are then tried again by :func:`waves` from every point solved.

    Parameters
    ----------
    executor : executor
        Its ``map`` runs the chains (one job each).
    values : sequence of float
        The scalar of each point (a bound, a speed).
    seeds : sequence of tuple
        Known solutions ``(value, label, start gait, x_guess)``.
    make_job : callable
        ``make_job(value, neighbour)``: the job of ``fn`` (neighbour: ``{"label", "start", "x_guess"}``).
    fn : callable
        ``fn(job)``: a row with ``success``, ``free``, ``amplitude_deg`` and ``x0`` (module level: picklable).
    report : callable, optional
        ``report(value, row)`` for each row.
    n : int, optional
        Number of chains (default: the executor's worker count, else 2).

    Returns
    -------
    list of dict
        The rows in the order of ``values``.
    """
    n = max(1, min(int(n or getattr(executor, "jobs", None) or 2), len(values)))
    order = sorted(float(v) for v in values)
    cuts = np.linspace(0, len(order), n + 1).round().astype(int)
    solved = [{"key": float(v), "label": lab, "start": dict(st or {}),
               "x_guess": None if x is None else np.asarray(x, float)} for v, lab, st, x in seeds]
    plans = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        seg = order[a:b]
        lo, hi = _nearest(seg[0], solved), _nearest(seg[-1], solved)
        seg, nb = (seg, lo) if abs(lo["key"] - seg[0]) <= abs(hi["key"] - seg[-1]) else (seg[::-1], hi)
        plans.append({"fn": fn, "values": seg, "first": make_job(seg[0], nb)})
    rows = {}
    for plan, out in zip(plans, executor.map(run_chain, plans)):
        for v, row in zip(plan["values"], out):
            rows[v] = row
            if report:
                report(v, row)
    failed = [v for v in order if not rows[v]["success"]]
    if failed:
        done = [(v, v, _gait(r), r["x0"]) for v, r in rows.items() if r["success"]]
        for v, row in zip(failed, waves(executor, failed, list(seeds) + done, make_job, fn, report, n)):
            rows[v] = row
    return [rows[float(v)] for v in values]


def run_chain(plan: dict) -> list[dict]:
    """One chain of :func:`chains` (a worker's job): ``plan["fn"]`` on ``plan["first"]``, then on the
    same job for each further value of ``plan["values"]`` (the job's ``bound``/``speed_mps``
    key), started from the last successful row (``start``, ``x_guess``, ``started_from``).

    Parameters
    ----------
    plan : dict
        ``fn`` (the point solver), ``values`` (in tracing order) and ``first`` (the first value's job).

    Returns
    -------
    list of dict
        One row per value, in the order of ``plan["values"]``.
    """
    fn, values, job = plan["fn"], plan["values"], dict(plan["first"])
    key = "bound" if "bound" in job else "speed_mps"
    rows = []
    for i, v in enumerate(values):
        job[key] = v
        row = fn(job)
        rows.append(row)
        if row["success"]:
            job |= {"start": _gait(row), "x_guess": np.asarray(row["x0"], float), "started_from": v}
    return rows


def _nearest(v: float, solved: list) -> dict:
    return min(solved, key=lambda s: abs(s["key"] - v))


def power_point(job: dict) -> dict:
    """One speed of :func:`birdocp.studies.gait_fronts.valid_power_curve` (a worker's job): the least-power
    gait at ``job["speed_mps"]`` by ``job["optimize"]``.

    Parameters
    ----------
    job : dict
        ``optimize``, ``cfg``, ``free``, ``speed_mps``, ``start``, ``x_guess``, ``options``.

    Returns
    -------
    dict
        Row of the power curve.
    """
    opt = job["optimize"](job["cfg"], job["free"], objective="power", speed_mps=job["speed_mps"], start=job["start"],
                          x_guess=job["x_guess"], **job["options"])
    row = pareto_row(None, opt)
    row.pop("bound")
    return row | {"speed_mps": job["speed_mps"], "started_from": job["started_from"],
                  "mean_shoulder_power_W": opt.means.get("flapping_power_W"),
                  "mean_aerodynamic_power_W": opt.means.get("aerodynamic_power_W")}
