"""What the orbit solver checks on a converged orbit: is the period minimal (or a k-fold cover of a
shorter orbit), how accurate is it (discretisation and solver error), and why a failed solve failed.

Minimal period: a guess of about k times the period converges, as it should, to the orbit traversed k
times -- a true solution of the shooting equations with the k-fold monodromy. The orbit x(t) of period
T is a k-fold cover when ``x(t + T/k) = x(t)`` for all t; :func:`cover_multiple` measures
``max_t |x(t + T/k) - x(t)|`` on the grid (cubic Hermite interpolation between grid points, with the
exact slopes f, error O(h^4)) for k = 2 .. 16 and returns the largest k for which it is below
``1e-3`` of the orbit's amplitude.

Error estimate (:func:`attach_error`): the discretisation error is Richardson's from the orbit
computed with N and 2N steps, ``2^p / (2^p - 1) |y_N - y_2N|`` (p the order of the integrator); the
solver error is the distance to the exact solution of the discrete equations, bounded to first
order by ``|g|_2 / sigma_min(J)`` (g the residual left by the solver, J the shooting matrix); its
effect on the multipliers is that distance relative to the orbit's size times the largest
multiplier times the condition number of the eigenvector basis. The estimate is the sum, and never
below the round-off of the value (16 eps |value|): a re-solve that takes no Newton step no longer
gives a silent 0.
"""
from __future__ import annotations

import numpy as np

__all__ = ["cover_multiple", "attach_error", "solver_error", "match_multipliers", "failure_reason", "richardson_errors"]

EPS = np.finfo(float).eps


def _hermite(traj, F, h, s):
    """x at fractional grid index s (array) on a periodic grid of N+1 points (last = first)."""
    N = traj.shape[0] - 1
    s = np.mod(s, N)
    j = np.minimum(np.floor(s).astype(int), N - 1)
    u = (s - j)[:, None]
    h00, h10 = 2 * u ** 3 - 3 * u ** 2 + 1, u ** 3 - 2 * u ** 2 + u
    h01, h11 = -2 * u ** 3 + 3 * u ** 2, u ** 3 - u ** 2
    return h00 * traj[j] + h10 * h * F[j] + h01 * traj[j + 1] + h11 * h * F[j + 1]


def cover_multiple(traj, F, period: float, k_max: int = 16, rel_tol: float = 1e-3) -> tuple:
    """(k, mismatch): the largest k in 2..k_max for which the orbit is a k-fold cover, and its
    relative mismatch ``max_t |x(t + T/k) - x(t)| / amplitude``; (1, nan) if none.

    Parameters
    ----------
    traj : array (N+1, nx)
        The states on the grid of one period (last row = first).
    F : array (N+1, nx)
        f at those states.
    period : float
        T.
    k_max : int
        Largest k tested.
    rel_tol : float
        Largest relative mismatch of a cover.

    Returns
    -------
    k : int
    mismatch : float
    """
    N = traj.shape[0] - 1
    amp = float(np.max(np.abs(traj - traj[0])))
    if not amp > 0:
        return 1, float("nan")
    h = period / N
    best, mis = 1, float("nan")
    for k in range(2, k_max + 1):
        if N / k < 4:
            break
        shifted = _hermite(traj, F, h, np.arange(N + 1) + N / k)
        d = float(np.max(np.abs(shifted - traj))) / amp
        if d <= rel_tol:
            best, mis = k, d
    return best, mis


def solver_error(J, g) -> float:
    """First-order distance from z to the exact solution of the discrete equations: |g|_2 / sigma_min(J)
    (inf when J is singular).

    Parameters
    ----------
    J : array_like
        Jacobian of the discrete equations.
    g : array_like
        Their residual.

    Returns
    -------
    float
    """
    if not (np.all(np.isfinite(J)) and np.all(np.isfinite(g))):
        return float("nan")
    smin = float(np.linalg.svd(J, compute_uv=False)[-1])
    return float(np.linalg.norm(g) / smin) if smin > 0 else float("inf")


def richardson_errors(lam, lam_fine, x0, x0_fine, means: dict, means_fine: dict, e_solver: float,
                      order: int = 4) -> dict:
    """Error estimates of a forced orbit solved on N and 2N steps: the differences of the matched
    multipliers, of x0 and of the period means scaled by ``2^order / (2^order - 1)`` (Richardson),
    plus the solver's part ``e_solver`` (added to x0 and, relative to the state's size ``1 +
    max|x0|``, to the multipliers); every estimate at least the round-off of its value.

    Parameters
    ----------
    lam, lam_fine : array_like
        Multipliers on N and 2N steps.
    x0, x0_fine : array_like
        Start states on N and 2N steps.
    means, means_fine : dict
        Period means by name on N and 2N steps.
    e_solver : float
        Solver error (:func:`solver_error`).
    order : int
        Order of the integrator.

    Returns
    -------
    dict
        ``multipliers`` (absolute, max over the matched multipliers), ``multipliers_relative``,
        ``x0`` (state units), ``means`` (by name).
    """
    from birdocp.engine.floquet import matched_distances

    eps, fac = np.finfo(float).eps, 2.0 ** order / (2.0 ** order - 1.0)
    lam, lam_fine = np.asarray(lam), np.asarray(lam_fine)
    xs = 1.0 + float(np.max(np.abs(x0)))
    dl = matched_distances(lam, lam_fine)
    return {"multipliers": float(fac * np.max(dl) + e_solver / xs * np.max(np.abs(lam)) + 16 * eps),
            "multipliers_relative": float(np.max((fac * dl + e_solver / xs + 16 * eps)
                                                 / np.maximum(np.abs(lam_fine), 1.0))),
            "x0": float(fac * np.max(np.abs(np.asarray(x0) - np.asarray(x0_fine))) + e_solver + 16 * eps * xs),
            "means": {k: float(fac * abs(v - means_fine[k]) + 16 * eps * abs(v)) for k, v in means.items()}}


