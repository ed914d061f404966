"""The engine's one Levenberg-Marquardt solver for square or over-determined shooting systems.

``levenberg_marquardt(system, z, ...)`` minimises ``|g(z)|_2^2`` with the exact Jacobian J of the
system (``system.evaluate(z) -> (g, J)``). The step solves ``(J^T J + lam D) dz = -J^T g`` with
Marquardt's scaling ``D = diag(J^T J)`` (zero entries replaced by 1), then the iterate is clipped to
the bounds ``lo <= z <= hi``. Two step-acceptance rules, named by ``accept``:

* ``"decrease"`` (default): a step is kept only if it lowers ``|g|_2``; then ``lam /= 10``, else
  ``lam *= 10`` and the step is recomputed (at most 12 times per iteration, then ``"stalled"``).
  A globalised Newton: far from the solution it takes short, gradient-like steps, near it Newton
  steps (quadratic convergence).
* ``"always"``: every step is kept (``lam /= 10`` if the max residual went down, else ``x 10``),
  the Algorithm 1 of the reference paper, kept for :class:`~birdocp.engine.method.OrbitMethod` on an ODE with data
  and ``solver="lm"`` so that its published iteration counts are reproduced.

``prepare(z)`` (optional) is called at every accepted iterate before its step: the orbit solver uses
it to re-anchor its Poincare section at the current iterate (the phase row then reads 0 there).
The iteration also stops as ``"stalled"`` when the max residual has fallen by less than a factor
``stall_factor`` over the last ``stall_window`` iterations (a solve that crawls will not converge
within any sensible budget), and as ``"time_limit"`` when ``deadline`` (a ``time.perf_counter()``
value) has passed.

Returns :class:`LMOutcome` ``(z, status, message, iterations, history)``; ``status`` is
``"converged"`` (max |g| <= tol), ``"max_iter"``, ``"stalled"``, ``"time_limit"``, ``"nan"`` or
``"singular"``; ``history`` holds max |g| at the start and after each iteration.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from birdocp.engine import interrupts

__all__ = ["LMOutcome", "levenberg_marquardt"]


class LMOutcome(NamedTuple):
    """What :func:`levenberg_marquardt` returns."""

    z: np.ndarray
    status: str
    message: str
    iterations: int
    history: list


def _maxabs(g) -> float:
    return float(np.max(np.abs(g))) if np.size(g) else 0.0


def _step(J, g, lam, scale_zero_to_one: bool):
    A = J.T @ J
    d = np.diag(A).copy()
    if scale_zero_to_one:
        d[d == 0] = 1.0
    return np.linalg.solve(A + lam * np.diag(d), -J.T @ g)


def levenberg_marquardt(system, z, *, tol: float, max_iter: int, lo=None, hi=None, accept: str = "decrease",
                        lam0: float = 1.0, prepare=None, deadline: float | None = None,
                        stall_window: int = 30, stall_factor: float = 10.0, jacobian=None, symbol: str = "g",
                        residual=None) -> LMOutcome:
    """Solve ``g(z) = 0`` in the least-squares sense (see the module docstring).

    Parameters
    ----------
    system
        Has ``evaluate(z) -> (g, J)`` (residual vector and its Jacobian, numpy).
    z : array
        The start (copied).
    tol : float
        Convergence: ``max |g| <= tol`` (``"always"``: ``< tol``, as the paper's algorithm).
    max_iter : int
        Iteration limit.
    lo, hi : array, optional
        Bounds on z (entries may be infinite); ``None`` for none.
    accept : {"decrease", "always"}
        The step-acceptance rule.
    lam0 : float
        The initial damping (relative to Marquardt's scaling). 1 (the paper's value) starts
        cautiously: from the reference toolbox's own guesses (isothermal oscillator, Goodwin,
        Lorenz) 1e-8 ran into a local minimum of |g| where 1 converged.
    prepare : callable, optional
        ``prepare(z)`` at every accepted iterate, before its residual is used for a step.
    deadline : float, optional
        ``time.perf_counter()`` value after which the iteration stops (``"time_limit"``).
    stall_window, stall_factor
        Stop as ``"stalled"`` when max |g| fell by less than ``stall_factor`` over
        ``stall_window`` iterations (``stall_window=0``: never).
    jacobian : callable, optional
        ``jacobian(z, g) -> J`` replacing ``system.evaluate``'s Jacobian (e.g. finite differences);
        the residual then comes from ``system.resid(z)``.
    symbol : str
        The residual's name in the messages (``max|g| = ...``).
    residual : callable, optional
        ``residual(z) -> g`` without the Jacobian, for the trial steps of the ``"decrease"`` rule
        (a rejected step then costs no Jacobian).

    Returns
    -------
    LMOutcome
        ``(z, status, message, iterations, history)``.
    """
    if accept not in ("decrease", "always"):
        raise ValueError(f"levenberg_marquardt: accept must be 'decrease' or 'always', got {accept!r}")
    z = np.array(z, float)
    resid = system.resid if jacobian is not None else (lambda v: system.evaluate(v)[0])
    if prepare is not None:
        prepare(z)
    g = resid(z)
    hist = [_maxabs(g)]
    lam, it = lam0, 0
    while True:
        interrupts.check()  # a Ctrl-C swallowed by a CasADi call in the last step
        stop = _verdict(z, g, hist, it, tol, max_iter, accept, deadline, stall_window, stall_factor, symbol)
        if stop is not None:
            return stop
        J = jacobian(z, g) if jacobian is not None else system.evaluate(z)[1]
        if not np.all(np.isfinite(J)):
            return LMOutcome(z, "nan", "non-finite Jacobian", it, hist)
        it += 1
        if accept == "always":
            z, g, lam, bad = _always_step(resid, J, g, z, lam, lo, hi, hist)
            if bad:
                return LMOutcome(z, "singular", bad, it - 1, hist)
        else:
            out = _decreasing_step(residual or resid, J, g, z, lam, lo, hi)
            if out is None:
                return LMOutcome(z, "stalled", f"no decreasing step, max|g| = {hist[-1]:.2e}", it, hist)
            z, g, lam = out
            if prepare is not None:
                prepare(z)
                g = resid(z)
        hist.append(_maxabs(g) if np.all(np.isfinite(g)) else float("nan"))


def _verdict(z, g, hist, it, tol, max_iter, accept, deadline, stall_window, stall_factor, symbol):
    """The LMOutcome that ends the iteration at this iterate, or None to go on."""
    if not np.all(np.isfinite(g)) or not np.all(np.isfinite(z)):
        return LMOutcome(z, "nan", "non-finite residual or iterate", it, hist)
    if (hist[-1] < tol) if accept == "always" else (hist[-1] <= tol):
        rel = "<" if accept == "always" else "<="
        return LMOutcome(z, "converged", f"max|{symbol}| = {hist[-1]:.3e} {rel} tol = {tol:.1e}", it, hist)
    if it >= max_iter:
        return LMOutcome(z, "max_iter", f"max_iter={max_iter} reached, max|{symbol}| = {hist[-1]:.3e}", it, hist)
    if deadline is not None and time.perf_counter() > deadline:
        return LMOutcome(z, "time_limit", f"time limit reached after {it} iterations, max|{symbol}| = {hist[-1]:.3e}",
                         it, hist)
    if stall_window and it >= stall_window and hist[-1] * stall_factor > hist[-1 - stall_window]:
        return LMOutcome(z, "stalled", f"max|{symbol}| fell by less than {stall_factor:g}x in {stall_window} "
                                       f"iterations (now {hist[-1]:.3e})", it, hist)
    return None


def _always_step(resid, J, g, z, lam, lo, hi, hist):
    """The paper's rule: take the step, then adapt lam on the max residual."""
    try:
        dz = _step(J, g, lam, False)
    except np.linalg.LinAlgError as e:
        return z, g, lam, f"singular shooting matrix: {e}"
    if not np.all(np.isfinite(dz)):
        return z, g, lam, "singular shooting matrix (non-finite step)"
    z = z + dz
    if lo is not None:
        z = np.clip(z, lo, hi)
    g = resid(z)
    err = _maxabs(g) if np.all(np.isfinite(g)) else float("inf")
    lam = lam / 10 if err < hist[-1] else lam * 10
    return z, g, lam, None


def _decreasing_step(resid, J, g, z, lam, lo, hi):
    """Up to 12 damped steps until one lowers |g|_2; None if none does."""
    n2 = float(g @ g)
    for _ in range(12):
        try:
            dz = _step(J, g, lam, True)
        except np.linalg.LinAlgError:
            lam *= 10
            continue
        zn = z + dz
        if lo is not None:
            zn = np.clip(zn, lo, hi)
        gn = resid(zn)
        if np.all(np.isfinite(gn)) and float(gn @ gn) < n2:
            return zn, gn, max(lam / 10, 1e-12)
        lam *= 10
    return None
