"""The shooting system of a periodic orbit: CasADi graphs, the residual with its exact Jacobian, and
the starting points (forward integration, the first return to the phase section)."""
from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache
from birdocp.engine.ode import ODE
from birdocp.engine.oracle import ConstraintOracle, Evaluator, ipopt_options
from birdocp.engine.method import OrbitMethod
from birdocp.engine.steppers import make_step, make_variational_step

__all__ = ["OrbitGraphs", "OrbitSystem", "orbit_graphs", "orbit_system", "orbit_residual_system", "initial_points",
           "forward_points", "first_return_period", "trajectory"]


class OrbitGraphs:
    """CasADi Functions for one (ode, N, S, integrator): segments, their Jacobians, the trajectory."""

    def __init__(self, ode: ODE, N: int, S: int, integrator: str):
        self.ode, self.N, self.S, self.n, self.integrator = ode, N, S, N // S, integrator
        nx, n_p = ode.nx, ode.np
        self.nq = nq = n_p + 2  # q = (p, T, t0)
        self.step, variational = _steps(ode, integrator)
        h = 1.0 / N
        acc = self.step.mapaccum("acc", self.n)
        xm, ts, qm = ca.MX.sym("x", nx), ca.MX.sym("tau0"), ca.MX.sym("q", nq)
        taus = ts + ca.DM(h * np.arange(self.n)).T
        X = acc(xm, taus, qm, h)
        seg = ca.Function("segment", [xm, ts, qm], [X[:, -1], X])
        self.segment = seg
        # the segment's exact Jacobians by the discrete variational equation (one augmented step per
        # step: the state and its derivatives with respect to the start point and to q)
        aug = variational.mapaccum("acc_sens", self.n)
        Aall = aug(ca.vertcat(xm, ca.vec(ca.DM.eye(nx)), ca.DM.zeros(nx * nq)), taus, qm, h)
        A = Aall[:, -1]
        segJ = ca.Function("segment_jac", [xm, ts, qm], [A[:nx], ca.reshape(A[nx:nx + nx * nx], nx, nx),
                                                        ca.reshape(A[nx + nx * nx:], nx, nq), Aall[:nx, :]])
        Xs = ca.MX.sym("X", nx, S)
        tgrid = ca.DM(np.arange(S) / S).T
        Xe, Jx, Jq, Xt = segJ.map(S)(Xs, tgrid, qm)
        self.sens = ca.Function("segments_sens", [Xs, qm], [Xe, Jx, Jq, Xt])  # Xt: the states on the grid
        Xe2, Xt = seg.map(S)(Xs, tgrid, qm)
        self.segments = ca.Function("segments", [Xs, qm], [Xe2, Xt])
        self.h = h


def _steps(ode: ODE, integrator: str):
    """(step, variational step) of the time-scaled ODE ``dx/dtau = T f(x, t0 + T tau, p)``, q = (p, T,
    t0): built once per (ode, integrator), kept by ``ode``, shared by the graphs of every grid."""
    def make():
        nx, n_p = ode.nx, ode.np
        x, tau, q = ca.SX.sym("x", nx), ca.SX.sym("tau"), ca.SX.sym("q", n_p + 2)
        F = ca.Function("scaled_rhs", [x, tau, q], [q[n_p] * ode.rhs(x, q[n_p + 1] + q[n_p] * tau, q[:n_p])])
        return make_step(F, integrator), make_variational_step(F, integrator)
    return owned_cache(ode).build(("steps", integrator), make)


def orbit_graphs(ode: ODE, N: int, S: int, integrator: str) -> OrbitGraphs:
    """The :class:`OrbitGraphs` of (N steps, S segments, integrator), kept by ``ode``.

    Parameters
    ----------
    ode : ODE
        System.
    N : int
        Integration steps per period.
    S : int
        Shooting segments.
    integrator : str
        Integrator name.

    Returns
    -------
    OrbitGraphs
    """
    return owned_cache(ode).build(("orbit_graphs", N, S, integrator), lambda: OrbitGraphs(ode, N, S, integrator))


