"""Sensitivities of a periodic orbit to a parameter, by the implicit function theorem.

A forced periodic orbit is a fixed point of its period map, ``x0 = Phi(x0, a)``. Along the family
of orbits ``x0(a)``, ``dx0/da = (I - Phi_x)^-1 Phi_a`` (``Phi_x`` is the monodromy matrix), and any
quantity ``F(x0, a)`` of the orbit (a period mean, the monodromy itself) changes by
``dF/da = F_a + F_x dx0/da``. Every cycle sensitivity in birdocp (period means, multipliers, the
level-flight amplitude held by a mean condition) goes through these two functions.
"""
from __future__ import annotations

import numpy as np

__all__ = ["orbit_state_derivative", "total_derivative"]


def orbit_state_derivative(monodromy, d_phi_d_param) -> np.ndarray:
    """``dx0/da = (I - Phi_x)^-1 Phi_a``.

    Parameters
    ----------
    monodromy : (nx, nx) array_like
        ``Phi_x``, the monodromy matrix at the orbit.
    d_phi_d_param : (nx,) or (nx, k) array_like
        ``Phi_a``, the derivative of the period map along one or k parameter directions at fixed x0.

    Returns
    -------
    numpy.ndarray
        ``dx0/da``, the shape of ``d_phi_d_param``.

    Raises
    ------
    numpy.linalg.LinAlgError
        When a multiplier is exactly 1 (the orbit is not isolated: a fold or a branch point).
    """
    M = np.asarray(monodromy, float)
    return np.linalg.solve(np.eye(M.shape[0]) - M, np.asarray(d_phi_d_param, float))


def total_derivative(partial_param, partial_state, dx0_da):
    """``dF/da = F_a + F_x dx0/da``: the derivative of a quantity of the orbit along the family.

    ``partial_state`` has the state as its last axis (``F_x``: (nx,) for a scalar, (..., nx) for an
    array); the contraction is over that axis.

    Parameters
    ----------
    partial_param : array_like
        F_a.
    partial_state : array_like
        F_x.
    dx0_da : array_like, shape (nx,)
        Derivative of the orbit's start state.

    Returns
    -------
    ndarray
    """
    return np.asarray(partial_param) + np.tensordot(np.asarray(partial_state), np.asarray(dx0_da), axes=(-1, 0))
