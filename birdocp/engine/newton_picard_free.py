"""Newton-Picard with free parameters held by period-mean conditions (the ``"newton-picard"`` solver of
:data:`birdocp.engine.shooting.SOLVERS` when the problem has ``free`` parameters, e.g. level flight
with the wingbeat amplitude free and the mean vertical speed held).

The free parameters ``p_f`` and the mean conditions ``m(x0, p_f) = q(x0, p_f) / T - target = 0`` join
the Newton subspace of :mod:`birdocp.engine.newton_picard`; the Picard part stays on the contracting
states. With ``r = x_T - x0``, ``M = dx_T/dx0`` (blocks on the Newton states P and the others F),
``X_p = dx_T/dp_f`` and ``Q_x = dm/dx0``, ``Q_p = dm/dp_f``, the Newton step solves

* fast rows ``b = (I - M_FF)^-1 (r_F + M_FP a + X_pF dp) ~ r_F + u_F + G a + H dp`` with
  ``G = M_FP + M_FF M_FP``, ``H = X_pF + M_FF X_pF`` (``u ~ M Q r_F`` as without free parameters);
* the reduced system on ``(a, dp)`` (``nP + nf`` unknowns): the Newton states' rows
  ``(I - M_PP - M_PF M_FP) a - (X_pP + M_PF X_pF) dp = r_P + u_P`` and the mean rows
  ``(Q_xP + Q_xF G) a + (Q_p + Q_xF H) dp = -m - Q_xF (r_F + u_F)``.

The chord matrices take two passes of the directional map (:func:`~birdocp.engine.newton_picard.directional_pass`):
``M V`` along the Newton states, then ``M Q W`` along the fast parts ``W = [M_FP, X_pF]``; the mean
rows' whole state Jacobian ``Q_x`` (a few rows) is one reverse sweep per condition
(:func:`mean_gradient`: the mean conditions may read every state, so ``Q_xF`` is not small the way
``M_FF`` is); ``X_p`` and ``Q_p`` are central differences of the period map in ``p_f`` (the
per-time data depends on the free parameters through the whole model; a chord matrix only sets the
rate of convergence, which is judged by the residual itself). The free parameters
are kept inside their bounds (a step is clipped), and a step that multiplies the residual by more
than :data:`GROWTH_LIMIT` (or makes it non-finite) is halved, up to :data:`HALVINGS` times. Every iterate evaluates the data at its own
``p_f`` (:meth:`~birdocp.engine.integrate.RK4Grid.blocks_numeric`, memoised). Convergence: the
max-norm of every periodicity and mean residual at most ``tol``; statuses as without free
parameters (``"not_contracting"`` hands over to the full Newton in the solver table).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.newton_picard import (ChordOps, NewtonPicardOutcome, chord_iterations, directional_pass,
                                          outcome_message, shooting_unknowns)

__all__ = ["newton_picard_free", "mean_gradient", "FD_STEP", "GROWTH_LIMIT", "HALVINGS"]

FD_STEP = 1e-6
"""Relative step of the central differences in the free parameters (``h = FD_STEP (1 + |p_f|)``)."""

GROWTH_LIMIT = 2.0
"""A step whose residual (max-norm) exceeds this factor times the previous one is halved."""
HALVINGS = 6
"""At most this many halvings of a step (the last trial is taken whatever its residual)."""


def mean_gradient(grid: RK4Grid, nm: int) -> ca.Function:
    """``(x0, D, p) -> dq[:nm]/dx0`` (nm x nx): the gradients of the first ``nm`` output integrals over
    the period with respect to the start state, by reverse AD through the one-period map (one
    reverse sweep per output: the mean rows' whole state Jacobian for the cost of a few state
    passes). Built once per grid and ``nm`` (kept while the grid lives); an ODE compiled to C is
    differentiated through its interpreted source.

    Parameters
    ----------
    grid : RK4Grid
        The grid (steps per period, outputs).
    nm : int
        Number of leading outputs (the mean conditions).

    Returns
    -------
    casadi.Function
    """
    return owned_cache(grid).build(("mean_gradient", int(nm)), lambda: _build_mean_gradient(grid, int(nm)))


def _build_mean_gradient(grid: RK4Grid, nm: int) -> ca.Function:
    """:func:`mean_gradient`, built."""
    src = getattr(grid.ode.numeric, "source", None)
    g = RK4Grid(src, grid.N, grid.S, grid.outputs) if src is not None else grid
    x, D, p = ca.MX.sym("x", g.ode.nx), ca.MX.sym("D", g.ode.nd, 3 * g.N), ca.MX.sym("p", g.ode.np)
    q = g.period_map(x, D, p)[2][:nm]
    Jt = ca.jtimes(q, x, ca.DM.eye(nm), True)  # nx x nm, reverse mode
    return ca.Function("mean_gradient", [x, D, p], [Jt.T], ["x", "D", "p"], ["dq_dx"])


@dataclass
class _FreeState:
    """One iterate: x0, the free values, the pass's x_T and trajectory X, the residuals r and m."""

    x: np.ndarray
    pf: np.ndarray
    x_T: np.ndarray
    X: np.ndarray
    r: np.ndarray
    m: np.ndarray

    @property
    def max_residual(self) -> float:
        """Max-norm of the periodicity and mean residuals."""
        v = np.concatenate([self.r, self.m])
        return float(np.max(np.abs(v))) if np.all(np.isfinite(v)) else float("nan")


