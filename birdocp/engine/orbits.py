"""Periodic orbits of any ODE by multiple shooting: autonomous (unknown period) or forced.

Formulation
-----------
Time is scaled to ``tau = (t - t0) / T`` in [0, 1], so the period T is an ordinary unknown:
``dx/dtau = T f(x, t0 + T tau, p)``. M shooting points X_0 .. X_{M-1} (M counts the closing point;
M-1 segments of N/(M-1) steps of size 1/N in tau) and, for an autonomous system, T are the unknowns of

* continuity   Phi(X_i; T, p) - X_{i+1} = 0,  i = 0 .. M-2
* periodicity  X_{M-1} - X_0 = 0
* phase        (X_0 - x_ref) . f(x_ref, p) = 0               (autonomous only)
* extra linear rows ``a . z = b`` (e.g. the amplitude condition of a Hopf start)

**Phase condition: a Poincare section through the reference point, orthogonal to the flow there.**
The integral phase condition (AUTO) needs a reference *orbit*; a user who finds an orbit for the
first time has only a point and a period guess. The section is one linear row (exact Jacobian for
free, no quadrature), independent of the number of shooting points and of the integrator, and it
pins X_0 near the user's start, so the same section also makes the orbits computed with N and 2N
steps directly comparable (the error estimate below). In a continuation the reference point moves
to the previous orbit's x0. Its one limitation -- the section must cross the orbit transversally
near x_ref -- holds by construction when x_ref is on (or near) the orbit.

Derivatives are exact: each segment's Jacobians with respect to its start point and to
``q = (p, T, t0)`` come from CasADi forward AD through the steps (for the implicit integrators
through the rootfinder, by the implicit function theorem); the shooting matrix is assembled around
them in numpy. IPOPT sees the constraints through :class:`~birdocp.engine.oracle.ConstraintOracle`.

Success means ``max_residual <= tol`` (all equations, absolute), whatever the solver's status, plus
a non-degenerate orbit: an equilibrium satisfies every equation for any T (a constant trajectory),
so a result whose amplitude ``max_t |x(t) - x0|`` is below ``min_amplitude (1 + |x0|)`` has status
``"equilibrium"`` and ``success=False``.

Accuracy: by default every successful result is re-solved with twice the steps from its own
solution (a few Newton iterations) and the differences, scaled Richardson-style by
``2^p / (2^p - 1)`` (p = order of the integrator), are the error estimates of the period, x0 and the
multipliers (``error_estimate``). ``accurate`` is False (and the message says so) when a relative
estimate exceeds ``OrbitMethod.accuracy``. ``steps_per_period=None`` doubles the steps until the
estimate is below ``accuracy``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from birdocp.engine import interrupts
from birdocp.engine.cache import bounded_cache
from birdocp.engine.floquet import monodromy_of, sort_multipliers
from birdocp.engine.ode import ODE
from birdocp.engine.problem import finite_vector
from birdocp.engine.oracle import ConstraintOracle, Evaluator, ipopt_options
from birdocp.engine.results import result_dict, serial
from birdocp.engine.shooting import ShootingGrid
from birdocp.engine.steppers import METHOD_ORDER, make_step

__all__ = ["OrbitMethod", "OrbitProblem", "PeriodicOrbit", "solve_orbit", "solve_orbit_system",
           "orbit_residual_system"]


@dataclass(frozen=True)
class OrbitMethod(ShootingGrid):
    """How to compute a periodic orbit.

    Attributes
    ----------
    points, steps_per_period
        M and N of the grid (:class:`~birdocp.engine.shooting.ShootingGrid`). N None (default):
        chosen by doubling from ``min_steps`` until the error estimate is below ``accuracy``
        (no fixed default that ignores the period and the stiffness of the system).
    integrator
        "rk4" | "radau" (stiff systems) | "gauss".
    solver
        "lm" (Levenberg-Marquardt / damped Newton on the exact shooting matrix) | "ipopt"
        (feasibility NLP through the same exact Jacobian). LM is the default: on the
        Rossler orbit it took 7 iterations (18 ms) against IPOPT's 11 (70 ms), and it
        converged with the Radau integrator where IPOPT's line search wandered off.
    tol
        max |residual| for success (absolute, all equations).
    accuracy
        relative error tolerance of period, x0 and multipliers (error estimate).
    error_estimate
        re-solve with 2N steps to estimate the discretisation error.
    min_amplitude
        relative amplitude below which a solution is an equilibrium (failure).
    period_bounds
        (lo, hi) as factors of the period guess (autonomous).
    max_iter
        iterations of the solver per grid.
    min_steps, max_steps_per_period
        the first and the largest N when N is chosen by doubling.
    ipopt_options
        extra IPOPT options (``solver="ipopt"``).
    """

    integrator: str = "rk4"
    solver: str = "lm"
    tol: float = 1e-10
    max_iter: int = 100
    accuracy: float = 1e-6
    error_estimate: bool = True
    min_amplitude: float = 1e-6
    min_steps: int = 32
    max_steps_per_period: int = 16384
    period_bounds: tuple = (1e-2, 1e2)
    ipopt_options: dict = field(default_factory=dict)

    def validate(self) -> None:
        """Raise ValueError on the first invalid field (named)."""
        self.validate_grid()
        if self.integrator not in METHOD_ORDER:
            raise ValueError(f"OrbitMethod.integrator must be one of {sorted(METHOD_ORDER)}, got {self.integrator!r}")
        if self.solver not in ("ipopt", "lm"):
            raise ValueError(f"OrbitMethod.solver must be 'ipopt' or 'lm', got {self.solver!r}")
        if not self.tol > 0 or not self.accuracy > 0:
            raise ValueError("OrbitMethod.tol and accuracy must be positive")
        if not isinstance(self.max_iter, (int, np.integer)) or self.max_iter < 0:
            raise ValueError(f"OrbitMethod.max_iter must be a non-negative integer, got {self.max_iter!r}")
        if not isinstance(self.min_steps, (int, np.integer)) or self.min_steps < 1:
            raise ValueError(f"OrbitMethod.min_steps must be a positive integer, got {self.min_steps!r}")
        lo, hi = (float(v) for v in self.period_bounds)
        if not 0 < lo <= 1 <= hi:
            raise ValueError(f"OrbitMethod.period_bounds must be factors (lo, hi) with 0 < lo <= 1 <= hi, "
                             f"got {self.period_bounds!r}")


@dataclass(eq=False)
class OrbitProblem:
    """A periodic orbit of ``ode`` at parameters ``p``.

    Attributes
    ----------
    ode
        the system (:class:`~birdocp.engine.ode.ODE`).
    p
        its parameters (np,).
    x_guess
        a point near the orbit (nx,), or guesses of the shooting points (M or M-1, nx).
    period_guess
        the period guess (autonomous: an unknown; forced: the period itself, default
        ``ode.forcing_period``; give a multiple for subharmonic orbits).
    t0
        the start time of the period (forced systems; it fixes the phase).
    phase_point
        the point the Poincare section passes through (autonomous; default: the first
        guess point). The section is orthogonal to f there.
    """

    ode: ODE
    p: np.ndarray
    x_guess: np.ndarray
    period_guess: float | None = None
    t0: float = 0.0
    phase_point: np.ndarray | None = None

    def __post_init__(self):
        self.p = finite_vector(self.p, "OrbitProblem.p", self.ode.np, f"the ODE has np={self.ode.np}")
        self.x_guess = np.asarray(self.x_guess, float)
        if self.x_guess.shape[-1:] != (self.ode.nx,) or self.x_guess.ndim > 2:
            raise ValueError(f"OrbitProblem.x_guess: shape {self.x_guess.shape}, expected ({self.ode.nx},) or (M, {self.ode.nx})")
        finite_vector(self.x_guess, "OrbitProblem.x_guess")
        if self.phase_point is not None:
            self.phase_point = finite_vector(self.phase_point, "OrbitProblem.phase_point", self.ode.nx,
                                             f"the ODE has nx={self.ode.nx}")
        self.t0 = float(finite_vector(self.t0, "OrbitProblem.t0", 1)[0])
        if self.period_guess is None:
            if self.ode.autonomous or self.ode.forcing_period is None:
                raise ValueError("OrbitProblem.period_guess is required (autonomous system or no forcing_period)")
            self.period_guess = float(self.ode.forcing_period)
        if not (np.isfinite(self.period_guess) and self.period_guess > 0):
            raise ValueError(f"OrbitProblem.period_guess must be positive, got {self.period_guess!r}")


@dataclass
class PeriodicOrbit:
    """Result of :func:`solve_orbit` (failures are results with ``success=False``).

    Attributes
    ----------
    status
        ``"converged"`` (max residual <= tol, a true orbit), ``"equilibrium"`` (the equations hold
        but the solution is a constant), ``"not_converged"`` (residual above tol), ``"nan"``
        (non-finite iterate), ``"bad_phase_point"`` (f = 0 at the section's point), ``"bad_period"``
        (T <= 0). ``solver_status`` keeps what the solver said (IPOPT's return status, or the LM's
        ``"converged"`` / ``"max_iter"`` / ``"stalled"`` / ``"nan"``).
    period, x0, shooting_points
        T (time units of the system); X_0; the shooting points (M x nx).
    multipliers
        All Floquet multipliers, largest modulus first (autonomous: the trivial one included);
        ``trivial_multiplier`` (autonomous) is the one closest to 1 and ``trivial_multiplier_error``
        = abs(it - 1) (an accuracy measure: exactly 0 for the exact flow); ``stable`` is decided on
        the other multipliers only.
    amplitude, arc_length
        max_t of the largest abs(x(t) - x0) component; the integral of the norm of f over the period
        (polygon of the steps).
    error_estimate
        ``{"period", "x0", "multipliers"}`` absolute estimates (Richardson, from 2N steps);
        ``accurate``: every relative estimate <= the method's accuracy.
    wall_s
        Seconds: build, solve, error_estimate, total (this grid); ``all_grids`` (with
        ``steps_per_period=None``: every grid tried).
    """

    success: bool
    status: str
    message: str
    solver_status: str
    iterations: int
    residual_history: np.ndarray
    max_residual: float
    period: float
    x0: np.ndarray
    p: np.ndarray
    shooting_points: np.ndarray
    trajectory_t: np.ndarray
    trajectory_x: np.ndarray
    amplitude: float
    arc_length: float
    autonomous: bool
    monodromy: np.ndarray | None = None
    multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    trivial_multiplier: complex | None = field(default=None, metadata=serial(complex=True))
    trivial_multiplier_error: float = float("nan")
    nontrivial_multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    stable: bool | None = None
    error_estimate: dict = field(default_factory=dict)
    accurate: bool | None = None
    method: dict = field(default_factory=dict)
    wall_s: dict = field(default_factory=dict)
    phase_point: np.ndarray | None = None
    free_params: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): complex numbers as [re, im]
        pairs, multipliers largest modulus first, NaN as null."""
        return result_dict(self)


# ----------------------------------------------------------------------------------------------
class _Graphs:
    """CasADi Functions for one (ode, N, S, integrator): segments, their Jacobians, the trajectory."""

    def __init__(self, ode: ODE, N: int, S: int, integrator: str):
        self.ode, self.N, self.S, self.n = ode, N, S, N // S
        nx, n_p = ode.nx, ode.np
        self.nq = nq = n_p + 2  # q = (p, T, t0)
        x, tau, q = ca.SX.sym("x", nx), ca.SX.sym("tau"), ca.SX.sym("q", nq)
        T, t0 = q[n_p], q[n_p + 1]
        F = ca.Function("scaled_rhs", [x, tau, q], [T * ode.rhs(x, t0 + T * tau, q[:n_p])])
        self.step = make_step(F, integrator)
        h = 1.0 / N
        acc = self.step.mapaccum("acc", self.n)
        xm, ts, qm = ca.MX.sym("x", nx), ca.MX.sym("tau0"), ca.MX.sym("q", nq)
        taus = ts + ca.DM(h * np.arange(self.n)).T
        X = acc(xm, taus, qm, h)
        seg = ca.Function("segment", [xm, ts, qm], [X[:, -1], X])
        self.segment = seg
        xe = X[:, -1]
        segJ = ca.Function("segment_jac", [xm, ts, qm], [xe, ca.jacobian(xe, xm), ca.jacobian(xe, qm)])
        Xs = ca.MX.sym("X", nx, S)
        tgrid = ca.DM(np.arange(S) / S).T
        Xe, Jx, Jq = segJ.map(S)(Xs, tgrid, qm)
        self.sens = ca.Function("segments_sens", [Xs, qm], [Xe, Jx, Jq])
        Xe2, Xt = seg.map(S)(Xs, tgrid, qm)
        self.segments = ca.Function("segments", [Xs, qm], [Xe2, Xt])
        self.h = h


_GRAPHS = bounded_cache("engine.orbits.graphs", 32)
_EVALS = bounded_cache("engine.orbits.evaluators", 32)


def _cached(cache, key, make):
    """The entry of ``key``, built by ``make()`` on a miss (entries hold the objects whose ids are
    in their keys, so an id is not reused while its entry lives)."""
    hit = cache.get(key)
    if hit is None:
        hit = make()
        cache.put(key, hit)
    return hit


def _graphs(ode: ODE, N: int, S: int, integrator: str) -> _Graphs:
    return _cached(_GRAPHS, (id(ode), N, S, integrator), lambda: _Graphs(ode, N, S, integrator))


class _Evaluator(Evaluator):
    """Residual and exact Jacobian of the shooting system for one layout of unknowns.

    z = [X_0 .. X_{M-1} (point-major), T (if period_free), free parameters]; rows = continuity,
    periodicity, linear rows ``lin_A z - lin_b``. The numbers (p, T, t0, linear rows) are the context.
    """

    def __init__(self, graphs: _Graphs, period_free: bool, free_idx: tuple, n_lin: int):
        self.G = graphs
        nx, S = graphs.ode.nx, graphs.S
        self.nx, self.S = nx, S
        self.period_free, self.free_idx, self.n_lin = period_free, tuple(free_idx), n_lin
        self.nX = nx * (S + 1)
        self.nz = self.nX + int(period_free) + len(free_idx)
        self.ng = self.nX + n_lin
        P = np.zeros((self.ng, self.nz), bool)
        for i in range(S):
            P[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = True
            P[i * nx:(i + 1) * nx, (i + 1) * nx:(i + 2) * nx] |= np.eye(nx, dtype=bool)
            P[i * nx:(i + 1) * nx, self.nX:] = True
        P[S * nx:self.nX, :nx] |= np.eye(nx, dtype=bool)
        P[S * nx:self.nX, S * nx:self.nX] |= np.eye(nx, dtype=bool)
        P[self.nX:, :] = True
        rows, cols = np.nonzero(P.T)
        self.jac_sparsity = ca.Sparsity.triplet(self.ng, self.nz, cols.tolist(), rows.tolist())
        self._last = None
        self._ctx = None
        self._solver = None
        self._oracle = None

    def set_context(self, p, T, t0, lin_A, lin_b):
        self._ctx = (np.asarray(p, float).copy(), float(T), float(t0),
                     np.asarray(lin_A, float).reshape(self.n_lin, self.nz), np.asarray(lin_b, float).ravel())
        self._last = None

    def q_of(self, z) -> np.ndarray:
        p, T, t0 = self._ctx[0].copy(), self._ctx[1], self._ctx[2]
        k = self.nX
        if self.period_free:
            T = z[k]
            k += 1
        for j, i in enumerate(self.free_idx):
            p[i] = z[k + j]
        return np.concatenate([p, [T, t0]])

    def points(self, z) -> np.ndarray:
        return np.asarray(z[:self.nX]).reshape(self.S + 1, self.nx).T

    def evaluate(self, z):
        z = np.asarray(z, float).ravel()
        key = z.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1], self._last[2]
        nx, S = self.nx, self.S
        X = self.points(z)
        q = self.q_of(z)
        try:
            Xe, Jx, Jq = (np.asarray(v) for v in self.G.sens(ca.DM(X[:, :S]), ca.DM(q)))
        except RuntimeError:  # e.g. an implicit stage solve failed far from the orbit
            Xe = np.full((nx, S), np.nan)
            Jx, Jq = np.full((nx, nx * S), np.nan), np.full((nx, self.G.nq * S), np.nan)
        A, b = self._ctx[3], self._ctx[4]
        g = np.concatenate([(Xe - X[:, 1:]).T.ravel(), X[:, S] - X[:, 0], A @ z - b])
        J = np.zeros((self.ng, self.nz))
        I = np.eye(nx)
        n_p = self.G.ode.np
        qcols = ([n_p] if self.period_free else []) + list(self.free_idx)
        nq = self.G.nq
        for i in range(S):
            r = slice(i * nx, (i + 1) * nx)
            J[r, i * nx:(i + 1) * nx] = Jx[:, i * nx:(i + 1) * nx]
            J[r, (i + 1) * nx:(i + 2) * nx] = -I
            if qcols:
                J[r, self.nX:] = Jq[:, i * nq:(i + 1) * nq][:, qcols]
        J[S * nx:self.nX, :nx] = -I
        J[S * nx:self.nX, S * nx:self.nX] = I
        J[self.nX:, :] = A
        self._last = (key, g, J, Jx)
        return g, J

    def blocks(self, z):
        self.evaluate(z)
        Jx = self._last[3]
        return [Jx[:, i * self.nx:(i + 1) * self.nx] for i in range(self.S)]

    def ipopt(self, method: OrbitMethod):
        if self._solver is None or self._solver[0] != repr(sorted(method.ipopt_options.items())) + str(
                (method.tol, method.max_iter)):
            if self._oracle is None:
                self._oracle = ConstraintOracle(self, "orbit")
            z = ca.MX.sym("z", self.nz)
            opts = ipopt_options(**{"show_eval_warnings": False, "ipopt.tol": method.tol,
                                    "ipopt.constr_viol_tol": method.tol, "ipopt.max_iter": int(method.max_iter),
                                    **method.ipopt_options})
            s = ca.nlpsol("orbit", "ipopt", {"x": z, "f": 0, "g": self._oracle(z)}, opts)
            self._solver = (repr(sorted(method.ipopt_options.items())) + str((method.tol, method.max_iter)), s)
        return self._solver[1]


def _evaluator(graphs, period_free, free_idx, n_lin) -> _Evaluator:
    return _cached(_EVALS, (id(graphs), bool(period_free), tuple(free_idx), int(n_lin)),
                   lambda: _Evaluator(graphs, period_free, free_idx, n_lin))


def _lm(ev: _Evaluator, z, tol, max_iter, lo, hi):
    """Levenberg-Marquardt with the exact Jacobian; a step is kept only if it lowers |g|_2 (the
    damping then shrinks x10, else it grows x10). Returns (z, status, message, iterations, history)."""
    g, J = ev.evaluate(z)
    hist = [float(np.max(np.abs(g)))]
    lam, it = 1e-8, 0
    while True:
        if not np.all(np.isfinite(g)):
            return z, "nan", "non-finite residual", it, hist
        if hist[-1] <= tol:
            return z, "converged", f"max|g| = {hist[-1]:.2e} <= tol", it, hist
        if it >= max_iter:
            return z, "max_iter", f"max_iter={max_iter} reached, max|g| = {hist[-1]:.2e}", it, hist
        it += 1
        A = J.T @ J
        rhs = -J.T @ g
        d = np.diag(A).copy()
        d[d == 0] = 1.0
        n2 = float(g @ g)
        for _ in range(12):
            try:
                dz = np.linalg.solve(A + lam * np.diag(d), rhs)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            zn = np.clip(z + dz, lo, hi)
            gn, Jn = ev.evaluate(zn)
            if np.all(np.isfinite(gn)) and float(gn @ gn) < n2:
                z, g, J = zn, gn, Jn
                lam = max(lam / 10, 1e-12)
                break
            lam *= 10
        else:
            return z, "stalled", f"no decreasing step, max|g| = {hist[-1]:.2e}", it, hist
        hist.append(float(np.max(np.abs(g))))


def _run_ipopt(ev: _Evaluator, z0, method, lo, hi):
    with interrupts.interruptible():  # Ctrl-C inside IPOPT: KeyboardInterrupt, not a status
        try:
            s = ev.ipopt(method)
            sol = s(x0=z0, lbx=lo, ubx=hi, lbg=0, ubg=0)
            st = s.stats()
            z = np.asarray(sol["x"]).ravel()
            return (z, str(st.get("return_status", "unknown")), int(st.get("iter_count", 0)),
                    list(np.asarray(st.get("iterations", {}).get("inf_pr", []), float)))
        except Exception as e:  # evaluation errors inside IPOPT
            interrupts.check_from(e)
            return z0, f"error: {e}", 0, []


def orbit_residual_system(ode: ODE, method: OrbitMethod, *, period_free: bool, free_idx=(), n_lin: int = 0,
                          cached: bool = True):
    """The shooting system (an evaluator with ``set_context``, ``evaluate(z) -> (g, J)``, ``g(z)``,
    ``blocks(z)``, ``nz``, ``ng``, ``points(z)``, ``q_of(z)``) for continuation and Hopf starts.

    The graphs are always cached; ``cached=False`` gives an evaluator of its own (its context -- the
    parameters and linear rows -- is then not changed by other solves)."""
    method.validate()
    if method.steps_per_period is None:
        raise ValueError("orbit_residual_system: give steps_per_period (a number)")
    S = method.points - 1
    G = _graphs(ode, int(method.steps_per_period), S, method.integrator)
    if not cached:
        return _Evaluator(G, period_free, tuple(free_idx), n_lin)
    return _evaluator(G, period_free, tuple(free_idx), n_lin)


def _initial_points(graphs: _Graphs, x_guess, p, T, t0) -> np.ndarray:
    """Shooting points (nx x (S+1)) from a guess: a single point is integrated forward over T; a
    list of M or M-1 points is used as is (closed with the first)."""
    S = graphs.S
    xg = np.asarray(x_guess, float)
    if xg.ndim == 2:
        pts = xg.T
        if pts.shape[1] == S:
            pts = np.column_stack([pts, pts[:, 0]])
        if pts.shape[1] != S + 1:
            raise ValueError(f"x_guess has {xg.shape[0]} points; expected {S} or {S + 1} (points-1 or points)")
        return pts.copy()
    return _forward_points(graphs, xg, p, T, t0)


def _forward_points(graphs: _Graphs, x, p, T, t0) -> np.ndarray:
    """Points along the trajectory from x at the shooting times (nx x (S+1))."""
    q = ca.DM(np.concatenate([p, [T, t0]]))
    pts = [np.asarray(x, float)]
    for i in range(graphs.S):
        try:
            nxt = np.asarray(graphs.segment(ca.DM(pts[-1]), i / graphs.S, q)[0]).ravel()
        except RuntimeError:  # an implicit stage solve failed
            nxt = np.full(pts[-1].shape, np.nan)
        pts.append(nxt if np.all(np.isfinite(nxt)) else pts[-1])
    return np.column_stack(pts)


def solve_orbit(problem: OrbitProblem, method: OrbitMethod = OrbitMethod(),
                warm_start: "PeriodicOrbit | None" = None) -> PeriodicOrbit:
    """Find the periodic orbit of ``problem`` (period too when autonomous) and its multipliers.

    Returns a :class:`PeriodicOrbit`; ``success`` means the residual is below ``method.tol`` and the
    orbit is not an equilibrium. With ``method.steps_per_period=None`` the steps are doubled from
    ``method.min_steps`` until the error estimate is below ``method.accuracy`` (a failed solve on a
    grid too coarse for the dynamics is retried on the finer grid too).

    Parameters
    ----------
    problem : OrbitProblem
        The ODE, its parameters, the guess of a state on the orbit and of the period.
    method : OrbitMethod
        Shooting points, steps per period (None: refined to ``accuracy``), integrator, solver,
        tolerances.
    warm_start : PeriodicOrbit, optional
        A previous orbit that starts the solve.

    Returns
    -------
    PeriodicOrbit
        ``success``, ``status``, ``period``, ``x0``, ``multipliers`` (the trivial one reported apart),
        ``stable``, ``error_estimate`` and ``accurate``.
    """
    method.validate()
    if method.steps_per_period is None:
        S = method.points - 1
        N = S * max(1, int(np.ceil(method.min_steps / S)))
        res, good = None, None
        t_start = time.perf_counter()
        while True:
            m = replace(method, steps_per_period=N, error_estimate=True)
            res = solve_orbit(problem, m, warm_start=good if good is not None else warm_start)
            res.wall_s["all_grids"] = time.perf_counter() - t_start
            if res.success and res.accurate:
                return res
            if res.success:
                good = res
            elif good is not None and res.status == "equilibrium":
                return res
            if 2 * N > method.max_steps_per_period:
                if res.success:
                    res.message += f"; accuracy not reached with max_steps_per_period={method.max_steps_per_period}"
                return res
            # a grid too coarse for the dynamics may also make the solve fail: refine and retry
            N *= 2
    return solve_orbit_system(problem, method, warm_start)


def solve_orbit_system(problem: OrbitProblem, method: OrbitMethod, warm_start=None, *, free_idx=(), lin=None,
                       z_start=None, x_ref=None, estimate=True) -> PeriodicOrbit:
    """:func:`solve_orbit` at a fixed number of steps, with extra unknowns and rows (Hopf starts,
    continuation): parameters ``free_idx`` become unknowns (after T), ``lin = (A, b)`` appends the
    rows ``A z - b`` after the phase row, ``z_start`` is the full initial unknown vector and ``x_ref``
    the point of the Poincare section (default: the problem's phase point or first guess point).
    """
    t_all = time.perf_counter()
    ode = problem.ode
    nx, S, N = ode.nx, method.points - 1, int(method.steps_per_period)
    auto = ode.autonomous
    t0 = time.perf_counter()
    G = _graphs(ode, N, S, method.integrator)
    p = problem.p.copy()
    T = float(problem.period_guess)
    if warm_start is not None and np.isfinite(warm_start.period):
        T = float(warm_start.period) if auto else T
        p = np.asarray(warm_start.p, float).copy() if free_idx else p
    if x_ref is None:
        if problem.phase_point is not None:
            x_ref = np.asarray(problem.phase_point, float).ravel()
        elif warm_start is not None and warm_start.phase_point is not None:
            x_ref = np.asarray(warm_start.phase_point, float)
        else:
            x_ref = problem.x_guess if problem.x_guess.ndim == 1 else problem.x_guess[0]
    # phase row: (X_0 - x_ref) . n = 0, n = f(x_ref)/|f(x_ref)|
    n_lin_user = 0 if lin is None else len(lin[1])
    n_lin = n_lin_user + (1 if auto else 0)
    ev = _evaluator(G, auto, tuple(free_idx), n_lin)
    nz = ev.nz
    A = np.zeros((n_lin, nz))
    b = np.zeros(n_lin)
    if auto:
        fr = ode.evaluate(x_ref, 0.0, p)
        nrm = np.linalg.norm(fr)
        if not np.isfinite(nrm) or nrm == 0:
            return _failed(problem, method, "bad_phase_point", "f is zero or non-finite at the phase point", x_ref, p, T)
        A[0, :nx] = fr / nrm
        b[0] = float(fr @ x_ref) / nrm
    if lin is not None:
        A[n_lin - n_lin_user:] = lin[0]
        b[n_lin - n_lin_user:] = lin[1]
    ev.set_context(p, T, problem.t0, A, b)
    build_s = time.perf_counter() - t0
    # initial point
    if z_start is not None:
        z0 = np.asarray(z_start, float).copy()
    else:
        if warm_start is not None and warm_start.shooting_points.shape == (S + 1, nx):
            X0 = warm_start.shooting_points.T.copy()
        elif warm_start is not None:
            X0 = _forward_points(G, warm_start.x0, p, T, problem.t0)
        else:
            X0 = _initial_points(G, problem.x_guess, p, T, problem.t0)
        z0 = np.concatenate([X0.T.ravel(), [T] if auto else [], p[list(free_idx)]])
    lo = np.full(nz, -np.inf)
    hi = np.full(nz, np.inf)
    if auto:
        lo[ev.nX] = method.period_bounds[0] * problem.period_guess
        hi[ev.nX] = method.period_bounds[1] * problem.period_guess
        z0[ev.nX] = np.clip(z0[ev.nX], lo[ev.nX], hi[ev.nX])
    ts = time.perf_counter()
    if method.solver == "ipopt":
        z, sstat, iters, hist = _run_ipopt(ev, z0, method, lo, hi)
        g = ev.g(z) if np.all(np.isfinite(z)) else np.full(ev.ng, np.nan)
        r = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
        if np.isfinite(r) and method.tol < r < 1e-3:
            # polish: IPOPT stops on scaled criteria; a few exact Newton steps reach the tolerance
            z, _, _, it2, h2 = _lm(ev, z, method.tol, 5, lo, hi)
            iters += it2
            hist += h2[1:]
        message = f"IPOPT: {sstat}"
    else:
        z, sstat, message, iters, hist = _lm(ev, z0.copy(), method.tol, method.max_iter, lo, hi)
    solve_s = time.perf_counter() - ts
    res = _assemble(problem, method, ev, G, z, sstat, message, iters, hist, x_ref)
    res.wall_s = {"build": build_s, "solve": solve_s}
    if free_idx:
        res.free_params = {ode.param_names[i] if ode.param_names else f"p{i}": float(res.p[i]) for i in free_idx}
    if res.success and method.error_estimate and estimate:
        te = time.perf_counter()
        fine_m = replace(method, steps_per_period=2 * N, solver="lm", max_iter=20)
        Gf = _graphs(ode, 2 * N, S, method.integrator)
        evf = _evaluator(Gf, auto, tuple(free_idx), n_lin)
        evf.set_context(p, T, problem.t0, A, b)
        fine = _assemble(problem, fine_m, evf, Gf, *_lm_wrap(evf, z, fine_m, lo, hi), x_ref)
        _attach_error(res, fine, METHOD_ORDER[method.integrator], method.accuracy)
        res.wall_s["error_estimate"] = time.perf_counter() - te
    res.wall_s["total"] = time.perf_counter() - t_all
    return res


def _lm_wrap(ev, z, method, lo, hi):
    z, st, msg, it, hist = _lm(ev, np.asarray(z, float).copy(), method.tol, method.max_iter, lo, hi)
    return z, st, msg, it, hist


def _failed(problem, method, status, message, x_ref, p, T):
    nx = problem.ode.nx
    nan = np.full(nx, np.nan)
    return PeriodicOrbit(False, status, message, status, 0, np.zeros(0), float("nan"), float(T), nan, p,
                         np.full((method.points, nx), np.nan), np.zeros(0), np.zeros((0, nx)), float("nan"),
                         float("nan"), problem.ode.autonomous, phase_point=np.asarray(x_ref, float))


def _assemble(problem, method, ev: _Evaluator, G: _Graphs, z, sstat, message, iters, hist, x_ref) -> PeriodicOrbit:
    ode = problem.ode
    nx, S = ode.nx, ev.S
    z = np.asarray(z, float).ravel()
    finite = np.all(np.isfinite(z))
    q = ev.q_of(z) if finite else np.full(G.nq, np.nan)
    p, T = q[:ode.np], float(q[ode.np])
    X = ev.points(z)
    g = ev.g(z) if finite else np.full(ev.ng, np.nan)
    r = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
    try:
        Xt = np.asarray(G.segments(ca.DM(X[:, :S]), ca.DM(q))[1]) if finite and np.all(np.isfinite(g)) else None
    except RuntimeError:
        Xt = None
    if Xt is not None:
        traj = np.vstack([X[:, 0][None, :], Xt.T])
    else:
        traj = np.full((G.N + 1, nx), np.nan)
    tt = problem.t0 + T * np.arange(G.N + 1) / G.N
    amp = float(np.max(np.abs(traj - traj[0]))) if np.all(np.isfinite(traj)) else float("nan")
    arc = float(np.sum(np.linalg.norm(np.diff(traj, axis=0), axis=1))) if np.all(np.isfinite(traj)) else float("nan")
    scale = 1.0 + float(np.max(np.abs(X[:, 0]))) if finite else 1.0
    if not (np.isfinite(r) and finite):
        status, success = "nan", False
    elif r > method.tol:
        status, success = "not_converged", False
        message += f"; max residual {r:.2e} > tol {method.tol:.1e}"
    elif ode.autonomous and not (amp > method.min_amplitude * scale):
        status, success = "equilibrium", False
        message += (f"; the solution is an equilibrium (amplitude {amp:.1e} <= {method.min_amplitude:.0e}"
                    f" x (1 + |x0|)), not a periodic orbit")
    elif ode.autonomous and not T > 0:
        status, success = "bad_period", False
    else:
        status, success = "converged", True
    res = PeriodicOrbit(success, status, message, str(sstat), int(iters), np.asarray(hist, float), r, T,
                        X[:, 0].copy(), p, X.T.copy(), tt, traj, amp, arc, ode.autonomous,
                        method={"points": method.points, "steps_per_period": G.N, "integrator": method.integrator,
                                "solver": method.solver, "tol": method.tol, "accuracy": method.accuracy},
                        phase_point=np.asarray(x_ref, float).copy())
    if finite and np.all(np.isfinite(g)):
        try:
            Mo = monodromy_of(ev.blocks(z))
            lam = np.linalg.eigvals(Mo).astype(complex)
            lam = sort_multipliers(lam)
            res.monodromy, res.multipliers = Mo, lam
            if ode.autonomous:
                k = int(np.argmin(np.abs(lam - 1.0)))
                res.trivial_multiplier = complex(lam[k])
                res.trivial_multiplier_error = float(abs(lam[k] - 1.0))
                res.nontrivial_multipliers = np.delete(lam, k)
            else:
                res.nontrivial_multipliers = lam
            res.stable = bool(np.all(np.abs(res.nontrivial_multipliers) < 1.0))
        except np.linalg.LinAlgError as e:
            res.message += f"; Floquet analysis failed: {e}"
    return res


def _match(a, b):
    """Max |a_i - b_j| over a greedy nearest matching of two multiplier lists, and of the relative."""
    b = list(b)
    ab, rel = 0.0, 0.0
    for v in a:
        j = int(np.argmin([abs(v - w) for w in b]))
        d = abs(v - b.pop(j))
        ab, rel = max(ab, d), max(rel, d / max(1.0, abs(v)))
    return ab, rel


def _attach_error(res: PeriodicOrbit, fine: PeriodicOrbit, order: int, accuracy: float) -> None:
    fac = 2.0 ** order / (2.0 ** order - 1.0)
    if not fine.success or fine.multipliers is None or res.multipliers is None:
        res.error_estimate = {"period": float("nan"), "x0": float("nan"), "multipliers": float("nan")}
        res.accurate = False
        res.message += f"; error estimate failed (2N solve: {fine.status})"
        return
    eT = fac * abs(res.period - fine.period)
    ex = fac * float(np.max(np.abs(res.x0 - fine.x0)))
    em, emr = _match(res.multipliers, fine.multipliers)
    em, emr = fac * em, fac * emr
    res.error_estimate = {"period": float(eT), "x0": float(ex), "multipliers": float(em),
                          "trivial_multiplier_2N": float(fine.trivial_multiplier_error)}
    rel = max(eT / max(abs(res.period), 1e-300), ex / (1.0 + float(np.max(np.abs(res.x0)))), emr)
    res.error_estimate["relative"] = float(rel)
    res.accurate = bool(rel <= accuracy)
    if not res.accurate:
        res.message += (f"; INACCURATE: estimated relative error {rel:.1e} > accuracy {accuracy:.0e} "
                        f"(increase steps_per_period or use steps_per_period=None)")