class OrbitSystem(Evaluator):
    """Residual and exact Jacobian of the shooting system for one layout of unknowns.

    z = [X_0 .. X_{M-1} (point-major), T (if period_free), free parameters]; rows = continuity,
    periodicity, linear rows ``lin_A z - lin_b``. The numbers (p, T, t0, linear rows) are the context.
    """

    def __init__(self, graphs: OrbitGraphs, period_free: bool, free_idx: tuple, n_lin: int):
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
        """The numbers of a solve: parameters, period, start time and the linear rows ``A z = b``.

        Parameters
        ----------
        p : array_like
            Parameters.
        T : float
            Period.
        t0 : float
            Start time.
        lin_A : ndarray
            Matrix of the linear rows.
        lin_b : ndarray
            Their right-hand side.

        Returns
        -------
        None
        """
        self._ctx = (np.asarray(p, float).copy(), float(T), float(t0),
                     np.array(lin_A, float).reshape(self.n_lin, self.nz), np.array(lin_b, float).ravel())
        self._last = None

    @property
    def context(self):
        """(p, T, t0, A, b) of the current solve (the linear rows ``A z = b`` live, as anchored)."""
        return self._ctx

    def q_of(self, z) -> np.ndarray:
        """(p, T, t0) at z.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        p, T, t0 = self._ctx[0].copy(), self._ctx[1], self._ctx[2]
        k = self.nX
        if self.period_free:
            T = z[k]
            k += 1
        for j, i in enumerate(self.free_idx):
            p[i] = z[k + j]
        return np.concatenate([p, [T, t0]])

    def points(self, z) -> np.ndarray:
        """The shooting points at z (nx x (S+1)).

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray, shape (nx, S + 1)
        """
        return np.asarray(z[:self.nX]).reshape(self.S + 1, self.nx).T

    def _core(self, z):
        """Segment ends and their Jacobians at z (cached for the last z)."""
        key = z.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        nx, S = self.nx, self.S
        try:
            core = tuple(np.asarray(v) for v in self.G.sens(ca.DM(self.points(z)[:, :S]), ca.DM(self.q_of(z))))
        except RuntimeError:  # e.g. an implicit stage solve failed far from the orbit
            core = (np.full((nx, S), np.nan), np.full((nx, nx * S), np.nan), np.full((nx, self.G.nq * S), np.nan),
                    np.full((nx, self.G.N), np.nan))
        self._last = (key, core)
        return core

    def residual(self, z):
        """The residual g alone (RK4: no Jacobian, 3-10 times cheaper than :meth:`evaluate` when z is
        not the point of the last evaluation; implicit integrators: the stage solves cost most of an
        evaluation and the Jacobian only ~25 % more, so it is computed too and kept for the next step).

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        z = np.asarray(z, float).ravel()
        if self.G.integrator != "rk4" or (self._last is not None and self._last[0] == z.tobytes()):
            return self.evaluate(z)[0]
        nx, S = self.nx, self.S
        X = self.points(z)
        try:
            Xe = np.asarray(self.G.segments(ca.DM(X[:, :S]), ca.DM(self.q_of(z)))[0])
        except RuntimeError:
            Xe = np.full((nx, S), np.nan)
        A, b = self._ctx[3], self._ctx[4]
        return np.concatenate([(Xe - X[:, 1:]).T.ravel(), X[:, S] - X[:, 0], A @ z - b])

    def evaluate(self, z):
        """Residual g (continuity, periodicity, linear rows) and its exact Jacobian at z.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        g, J : ndarray
        """
        z = np.asarray(z, float).ravel()
        Xe, Jx, Jq, _ = self._core(z)
        nx, S = self.nx, self.S
        X = self.points(z)
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
        return g, J

    def trajectory(self, z):
        """The states at the N+1 grid times of the period at z (one row per time; the evaluation's,
        no new integration), or None when they are not all finite.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray, shape (N + 1, nx) or None
        """
        z = np.asarray(z, float).ravel()
        traj = np.vstack([self.points(z)[:, 0][None, :], self._core(z)[3].T])
        return traj if np.all(np.isfinite(traj)) else None

    def anchor_phase(self, z, row: int = 0) -> None:
        """Re-anchor linear row ``row`` as the Poincare section through X_0(z) orthogonal to the flow
        there (the row then reads 0 at z); no change where f(X_0) is zero or not finite.

        Parameters
        ----------
        z : ndarray
            Unknowns.
        row : int
            Linear row re-anchored.
        """
        x0 = np.asarray(z[:self.nx], float)
        q = self.q_of(z)
        f = self.G.ode.evaluate(x0, q[-1], q[:self.G.ode.np])
        nrm = float(np.linalg.norm(f))
        if not (np.isfinite(nrm) and nrm > 0):
            return
        A, b = self._ctx[3], self._ctx[4]
        A[row] = 0.0
        A[row, :self.nx] = f / nrm
        b[row] = float(A[row] @ z)

    def blocks(self, z):
        """The segment Jacobians (monodromy factors) at z.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        list of ndarray
        """
        Jx = self._core(np.asarray(z, float).ravel())[1]
        return [Jx[:, i * self.nx:(i + 1) * self.nx] for i in range(self.S)]

    def ipopt(self, method: OrbitMethod):
        """The IPOPT feasibility solver of this system (built once per option set).

        Parameters
        ----------
        method : OrbitMethod
            Method (its IPOPT options).

        Returns
        -------
        casadi.Function
        """
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


