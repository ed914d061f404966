"""The CasADi graphs of one forced multiple-shooting configuration (:class:`ShootingGraphs`) and their
caches: the RK4 grid, the residual with its exact Jacobian (segment blocks by forward AD, assembled in
numpy), the IPOPT feasibility NLP over them."""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.rk4 import column_blocks
from birdocp.engine.oracle import ConstraintOracle, Evaluator, ipopt_options
from birdocp.engine.method import IPOPT_DEFAULTS, OrbitMethod
from birdocp.engine.problem import OrbitProblem

__all__ = ["ShootingGraphs", "shooting_graphs", "rk4_grid", "initial_points"]


def rk4_grid(ode, method: OrbitMethod, outputs) -> RK4Grid:
    """The :class:`~birdocp.engine.integrate.RK4Grid` of (method's grid, outputs), kept by ``ode``.

    Parameters
    ----------
    ode : ODE
        System.
    method : OrbitMethod
        Method (its grid).
    outputs : sequence of casadi.Function
        Outputs integrated along the grid.

    Returns
    -------
    RK4Grid
    """
    method = method.resolved(True)
    outputs = tuple(outputs)
    key = ("rk4_grid", int(method.steps_per_period), int(method.points) - 1, outputs)
    return owned_cache(ode).build(key, lambda: RK4Grid(ode, method.steps_per_period, method.points - 1, outputs))


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

    def __init__(self, ode, method: OrbitMethod, free_idx, mean_fns, extra_fns):
        self.ode = ode
        self.refs = (tuple(mean_fns), tuple(extra_fns))
        outputs = tuple(mean_fns) + tuple(extra_fns)
        self.grid = grid = rk4_grid(ode, method, outputs)
        nx, nd, np_ = ode.nx, ode.nd, ode.np
        S, N = grid.S, grid.N
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
            pfull, dsym, D, D_plain, dD, seed_p = self._free_data(ode, grid, pf, pp)
        else:
            pfull, dD, seed_p = pp, None, None
            dsym = ca.MX.sym("D", nd, 3 * N)
            D = D_plain = dsym
        # the residual alone (resid) needs the data without its parameter derivative
        self._sym = (X, pf, dsym, pp, tgt, D_plain, pfull)
        self.sens = self._sens_function(X, pf, dsym, pp, tgt, D, pfull, dD, seed_p)
        self._jac_pattern()
        self._ctx = None
        self._ctx_id = 0
        self._last = None
        self._resid = None
        self._nlp = None
        self._solvers = {}
        self._oracle = None

    def _free_data(self, ode, grid, pf, pp):
        """The per-time data as a graph of the free parameters (pfull, the data symbol, D, D without
        its derivative, dD/dpf column blocks, the parameter seeds)."""
        free_idx, nf, nd, np_, N = self.free_idx, self.nf, ode.nd, ode.np, self.N
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
        return pfull, dsym, D, D_plain, dD, seed_p

    def _sens_function(self, X, pf, dsym, pp, tgt, D, pfull, dD, seed_p):
        """The Function ``shooting_sens``: residual, segment Jacobians, mean rows, means and d g / d pf."""
        grid, nx, S, nf, nm, T = self.grid, self.nx, self.S, self.nf, self.nm, self.ode.forcing_period
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
        return ca.Function("shooting_sens", [X, pf, dsym, pp, tgt], outs,
                                ["X", "pf", "data", "p", "target"], ["g", "J", "JM", "means", "Jpf"])

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
        when parameters are free), the full parameter vector and the mean targets.

        Parameters
        ----------
        dpar : casadi.DM
            Data input (stage blocks, or the stage times when parameters are free).
        p : array_like
            Full parameter vector.
        targets : array_like
            Targets of the mean conditions.
        """
        self._ctx = (dpar, ca.DM(np.asarray(p, float)), ca.DM(np.asarray(targets, float)))
        self._ctx_id += 1
        self._last = None

    @property
    def context(self):
        """The numbers of the current solve, as given to :meth:`set_context` (identity changes with it)."""
        return self._ctx

    def symbolic_context(self, t0: float, p) -> ca.DM:
        """The data input of the graphs when parameters are free: the stage times, and with the
        pre/post split also pre's values there (numbers: pre does not depend on the free ones).

        Parameters
        ----------
        t0 : float
            Start time [s].
        p : array_like
            Parameter vector.

        Returns
        -------
        casadi.DM
        """
        times = ca.DM(self.grid.times(t0)).reshape((1, -1))
        if not self.split:
            return times
        if self.affine:  # the stage blocks themselves, at p (post evaluated here, once per context)
            return self.grid.blocks_numeric(t0, p)
        return ca.vertcat(times, self.grid.pre_numeric(t0, p))

    def evaluate(self, z):
        """(g, dense Jacobian dg/dz) at z for the current context; the last point is kept.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        g, J : ndarray
        """
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
        """The segment Jacobians J_i (list) at z if z is the last evaluated point, else None.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        list of ndarray or None
        """
        z = np.asarray(z, float).ravel()
        if self._last is None or self._last[0] != (self._ctx_id, z.tobytes()):
            return None
        nx = self.nx
        Jb = self._last[3]
        return [Jb[:, i * nx:(i + 1) * nx] for i in range(self.S)]

    def means_at(self, z):
        """The period means of all outputs (mean conditions first, then the extra outputs) at z if z
        is the last evaluated point, else None.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray or None
        """
        z = np.asarray(z, float).ravel()
        if self._last is None or self._last[0] != (self._ctx_id, z.tobytes()):
            return None
        return self._last[4]

    # -- residual alone (LM with derivatives='fd', chord steps of the continuation) ----------------
    def resid(self, z):
        """The residual g at z alone (no Jacobian), from a graph built on first use.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        if self._resid is None:
            X, pf, dsym, pp, tgt, D, pfull = self._sym
            S, nm = self.S, self.nm
            Xe, _, Q = self.grid.segments(X[:, :S], D, pfull)
            means = ca.sum2(Q) / self.ode.forcing_period if self.grid.nq else ca.MX(0, 1)
            mres = means[list(range(nm))] - tgt if nm else ca.MX(0, 1)
            g = ca.vertcat(ca.vec(Xe - X[:, 1:]), X[:, S] - X[:, 0], mres)
            self._resid = ca.Function("resid", [X, pf, dsym, pp, tgt], [g])
        z = np.asarray(z, float).ravel()
        n = self.nx * (self.S + 1)
        return np.asarray(self._resid(ca.DM(z[:n].reshape(self.S + 1, self.nx).T), ca.DM(z[n:]),
                                      *self._ctx)).ravel()

    def ipopt(self, method: OrbitMethod, fallback: bool = False):
        """The IPOPT solver of this system's feasibility problem (objective: a regularisation weight/2 times
        |z - z_ref|^2, both NLP parameters), built once per option set.

        Parameters
        ----------
        method : OrbitMethod
            Method (iteration limit, tolerance, IPOPT options).
        fallback : bool
            Reject trial steps IPOPT would accept unconditionally (``accept_every_trial_step = no``).

        Returns
        -------
        casadi.Function
        """
        tol = method.tol
        opts = ipopt_options(**IPOPT_DEFAULTS)
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


