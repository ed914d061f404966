"""The ``"monodromy"`` chord of the ``"newton-picard"`` solver (``OrbitMethod.chord``): Newton on the
periodicity residual of every state, the chord matrix from an approximate monodromy at the start,
improved by Broyden's update along the steps; each iteration then costs one pass of the state alone.

With ``r(x0) = P(x0) - x0`` (``P`` the one-period map of the RK4 grid) and ``M = dP/dx0`` the monodromy,
the Newton step is ``(I - M) dx = r``. The subspace chord of :mod:`birdocp.engine.newton_picard`
forms ``M`` only along the Newton states (two passes of ``p`` sensitivity directions) and treats the
complement by Picard sweeps, one sensitivity direction per iteration. Here the whole ``M`` is
approximated once, at the start, from the right-hand side's state Jacobian at every step's start
evaluated in batch (:func:`birdocp.engine.step_jacobians.frozen_monodromy`: each step's Jacobian is
RK4's step of the linearisation frozen over the step), and its inverse ``H`` is updated after every
step ``s`` by Broyden's ("good") rank-one formula ``H += (s - H y) (s^T H) / (s^T H y)`` with
``y = r_k - r_{k+1}``, so that the chord follows the Jacobian along the path (with the matrix of the
start alone, even exact, the error falls only linearly, by the Jacobian's change). The chord
only sets the rate of convergence: convergence is the residual's. When the residual falls by less
than :data:`~birdocp.engine.newton_picard.REFRESH_RATIO`, the chord is formed again at the current
iterate; when it falls by less than ``OrbitMethod.picard_max_rate`` three times in a row (or becomes
non-finite) the solve stops with status ``"not_contracting"`` at its best iterate (the solver table
then runs the full Newton from there). Statuses and the outcome are those of the subspace chord
(:class:`~birdocp.engine.newton_picard.NewtonPicardOutcome`; no Picard growth is recorded).

Measured on the ibis with dynamic stall (52 states, 148 steps; CPU time, one process): the state pass
0.073 s, the frozen monodromy 0.14 s (the exact one from the stage Jacobians 0.48 s, the same five
iterations from the benchmark's start); 0.58 s in all, where the subspace chord took 1.32 s (seven
iterations; its passes carry 1 to 4 sensitivity directions at 0.032 s each, and its chord needs two
passes of 4). The subspace chord stays the engine's default: it needs no state Jacobian at all and
wins when those are expensive against a pass (many states and a cheap right-hand side).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine import interrupts
from birdocp.engine.newton_picard import REFRESH_RATIO, NewtonPicardOutcome, shooting_unknowns
from birdocp.engine.step_jacobians import frozen_monodromy, step_start_jacobians

__all__ = ["newton_picard_monodromy", "monodromy_chord_available"]


def monodromy_chord_available(grid) -> bool:
    """Whether the grid's right-hand side has the SX state Jacobian the frozen monodromy needs (built
    here, once per grid); when not (e.g. a right-hand side without SX derivatives), the solver table
    runs the subspace chord instead.

    Parameters
    ----------
    grid : RK4Grid
        The grid.

    Returns
    -------
    bool
    """
    try:
        step_start_jacobians(grid)
    except Exception as e:  # noqa: BLE001 - any failure to build: the subspace chord
        interrupts.check_from(e)
        return False
    return True


class _Pass:
    """The state pass of one iterate: x0, x_T, the trajectory X and the residual r."""

    def __init__(self, grid, D, p, x):
        x_T, X, _ = (np.asarray(v) for v in grid.period_map(ca.DM(x), D, p))
        self.x, self.x_T, self.X = x, x_T.ravel(), X
        self.r = self.x_T - x
        self.max_residual = float(np.max(np.abs(self.r))) if np.all(np.isfinite(self.r)) else float("nan")


def newton_picard_monodromy(graphs, problem, z0, *, tol: float, max_iter: int,
                            max_rate: float = 0.5) -> NewtonPicardOutcome:
    """Chord Newton with a frozen monodromy at the start and Broyden's update (module docstring) from
    the multiple-shooting unknowns ``z0``.

    Parameters
    ----------
    graphs : ShootingGraphs
        The shooting graphs (grid; a problem with free parameters is refused).
    problem : OrbitProblem
        The problem (ODE, parameters, t0).
    z0 : ndarray
        Start: the shooting points (the first is used).
    tol : float
        Max-norm of the residual for convergence.
    max_iter : int
        Iteration limit.
    max_rate : float
        A residual that falls by less than this factor three times in a row is not converging.

    Returns
    -------
    NewtonPicardOutcome
    """
    if graphs.nf:
        raise ValueError("OrbitMethod.chord='monodromy' does not handle free parameters (mean conditions): "
                         "use chord 'subspace'")
    grid, p = graphs.grid, ca.DM(np.asarray(problem.p, float))
    D = grid.blocks_numeric(float(problem.t0), problem.p)
    st = _Pass(grid, D, p, np.asarray(z0, float)[:problem.ode.nx].copy())
    best, hist, it, jacobians, H, fresh = st, [st.max_residual], 0, 0, None, False
    status = "max_iter" if np.isfinite(hist[0]) else "nan"
    while status == "max_iter" and hist[-1] > tol and it < max_iter:
        interrupts.check()
        fresh = H is None or (not fresh and hist[-1] > REFRESH_RATIO * hist[-2])
        if fresh:
            H, jacobians = _chord(grid, st, D, p), jacobians + 1
            if H is None:
                status = "singular"
                break
        s = H @ st.r
        new = _Pass(grid, D, p, st.x + s)
        if np.isfinite(new.max_residual):
            H = _broyden(H, s, st.r - new.r)
        st, it = new, it + 1
        hist.append(st.max_residual)
        if np.isfinite(hist[-1]) and hist[-1] < best.max_residual:
            best = st
        if not np.isfinite(hist[-1]) or (len(hist) >= 4 and all(hist[-i] > max_rate * hist[-i - 1] for i in (1, 2, 3))):
            status = "not_contracting"
    if best.max_residual <= tol:
        status = "converged"
    z = shooting_unknowns(grid, best.x, best.X, best.x_T)
    return NewtonPicardOutcome(z, status, _message(status, it, hist, jacobians, max_rate), it, hist, [])


def _chord(grid, st: _Pass, D, p):
    """``(I - M)^-1`` at the iterate ``st`` (M the frozen monodromy), or None when it is singular or not
    finite."""
    A = np.eye(len(st.x)) - frozen_monodromy(grid, st.x, st.X, D, p)
    if not np.all(np.isfinite(A)):
        return None
    try:
        H = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        return None
    return H if np.all(np.isfinite(H)) else None


def _broyden(H, s, y):
    """Broyden's ("good") update of the inverse chord ``H ~ (I - M)^-1`` by the step ``s`` and the
    residual's fall ``y = r_k - r_{k+1}`` (``H_new y = s``); unchanged when ``s^T H y`` vanishes."""
    Hy = H @ y
    den = float(s @ Hy)
    if not abs(den) > 1e-14 * np.linalg.norm(s) * np.linalg.norm(Hy):
        return H
    return H + np.outer(s - Hy, s @ H) / den


def _message(status, it, hist, jacobians, max_rate) -> str:
    """One line: the outcome, the iterations, the residual, the monodromy evaluations."""
    ratio = f"{hist[-1] / hist[-2]:.3g}" if len(hist) >= 2 and hist[-2] > 0 else "n/a"
    head = {"converged": "converged", "max_iter": "iteration limit reached",
            "not_contracting": f"the chord iteration does not converge (residual ratio {ratio}, limit "
                               f"{max_rate:g} three times in a row, or a non-finite residual)",
            "singular": "I - M is singular", "nan": "non-finite residual"}[status]
    return (f"newton-picard: {head} after {it} iterations, max residual {hist[-1]:.2e} (monodromy chord: "
            f"{jacobians} frozen monodromy evaluation{'s' if jacobians != 1 else ''}, Broyden updates)")