class _FreeIteration:
    """The shooting problem with free parameters: grid, index split, data at each free value."""

    def __init__(self, graphs, problem, newton_states, lo, hi):
        self.grid, self.t0 = graphs.grid, float(problem.t0)
        self.p0 = np.asarray(problem.p, float).copy()
        self.free = list(graphs.free_idx)
        self.nm, self.T = graphs.nm, float(problem.ode.forcing_period)
        self.targets = np.array([c.target for c in problem.means], float)
        self.lo, self.hi = np.asarray(lo, float), np.asarray(hi, float)
        nx = problem.ode.nx
        idx = sorted({int(i) for i in newton_states})
        if not idx or idx[0] < 0 or idx[-1] >= nx:
            raise ValueError(f"OrbitMethod.newton_states must name state indices in [0, {nx}), got {newton_states!r}")
        self.P = np.array(idx, int)
        self.F = np.array([i for i in range(nx) if i not in set(idx)], int)
        self.pass_P = directional_pass(self.grid, len(idx))
        self.pass_W = directional_pass(self.grid, len(idx) + len(self.free))
        self.pass_1 = directional_pass(self.grid, 1)
        self.grad = mean_gradient(self.grid, self.nm)

    def data(self, pf):
        """(p, D): the full parameter vector and the stage data at the free values ``pf``."""
        p = self.p0.copy()
        p[self.free] = pf
        return ca.DM(p), self.grid.blocks_numeric(self.t0, p)

    def _of(self, x, pf, x_T, X, q) -> _FreeState:
        m = np.asarray(q, float).ravel()[:self.nm] / self.T - self.targets
        return _FreeState(x, np.asarray(pf, float), x_T.ravel(), X, x_T.ravel() - x, m)

    def state(self, x, pf) -> _FreeState:
        """The state pass at (x0, p_f)."""
        p, D = self.data(pf)
        x_T, X, q = (np.asarray(v) for v in self.grid.period_map(ca.DM(x), D, p))
        return self._of(x, pf, x_T, X, q)

    def state_along(self, x, pf, seed):
        """The state pass with the one direction ``Q seed``: (state, ``M Q seed``)."""
        p, D = self.data(pf)
        Y = np.zeros((len(x), 1))
        Y[self.F, 0] = seed
        x_T, MY, q, _, X = (np.asarray(v) for v in self.pass_1(ca.DM(x), ca.DM(Y), D, p))
        return self._of(x, pf, x_T, X, q), MY.ravel()


def newton_picard_free(graphs, problem, z0, newton_states, lo, hi, *, tol: float, max_iter: int,
                       max_rate: float = 0.5) -> NewtonPicardOutcome:
    """Newton-Picard iterations with free parameters (module docstring) from the unknowns ``z0``.

    Parameters
    ----------
    graphs : ShootingGraphs
        The shooting graphs (grid, free parameters, one mean condition per free parameter).
    problem : OrbitProblem
        The problem (ODE, parameters, t0, mean conditions).
    z0 : ndarray
        Start: the shooting points (the first is used), then the free values.
    newton_states : sequence of int
        Indices of the states of the Newton subspace; the others are iterated by Picard.
    lo, hi : ndarray
        Bounds of the free parameters.
    tol : float
        Max-norm of the residual (periodicity and means) for convergence.
    max_iter : int
        Iteration limit.
    max_rate : float
        Largest acceptable growth per period of the Picard complement along its direction.

    Returns
    -------
    NewtonPicardOutcome
        ``z`` holds the shooting points then the free values of the best iterate.
    """
    pb = _FreeIteration(graphs, problem, newton_states, lo, hi)
    z0 = np.asarray(z0, float)
    nx, nf = problem.ode.nx, len(pb.free)
    st = pb.state(z0[:nx].copy(), np.clip(z0[len(z0) - nf:], pb.lo, pb.hi))
    ops = ChordOps(lambda s: _free_reduced(pb, s), lambda s, seed: pb.state_along(s.x, s.pf, seed)[1],
                   lambda s, seed, w: _free_picard_term(pb, s, seed, w),
                   lambda s, red, u: _free_step(pb, s, red, u),
                   lambda s, move, seed: _damped(pb, s, move[0], move[1], seed))
    best, status, it, hist, rates = chord_iterations(st, pb.F, ops, tol=tol, max_iter=max_iter, max_rate=max_rate)
    z = np.concatenate([shooting_unknowns(pb.grid, best.x, best.X, best.x_T), best.pf])
    return NewtonPicardOutcome(z, status, outcome_message(status, it, hist, rates, max_rate), it, hist, rates)


