"""Floquet analysis of a periodic orbit of a (forced, non-autonomous) ODE.

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

import numpy as np

from birdocp.engine.results import complex_pairs  # noqa: F401  (re-exported: the [re, im] convention)
from birdocp.engine.results import result_dict

__all__ = ["FloquetResult", "floquet_from_jacobians", "multipliers_info", "monodromy_of", "complex_pairs",
           "multiplier_order", "sort_multipliers", "matched_distances", "doubling_time_s",
           "multiplier_doubling_time_s"]


@dataclass
class FloquetResult:
    """The Floquet analysis of one periodic orbit (the conventions of this module): the monodromy
    matrix, its multipliers, eigenvectors (columns), exponents [1/s] and signed doubling times [s],
    ``stable`` (every |multiplier| < 1), the largest difference between the monodromy and the
    one-period map's Jacobian computed in one go, and the segment Jacobians it is the product of."""

    monodromy: np.ndarray
    multipliers: np.ndarray
    eigenvectors: np.ndarray
    floquet_exponents: np.ndarray
    doubling_times_s: np.ndarray
    stable: bool
    monodromy_vs_full_period_jacobian: float
    segment_jacobians: list

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`: complex numbers as [re, im]
        pairs, non-finite numbers as null).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


def multiplier_order(lam) -> np.ndarray:
    """Indices sorting multipliers by modulus, largest first, then positive imaginary part first (the
    order of every result).

    Parameters
    ----------
    lam : array_like
        Multipliers.

    Returns
    -------
    ndarray of int
    """
    lam = np.asarray(lam)
    return np.lexsort((-lam.imag, -np.abs(lam)))


def sort_multipliers(lam) -> np.ndarray:
    """Multipliers (complex) in the order of :func:`multiplier_order`.

    Parameters
    ----------
    lam : array_like
        Multipliers.

    Returns
    -------
    ndarray of complex
    """
    lam = np.asarray(lam).astype(complex)
    return lam[multiplier_order(lam)]


def matched_distances(lam, ref) -> np.ndarray:
    """``|lam_k - ref_k|`` with ``lam`` permuted to minimise the largest distance (``ref``'s order kept;
    ties broken by the sum): the distance between two sets of multipliers that does not depend on how
    each was sorted. Exhaustive over the permutations up to 7 multipliers; beyond (a model with
    aerodynamic states has dozens), greedy: the closest remaining pair first.

    Parameters
    ----------
    lam, ref : array_like
        Two sets of multipliers of equal size.

    Returns
    -------
    ndarray
        One distance per entry of ``ref``.
    """
    import itertools

    lam, ref = np.asarray(lam, complex), np.asarray(ref, complex)
    if len(lam) > 7:
        d = np.abs(lam[:, None] - ref[None, :])
        out = np.full(len(ref), np.nan)
        for _ in range(min(len(lam), len(ref))):
            i, j = np.unravel_index(np.argmin(d), d.shape)
            out[j] = d[i, j]
            d[i, :], d[:, j] = np.inf, np.inf
        return out
    best = min(itertools.permutations(range(len(lam))),
               key=lambda perm: (np.max(np.abs(lam[list(perm)] - ref)), np.sum(np.abs(lam[list(perm)] - ref))))
    return np.abs(lam[list(best)] - ref)


def doubling_time_s(rate_per_s):
    """Signed doubling time [s] of a growth rate ``rate_per_s`` = Re μ [1/s]: ``ln 2 / rate``
    (positive: the time to double; negative: minus the time to halve; inf for a zero rate).

    The one place a doubling or halving time is computed (the Floquet results, the CLI's text, the
    study tables): ``1 / rate`` would be the e-folding time, ``ln 2`` times shorter. Works on scalars
    and arrays (a float for a scalar).

    Parameters
    ----------
    rate_per_s : float or array_like
        Growth rate [1/s].

    Returns
    -------
    float or ndarray
        [s].
    """
    rate = np.asarray(rate_per_s, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(rate == 0, np.inf, np.log(2.0) / np.where(rate == 0, 1.0, rate))
    return float(t) if t.ndim == 0 else t


def multiplier_doubling_time_s(multiplier, period_s: float):
    """Signed doubling time [s] of a Floquet multiplier Λ of a cycle of period ``period_s``:
    ``T ln 2 / ln|Λ|`` (:func:`doubling_time_s` of the rate ``ln|Λ| / T``; 0 for Λ = 0).

    Parameters
    ----------
    multiplier : complex or array_like
        Λ.
    period_s : float
        Period T [s].

    Returns
    -------
    float or ndarray
        [s].
    """
    with np.errstate(divide="ignore"):
        rate = np.log(np.abs(np.asarray(multiplier, complex))) / float(period_s)
    return doubling_time_s(rate)


def multipliers_info(monodromy: np.ndarray, period_s: float):
    """(multipliers, eigenvectors, exponents, doubling times, stable) from a monodromy matrix.

    Parameters
    ----------
    monodromy : ndarray, shape (n, n)
        Monodromy matrix.
    period_s : float
        Period [s].

    Returns
    -------
    tuple
        ``(multipliers, eigenvectors, exponents [1/s], doubling times [s], stable)``.
    """
    lam, vec = np.linalg.eig(monodromy)
    order = multiplier_order(lam)
    lam = lam[order].astype(complex)
    vec = vec[:, order].astype(complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = np.log(lam) / period_s
    dbl = doubling_time_s(mu.real)
    stable = bool(np.all(np.abs(lam) < 1.0))
    return lam, vec, mu, dbl, stable


def monodromy_of(jacobians) -> np.ndarray:
    """The monodromy matrix: the product J_{M-2} ... J_1 J_0 of the segment Jacobians (in time order).

    Parameters
    ----------
    jacobians : sequence of array_like
        Segment Jacobians in time order.

    Returns
    -------
    ndarray
    """
    Mo = np.eye(np.asarray(jacobians[0]).shape[0])
    for J in jacobians:
        Mo = np.asarray(J) @ Mo
    return Mo


def floquet_from_jacobians(jacobians, full_period_jacobian, period_s) -> FloquetResult:
    """Floquet analysis from the segment Jacobians (time order) of a converged orbit; the monodromy is
    compared with ``full_period_jacobian`` (the one-period map's Jacobian) as an accuracy indicator.

    Parameters
    ----------
    jacobians : sequence of array_like
        Segment Jacobians in time order.
    full_period_jacobian : array_like
        Jacobian of the one-period map.
    period_s : float
        Period [s].

    Returns
    -------
    FloquetResult
    """
    Mo = monodromy_of(jacobians)
    lam, vec, mu, dbl, stable = multipliers_info(Mo, period_s)
    diff = float(np.max(np.abs(Mo - full_period_jacobian))) if full_period_jacobian is not None else float("nan")
    return FloquetResult(Mo, lam, vec, mu, dbl, stable, diff, [np.asarray(J) for J in jacobians])
