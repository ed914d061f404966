"""Floquet analysis of a periodic orbit of a (forced, non-autonomous) PeriodicODE.

The monodromy matrix is the product of the segment Jacobians J_{M-2} ... J_0 (exact CasADi forward
AD through the RK4 steps) evaluated at the shooting points; as an accuracy indicator it is compared
with the Jacobian of the one-period map computed in one go from x0.  Eigenvalues come from numpy.

Conventions
-----------
* ``multipliers`` Λ are sorted by modulus, largest first; ``eigenvectors`` columns match.
* ``floquet_exponents`` μ = ln(Λ)/T (principal complex log, 1/s); Re μ = ln|Λ|/T.
* ``doubling_times_s`` = ln 2 / Re μ, *signed*: positive = time for a perturbation along that mode to
  double (|Λ| > 1); negative = minus the time to halve (|Λ| < 1); inf when |Λ| = 1; 0 when Λ = 0.
* ``stable`` = all |Λ| < 1.  The ODEs here are forced (explicitly time-periodic) so there is no
  trivial multiplier 1 to exclude, unlike for autonomous limit cycles.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from birdocp.engine.problem import PeriodicODE

__all__ = ["FloquetResult", "floquet", "floquet_from_jacobians", "multipliers_info"]


@dataclass
class FloquetResult:
    monodromy: np.ndarray
    multipliers: np.ndarray
    eigenvectors: np.ndarray
    floquet_exponents: np.ndarray
    doubling_times_s: np.ndarray
    stable: bool
    monodromy_vs_full_period_jacobian: float
    segment_jacobians: list


def multipliers_info(monodromy: np.ndarray, period_s: float):
    """(multipliers, eigenvectors, exponents, doubling times, stable) from a monodromy matrix."""
    lam, vec = np.linalg.eig(monodromy)
    order = np.lexsort((-lam.imag, -np.abs(lam)))  # modulus descending, then +imag first
    lam = lam[order].astype(complex)
    vec = vec[:, order].astype(complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = np.log(lam) / period_s
        re = mu.real
        dbl = np.where(re == 0, np.inf, np.log(2.0) / re)
    stable = bool(np.all(np.abs(lam) < 1.0))
    return lam, vec, mu, dbl, stable


def monodromy_of(jacobians) -> np.ndarray:
    """The monodromy matrix: the product J_{M-2} ... J_1 J_0 of the segment Jacobians (in time order)."""
    Mo = np.eye(np.asarray(jacobians[0]).shape[0])
    for J in jacobians:
        Mo = np.asarray(J) @ Mo
    return Mo


def floquet_from_jacobians(jacobians, full_period_jacobian, period_s) -> FloquetResult:
    Mo = monodromy_of(jacobians)
    lam, vec, mu, dbl, stable = multipliers_info(Mo, period_s)
    diff = float(np.max(np.abs(Mo - full_period_jacobian))) if full_period_jacobian is not None else float("nan")
    return FloquetResult(Mo, lam, vec, mu, dbl, stable, diff, [np.asarray(J) for J in jacobians])


def floquet(ode: PeriodicODE, x0, p, method=None, *, t0: float = 0.0, points=None, _grid=None, _blocks=None) -> FloquetResult:
    """Floquet analysis at the periodic orbit through ``x0`` (at time t0) for parameters ``p``.

    ``method`` is a :class:`~birdocp.engine.shooting.MultipleShooting` (points, steps_per_period); default
    ``MultipleShooting()``.  ``points`` (M x nx or (M-1) x nx) are the shooting points; by default
    they are obtained by integrating forward from x0 (identical at a converged orbit).
    """
    from birdocp.engine.shooting import MultipleShooting, _get_grid

    method = method or MultipleShooting()
    method.validate()
    grid = _grid or _get_grid(ode, method, ())
    D = _blocks if _blocks is not None else grid.blocks_numeric(t0, p)
    pd = ca.DM(np.asarray(p, float))
    x0 = np.asarray(x0, float).ravel()
    S, nx = grid.S, ode.nx
    if points is None:
        Xt = np.asarray(grid.period_map(ca.DM(x0), D, pd)[1])
        pts = np.column_stack([x0] + [Xt[:, grid.n * (i + 1) - 1] for i in range(S - 1)])
    else:
        pts = np.asarray(points, float)[:S].T
    _, Jcat = grid.segment_jacobians(ca.DM(pts), D, pd)
    Jcat = np.asarray(Jcat)
    Js = [Jcat[:, i * nx:(i + 1) * nx] for i in range(S)]
    _, Jfull = grid.period_jacobian(ca.DM(pts[:, 0]), D, pd)
    return floquet_from_jacobians(Js, np.asarray(Jfull), ode.period_s)