def _damped(pb: _FreeIteration, st: _FreeState, dx, pf, seed):
    """The pass at ``st + dx`` (free values ``pf``); while its residual is non-finite or more than
    :data:`GROWTH_LIMIT` times ``st``'s, the step is halved (at most :data:`HALVINGS` times: far from
    the cycle a full Newton step of a nonlinear mean condition can overshoot)."""
    lam = 1.0
    for _ in range(HALVINGS + 1):
        out = pb.state_along(st.x + lam * dx, st.pf + lam * (pf - st.pf), seed)
        res = out[0].max_residual
        if np.isfinite(res) and res <= GROWTH_LIMIT * st.max_residual:
            break
        lam *= 0.5
    return out


def _free_fd(pb: _FreeIteration, st: _FreeState):
    """``X_p`` (nx x nf) and ``Q_p`` (nm x nf) at ``st`` by central differences in the free values."""
    cols_x, cols_m = [], []
    for k in range(len(pb.free)):
        h = FD_STEP * (1.0 + abs(float(st.pf[k])))
        e = np.zeros(len(pb.free))
        e[k] = h
        up, dn = pb.state(st.x, st.pf + e), pb.state(st.x, st.pf - e)
        cols_x.append((up.x_T - dn.x_T) / (2 * h))
        cols_m.append((up.m - dn.m) / (2 * h))
    return np.column_stack(cols_x), np.column_stack(cols_m)


def _free_reduced(pb: _FreeIteration, st: _FreeState):
    """The chord matrices at ``st`` (module docstring): the reduced matrix on (a, dp), the fast
    states' responses ``G`` to the Newton states and ``H`` to the free parameters, and the mean rows'
    state Jacobian ``Q_x`` (reverse AD)."""
    P, F, nx, nP, T = pb.P, pb.F, len(st.x), len(pb.P), pb.T
    p, D = pb.data(st.pf)
    V = np.zeros((nx, nP))
    V[P, np.arange(nP)] = 1.0
    MV = np.asarray(pb.pass_P(ca.DM(st.x), ca.DM(V), D, p)[1])
    Xp, Qp = _free_fd(pb, st)
    W = np.zeros((nx, nP + len(pb.free)))
    W[F, :nP], W[F, nP:] = MV[F], Xp[F]
    MW = np.asarray(pb.pass_W(ca.DM(st.x), ca.DM(W), D, p)[1])
    Qx = np.asarray(pb.grad(ca.DM(st.x), D, p)) / T
    G, H = MV[F] + MW[F, :nP], Xp[F] + MW[F, nP:]
    top = np.hstack([np.eye(nP) - MV[P] - MW[P, :nP], -(Xp[P] + MW[P, nP:])])
    bottom = np.hstack([Qx[:, P] + Qx[:, F] @ G, Qp + Qx[:, F] @ H])
    return np.vstack([top, bottom]), G, H, Qx[:, F]


def _free_picard_term(pb: _FreeIteration, st: _FreeState, seed, w):
    """``u ~ M Q r_F`` at ``st`` from ``w = M Q seed`` (the pass along the previous residual's fast
    part): ``u = w (seed . r_F) / |seed|^2``; and the complement's growth ``|Q^T w| / |seed|``."""
    ns2 = float(seed @ seed)
    if not ns2 > 0:
        return np.zeros(len(st.x)), float("nan")
    return w * (float(seed @ st.r[pb.F]) / ns2), float(np.linalg.norm(w[pb.F]) / np.sqrt(ns2))


def _free_step(pb: _FreeIteration, st: _FreeState, reduced, u):
    """The step at ``st``: (dx, the new free values clipped to their bounds)."""
    J, G, H, QxF = reduced
    P, F, nP = pb.P, pb.F, len(pb.P)
    sol = np.linalg.solve(J, np.concatenate([st.r[P] + u[P], -st.m - QxF @ (st.r[F] + u[F])]))
    a, dp = sol[:nP], sol[nP:]
    pf = np.clip(st.pf + dp, pb.lo, pb.hi)
    dp = pf - st.pf
    dx = np.zeros(len(st.x))
    dx[P] = a
    dx[F] = st.r[F] + u[F] + G @ a + H @ dp
    return dx, pf