def match_multipliers(a, b):
    """Max |a_i - b_j| over a greedy nearest matching of two multiplier lists, and of the relative.

    Parameters
    ----------
    a, b : sequence of complex
        Multipliers.

    Returns
    -------
    max_abs, max_rel : float
    """
    b = list(b)
    ab, rel = 0.0, 0.0
    for v in a:
        j = int(np.argmin([abs(v - w) for w in b]))
        d = abs(v - b.pop(j))
        ab, rel = max(ab, d), max(rel, d / max(1.0, abs(v)))
    return ab, rel


def _eig_condition(monodromy) -> float:
    try:
        _, V = np.linalg.eig(monodromy)
        return float(np.linalg.cond(V))
    except np.linalg.LinAlgError:
        return float("inf")


def attach_error(res, fine, order: int, accuracy: float, e_solver: float) -> None:
    """Fill ``res.error_estimate`` and ``res.accurate`` from the 2N re-solve ``fine`` (an OrbitResult)
    and the solver error ``e_solver`` (see the module docstring).

    Parameters
    ----------
    res : OrbitResult
        Result, changed in place.
    fine : OrbitResult
        The re-solve on 2N steps.
    order : int
        Order of the integrator.
    accuracy : float
        Accuracy asked for.
    e_solver : float
        Solver error (:func:`solver_error`).
    """
    fac = 2.0 ** order / (2.0 ** order - 1.0)
    e_solver = float(e_solver) if np.isfinite(e_solver) else float("inf")
    if not fine.success or fine.multipliers is None or res.multipliers is None:
        res.error_estimate = {"period": float("nan"), "x0": float("nan"), "multipliers": float("nan"),
                              "solver": e_solver}
        res.accurate = False
        res.message += f"; error estimate failed (2N solve: {fine.status})"
        return
    xs = 1.0 + float(np.max(np.abs(res.x0)))
    lam_max = float(np.max(np.abs(res.multipliers)))
    eT = fac * abs(res.period - fine.period) + e_solver + 16 * EPS * abs(res.period)
    ex = fac * float(np.max(np.abs(res.x0 - fine.x0))) + e_solver + 16 * EPS * xs
    em, emr = match_multipliers(res.multipliers, fine.multipliers)
    e_sol_m = e_solver / xs * lam_max * _eig_condition(res.monodromy) if res.monodromy is not None else 0.0
    em = fac * em + e_sol_m + 16 * EPS * max(1.0, lam_max)
    emr = fac * emr + (e_sol_m + 16 * EPS * max(1.0, lam_max)) / max(1.0, lam_max)
    res.error_estimate = {"period": float(eT), "x0": float(ex), "multipliers": float(em), "solver": e_solver,
                          "trivial_multiplier_2N": float(fine.trivial_multiplier_error)}
    rel = max(eT / max(abs(res.period), 1e-300), ex / xs, emr)
    res.error_estimate["relative"] = float(rel)
    res.error_estimate["relative_solver"] = float(max(e_solver / max(abs(res.period), 1e-300), e_solver / xs,
                                                      e_sol_m / max(1.0, lam_max)))
    res.accurate = bool(rel <= accuracy)
    if not res.accurate:
        res.message += (f"; INACCURATE: estimated relative error {rel:.1e} > accuracy {accuracy:.0e} "
                        f"(increase steps_per_period or use steps_per_period=None)")


def failure_reason(traj, x_ref, normal, period, period_lo, period_hi, amplitude0) -> str:
    """Why a solve that did not converge failed, from its last iterate (empty if nothing is known):
    the period at a bound, a fixed section that the trajectory never meets, a trajectory collapsing
    onto an equilibrium.

    Parameters
    ----------
    traj : ndarray, shape (N + 1, nx)
        Trajectory of the last iterate.
    x_ref : ndarray
        Point of the phase condition.
    normal : ndarray
        Normal of the phase condition.
    period : float
        Period of the last iterate.
    period_lo, period_hi : float
        Bounds of the period.
    amplitude0 : float
        Amplitude of the guess.

    Returns
    -------
    str
    """
    reasons = []
    if np.isfinite(period) and (period <= period_lo * (1 + 1e-9) or period >= period_hi * (1 - 1e-9)):
        reasons.append(f"the period ran to its bound ({period:.4g}; OrbitMethod.period_bounds)")
    if traj is not None and normal is not None:
        s = (traj - x_ref) @ normal
        if np.all(s > 0) or np.all(s < 0):
            reasons.append("the phase section does not meet the trajectory (use OrbitMethod(phase='moving') "
                           "or a phase_point on the orbit)")
    if traj is not None and amplitude0 > 0:
        amp = float(np.max(np.abs(traj - traj[0])))
        if amp < 1e-3 * amplitude0:
            reasons.append(f"the iterate collapsed onto an equilibrium (amplitude {amp:.1e})")
    return "; ".join(reasons)
