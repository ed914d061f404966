"""Control of a model with aerodynamic states (``aero.unsteady = "wagner"``, ``aero.section =
"dynamic-stall"``): the quasi-steady manifold's slope, the body-state gains folded from full-state
gains, and the body-state weights padded over the aerodynamic states (:mod:`birdocp.studies.control`)."""

from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["manifold_slopes", "body_gains", "pad_weight"]


def manifold_slopes(m, x_starts, t_starts, p) -> np.ndarray:
    """d(aerodynamic states)/d(body state) of the quasi-steady manifold at each (x_i, t_i): (N, n - 4, 4).

    Parameters
    ----------
    m : BirdModel
        Model with aerodynamic states.
    x_starts : array_like, shape (N, n)
        States at the interval starts.
    t_starts : array_like, shape (N,)
        Times of the interval starts [s].
    p : array_like
        Parameter vector.

    Returns
    -------
    ndarray, shape (N, n - 4, 4)
    """
    x4 = ca.MX.sym("x4", 4)
    d = ca.MX.sym("d", m.ode.nd)
    pp = ca.MX.sym("p", m.ode.np)
    jac = ca.Function("aero_manifold_slope", [x4, d, pp], [ca.jacobian(m.aero_guess_d(x4, d, pp), x4)])
    pd = ca.DM(np.asarray(p, float))
    return np.array([np.asarray(jac(ca.DM(x[:4]), m.data(float(t), pd), pd)) for x, t in zip(x_starts, t_starts)])


def body_gains(wm, K) -> np.ndarray:
    """Gains (N, m, nb) on the nb body states alone (4; 8 in six degrees of freedom, heading excluded)
    from full-state gains (N, m, n): the aerodynamic
    states' columns folded in through the slope of their quasi-steady manifold at each interval start
    (``du = -(K_b + K_a S_i) dx_body``: the feedback a flier that senses only its flight state applies,
    assuming its lag and separation states follow the body state). Unchanged without aerodynamic states.

    Parameters
    ----------
    wm : WingbeatMap
        Linearised wingbeat map.
    K : array_like, shape (N, m, n)
        Full-state gains.

    Returns
    -------
    ndarray, shape (N, m, nb)
    """
    K = np.asarray(K, float)
    nb = wm.n_body
    if wm.manifold is None or K.shape[2] == nb:
        return K
    return K[:, :, :nb] + np.einsum("imk,ikj->imj", K[:, :, nb:], wm.manifold)


def pad_weight(Q, n: int) -> np.ndarray:
    """A body-state weight (4 x 4) extended by zeros over the aerodynamic states (n x n).

    Parameters
    ----------
    Q : array_like
        Body-state weight (4 x 4), or already n x n.
    n : int
        Number of states.

    Returns
    -------
    ndarray, shape (n, n)
    """
    Q = np.asarray(Q, float)
    if Q.shape[0] == n:
        return Q
    out = np.zeros((n, n))
    out[:Q.shape[0], :Q.shape[1]] = Q
    return out
