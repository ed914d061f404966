"""Flight quantities of a cycle: inertial velocities W and U and the flight-path condition.

* ``W = u sin(theta) - w cos(theta)``: inertial vertical speed (m/s, positive climbing);
* ``U = u cos(theta) + w sin(theta)``: inertial horizontal speed (m/s, forward);
* the flight-path angle ``atan(mean W / mean U)`` (degrees, positive climbing).

The outputs are CasADi Functions ``(x, d, p) -> scalar`` as the engine's mean conditions and
outputs expect; each is built once per process and reused, so the shooting graphs that hold them
are reused too.
"""
from __future__ import annotations

import math

import casadi as ca

from birdocp.bird.config import PARAM_NAMES
from birdocp.bird.model import N_DATA
from birdocp.engine.cache import bounded_cache

__all__ = ["inertial_velocities", "flight_outputs", "path_angle_output", "flight_path_angle_deg"]


def inertial_velocities(x):
    """(W, U) in m/s of the body state ``x = (u, w, q, theta)`` (symbolic or numeric).

    Parameters
    ----------
    x : array_like or casadi.SX
        Body state (u, w, q, theta).

    Returns
    -------
    W, U
        Vertical (up) and horizontal (forward) inertial velocity [m/s].
    """
    u, w, th = x[0], x[1], x[3]
    return u * ca.sin(th) - w * ca.cos(th), u * ca.cos(th) + w * ca.sin(th)


def _symbols(nd: int, nx: int = 4):
    return ca.SX.sym("x", int(nx)), ca.SX.sym("d", int(nd)), ca.SX.sym("p", len(PARAM_NAMES))


# the output Functions by value (sizes, angle): the same Functions for every caller, so the shooting
# graphs kept by an ODE (keyed by their outputs) are reused
_OUTPUTS = bounded_cache("bird.flight_outputs", 64)


def flight_outputs(nd: int = N_DATA, nx: int = 4) -> dict:
    """``{"vertical_speed_mps": W, "forward_speed_mps": U}`` as Functions of ``(x, d, p)`` (the same
    Functions on every call with the same sizes).

    Parameters
    ----------
    nd : int
        Size of the model's data vector, ``model.ode.nd`` (N_DATA + N_MASS with wing masses).
    nx : int
        Size of its state, ``model.ode.nx`` (4, plus the aerodynamic states of an unsteady or
        dynamic-stall section).

    Returns
    -------
    dict of str to casadi.Function
    """
    return _OUTPUTS.build(("flight", int(nd), int(nx)), lambda: _flight_outputs(int(nd), int(nx)))


def _flight_outputs(nd: int, nx: int) -> dict:
    x, d, p = _symbols(nd, nx)
    W, U = inertial_velocities(x)
    return {"vertical_speed_mps": ca.Function("vertical_speed_mps", [x, d, p], [W]),
            "forward_speed_mps": ca.Function("forward_speed_mps", [x, d, p], [U])}


def path_angle_output(beta_deg: float, nd: int = N_DATA, nx: int = 4) -> ca.Function:
    """``W - tan(beta) U`` as a Function of ``(x, d, p)``: its period mean is zero on a flight path of
    ``beta_deg`` degrees (one Function per angle and sizes, so the shooting graphs are reused).

    Parameters
    ----------
    beta_deg : float
        Flight-path angle [deg], positive climbing.
    nd : int
        Size of the model's data vector.
    nx : int
        Size of its state.

    Returns
    -------
    casadi.Function
    """
    return _OUTPUTS.build(("path_angle", float(beta_deg), int(nd), int(nx)),
                          lambda: _path_angle_output(float(beta_deg), int(nd), int(nx)))


def _path_angle_output(beta_deg: float, nd: int, nx: int) -> ca.Function:
    x, d, p = _symbols(nd, nx)
    W, U = inertial_velocities(x)
    return ca.Function("path_angle_residual", [x, d, p], [W - math.tan(math.radians(float(beta_deg))) * U])


def flight_path_angle_deg(mean_vertical_speed_mps: float, mean_forward_speed_mps: float) -> float:
    """The flight-path angle in degrees from the period-mean inertial velocities.

    Parameters
    ----------
    mean_vertical_speed_mps : float
        Mean vertical speed (up) [m/s].
    mean_forward_speed_mps : float
        Mean horizontal speed [m/s].

    Returns
    -------
    float
    """
    return math.degrees(math.atan2(mean_vertical_speed_mps, mean_forward_speed_mps))
