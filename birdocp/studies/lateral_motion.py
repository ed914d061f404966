"""A perturbed six-degree-of-freedom flight for drawing: the trimmed cycle with its bank angle
disturbed, integrated over several wingbeats by the engine's RK4 (the nonlinear equations of
:mod:`birdocp.bird.sixdof`), and the bird's geometry and circulation at chosen frames.

The wing geometry of a frame is the gait's (:func:`birdocp.bird.snapshots.motion`, both wings
moving alike: the gait is symmetric); the circulation is the six-degree-of-freedom lifting line's in
the frame's state (sideslip and roll/yaw rates included: the two wings differ). The path of the
centre of mass is integrated from the body velocities through the attitude (3-2-1 Euler angles,
north-east-down).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import Config, from_dict
from birdocp.bird.sixdof import LATERAL_PARAM_NAMES, body_loads, sixdof_model
from birdocp.bird.snapshots import motion
from birdocp.engine.integrate import simulate

__all__ = ["perturbed_flight", "lateral_motion", "body_to_earth"]


def body_to_earth(phi: float, theta: float, psi: float) -> np.ndarray:
    """The rotation matrix from body axes (x' forward, y' right, z' down) to north-east-down for the
    3-2-1 Euler angles [rad] (yaw psi, then pitch theta, then roll phi).

    Parameters
    ----------
    phi, theta, psi : float
        Roll, pitch and yaw [rad].

    Returns
    -------
    ndarray, shape (3, 3)
    """
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    Rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1.0]])
    Ry = np.array([[ct, 0, st], [0, 1.0, 0], [-st, 0, ct]])
    Rx = np.array([[1.0, 0, 0], [0, cf, -sf], [0, sf, cf]])
    return Rz @ Ry @ Rx


def perturbed_flight(cfg: Config, x0, p6, bank_deg: float = 15.0, wingbeats: int = 6,
                     steps_per_period: int = 96) -> dict:
    """The flight from a cycle's start state with the bank angle changed by ``bank_deg``.

    Parameters
    ----------
    cfg : Config
        A six-degree-of-freedom configuration.
    x0 : array_like
        The cycle's start state (9).
    p6 : array_like
        Its parameter vector (:data:`birdocp.bird.config.PARAM_NAMES` + the lateral inertias).
    bank_deg : float
        Bank-angle perturbation [deg] (right wing down positive).
    wingbeats : int
        Wingbeats integrated.
    steps_per_period : int
        RK4 steps per wingbeat.

    Returns
    -------
    dict
        ``t_s`` (K), ``x`` (K, 9) and the path of the centre of mass ``north_m``, ``east_m``,
        ``up_m`` (K, from the start, trapezoidal rule on the earth-frame velocity), ``period_s``,
        ``bank_deg``.
    """
    six = sixdof_model(cfg)
    x = np.asarray(x0, float).copy()
    x[6] += np.radians(bank_deg)
    t, X = simulate(six.ode, x, np.asarray(p6, float), steps_per_period=int(steps_per_period), n_periods=int(wingbeats))
    vel = np.array([body_to_earth(s[6], s[7], s[8]) @ s[:3] for s in X])
    dt = np.diff(t)[:, None]
    ned = np.vstack([np.zeros(3), np.cumsum(0.5 * dt * (vel[1:] + vel[:-1]), axis=0)])
    return {"t_s": t, "x": X, "north_m": ned[:, 0], "east_m": ned[:, 1], "up_m": -ned[:, 2],
            "period_s": six.period_s, "bank_deg": float(bank_deg)}


def _gamma_function(six):
    x = ca.SX.sym("x", 9)
    d = ca.SX.sym("d", six.ode.nd)
    p = ca.SX.sym("p", six.ode.np)
    return ca.Function("gamma6", [x, d, p], [body_loads(x, d, p[:six.ode.np - len(LATERAL_PARAM_NAMES)], section=six.section,
                                                          normalwash=six.structure.normalwash)[2]["Gamma"]])


def lateral_motion(cfg: Config, flight: dict, frames: np.ndarray, p6) -> dict:
    """The drawing data of :func:`birdocp.bird.snapshots.motion` at the samples ``frames`` (indices
    into ``flight``), with ``x`` the 9-states and ``gamma_m2ps`` the 6-DOF circulation.

    Parameters
    ----------
    cfg : Config
        The six-degree-of-freedom configuration.
    flight : dict
        :func:`perturbed_flight`'s result.
    frames : array_like of int
        Sample indices to draw.
    p6 : array_like
        The parameter vector of the flight.

    Returns
    -------
    dict
    """
    six = sixdof_model(cfg)
    idx = np.asarray(frames, int)
    t = np.asarray(flight["t_s"])[idx]
    T = flight["period_s"]
    p6 = np.asarray(p6, float)
    n_planar = len(p6) - len(LATERAL_PARAM_NAMES)
    mo = motion(from_dict(_planar_dict(cfg)), np.mod(t, T), None, p6[:n_planar])
    g = _gamma_function(six)
    X = np.asarray(flight["x"])[idx]
    mo["gamma_m2ps"] = np.array([np.asarray(g(X[i], six.data(float(np.mod(t[i], T)), p6), p6)).ravel()
                                 for i in range(len(idx))])
    mo["x"] = X
    mo["t_s"] = t
    return mo


def _planar_dict(cfg: Config) -> dict:
    """``cfg`` as a dict with the planar model selected (the geometry is the same)."""
    from birdocp.bird.config import to_dict

    d = to_dict(cfg)
    d["model"]["degrees_of_freedom"] = 4
    return d