def orbit_system(graphs, period_free, free_idx, n_lin) -> OrbitSystem:
    """The :class:`OrbitSystem` over ``graphs`` for one layout of unknowns and linear rows, kept by ``graphs``.

    Parameters
    ----------
    graphs : OrbitGraphs
        Graphs of the system.
    period_free : bool
        The period is an unknown.
    free_idx : sequence of int
        Indices of the free parameters.
    n_lin : int
        Number of linear rows.

    Returns
    -------
    OrbitSystem
    """
    return owned_cache(graphs).build(("orbit_system", bool(period_free), tuple(free_idx), int(n_lin)),
                                     lambda: OrbitSystem(graphs, period_free, free_idx, n_lin))


def orbit_residual_system(ode: ODE, method: OrbitMethod, *, period_free: bool, free_idx=(), n_lin: int = 0,
                          cached: bool = True):
    """The shooting system (an evaluator with ``set_context``, ``evaluate(z) -> (g, J)``, ``g(z)``,
    ``blocks(z)``, ``nz``, ``ng``, ``points(z)``, ``q_of(z)``) for continuation and Hopf starts.

    The graphs are always cached; ``cached=False`` gives an evaluator of its own (its context -- the
    parameters and linear rows -- is then not changed by other solves).

    Parameters
    ----------
    ode : ODE
        System.
    method : OrbitMethod
        Method (points, steps, integrator).
    period_free : bool
        The period is an unknown.
    free_idx : sequence of int
        Indices of the free parameters.
    n_lin : int
        Number of linear rows.
    cached : bool
        Share the cached evaluator.

    Returns
    -------
    OrbitSystem
    """
    method.validate()
    if method.steps_per_period is None:
        raise ValueError("orbit_residual_system: give steps_per_period (a number)")
    S = method.points - 1
    G = orbit_graphs(ode, int(method.steps_per_period), S, method.integrator)
    if not cached:
        return OrbitSystem(G, period_free, tuple(free_idx), n_lin)
    return orbit_system(G, period_free, tuple(free_idx), n_lin)


def initial_points(graphs: OrbitGraphs, x_guess, p, T, t0) -> np.ndarray:
    """Shooting points (nx x (S+1)) from a guess: a single point is integrated forward over T; a
    list of M or M-1 points is used as is (closed with the first).

    Parameters
    ----------
    graphs : OrbitGraphs
        Graphs of the system.
    x_guess : array_like
        One point or a list of points.
    p : array_like
        Parameters.
    T : float
        Period.
    t0 : float
        Start time.

    Returns
    -------
    ndarray, shape (nx, S + 1)
    """
    S = graphs.S
    xg = np.asarray(x_guess, float)
    if xg.ndim == 2:
        pts = xg.T
        if pts.shape[1] == S:
            pts = np.column_stack([pts, pts[:, 0]])
        if pts.shape[1] != S + 1:
            raise ValueError(f"x_guess has {xg.shape[0]} points; expected {S} or {S + 1} (points-1 or points)")
        return pts.copy()
    return forward_points(graphs, xg, p, T, t0)