def shooting_graphs(problem: OrbitProblem, method: OrbitMethod, free_idx=None):
    """The graphs (kept by the problem's ode) of (outputs, method) with the problem's free parameters, or
    ``free_idx`` instead (the continuation adds its parameter: one unknown more than equations).

    Parameters
    ----------
    problem : OrbitProblem
        Problem (its ODE, outputs and free parameters).
    method : OrbitMethod
        Method.
    free_idx : sequence of int, optional
        Free parameter indices replacing the problem's.

    Returns
    -------
    graphs : ShootingGraphs
    build_s : float
        Wall time of the lookup or build [s].
    """
    method = method.resolved(True)
    ode = problem.ode
    mean_fns = tuple(m.output for m in problem.means)
    extra_fns = tuple(problem.outputs.values())
    free_idx = tuple(problem.free_indices() if free_idx is None else (int(j) for j in free_idx))
    key = ("shooting_graphs", int(method.steps_per_period), int(method.points), free_idx, mean_fns, extra_fns)
    cache = owned_cache(ode)
    hit = cache.get(key)
    if hit is not None:
        return hit, 0.0
    t = time.perf_counter()
    b = ShootingGraphs(ode, method, free_idx, mean_fns, extra_fns)
    cache.put(key, b)
    return b, time.perf_counter() - t


# ----------------------------------------------------------------------------------------------
def initial_points(b: ShootingGraphs, x_start, D, p):
    """X_0 = x_start, X_i by integrating forward (non-finite points replaced by x_start).

    Parameters
    ----------
    b : ShootingGraphs
        Graphs of the problem.
    x_start : array_like
        Start state X_0.
    D : casadi.DM
        Stage data of the grid.
    p : array_like
        Parameters.

    Returns
    -------
    ndarray, shape (nx, M)
        The shooting points as columns.
    """
    grid = b.grid
    Xt = np.asarray(grid.period_map(ca.DM(x_start), D, ca.DM(p))[1])
    pts = [x_start] + [Xt[:, grid.n * (i + 1) - 1] for i in range(b.S)]
    pts = [q if np.all(np.isfinite(q)) else x_start for q in pts]
    return np.column_stack(pts)
