"""Multiple shooting for periodic orbits of a forced PeriodicODE (IPOPT or Levenberg-Marquardt).

Unknowns: the shooting points X_0 .. X_{M-1} at t0 + i T/(M-1) (M counts the closing point, as in
the paper, so there are M-1 segments) and the free parameters.  Equations:

* continuity   Phi_seg(X_i) - X_{i+1} = 0,  i = 0 .. M-2  (Phi_seg: n = N/(M-1) RK4 steps)
* periodicity  X_{M-1} - X_0 = 0
* mean conditions  (1/T) integral over the period of output_k  - target_k = 0

``solver='ipopt'``: a pure feasibility NLP (objective 0; the system is square when there is one mean
condition per free parameter), limited-memory Hessian, MUMPS.  ``solver='lm'``: the paper's
Algorithm 1 (Levenberg-Marquardt on the shooting matrix, every step accepted, lambda /10 or x10).

CasADi graphs are built once per (ode, steps_per_period, points, solver, derivatives, free set,
mean/extra output Functions) and cached in this module (:mod:`birdocp.engine.cache` registry); a sweep that
re-solves with new parameter values, targets, t0 or guesses reuses them (only numbers change: the
data grid and the parameter vector are NLP parameters, not constants baked into the graph).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.engine import interrupts
from birdocp.engine.cache import bounded_cache, clear_caches
from birdocp.engine.floquet import FloquetResult, floquet_from_jacobians
from birdocp.engine.integrate import RK4Grid, column_blocks
from birdocp.engine.lm import levenberg_marquardt
from birdocp.engine.nlp import run_ipopt
from birdocp.engine.oracle import ConstraintOracle, Evaluator, ipopt_options
from birdocp.engine.problem import LimitCycleProblem, PeriodicODE, finite_vector
from birdocp.engine.results import result_dict, serial

__all__ = ["ShootingGrid", "MultipleShooting", "LimitCycleResult", "solve", "clear_cache", "floquet", "ShootingGraphs",
           "shooting_graphs", "initial_points", "rk4_grid"]

_IPOPT_DEFAULTS = {
    # Full (undamped) Newton-type steps, like the paper's LM which accepts every step. Measured on a
    # forced Duffing oscillator from a poor guess (max residual 1.2): IPOPT's filter line search
    # ended in Infeasible_Problem_Detected for M = 2, 3, 9 (and with an exact Hessian, or a
    # regularisation objective 1e-8..1e-2, for all M) while full steps converged in 7-18 iterations.
    # When this first attempt fails, solve() retries once with IPOPT's filter line search
    # (MultipleShooting.ipopt_fallback).
    "ipopt.accept_every_trial_step": "yes",
}


@dataclass(frozen=True)
class ShootingGrid:
    """The grid of a multiple-shooting method (the base of :class:`MultipleShooting` and
    :class:`birdocp.engine.orbits.OrbitMethod`).

    Attributes
    ----------
    points
        M, shooting points INCLUDING the closing one (M-1 segments), M >= 2.
    steps_per_period
        N, integrator steps over the period; a multiple of points-1 (None: chosen by the method).
    """

    points: int = 5
    steps_per_period: int | None = None

    def validate_grid(self) -> None:
        """Raise ValueError (naming the class and the field) unless M >= 2 and N is a positive
        multiple of M-1 (or None)."""
        name, n = type(self).__name__, self.steps_per_period
        if not isinstance(self.points, (int, np.integer)) or self.points < 2:
            raise ValueError(f"{name}.points must be an integer >= 2, got {self.points!r}")
        if n is None:
            return
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"{name}.steps_per_period must be a positive integer, got {n!r}")
        if n % (self.points - 1):
            raise ValueError(f"{name}.steps_per_period={n} must be a multiple of points-1={self.points - 1}")


@dataclass(frozen=True)
class MultipleShooting(ShootingGrid):
    """How to solve a LimitCycleProblem.

    Attributes
    ----------
    points, steps_per_period
        M and N of the grid (:class:`ShootingGrid`); N is required (RK4 steps over the period).
    solver
        "ipopt" | "lm" (the paper's Levenberg-Marquardt).
    derivatives
        "exact" (CasADi AD) | "fd" (forward differences of the segment flow, relative
        step 1e-3*x_j, absolute step 1e-3*fd_floor when |x_j| < fd_floor; lm only).
    tol
        None -> 1e-10 for ipopt (``constr_viol_tol`` and ``tol``),
        1e-5 for lm (max |E|, as in the paper). Both are absolute max-norms.
    max_iter
        iteration limit.
    ipopt_options
        merged over the defaults (full steps ``accept_every_trial_step``, limited-
        memory Hessian, MUMPS, silent).
    fd_floor
        see ``derivatives``.
    regularization
        ipopt objective weight w in w/2 |z - z_guess|^2 (z = shooting points and free
        parameters). Default 0: pure feasibility (measured: no weight in 1e-8..1e-2
        helped IPOPT converge; the square system fixes the solution anyway).
    ipopt_fallback
        if the first IPOPT attempt (full steps) fails, retry once from the same guess
        with IPOPT's filter line search; iterations and histories are concatenated.
    """

    steps_per_period: int = 148  # the paper's grid (M = 5: 37 steps per segment)
    solver: str = "ipopt"
    derivatives: str = "exact"
    tol: float | None = None
    max_iter: int = 100
    ipopt_options: dict = field(default_factory=dict)
    fd_floor: float = 1e-3
    regularization: float = 0.0
    ipopt_fallback: bool = True

    def validate(self) -> None:
        """Raise ValueError on the first invalid field (named)."""
        if self.steps_per_period is None:
            raise ValueError("MultipleShooting.steps_per_period must be a positive integer, got None")
        self.validate_grid()
        if self.solver not in ("ipopt", "lm"):
            raise ValueError(f"MultipleShooting.solver must be 'ipopt' or 'lm', got {self.solver!r}")
        if self.derivatives not in ("exact", "fd"):
            raise ValueError(f"MultipleShooting.derivatives must be 'exact' or 'fd', got {self.derivatives!r}")
        if self.derivatives == "fd" and self.solver != "lm":
            raise ValueError("MultipleShooting.derivatives='fd' is only available with solver='lm'")
        if self.tol is not None and not self.tol > 0:
            raise ValueError(f"MultipleShooting.tol must be positive, got {self.tol!r}")
        if not isinstance(self.max_iter, (int, np.integer)) or self.max_iter < 0:
            raise ValueError(f"MultipleShooting.max_iter must be a non-negative integer, got {self.max_iter!r}")

    @property
    def resolved_tol(self) -> float:
        if self.tol is not None:
            return float(self.tol)
        return 1e-10 if self.solver == "ipopt" else 1e-5


@dataclass
class LimitCycleResult:
    """Outcome of :func:`solve`. Failures are results (``success=False``), not exceptions.

    Attributes
    ----------
    status
        IPOPT ``return_status`` (e.g. "Solve_Succeeded") for ipopt; "converged", "max_iter",
        "nan", "singular" for lm; "nan" also when an ipopt iterate is non-finite or the residual is
        not finite; "residual_above_tol" when the status claims convergence ("Solve_Succeeded",
        "converged") but the max residual exceeds the tolerance (IPOPT's approximate statuses,
        e.g. "Solved_To_Acceptable_Level", are kept, with success False). ``success`` means converged: a finite max residual at most the
        tolerance (10 x tol for ipopt, whose own measure can differ slightly), finite multipliers.
    residual_history
        max |continuity + periodicity (+ mean) residual| per iteration (ipopt: inf_pr
        as reported by IPOPT, unscaled; lm: max|E| before each step and after the last).
    max_residual
        max abs of all equations (continuity, periodicity, mean conditions) at the result.
    means
        period mean of each mean-condition output and each extra output (by name).
    monodromy_vs_full_period_jacobian
        max abs difference between the product of segment Jacobians
        and the Jacobian of the one-period map from x0 (accuracy indicator).
    doubling_times_s
        ln 2 / Re(exponent), signed (negative = minus the halving time); see floquet.

    ``to_dict()`` is the JSON of every result (:func:`birdocp.engine.results.result_dict`): complex
    numbers as ``[re, im]`` pairs (``eigenvectors``: one list of pairs per mode, in the order of the
    multipliers), NaN and inf as null.
    """

    success: bool
    status: str
    message: str
    iterations: int
    residual_history: np.ndarray
    wall_s: dict
    shooting_times: np.ndarray
    shooting_points: np.ndarray
    x0: np.ndarray
    p: np.ndarray
    free_values: dict
    trajectory_t: np.ndarray
    trajectory_x: np.ndarray
    max_residual: float
    means: dict
    monodromy: np.ndarray | None = None
    multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    eigenvectors: np.ndarray | None = field(default=None, metadata=serial(complex=True, columns=True))
    floquet_exponents: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    doubling_times_s: np.ndarray | None = None
    stable: bool | None = None
    monodromy_vs_full_period_jacobian: float = float("nan")
    method: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """JSON-ready dict (see the class docstring)."""
        return result_dict(self)


# ----------------------------------------------------------------------------------------------
# caches
_GRIDS = bounded_cache("engine.rk4_grids", 32)
_GRAPHS = bounded_cache("engine.shooting_graphs", 32)


def clear_cache() -> None:
    """Clear every in-memory cache of the process (:func:`birdocp.engine.cache.clear_caches`)."""
    clear_caches()


def rk4_grid(ode, method: MultipleShooting, outputs) -> RK4Grid:
    """The cached :class:`~birdocp.engine.integrate.RK4Grid` of (ode, method's grid, outputs)."""
    outputs = tuple(outputs)
    key = (id(ode), int(method.steps_per_period), int(method.points) - 1, tuple(id(g) for g in outputs))
    hit = _GRIDS.get(key)
    if hit is not None and hit[0] is ode:
        return hit[2]
    grid = RK4Grid(ode, method.steps_per_period, method.points - 1, outputs)
    _GRIDS.put(key, (ode, outputs, grid))  # holding the references keeps the ids unique
    return grid


class ShootingGraphs(Evaluator):
    """The graphs of one shooting configuration (see module docstring for the cache key).

    Residual and Jacobian (``evaluate``): one CasADi Function ``sens`` returns the segment ends, the
    output integrals and their state Jacobians (forward AD, nx directions, per segment) and, with
    free parameters, the derivative of the residual with respect to them (forward AD through the
    per-time data, one direction per free parameter); the shooting matrix (J_i, -I, the periodicity
    rows, the mean rows) is assembled around the blocks in numpy. IPOPT sees g(z) as a callback that
    evaluates g and its Jacobian together and keeps the last point (IPOPT asks for the Jacobian at
    the point where it just evaluated g), so each iterate costs one such evaluation, and the
    blocks at the solution are the monodromy factors. Measured on the reference trim: IPOPT's own
    AD of the MX shooting graph took 1.6 s to build (``nlpsol``) and colours the 20 x 20 Jacobian
    with 8 forward directions through the segments; this needs 4 and builds in ~0.2 s.
    """

    def __init__(self, ode, method: MultipleShooting, free_idx, mean_fns, extra_fns):
        self.ode = ode
        self.refs = (tuple(mean_fns), tuple(extra_fns))
        outputs = tuple(mean_fns) + tuple(extra_fns)
        self.grid = grid = rk4_grid(ode, method, outputs)
        nx, nd, np_ = ode.nx, ode.nd, ode.np
        S, N, T = grid.S, grid.N, ode.period_s
        self.M, self.S, self.N = S + 1, S, N
        self.nx = nx
        self.free_idx = tuple(free_idx)
        nf, nm = len(free_idx), len(mean_fns)
        self.nf, self.nm = nf, nm
        self.symbolic_data = bool(nf)
        self.split = False
        self.affine = False
        self.nz = nx * (S + 1) + nf
        self.ng = nx * (S + 1) + nm

        X = ca.MX.sym("X", nx, S + 1)
        pf = ca.MX.sym("pf", nf)
        pp = ca.MX.sym("p", np_)
        tgt = ca.MX.sym("target", nm)
        if nf:
            pels = [pp[j] for j in range(np_)]
            for k, j in enumerate(free_idx):
                pels[j] = pf[k]
            pfull = ca.vertcat(*pels)
            dsym = ca.MX.sym("times", 1, 2 * N + 1)
            K = 2 * N + 1
            seed_p = ca.DM.zeros(np_, nf)
            for k, j in enumerate(free_idx):
                seed_p[j, k] = 1.0
            self.split = ode.pre is not None and not (set(free_idx) & set(ode.pre_params))
            C = _affine_columns(ode, free_idx) if self.split else None
            if C is not None:
                # every free parameter enters post affinely with a constant coefficient (e.g. the
                # wing-root position: a translation of the element centres): the data is a number of
                # the context, evaluated at the context's p, plus C (pf - p_free) on every column
                self.affine = True
                dsym = ca.MX.sym("D", nd, 3 * N)
                D = D_plain = dsym + ca.repmat(ca.mtimes(C, pf - pp[list(free_idx)]), 1, 3 * N)
                dD = ca.horzcat(*[ca.repmat(C[:, k], 1, 3 * N) for k in range(nf)])
            elif self.split:
                # data = post(pre(t, p), t, p) with pre independent of the free parameters: pre's
                # values on the stage grid are numbers of the context (row 0: times, rows 1..: pre),
                # only post (and its derivative along the free parameters) is in the graph
                nl = ode.pre.size1_out(0)
                dsym = ca.MX.sym("data", 1 + nl, K)
                ts_, ls_, ps_ = ca.SX.sym("t"), ca.SX.sym("local", nl), ca.SX.sym("p", np_)
                d_ = ode.post(ls_, ts_, ps_)
                dfw = ode.fast(ca.Function("post_dpf", [ts_, ls_, ps_], [d_, ca.jtimes(d_, ps_, seed_p)]),
                               "post_dpf " + ",".join(str(j) for j in free_idx))
                Dg, dDt = dfw.map(K)(dsym[0, :], dsym[1:, :], pfull)
                dDg = ca.horzcat(*[dDt[:, list(range(k, K * nf, nf))] for k in range(nf)])
                D_plain = grid.numeric_post_grid(dsym[1:, :], dsym[0, :], pfull)[:, grid.block_index]
            elif ode.data.is_a("SXFunction") or ode.pre is not None:
                # data and its derivative along the free parameters as one SX Function (shared
                # subexpressions; constant seeds prune the parts that do not depend on them):
                # measured 0.43 s on the stage grid vs 0.2 s data + 0.64 s its forward derivative
                ts_, ps_ = ca.SX.sym("t"), ca.SX.sym("p", np_)
                d_ = ode.post(ode.pre(ts_, ps_), ts_, ps_) if ode.pre is not None else ode.data(ts_, ps_)
                dfw = ca.Function("data_dpf", [ts_, ps_], [d_, ca.jtimes(d_, ps_, seed_p)])
                Dg, dDt = dfw.map(K)(dsym, pfull)  # dDt: time-major (nf columns per time)
                dDg = ca.horzcat(*[dDt[:, list(range(k, K * nf, nf))] for k in range(nf)])
                D_plain = grid.data_grid(dsym, pfull)[:, grid.block_index]
            else:
                Dg = grid.data_grid(dsym, pfull)
                seed_map = ca.horzcat(*[ca.repmat(seed_p[:, k], 1, K) for k in range(nf)])  # p is mapped
                dDg = grid.data_grid.forward(nf)(dsym, pfull, Dg, ca.DM.zeros(1, K * nf), seed_map)
                D_plain = None
            if C is None:
                D = Dg[:, grid.block_index]
                if D_plain is None:
                    D_plain = D
                dD = ca.horzcat(*[dk[:, grid.block_index] for dk in column_blocks(dDg, nf)])
        else:
            pfull = pp
            dsym = ca.MX.sym("D", nd, 3 * N)
            D = D_plain = dsym
        # the residual alone (resid) needs the data without its parameter derivative
        self._sym = (X, pf, dsym, pp, tgt, D_plain, pfull)
        Xe, Q, J, JQ = grid.segment_sensitivities(X[:, :S], D, pfull)
        means = ca.sum2(Q) / T if grid.nq else ca.MX(0, 1)
        mres = means[list(range(nm))] - tgt if nm else ca.MX(0, 1)
        g = ca.vertcat(ca.vec(Xe - X[:, 1:]), X[:, S] - X[:, 0], mres)
        outs = [g, J, JQ[list(range(nm)), :] / T if nm else ca.MX(0, nx * S), means]
        if nf:
            # d g / d pf by forward AD along each free parameter, through the data (one directional
            # derivative of the data map, reusing its nominal values) and the segments
            # (one single-direction call per parameter: called alone, 2 x 21 ms against 62 ms for
            # one call with two directions on the bird's 148-step grid; inside this graph the level
            # continuation's evaluation measured the same 0.20 s either way)
            Xe2, Xt2, Q2 = grid.segments(X[:, :S], D, pfull)
            fwd1 = grid.segments.forward(1)
            cols = []
            for k, dDk in enumerate(column_blocks(dD, nf)):
                dXe, _, dQ = fwd1(X[:, :S], D, pfull, Xe2, Xt2, Q2, ca.DM.zeros(nx, S), dDk, seed_p[:, k])
                dQk = ca.sum2(dQ)[list(range(nm))] / T if nm else ca.MX(0, 1)
                cols.append(ca.vertcat(ca.vec(dXe), dQk))
            outs.append(ca.horzcat(*cols))
        else:
            outs.append(ca.MX(nx * S + nm, 0))
        self.sens = ca.Function("shooting_sens", [X, pf, dsym, pp, tgt], outs,
                                ["X", "pf", "data", "p", "target"], ["g", "J", "JM", "means", "Jpf"])
        self._jac_pattern()
        self._ctx = None
        self._ctx_id = 0
        self._last = None
        self._resid = None
        self._nlp = None
        self._solvers = {}
        self._oracle = None

    def _jac_pattern(self):
        nx, S, nf = self.nx, self.S, self.nf
        P = np.zeros((self.ng, self.nz), bool)
        I = np.eye(nx, dtype=bool)
        for i in range(S):
            r = slice(i * nx, (i + 1) * nx)
            P[r, i * nx:(i + 1) * nx] = True
            P[r, (i + 1) * nx:(i + 2) * nx] |= I
        P[S * nx:(S + 1) * nx, 0:nx] |= I
        P[S * nx:(S + 1) * nx, S * nx:(S + 1) * nx] |= I
        P[(S + 1) * nx:, :S * nx] = True
        if nf:
            P[:S * nx, -nf:] = True
            P[(S + 1) * nx:, -nf:] = True
        rows, cols = np.nonzero(P.T)  # column-major order, as CasADi stores nonzeros
        self.jac_sparsity = ca.Sparsity.triplet(self.ng, self.nz, cols.tolist(), rows.tolist())

    # -- numbers of one solve ----------------------------------------------------------------
    def set_context(self, dpar: ca.DM, p, targets) -> None:
        """The numbers the residual depends on besides z: data (stage blocks D, or the stage times
        when parameters are free), the full parameter vector and the mean targets."""
        self._ctx = (dpar, ca.DM(np.asarray(p, float)), ca.DM(np.asarray(targets, float)))
        self._ctx_id += 1
        self._last = None

    @property
    def context(self):
        """The numbers of the current solve, as given to :meth:`set_context` (identity changes with it)."""
        return self._ctx

    def symbolic_context(self, t0: float, p) -> ca.DM:
        """The data input of the graphs when parameters are free: the stage times, and with the
        pre/post split also pre's values there (numbers: pre does not depend on the free ones)."""
        times = ca.DM(self.grid.times(t0)).reshape((1, -1))
        if not self.split:
            return times
        if self.affine:  # the stage blocks themselves, at p (post evaluated here, once per context)
            return self.grid.blocks_numeric(t0, p)
        return ca.vertcat(times, self.grid.pre_numeric(t0, p))

    def evaluate(self, z):
        """(g, dense Jacobian dg/dz) at z for the current context; the last point is kept."""
        z = np.asarray(z, float).ravel()
        key = (self._ctx_id, z.tobytes())
        if self._last is not None and self._last[0] == key:
            return self._last[1], self._last[2]
        nx, S, nf, nm = self.nx, self.S, self.nf, self.nm
        X = z[:nx * (S + 1)].reshape(S + 1, nx).T
        dpar, pd, tg = self._ctx
        g, J, JM, means, Jpf = self.sens(ca.DM(X), ca.DM(z[nx * (S + 1):]), dpar, pd, tg)
        g = np.asarray(g).ravel()
        Jb = np.asarray(J)
        A = np.zeros((self.ng, self.nz))
        I = np.eye(nx)
        for i in range(S):
            A[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = Jb[:, i * nx:(i + 1) * nx]
            A[i * nx:(i + 1) * nx, (i + 1) * nx:(i + 2) * nx] = -I
        A[S * nx:(S + 1) * nx, 0:nx] = -I
        A[S * nx:(S + 1) * nx, S * nx:(S + 1) * nx] = I
        if nm:
            A[(S + 1) * nx:, :S * nx] = np.asarray(JM)
        if nf:
            Jp = np.asarray(Jpf)
            A[:S * nx, -nf:] = Jp[:S * nx]
            A[(S + 1) * nx:, -nf:] = Jp[S * nx:]
        self._last = (key, g, A, Jb, np.asarray(means).ravel())
        return g, A

    def blocks_at(self, z):
        """The segment Jacobians J_i (list) at z if z is the last evaluated point, else None."""
        z = np.asarray(z, float).ravel()
        if self._last is None or self._last[0] != (self._ctx_id, z.tobytes()):
            return None
        nx = self.nx
        Jb = self._last[3]
        return [Jb[:, i * nx:(i + 1) * nx] for i in range(self.S)]

    def means_at(self, z):
        """The period means of all outputs (mean conditions first, then the extra outputs) at z if z
        is the last evaluated point, else None."""
        z = np.asarray(z, float).ravel()
        if self._last is None or self._last[0] != (self._ctx_id, z.tobytes()):
            return None
        return self._last[4]

    # -- residual alone (LM with derivatives='fd', chord steps of the continuation) ----------------
    def resid(self, z):
        if self._resid is None:
            X, pf, dsym, pp, tgt, D, pfull = self._sym
            S, nm = self.S, self.nm
            Xe, _, Q = self.grid.segments(X[:, :S], D, pfull)
            means = ca.sum2(Q) / self.ode.period_s if self.grid.nq else ca.MX(0, 1)
            mres = means[list(range(nm))] - tgt if nm else ca.MX(0, 1)
            g = ca.vertcat(ca.vec(Xe - X[:, 1:]), X[:, S] - X[:, 0], mres)
            self._resid = ca.Function("resid", [X, pf, dsym, pp, tgt], [g])
        z = np.asarray(z, float).ravel()
        n = self.nx * (self.S + 1)
        return np.asarray(self._resid(ca.DM(z[:n].reshape(self.S + 1, self.nx).T), ca.DM(z[n:]),
                                      *self._ctx)).ravel()

    def ipopt(self, method: MultipleShooting, fallback: bool = False):
        tol = method.resolved_tol
        opts = ipopt_options(**_IPOPT_DEFAULTS)
        opts.update({"ipopt.max_iter": int(method.max_iter), "ipopt.tol": tol, "ipopt.constr_viol_tol": tol})
        opts.update(method.ipopt_options)
        if fallback:
            opts["ipopt.accept_every_trial_step"] = "no"
        key = repr(sorted(opts.items()))
        s = self._solvers.get(key)
        if s is None:
            if self._nlp is None:
                # objective: regularization/2 * |z - z_ref|^2 (z_ref = the initial guess, an NLP
                # parameter); the weight is a parameter too, so 0 (pure feasibility) and >0 share one graph
                self._oracle = ConstraintOracle(self, "shooting")
                z = ca.MX.sym("z", self.nz)
                zref = ca.MX.sym("zref", self.nz)
                wreg = ca.MX.sym("wreg")
                self._nlp = {"x": z, "p": ca.vertcat(zref, wreg), "f": 0.5 * wreg * ca.sumsqr(z - zref),
                             "g": self._oracle(z)}
            s = ca.nlpsol("shooting", "ipopt", self._nlp, opts)
            self._solvers[key] = s
        return s


def _affine_columns(ode, free_idx):
    """C (nd x nf, numbers) when post(local, t, p) is affine in every free parameter with a constant
    coefficient (d post / d p_j depends on nothing), else None. Measured 0.02-0.04 s on the bird, once
    per (cached) builder."""
    ts_, ls_, ps_ = ca.SX.sym("t"), ca.SX.sym("local", ode.post.size1_in(0)), ca.SX.sym("p", ode.np)
    d_ = ode.post(ls_, ts_, ps_)
    cols = []
    for j in free_idx:
        cj = ca.jacobian(d_, ps_[j])
        if ca.depends_on(cj, ca.vertcat(ts_, ls_, ps_)):
            cols = None
            break
        cols.append(ca.DM(ca.evalf(cj)))
    return ca.horzcat(*cols) if cols else None


def shooting_graphs(problem: LimitCycleProblem, method: MultipleShooting, free_idx=None):
    """The cached graphs of (problem's ode, outputs, method) with the problem's free parameters, or
    ``free_idx`` instead (the continuation adds its parameter: one unknown more than equations)."""
    ode = problem.ode
    mean_fns = tuple(m.output for m in problem.means)
    extra_fns = tuple(problem.outputs.values())
    free_idx = tuple(problem.free_indices() if free_idx is None else (int(j) for j in free_idx))
    key = (id(ode), int(method.steps_per_period), int(method.points), free_idx,
           tuple(id(f) for f in mean_fns), tuple(id(f) for f in extra_fns))
    hit = _GRAPHS.get(key)
    if hit is not None and hit.ode is ode:
        return hit, 0.0
    t = time.perf_counter()
    b = ShootingGraphs(ode, method, free_idx, mean_fns, extra_fns)
    _GRAPHS.put(key, b)
    return b, time.perf_counter() - t


# ----------------------------------------------------------------------------------------------
def initial_points(b: ShootingGraphs, x_start, D, p):
    """X_0 = x_start, X_i by integrating forward (non-finite points replaced by x_start)."""
    grid = b.grid
    Xt = np.asarray(grid.period_map(ca.DM(x_start), D, ca.DM(p))[1])
    pts = [x_start] + [Xt[:, grid.n * (i + 1) - 1] for i in range(b.S)]
    pts = [q if np.all(np.isfinite(q)) else x_start for q in pts]
    return np.column_stack(pts)


def _lm(b: ShootingGraphs, method, problem, z, lo, hi, fd):
    """The paper's Algorithm 1: :func:`birdocp.engine.lm.levenberg_marquardt` with every step accepted
    (``accept="always"``, lam from 1). Returns (z, status, message, iterations, history).

    Exact derivatives: the shooting matrix from :meth:`ShootingGraphs.evaluate` (segment blocks by forward
    AD, assembled in numpy; residual and Jacobian in one evaluation per iterate); ``fd``: forward
    differences (:func:`_fd_jacobian`)."""
    nf = b.nf
    nzx = b.nz - nf
    lo_z = np.concatenate([np.full(nzx, -np.inf), lo]) if nf else None
    hi_z = np.concatenate([np.full(nzx, np.inf), hi]) if nf else None
    jac = (lambda zz, r: _fd_jacobian(b, problem, zz, r, method.fd_floor)) if fd else None
    out = levenberg_marquardt(b, z, tol=method.resolved_tol, max_iter=method.max_iter, lo=lo_z, hi=hi_z,
                              accept="always", lam0=1.0, stall_window=0, jacobian=jac, symbol="E")
    return out.z, out.status, out.message, out.iterations, out.history


def _fd_jacobian(b: ShootingGraphs, problem, z, r0, floor):
    """Forward differences as in the paper: segment Jacobians column by column (all segments in one
    mapped call per state), the shooting matrix assembled around them; free-parameter columns by
    forward differences of the whole residual."""
    nx, S, nf, nm = problem.ode.nx, b.S, b.nf, b.nm
    T = problem.ode.period_s
    X = z[: nx * (S + 1)].reshape(S + 1, nx).T
    pfull = problem.p.copy()
    if nf:
        pfull[list(b.free_idx)] = z[-nf:]
    Dn = b.grid.blocks_numeric(problem.t0, pfull)
    J = np.zeros((b.ng, b.nz))
    I = np.eye(nx)
    Js, dQ = b.grid.fd_segment_jacobians(X[:, :S], Dn, pfull, floor)
    dM = dQ[:nm] / T
    for i in range(S):
        J[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = Js[i]
        J[i * nx:(i + 1) * nx, (i + 1) * nx:(i + 2) * nx] = -I
        for k in range(nm):
            J[(S + 1) * nx + k, i * nx:(i + 1) * nx] = dM[k, i]
    J[S * nx:(S + 1) * nx, 0:nx] = -I
    J[S * nx:(S + 1) * nx, S * nx:(S + 1) * nx] = I
    for k in range(nf):
        col = b.nz - nf + k
        zp = z.copy()
        hk = 1e-3 * z[col] if abs(z[col]) >= floor else 1e-3 * floor
        zp[col] += hk
        rp = b.resid(zp)
        J[:, col] = (rp - r0) / hk
    return J


def _run_ipopt(solver, z0, method, lbx, ubx):
    """One IPOPT attempt through the engine's one front (:func:`birdocp.engine.nlp.run_ipopt`)."""
    out = run_ipopt(solver, z0, lbx=lbx, ubx=ubx, p=np.concatenate([z0, [method.regularization]]))
    return out.z, out.status, out.success, out.iterations, out.history, out.message


def solve(problem: LimitCycleProblem, method: MultipleShooting = MultipleShooting(),
          warm_start: "LimitCycleResult | None" = None) -> LimitCycleResult:
    """Find the periodic orbit (and free parameters) of ``problem`` and its Floquet multipliers.

    ``success`` means converged: the max residual of all equations at the result is finite and at
    most the method's tolerance (10 x tol for IPOPT), whatever the solver's status says (IPOPT's
    ``Feasible_Point_Found`` or ``Solved_To_Acceptable_Level`` with a larger residual is a failure;
    a ``Solve_Succeeded`` with a larger residual becomes status ``residual_above_tol``). A Ctrl-C
    during the solve raises ``KeyboardInterrupt`` (never a status, never a retry), also when CasADi
    caught it inside IPOPT.
    """
    with interrupts.interruptible():
        return _solve(problem, method, warm_start)


def _converged(max_res: float, tol: float) -> bool:
    return bool(np.isfinite(max_res) and max_res <= tol)


def _solve(problem, method, warm_start):
    t_total = time.perf_counter()
    method.validate()
    ode = problem.ode
    nx, T, t0 = ode.nx, ode.period_s, float(problem.t0)
    b, build_s = shooting_graphs(problem, method)
    grid, S, N = b.grid, b.S, b.N
    free_idx = b.free_idx
    nf = len(free_idx)
    lo, hi = problem.free_bounds() if nf else (np.zeros(0), np.zeros(0))
    wall = {"build": build_s, "data": 0.0, "solve": 0.0, "floquet": 0.0}

    # --- initial values
    p_init = problem.p.copy()
    if warm_start is not None and np.shape(warm_start.p) == p_init.shape and nf:
        p_init[list(free_idx)] = np.asarray(warm_start.p)[list(free_idx)]
    if nf:
        p_init[list(free_idx)] = np.clip(p_init[list(free_idx)], lo, hi)
    td = time.perf_counter()
    D_init = grid.blocks_numeric(t0, p_init)
    wall["data"] += time.perf_counter() - td
    if warm_start is not None and np.shape(warm_start.shooting_points) == (S + 1, nx) \
            and np.all(np.isfinite(warm_start.shooting_points)):
        X0 = np.asarray(warm_start.shooting_points, float).T.copy()
    else:
        x_start = np.asarray(warm_start.x0, float) if warm_start is not None else problem.x_guess
        if not np.all(np.isfinite(x_start)):
            x_start = problem.x_guess
        X0 = initial_points(b, x_start, D_init, p_init)
    z0 = np.concatenate([X0.T.ravel(), p_init[list(free_idx)]])
    targets = np.array([m.target for m in problem.means], float)
    if b.symbolic_data:
        b.set_context(b.symbolic_context(t0, problem.p), problem.p, targets)
    else:
        b.set_context(D_init, p_init, targets)

    # --- solve
    ts = time.perf_counter()
    if method.solver == "ipopt":
        lbx = np.concatenate([np.full(nx * (S + 1), -np.inf), lo])
        ubx = np.concatenate([np.full(nx * (S + 1), np.inf), hi])
        attempts = [False, True] if method.ipopt_fallback and "ipopt.accept_every_trial_step" not in \
            method.ipopt_options else [False]
        iters, hists, msgs = 0, [], []
        for fallback in attempts:
            z, status, success, it, h, msg = _run_ipopt(b.ipopt(method, fallback), z0, method, lbx, ubx)
            if np.all(np.isfinite(z)):  # the status alone is not convergence: the residual decides
                r_try = b.evaluate(z)[0]  # IPOPT's last evaluation (kept), or one more
                success = _converged(float(np.max(np.abs(r_try))) if r_try.size else 0.0,
                                     10 * method.resolved_tol)
            iters += it
            hists.append(h)
            msgs.append(("filter line search: " if fallback else "") + msg)
            if success:
                break
        hist = np.concatenate(hists)
        message = "; retried: ".join(msgs)
    else:
        z, status, message, iters, hist = _lm(b, method, problem, z0.copy(), lo, hi,
                                              method.derivatives == "fd")
        success = status == "converged"
        hist = np.asarray(hist, float)
    wall["solve"] = time.perf_counter() - ts

    # --- evaluate at the result (numerically: the data at the solved parameters once, then the
    # segments; the same numbers also give the Floquet blocks' full-period check below)
    nzx = nx * (S + 1)
    pfull = problem.p.copy() if nf else p_init.copy()
    if nf:
        pfull[list(free_idx)] = z[nzx:]
    if nf and np.all(np.isfinite(pfull)):
        td = time.perf_counter()
        Dn = grid.blocks_numeric(t0, pfull)
        wall["data"] += time.perf_counter() - td
    elif nf:
        Dn = None
    else:
        Dn = D_init
    pd = ca.DM(pfull)
    if Dn is not None:
        Xz = z[:nzx].reshape(S + 1, nx).T
        Xe, Xt, Qv = (np.asarray(v) for v in grid.segments(ca.DM(Xz[:, :S]), Dn, pd))
        means_v = np.sum(Qv, axis=1) / T if grid.nq else np.zeros(0)
        g = np.concatenate([(Xe - Xz[:, 1:]).T.ravel(), Xz[:, S] - Xz[:, 0], means_v[:b.nm] - targets])
    else:
        Xt = np.full((nx, N), np.nan)
        means_v = np.full(grid.nq, np.nan)
        g = np.full(b.ng, np.nan)
    max_res = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
    tol_ok = method.resolved_tol * (10 if method.solver == "ipopt" else 1)
    if not _converged(max_res, tol_ok):
        message += (f" (max residual {max_res:.2e} > tol {tol_ok:.1e}: not converged)"
                    if np.isfinite(max_res) else " (non-finite residual: not converged)")
        if status in ("converged", "Solve_Succeeded"):  # a status that claims the tolerance: replaced
            status = "residual_above_tol" if np.isfinite(max_res) else "nan"
        success = False
    elif not success and method.solver == "ipopt":
        # converged means the residual is below the tolerance, whatever IPOPT's status says
        message += f" (max residual {max_res:.2e}: converged)"
        success = True
    X = z[: nx * (S + 1)].reshape(S + 1, nx)
    traj_x = np.vstack([X[0][None, :], Xt.T])
    names = problem.mean_names()
    means = {n: float(v) for n, v in zip(names, means_v.ravel())}
    res = LimitCycleResult(
        success=bool(success), status=status, message=message, iterations=int(iters),
        residual_history=hist, wall_s=wall,
        shooting_times=t0 + T / S * np.arange(S + 1), shooting_points=X, x0=X[0].copy(), p=pfull,
        free_values={problem.free_name(i): float(pfull[i]) for i in free_idx},
        trajectory_t=t0 + grid.h * np.arange(N + 1), trajectory_x=traj_x,
        max_residual=max_res, means=means,
        method={"points": method.points, "steps_per_period": method.steps_per_period,
                "solver": method.solver, "derivatives": method.derivatives,
                "tol": method.resolved_tol, "max_iter": method.max_iter},
    )

    # --- Floquet (also after a failure, when the iterate is finite: useful for diagnosis)
    if np.all(np.isfinite(z)) and np.all(np.isfinite(g)):
        tf = time.perf_counter()
        try:
            Js = b.blocks_at(z)  # IPOPT's (or LM's) last Jacobian evaluation, when at z
            if Js is None:
                _, Jcat = grid.segment_jacobians(ca.DM(X[:S].T), Dn, pd)
                Jcat = np.asarray(Jcat)
                Js = [Jcat[:, i * nx:(i + 1) * nx] for i in range(S)]
            _, Jfull = grid.period_jacobian(ca.DM(X[0]), Dn, pd)
            fr = floquet_from_jacobians(Js, np.asarray(Jfull), T)
            res.monodromy, res.multipliers, res.eigenvectors = fr.monodromy, fr.multipliers, fr.eigenvectors
            res.floquet_exponents, res.doubling_times_s = fr.floquet_exponents, fr.doubling_times_s
            res.stable = fr.stable
            res.monodromy_vs_full_period_jacobian = fr.monodromy_vs_full_period_jacobian
        except Exception as e:  # never raise from the analysis of a result
            interrupts.check_from(e)
            res.message += f"; Floquet analysis failed: {e}"
        if res.success and (res.multipliers is None or not np.all(np.isfinite(res.multipliers))):
            res.success, res.status = False, "nan"  # a cycle without finite multipliers is no success
            res.message += "; non-finite Floquet multipliers"
        wall["floquet"] = time.perf_counter() - tf
    wall["total"] = time.perf_counter() - t_total
    return res


def floquet(ode: PeriodicODE, x0, p, method=None, *, t0: float = 0.0, points=None, grid=None, blocks=None) -> FloquetResult:
    """Floquet analysis at the periodic orbit through ``x0`` (at time t0) for parameters ``p``.

    ``method`` is a :class:`~birdocp.engine.shooting.MultipleShooting` (points, steps_per_period); default
    ``MultipleShooting()``.  ``points`` (M x nx or (M-1) x nx) are the shooting points; by default
    they are obtained by integrating forward from x0 (identical at a converged orbit).
    """
    method = method or MultipleShooting()
    method.validate()
    grid = grid or rk4_grid(ode, method, ())
    x0 = finite_vector(x0, "floquet x0", ode.nx, f"the ODE has nx={ode.nx}")
    p = finite_vector(p, "floquet p", ode.np, f"the ODE has np={ode.np}")
    D = blocks if blocks is not None else grid.blocks_numeric(t0, p)
    pd = ca.DM(p)
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
