"""The linearisation of ``x' = f(x, p)`` at a point (:mod:`birdocp.engine.equilibria`): the Jacobians,
the eigenpairs in the order of the equilibrium results, and the critical complex pair of a Hopf point.

Split from :mod:`birdocp.engine.equilibria` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine.ode import ODE

__all__ = ["ode_jacobians", "sorted_eig", "critical_pair"]


def ode_jacobians(ode: ODE, x, p, t=0.0):
    """(df/dx, df/dp) at (x, t, p) as numpy arrays.

    Parameters
    ----------
    ode : ODE
        System.
    x : array_like
        State.
    p : array_like
        Parameters.
    t : float
        Time.

    Returns
    -------
    fx, fp : ndarray
    """
    fx, fp = ode.jacobian_function()(ca.DM(x), t, ca.DM(p))
    return np.asarray(fx), np.asarray(fp)


def sorted_eig(J):
    """Eigenvalues and eigenvectors of J, largest real part first (then largest imaginary part).

    Parameters
    ----------
    J : array_like, shape (n, n)
        Matrix.

    Returns
    -------
    lam : ndarray
    V : ndarray
        Eigenvectors as columns.
    """
    lam, V = np.linalg.eig(J)
    order = np.lexsort((-lam.imag, -lam.real))
    return lam[order].astype(complex), V[:, order].astype(complex)


def critical_pair(lam, tol_imag=1e-8):
    """Index of the complex eigenvalue (Im > 0) with the real part closest to 0, or None.

    Parameters
    ----------
    lam : array_like
        Eigenvalues.
    tol_imag : float
        Smallest imaginary part of a complex eigenvalue.

    Returns
    -------
    int or None
    """
    idx = [i for i, v in enumerate(lam) if v.imag > tol_imag]
    if not idx:
        return None
    return min(idx, key=lambda i: abs(lam[i].real))