def forward_points(graphs: OrbitGraphs, x, p, T, t0) -> np.ndarray:
    """Points along the trajectory from x at the shooting times (nx x (S+1)).

    Parameters
    ----------
    graphs : OrbitGraphs
        Graphs of the system.
    x : array_like
        Start point.
    p : array_like
        Parameters.
    T : float
        Period.
    t0 : float
        Start time.

    Returns
    -------
    ndarray, shape (nx, S + 1)
    """
    q = ca.DM(np.concatenate([p, [T, t0]]))
    pts = [np.asarray(x, float)]
    for i in range(graphs.S):
        try:
            nxt = np.asarray(graphs.segment(ca.DM(pts[-1]), i / graphs.S, q)[0]).ravel()
        except RuntimeError:  # an implicit stage solve failed
            nxt = np.full(pts[-1].shape, np.nan)
        pts.append(nxt if np.all(np.isfinite(nxt)) else pts[-1])
    return np.column_stack(pts)


def first_return_period(graphs: OrbitGraphs, x, p, T_guess: float, t0: float = 0.0):
    """The return time of the trajectory from ``x`` closest to ``x``, among its crossings of the section
    through x orthogonal to f(x) (in the direction of the flow) between T_guess/1.6 and 1.6 T_guess.

    Returns ``(T, distance)`` (None, inf when there is no such crossing). The trajectory is the
    graphs' grid stretched to 1.6 T_guess (steps 1.6 times longer).

    Parameters
    ----------
    graphs : OrbitGraphs
        Graphs of the system.
    x : array_like
        Start point.
    p : array_like
        Parameters.
    T_guess : float
        Period guess.
    t0 : float
        Start time.

    Returns
    -------
    T : float or None
    distance : float
    """
    ode = graphs.ode
    x = np.asarray(x, float)
    f = ode.evaluate(x, t0, p)
    n = f / np.linalg.norm(f) if np.linalg.norm(f) > 0 else None
    span = 1.6 * T_guess
    traj = trajectory(graphs, forward_points(graphs, x, p, span, t0), p, span, t0)
    if n is None or traj is None:
        return None, float("inf")
    s = (traj - x) @ n
    t = span * np.arange(traj.shape[0]) / (traj.shape[0] - 1)
    best, dist = None, float("inf")
    for k in np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]:
        w = s[k] / (s[k] - s[k + 1])
        tc = t[k] + w * (t[k + 1] - t[k])
        if not T_guess / 1.6 <= tc <= span:
            continue
        d = float(np.linalg.norm(traj[k] + w * (traj[k + 1] - traj[k]) - x))
        if d < dist:
            best, dist = float(tc), d
    return best, dist


def trajectory(graphs: OrbitGraphs, X, p, T: float, t0: float = 0.0):
    """The states at the N+1 grid times of the period from the shooting points X (nx x (S+1)), or
    None when an evaluation fails or is not finite.

    Parameters
    ----------
    graphs : OrbitGraphs
        Graphs of the system.
    X : array_like, shape (nx, S + 1)
        Shooting points.
    p : array_like
        Parameters.
    T : float
        Period.
    t0 : float
        Start time.

    Returns
    -------
    ndarray, shape (N + 1, nx) or None
    """
    q = ca.DM(np.concatenate([p, [T, t0]]))
    try:
        Xt = np.asarray(graphs.segments(ca.DM(X[:, :graphs.S]), q)[1])
    except RuntimeError:
        return None
    traj = np.vstack([X[:, 0][None, :], Xt.T])
    return traj if np.all(np.isfinite(traj)) else None
