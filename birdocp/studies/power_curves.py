"""Level flight over a range of forward speeds: the power curve of a gait (the speed held by one
key, level flight by the amplitude), its minimum-power and maximum-range speeds over valid rows,
(the power curve over valid gaits: :func:`birdocp.studies.gait_fronts.valid_power_curve`)."""

from __future__ import annotations

import numpy as np

from birdocp.bird.config import Config, get_value, with_values
from birdocp.bird.validity import periodic_validity
from birdocp.io.progress import text_reporter
from birdocp.studies.gait_cycle import AMPLITUDE_KEY, ReducedLevelCycle
from birdocp.studies.gait_types import Evaluation, WarmStart

__all__ = ["level_at_speed", "power_curve", "curve_optima", "SPEED_KEY"]

SPEED_KEY = "gait.shoulder_incidence.offset_deg"
"""The gait parameter that holds the forward speed in the power curve (with the amplitude holding
level flight): the wing's mean incidence."""


def level_at_speed(cfg: Config, speed_mps: float, key: str = SPEED_KEY, bounds=(-10.0, 35.0),
                   steps_per_period: int | None = None, rc: ReducedLevelCycle | None = None) -> Evaluation:
    """Level flight at mean forward speed ``speed_mps``: the amplitude and ``key`` solved.

    Parameters
    ----------
    cfg : Config
        Configuration.
    speed_mps : float
        Mean forward speed [m/s].
    key : str
        Dotted key solved with the amplitude.
    bounds : (float, float)
        Bounds of ``key``.
    steps_per_period : int, optional
        RK4 steps per period.
    rc : ReducedLevelCycle, optional
        Reduced problem to reuse (warm start).

    Returns
    -------
    Evaluation
    """
    rc = rc or ReducedLevelCycle(cfg, [key], steps_per_period)
    theta = rc.warm_start.theta
    theta = theta if theta is not None else np.array([float(get_value(cfg, key))])
    return rc.solve_speed(speed_mps, theta, 0, bounds)


