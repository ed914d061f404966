"""Newton-Picard for the periodic orbits of a forced ODE with data (:class:`~birdocp.engine.ode.ODE`) whose state splits into a few
dominant states and many strongly contracting ones (the ``"newton-picard"`` entry of the solver table
:data:`birdocp.engine.shooting.SOLVERS`).

The method of Lust, Roose, Spence & Champneys (1998, SIAM J. Sci. Comput. 19, "An adaptive
Newton-Picard algorithm with subspace iteration for computing periodic solutions"), with the
dominant subspace spanned by coordinate directions the caller names (``OrbitMethod.newton_states``,
e.g. the rigid-body states of a flier whose aerodynamic lag states are strongly damped). With
``x_T = P(x0)`` the one-period map, ``r = x_T - x0`` the periodicity residual, ``V`` the Newton
coordinates, ``Q`` the others and ``M = dP/dx0`` (blocks ``M_PP, M_PF, M_FP, M_FF``), the Newton
step ``(I - M) dx = r`` is solved through its Schur complement on the Newton states, with
``(I - M_FF)^-1`` replaced by its first Neumann terms ``I + M_FF`` (the Picard sweeps of the
contracting part):

* the chord matrices, at the start and again whenever the residual fell by less than
  :data:`REFRESH_RATIO`: ``G = M_FP + M_FF M_FP`` (the fast states' response to the Newton states)
  and ``J = I - M_PP - M_PF M_FP`` (two forward-AD passes of ``p`` directions, ``M V`` then
  ``M Q Q^T M V``: RK4 steps of the state and of its sensitivity along the seeds, the exact
  derivative of the discrete map);
* every iteration: ``a = J^-1 (r_P + u_P)``, ``b = r_F + u_F + G a``, ``x0 += V a + Q b`` with
  ``u ~ M Q r_F``; then one pass over the period at the new x0, the state and one sensitivity
  direction: ``r`` and ``w = M Q s`` along the previous residual's fast part ``s`` (the residuals of
  a linearly converging iteration line up, as in a power iteration), so that the next
  ``u = w (s . r_F) / |s|^2``. The first iteration takes ``u = M Q r_F`` itself (one more pass).

The error falls by about the square of the complement's contraction per iteration (plus the chord's
error and that of ``u``). The growth of the complement along its current direction,
``|Q^T M Q s| / |s|`` (a power-iteration estimate of its spectral radius), is recorded at every
iteration; when it stays above ``OrbitMethod.picard_max_rate`` (twice in a row), or the residual
falls by less than that factor three times in a row, or becomes non-finite, the complement is not
contracting enough and the solve stops with status ``"not_contracting"`` at its best iterate (the
solver table's entry then runs the full Newton from there). Convergence is the max-norm of the full
residual (every state) at most ``tol``: on the multiple-shooting points built from the trajectory the continuity equations hold
to round-off and the periodicity rows are ``r``. Free parameters held by mean conditions:
:mod:`birdocp.engine.newton_picard_free` (they join the Newton subspace).

Cost per iteration: one pass over the period with one sensitivity direction (against ``nx`` for the
full Newton), plus two passes of ``p`` directions whenever the chord matrices are refreshed; the exact
monodromy (all multipliers) is then one full variational pass at the converged cycle. Measured on the
ibis with Wagner lags (36 states, 4 Newton states), CPU time: the state alone over the period 0.022 s,
with 4 directions 0.054 s, the full variational pass 0.35 s.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.engine import interrupts
from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.rk4 import accumulate

__all__ = ["newton_picard", "NewtonPicardOutcome", "ChordOps", "chord_iterations", "directional_pass",
           "shooting_unknowns", "REFRESH_RATIO", "not_contracting", "outcome_message"]

REFRESH_RATIO = 0.25
"""The chord matrices are recomputed at an iterate whose residual fell by less than this factor."""


@dataclass
class NewtonPicardOutcome:
    """The end of a Newton-Picard solve.

    Attributes
    ----------
    z : ndarray
        The unknowns of the multiple-shooting formulation (the points from the trajectory) at the
        best iterate (smallest residual).
    status : str
        ``"converged"``, ``"max_iter"``, ``"not_contracting"``, ``"singular"`` (the reduced Newton
        matrix) or ``"nan"``.
    message : str
        What happened, with the last residual and the contraction estimate.
    iterations : int
        Newton-Picard iterations.
    history : list of float
        Max-norm of the residual at every iterate (the start included).
    picard_rates : list of float
        ``|Q^T M Q s| / |s|`` at every iteration (the complement's growth along the seed s, the
        previous residual's fast part; NaN when ``s = 0``).
    """

    z: np.ndarray
    status: str
    message: str
    iterations: int
    history: list = field(default_factory=list)
    picard_rates: list = field(default_factory=list)


def directional_pass(grid: RK4Grid, directions: int) -> ca.Function:
    """The one-period map with its derivatives along ``directions`` seed vectors, the output
    integrals with theirs, and the trajectory: ``(x0, Y[nx x d], D, p) -> (x_T, M Y, q, dq/dx0 Y,
    X[nx x N])``.

    RK4 steps of the state and of its sensitivity along the seeds (forward AD of the grid's step,
    ``casadi.jtimes``: the exact derivative of the discrete map), accumulated over the period. Built
    once per grid and number of directions (kept while the grid lives). An ODE compiled to C
    (``numeric.source``) is differentiated through its interpreted source.

    Parameters
    ----------
    grid : RK4Grid
        The grid (its step, steps per period and outputs).
    directions : int
        Number of seed vectors d.

    Returns
    -------
    casadi.Function
    """
    d = int(directions)
    return owned_cache(grid).build(("directional_pass", d), lambda: _build_pass(grid, d))


def _build_pass(grid: RK4Grid, d: int) -> ca.Function:
    """:func:`directional_pass`, built."""
    src = getattr(grid.ode.numeric, "source", None)
    g = RK4Grid(src, grid.N, grid.S, grid.outputs) if src is not None else grid
    ode = g.ode
    nx, nd, nq = ode.nx, ode.nd, g.nq
    s = ca.SX.sym("s", nx + nx * d + nq + nq * d)
    D3, p = ca.SX.sym("D3", nd, 3), ca.SX.sym("p", ode.np)
    x, Y = s[:nx], ca.reshape(s[nx:nx + nx * d], nx, d)
    k = nx + nx * d
    xn, qi = g.step(x, D3, p, g.h)
    out = [xn, ca.vec(ca.jtimes(xn, x, Y)), s[k:k + nq] + qi, s[k + nq:] + ca.vec(ca.jtimes(qi, x, Y))]
    step = ca.Function("rk4_directional_step", [s, D3, p], [ca.vertcat(*out)])
    x0, Ym = ca.MX.sym("x", nx), ca.MX.sym("Y", nx, d)
    Dm, pm = ca.MX.sym("D", nd, 3 * g.N), ca.MX.sym("p", ode.np)
    s0 = ca.vertcat(x0, ca.vec(Ym), ca.DM.zeros(nq + nq * d))
    Sall = accumulate(step, g.N, s0, Dm, pm, name="directional_acc")[0]
    S = Sall[:, -1]
    outs = [S[:nx], ca.reshape(S[nx:k], nx, d), S[k:k + nq], ca.reshape(S[k + nq:], nq, d), Sall[:nx, :]]
    return ca.Function("directional_pass", [x0, Ym, Dm, pm], outs, ["x", "Y", "D", "p"],
                       ["x_T", "MY", "q", "dq", "X"])


def shooting_unknowns(grid: RK4Grid, x0, X, x_T) -> np.ndarray:
    """The multiple-shooting unknowns z of the orbit through ``x0`` (no free parameters): the
    shooting points taken from the trajectory ``X`` (states after each RK4 step) at the segment ends,
    then the closing point ``x_T``.

    Parameters
    ----------
    grid : RK4Grid
        The grid (segments and steps per segment).
    x0 : ndarray (nx,)
        The state at t0.
    X : ndarray (nx, N)
        The states after each of the N steps.
    x_T : ndarray (nx,)
        The state after one period.

    Returns
    -------
    ndarray
    """
    pts = [np.asarray(x0, float)] + [np.asarray(X)[:, grid.n * (i + 1) - 1] for i in range(grid.S - 1)]
    return np.concatenate(pts + [np.asarray(x_T, float)])


@dataclass
class _State:
    """One iterate: x0, the pass's x_T and trajectory X, the residual r = x_T - x0."""

    x: np.ndarray
    x_T: np.ndarray
    X: np.ndarray
    r: np.ndarray

    @property
    def max_residual(self) -> float:
        """Max-norm of the periodicity residual."""
        return float(np.max(np.abs(self.r))) if np.all(np.isfinite(self.r)) else float("nan")


class _Iteration:
    """What the iteration needs of the shooting problem: the grid, the data, the index split."""

    def __init__(self, graphs, problem, newton_states):
        if graphs.nf:
            raise ValueError("OrbitMethod.solver='newton-picard' does not handle free parameters (mean "
                             "conditions): use solver 'ipopt' or 'lm'")
        self.grid = graphs.grid
        self.p = ca.DM(np.asarray(problem.p, float))
        self.D = self.grid.blocks_numeric(float(problem.t0), problem.p)
        nx = problem.ode.nx
        idx = sorted({int(i) for i in newton_states})
        if not idx or idx[0] < 0 or idx[-1] >= nx:
            raise ValueError(f"OrbitMethod.newton_states must name state indices in [0, {nx}), got {newton_states!r}")
        self.P = np.array(idx, int)
        self.F = np.array([i for i in range(nx) if i not in set(idx)], int)
        self.pass_p = directional_pass(self.grid, len(idx))
        self.pass_1 = directional_pass(self.grid, 1)

    def state(self, x) -> _State:
        """The state pass at x0."""
        x_T, X, _ = (np.asarray(v) for v in self.grid.period_map(ca.DM(x), self.D, self.p))
        return _State(x, x_T.ravel(), X, x_T.ravel() - x)

    def state_along(self, x, seed):
        """The state pass at x0 with the one direction ``Q seed``: (state, ``M Q seed``)."""
        Y = np.zeros((len(x), 1))
        Y[self.F, 0] = seed
        x_T, MY, _, _, X = (np.asarray(v) for v in self.pass_1(ca.DM(x), ca.DM(Y), self.D, self.p))
        return _State(x, x_T.ravel(), X, x_T.ravel() - x), MY.ravel()


def newton_picard(graphs, problem, z0, newton_states, *, tol: float, max_iter: int,
                  max_rate: float = 0.5) -> NewtonPicardOutcome:
    """Newton-Picard iterations (module docstring) from the multiple-shooting unknowns ``z0``.

    Parameters
    ----------
    graphs : ShootingGraphs
        The shooting graphs (grid; a problem with free parameters is refused).
    problem : OrbitProblem
        The problem (ODE, parameters, t0).
    z0 : ndarray
        Start: the shooting points (the first is used).
    newton_states : sequence of int
        Indices of the states of the Newton subspace; the others are iterated by Picard.
    tol : float
        Max-norm of the residual for convergence.
    max_iter : int
        Iteration limit.
    max_rate : float
        Largest acceptable growth per period of the Picard complement along its direction (see the
        module docstring for ``"not_contracting"``).

    Returns
    -------
    NewtonPicardOutcome
    """
    pb = _Iteration(graphs, problem, newton_states)
    st = pb.state(np.asarray(z0, float)[:problem.ode.nx].copy())
    ops = ChordOps(lambda s: _reduced(pb, s), lambda s, seed: pb.state_along(s.x, seed)[1],
                   lambda s, seed, w: _picard_term(pb, s, seed, w), lambda s, red, u: _step(pb, s, red, u),
                   lambda s, dx, seed: pb.state_along(s.x + dx, seed))
    best, status, it, hist, rates = chord_iterations(st, pb.F, ops, tol=tol, max_iter=max_iter, max_rate=max_rate)
    z = shooting_unknowns(pb.grid, best.x, best.X, best.x_T)
    return NewtonPicardOutcome(z, status, outcome_message(status, it, hist, rates, max_rate), it, hist, rates)


@dataclass(frozen=True)
class ChordOps:
    """The five operations of a Newton-Picard iteration that depend on the unknowns (a cycle, or a cycle
    with free parameters), for :func:`chord_iterations`.

    ``reduced(state)``: the chord matrices; ``along(state, seed)``: ``M Q seed`` at the state;
    ``picard(state, seed, w)``: the Picard term ``u`` and the complement's growth; ``step(state, reduced,
    u)``: the Newton move; ``advance(state, move, seed)``: the next state and its ``M Q seed``.
    """

    reduced: object
    along: object
    picard: object
    step: object
    advance: object


def chord_iterations(st, fast, ops: ChordOps, *, tol: float, max_iter: int, max_rate: float):
    """The Newton-Picard loop shared by the fixed and the free-parameter iterations: chord matrices
    refreshed when the residual stops falling by :data:`REFRESH_RATIO`, the Picard term along the last
    fast residual, the Newton move, and the contraction test (:func:`not_contracting`).

    Parameters
    ----------
    st : object
        The start state (``max_residual``, ``r``).
    fast : sequence of int
        Indices of the Picard (fast) states in the residual ``st.r``.
    ops : ChordOps
        The operations on states of this kind.
    tol : float
        Max-norm of the residual for convergence.
    max_iter : int
        Iteration limit.
    max_rate : float
        Largest acceptable growth per period of the Picard complement.

    Returns
    -------
    tuple
        ``(best state, status, iterations, residual history, growth rates)``; status ``"converged"``,
        ``"max_iter"``, ``"nan"``, ``"singular"`` or ``"not_contracting"``.
    """
    best, hist, rates, it, reduced, fresh = st, [st.max_residual], [], 0, None, False
    status = "nan" if not np.isfinite(hist[0]) else "max_iter"
    seed, w = None, None
    while status == "max_iter" and hist[-1] > tol and it < max_iter:
        interrupts.check()
        if reduced is None or (not fresh and hist[-1] > REFRESH_RATIO * hist[-2]):
            reduced, fresh = ops.reduced(st), True
        else:
            fresh = False
        if seed is None:  # the first iteration: M Q r_F itself
            seed = st.r[fast]
            w = ops.along(st, seed)
        u, rate = ops.picard(st, seed, w)
        rates.append(rate)
        seed = st.r[fast]
        try:
            move = ops.step(st, reduced, u)
        except np.linalg.LinAlgError:
            status = "singular"
            break
        st, w = ops.advance(st, move, seed)
        it += 1
        hist.append(st.max_residual)
        if np.isfinite(hist[-1]) and hist[-1] < best.max_residual:
            best = st
        if not_contracting(hist, rates, max_rate):
            status = "not_contracting"
    if best.max_residual <= tol:
        status = "converged"
    return best, status, it, hist, rates


def not_contracting(hist, rates, max_rate) -> bool:
    """Whether the complement does not contract enough: a non-finite residual, the Picard growth above
    ``max_rate`` twice in a row, or the residual falling by less than ``max_rate`` three times in a row
    (converging, it falls by about the square of the complement's contraction).

    Parameters
    ----------
    hist : list of float
        Max-norm of the residual at every iterate.
    rates : list of float
        The complement's growth at every iteration.
    max_rate : float
        Largest acceptable growth per period.

    Returns
    -------
    bool
    """
    if not np.isfinite(hist[-1]):
        return True
    if len(rates) >= 2 and min(rates[-2:]) > max_rate:
        return True
    return len(hist) >= 4 and all(hist[-i] > max_rate * hist[-i - 1] for i in (1, 2, 3))


def _reduced(pb: _Iteration, st: _State):
    """The chord matrices at ``st``: the reduced Newton matrix ``I - M_PP - M_PF G`` and the fast
    states' response ``G = (I - M_FF)^-1 M_FP ~ M_FP + M_FF M_FP`` to the Newton states (two passes of
    p directions: ``M V``, then ``M Q Q^T M V``; ``M_PF M_FF M_FP`` is left out)."""
    P, F, nx = pb.P, pb.F, len(st.x)
    V = np.zeros((nx, len(P)))
    V[P, np.arange(len(P))] = 1.0
    MV = np.asarray(pb.pass_p(ca.DM(st.x), ca.DM(V), pb.D, pb.p)[1])
    W = np.zeros_like(V)
    W[F] = MV[F]
    MW = np.asarray(pb.pass_p(ca.DM(st.x), ca.DM(W), pb.D, pb.p)[1])
    return np.eye(len(P)) - MV[P] - MW[P], MV[F] + MW[F]


def _picard_term(pb: _Iteration, st: _State, seed, w):
    """``u ~ M Q r_F`` at ``st`` from ``w = M Q seed`` (the pass along the previous residual's fast
    part): ``u = w (seed . r_F) / |seed|^2``; and the complement's growth ``|Q^T w| / |seed|``."""
    F = pb.F
    ns2 = float(seed @ seed)
    if not ns2 > 0:
        return np.zeros(len(st.x)), float("nan")
    return w * (float(seed @ st.r[F]) / ns2), float(np.linalg.norm(w[F]) / np.sqrt(ns2))


def _step(pb: _Iteration, st: _State, reduced, u):
    """The Newton-Picard step at ``st`` with the chord matrices ``reduced`` and ``u ~ M Q r_F``."""
    P, F = pb.P, pb.F
    J, G = reduced
    a = np.linalg.solve(J, st.r[P] + u[P])
    dx = np.zeros(len(st.x))
    dx[P] = a
    dx[F] = st.r[F] + u[F] + G @ a
    return dx


def _last_ratio(hist) -> str:
    """The last residual over the one before, formatted (n/a before the first step)."""
    return f"{hist[-1] / hist[-2]:.3g}" if len(hist) >= 2 and hist[-2] > 0 else "n/a"


def outcome_message(status, it, hist, rates, max_rate) -> str:
    """One line: the outcome, the iterations, the residual, the Picard growth.

    Parameters
    ----------
    status : str
        The status (see :class:`NewtonPicardOutcome`).
    it : int
        Iterations.
    hist : list of float
        Max-norm of the residual at every iterate.
    rates : list of float
        The complement's growth at every iteration.
    max_rate : float
        Largest acceptable growth per period.

    Returns
    -------
    str
    """
    finite = [r for r in rates if np.isfinite(r)]
    rho = f"{max(finite[-3:]):.3g}" if finite else "n/a"
    head = {"converged": "converged", "max_iter": "iteration limit reached",
            "not_contracting": f"the Picard complement is not contracting enough (limit {max_rate:g} per "
                               f"period; growth {rho}, last residual ratio {_last_ratio(hist)}): "
                               "use the full Newton (solver 'lm' or 'ipopt') or more newton_states",
            "singular": "the reduced Newton matrix is singular", "nan": "non-finite residual"}[status]
    return f"newton-picard: {head} after {it} iterations, max residual {hist[-1]:.2e}, Picard growth {rho}"
