"""Aerodynamic states (``aero.unsteady = "wagner"``, ``aero.section = "dynamic-stall"``) in the
six-degree-of-freedom simulation and feedback: their quasi-steady manifold over the 9 body states, the
start of a simulation from a body state, and the manifold's slope the body-state gains are folded
through (:mod:`birdocp.studies.lateral_control`, as the planar :mod:`birdocp.studies.control_aero`).

On the quasi-steady manifold the lag states are ``z_i = eps A_i g`` (the circulation ``g`` of the section
law with A0 = 1 and no lag) and the separation point is ``f0(alpha_E)``, each element over both wings in
the asymmetric flow (sideslip, roll and yaw rates in its air velocity):
:func:`birdocp.bird.graphs.quasi_steady_aero_states`, the planar model's start of these states, with
the 6-DOF flow.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES
from birdocp.bird.graphs import quasi_steady_aero_states
from birdocp.bird.model import unpack_data
from birdocp.bird.sixdof import HEADING, air_velocity
from birdocp.engine.cache import owned_cache

__all__ = ["n_aero_states", "aero_guess_function", "complete_state6", "manifold_slopes6"]


def n_aero_states(six) -> int:
    """Aerodynamic states of a 6-DOF model after its 9 body states (0 without a lag or separation state).

    Parameters
    ----------
    six : SixDofModel
        The model.

    Returns
    -------
    int
    """
    return six.section.n_states if six.section is not None else 0


def aero_guess_function(six) -> ca.Function:
    """``z(x, d, p) -> aerodynamic states`` on the quasi-steady manifold at the 9-state ``x`` (built once
    per model).

    Parameters
    ----------
    six : SixDofModel
        A model with aerodynamic states.

    Returns
    -------
    casadi.Function
    """
    def build():
        law = six.section
        x, d, p6 = ca.SX.sym("x", 9), ca.SX.sym("d", six.rhs.size1_in(1)), ca.SX.sym("p", six.ode.np)
        b = unpack_data(d)
        flow = {"V": air_velocity(x, b["r_m"], b["v_kin_mps"]), "Omega": ca.vertcat(x[4], -x[5], -x[3])}
        z = quasi_steady_aero_states({"unsteady": law.unsteady, "section": law.section,
                                      "newton_steps": law.newton_steps}, ca.vertcat(x[0], x[2], x[4]), d,
                                     law.data_offset, p6[:len(PARAM_NAMES)], flow=flow)
        return ca.Function("aero_guess6", [x, d, p6], [z], ["x", "d", "p"], ["z"])

    return owned_cache(six).build(("aero_guess6",), build)


def complete_state6(six, x, p, t_s: float = 0.0) -> np.ndarray:
    """The full state (9 body states, then the aerodynamic states) of ``x``: a body state (8 without
    the heading, taken 0, or 9) gets its aerodynamic states on the quasi-steady manifold at ``t_s``
    (as the planar :meth:`birdocp.bird.model.BirdModel.complete_state`); a full state (8 or 9 body
    states, then all aerodynamic ones) is returned with its heading.

    Parameters
    ----------
    six : SixDofModel
        The model.
    x : array_like
        State.
    p : array_like
        The model's parameter vector.
    t_s : float
        Time [s].

    Returns
    -------
    ndarray, shape (9 + aerodynamic states,)
    """
    x = np.asarray(x, float).ravel()
    n_a = n_aero_states(six)
    if x.size == 8 or (n_a and x.size == 8 + n_a):  # no heading: psi = 0
        x = np.insert(x, HEADING, 0.0)
    if x.size not in (9, 9 + n_a):
        raise ValueError(f"a 6-DOF state has 8 or 9 body states, then the {n_a} aerodynamic states; got {x.size}")
    if x.size == 9 + n_a:
        return x
    pd = ca.DM(np.asarray(p, float))
    z = np.asarray(aero_guess_function(six)(ca.DM(x), six.data(float(t_s), pd), pd)).ravel()
    return np.concatenate([x, z])


def manifold_slopes6(six, x_starts, t_starts, p) -> np.ndarray:
    """d(aerodynamic states)/d(8 body states, heading excluded) of the quasi-steady manifold at each
    interval start (x_i, t_i): (N, n_a, 8).

    Parameters
    ----------
    six : SixDofModel
        A model with aerodynamic states.
    x_starts : array_like, shape (N, 8 + n_a)
        States at the interval starts (heading excluded).
    t_starts : array_like, shape (N,)
        Times [s].
    p : array_like
        The model's parameter vector.

    Returns
    -------
    ndarray, shape (N, n_a, 8)
    """
    f = aero_guess_function(six)
    x8 = ca.SX.sym("x8", HEADING)
    d, pp = ca.SX.sym("d", six.rhs.size1_in(1)), ca.SX.sym("p", six.ode.np)
    z = f(ca.vertcat(x8, 0), d, pp)
    jac = ca.Function("aero_manifold_slope6", [x8, d, pp], [ca.jacobian(z, x8)])
    pd = ca.DM(np.asarray(p, float))
    return np.array([np.asarray(jac(ca.DM(np.asarray(x, float)[:HEADING]), six.data(float(t), pd), pd))
                     for x, t in zip(x_starts, t_starts)])