def power_curve(cfg: Config | None = None, speeds=None, key: str = SPEED_KEY, bounds=(-10.0, 35.0),
                steps_per_period: int | None = None, progress: bool = False) -> dict:
    """Level flight over a range of forward speeds (the speed held by ``key``, level flight by the
    amplitude), with the power outputs and the multipliers of every point.

    The points are continued outward from the speed of the configured gait's level cycle. Returns
    ``{"rows": [...], "minimum_power": {...}, "maximum_range": {...}, "key": key}``; minimum-power and
    maximum-range (minimum P/U) speeds from a parabola through the three points around the discrete
    minimum, over the rows whose cycle is *valid* only (each row carries ``validity`` and ``valid``,
    and the cycle: ``x0``, the key's value and ``amplitude_deg``); ``"interior": False`` when the
    minimum lies at an end of the valid rows. ``minimum_power_all_rows`` and
    ``maximum_range_all_rows``: the same over every converged row, valid or not.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    speeds : sequence of float, optional
        Forward speeds [m/s] (default 12..24 m/s by 1 m/s).
    key : str
        The gait key that sets the speed.
    bounds : (float, float)
        Bounds of ``key`` (its units).
    steps_per_period : int, optional
        RK4 steps per period (default ``cfg.solve.steps_per_period``).
    progress : bool
        One line per point on stderr.

    Returns
    -------
    dict
        ``rows``, ``minimum_power``, ``maximum_range`` (over valid rows), their ``*_all_rows`` and ``key``.
    """
    from birdocp.bird.energetics import cycle_energetics

    cfg = cfg or Config()
    speeds = np.sort(np.asarray(speeds if speeds is not None else np.arange(12.0, 24.01, 1.0), float))
    rc = ReducedLevelCycle(cfg, [key], steps_per_period)
    ev0 = rc.evaluate(np.array([float(get_value(cfg, key))]))
    U0 = ev0.means["forward_speed_mps"]
    up = [s for s in speeds if s >= U0]
    down = [s for s in speeds[::-1] if s < U0]
    rows = []
    for branch in (up, down):
        rc.restart_from(WarmStart(ev0.y, ev0.theta, None))  # each branch from the configured gait's cycle
        ev_prev = ev0
        for s in branch:
            row = {"speed_mps": float(s), "success": False}
            try:
                ev = rc.solve_speed(float(s), ev_prev.theta, 0, bounds)
            except RuntimeError as e:
                row["message"] = str(e)
                rows.append(row)
                if progress:
                    text_reporter(progress, "power curve")(f"{s:.3g} m/s failed: {e}")
                break
            ev_prev = ev
            p = rc.pfull(ev.theta, ev.amplitude_deg)
            e = cycle_energetics(rc.m, p, ev.x0, rc.N)
            v = periodic_validity(with_values(cfg, {key: float(ev.theta[0]), AMPLITUDE_KEY: ev.amplitude_deg}),
                                  ev.x0, p, steps_per_period=rc.N).to_dict()
            lam = ev.multipliers
            row.update({"success": True, key: float(ev.theta[0]), "amplitude_deg": ev.amplitude_deg,
                        "x0": ev.x0.tolist(), "mean_forward_speed_mps": ev.means["forward_speed_mps"],
                        "mean_vertical_speed_mps": ev.means["vertical_speed_mps"],
                        **{k: e[k] for k in ("mean_shoulder_power_W", "mean_aerodynamic_power_W",
                                             "mean_positive_power_W", "cost_of_transport",
                                             "strouhal_number", "reduced_frequency")},
                        "multipliers": [[float(v.real), float(v.imag)] for v in lam],
                        "largest_modulus": float(np.max(np.abs(lam))), "validity": v, "valid": bool(v["valid"])})
            rows.append(row)
            if progress:
                text_reporter(progress, "power curve")(f"U {s:6.2f} m/s  {key} {ev.theta[0]:8.4f}  A "
                                                       f"{ev.amplitude_deg:8.4f} deg  P {e['mean_shoulder_power_W']:8.4f} W"
                                                       f"  |L1| {row['largest_modulus']:.4f}")
    rows.sort(key=lambda r: r["speed_mps"])
    return {"key": key, "rows": rows} | curve_optima(rows)


def curve_optima(rows: list) -> dict:
    """``minimum_power`` and ``maximum_range`` over the valid converged rows (``mean_shoulder_power_W``
    against ``speed_mps``), and ``..._all_rows`` over every converged row.

    Parameters
    ----------
    rows : list of dict
        Rows of the power curve.

    Returns
    -------
    dict
    """
    out = {}
    for tag, keep in (("", lambda r: r.get("valid")), ("_all_rows", lambda r: True)):
        ok = [r for r in rows if r["success"] and keep(r)]
        U = np.array([r["speed_mps"] for r in ok])
        P = np.array([r["mean_shoulder_power_W"] for r in ok])
        out["minimum_power" + tag] = _vertex(U, P, "power_W")
        out["maximum_range" + tag] = _vertex(U, P / U if len(U) else P, "power_per_speed_J_per_m", P)
    return out


def _vertex(U, y, name, P=None) -> dict:
    """The minimum of y(U) from the parabola through the discrete minimum and its neighbours
    (at an end of the range: the end point, flagged)."""
    if len(U) < 3:
        return {"speed_mps": None, name: None, "interior": False}
    i = int(np.argmin(y))
    if i == 0 or i == len(U) - 1:
        out = {"speed_mps": float(U[i]), name: float(y[i]), "interior": False}
    else:
        c = np.polyfit(U[i - 1:i + 2], y[i - 1:i + 2], 2)
        us = float(-c[1] / (2 * c[0]))
        out = {"speed_mps": us, name: float(np.polyval(c, us)), "interior": True}
    if P is not None and out["speed_mps"] is not None:
        out["power_W"] = out[name] * out["speed_mps"]
    return out
