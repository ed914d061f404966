"""Fixed-step RK4 on a :class:`~birdocp.engine.ode.ODE`, as CasADi Functions.

Layout of the data (the time-dependent vector d(t, p)):

* For N RK4 steps of size h = T/N starting at t0, RK4 needs d at the 2N+1 times
  ``t0 + k h/2`` (k = 0..2N): the *data grid*, nd x (2N+1), computed with ``data.map(2N+1)``.
* Step k uses the columns (2k, 2k+1, 2k+2) (d at t, t+h/2, t+h); these nd x 3 blocks hstacked give
  the *stage blocks*, nd x 3N, which is what the segment Functions (``step.mapaccum``) consume.

Quadrature of outputs g(x, d, p) (period means): the state is augmented with the running integral
q' = g(x, d, p) and the augmented system is integrated with the same RK4 step, i.e. the increment
is h/6 (g(k-stage 1) + 2 g(stage 2) + 2 g(stage 3) + g(stage 4)) evaluated at the RK4 stage states.
This is exactly RK4 on (x, q), so the means converge with the same 4th order as the orbit.
"""
from __future__ import annotations

import functools
import hashlib

import casadi as ca
import numpy as np

from birdocp.engine import datastore
from birdocp.engine.cache import bounded_cache
from birdocp.engine.ode import ODE
from birdocp.engine.period_jacobian import PeriodJacobianFromFirst
from birdocp.engine.rk4 import accumulate, column_blocks, rk4_step, rk4_update
from birdocp.engine.stage_grid import stage_block_index, stage_time_grid  # noqa: F401 (re-exported)

__all__ = [
    "stage_time_grid",
    "stage_block_index",
    "RK4Grid",
    "simulate",
    "clear_stage_data",
]

# the numbers of a gait on a grid, shared by every grid of the same data Function (a value cache):
# ("stage", id(data), N, t0, p) -> (data, stage blocks DM); ("pre", id(pre), N, t0, pre values) -> (pre,
# pre grid DM): ids, not the Functions, in the keys (hashing a LazyFunction would load it); each entry
# holds its Function, so an id is not reused while the entry lives
_DATA_VALUES = bounded_cache("engine.data_values", 12)


def clear_stage_data() -> None:
    """Forget the memoised stage data of every grid (the next solve evaluates the data again; the
    on-disk store of pre values is not touched)."""
    _DATA_VALUES.clear()


class RK4Grid:
    """All integrator Functions for one (ode, steps per period, segments, outputs) choice.

    Functions (h is baked in as a constant; D is the stage-block matrix, nd x 3n):

    * ``data_grid(times[1 x 2N+1], p) -> nd x (2N+1)``  (``data.map``)
    * ``segment(x, Dseg, p) -> (x_end, X[nx x n], q[nq])``  one segment of n = N/(M-1) steps;
      X holds the states after each step, q the integrals of the outputs over the segment.
    * ``segments(X[nx x (M-1)], D[nd x 3N], p) -> (X_end, Xtraj[nx x N], Q[nq x (M-1)])``  mapped.
    * ``segment_jacobians(X, D, p) -> (X_end, J[nx x nx(M-1)])``  blocks hstacked.
    * ``segment_sensitivities(X, D, p) -> (X_end, Q, J[nx x nx(M-1)], JQ[nq x nx(M-1)])``: the segment
      ends and output integrals with their state Jacobians (forward AD, nx directions), mapped.
    * ``period_map(x0, D, p) -> (x_T, X[nx x N], q[nq])`` and
      ``period_jacobian(x0, D, p) -> (x_T, dx_T/dx0)``.

    Construction cost (measured, reference bird, 148 steps, 4 segments): the one-period map is the
    M-1 segments called one after the other (the same RK4 steps on the same data columns as a
    148-step ``mapaccum``, whose unrolled graph took 0.3 s to build and 1.1 s more to differentiate);
    the Jacobian Functions are built on first use (a trim by IPOPT needs ``segment_sensitivities``
    and ``period_jacobian_from_first``; the plain ``segment_jacobians`` only :func:`birdocp.engine.shooting.floquet`).
    ``period_jacobian`` is the product of the segment Jacobians along the trajectory integrated from
    x0 (chain rule: the exact Jacobian of the one-period map, as one forward-AD pass through it).
    """

    def __init__(self, ode: ODE, steps_per_period: int, n_segments: int, outputs=()):
        if steps_per_period % n_segments:
            raise ValueError("steps_per_period must be a multiple of the number of segments (points - 1)")
        self.ode = ode
        self.N = int(steps_per_period)
        self.S = int(n_segments)
        self.n = self.N // self.S
        self.h = ode.forcing_period / self.N
        self.nq = sum(int(g.numel_out(0)) for g in outputs)  # an output may be a column
        self._outputs = tuple(outputs)
        self._pre_grid = self._post_grid = None
        self.block_index = stage_block_index(self.N)

    @property
    def outputs(self) -> tuple:
        """The outputs integrated along the steps (casadi.Function ``g(x, d, p)`` each)."""
        return self._outputs

    # -- the time-stepping Functions (built on first use: a grid used for its data builds none) ----
    @functools.cached_property
    def step(self) -> ca.Function:
        """One RK4 step with the output increments (:func:`rk4_step`)."""
        return rk4_step(self.ode, self._outputs)

    @functools.cached_property
    def segment(self) -> ca.Function:
        """(x, Dseg, p) -> (x_end, X, q): one segment of n steps (``step.mapaccum``)."""
        x, Dn, p = self._symbols(1, 3 * self.n)
        X, Q = accumulate(self.step, self.n, x, Dn, p, self.h)
        q = ca.sum2(Q) if self.nq else ca.MX(0, 1)
        return ca.Function("segment", [x, Dn, p], [X[:, -1], X, q], ["x", "D", "p"], ["x_end", "X", "q"])

    @functools.cached_property
    def segments(self) -> ca.Function:
        """(X[nx x S], D, p) -> (X_end, Xtraj, Q): the S segments, mapped."""
        Xs, D, p = self._symbols(self.S, 3 * self.N)
        Xe, Xt, Q = self.segment.map(self.S)(Xs, D, p)
        return ca.Function("segments", [Xs, D, p], [Xe, Xt, Q], ["X", "D", "p"], ["X_end", "Xtraj", "Q"])

    @functools.cached_property
    def period_map(self) -> ca.Function:
        """(x0, D, p) -> (x_T, X[nx x N], q): the one-period map (the segments one after the other)."""
        x, D, p = self._symbols(1, 3 * self.N)
        if self.S == 1:
            return ca.Function("period_map", [x, D, p], self.segment(x, D, p), ["x", "D", "p"],
                               ["x_end", "X", "q"])
        xi, Xparts, qs = x, [], []
        for Di in column_blocks(D, self.S):
            xi, Xi, qi = self.segment(xi, Di, p)
            Xparts.append(Xi)
            qs.append(qi)
        return ca.Function("period_map", [x, D, p], [xi, ca.horzcat(*Xparts), sum(qs[1:], qs[0])],
                           ["x", "D", "p"], ["x_end", "X", "q"])

    # -- lazily built Jacobian Functions (built on first use, then kept) ------------------------
    def _symbols(self, nx_cols: int, d_cols: int):
        """MX symbols (x: nx x nx_cols, D: nd x d_cols, p: np) of a Function's inputs."""
        ode = self.ode
        return ca.MX.sym("x", ode.nx, nx_cols), ca.MX.sym("D", ode.nd, d_cols), ca.MX.sym("p", ode.np)

    @functools.cached_property
    def segment_jacobian(self) -> ca.Function:
        """One segment with its state Jacobians: (x, Dseg, p) -> (x_end, q, dx_end/dx, dq/dx).

        Built as the RK4 steps of the variational equations (:meth:`variational_step`), accumulated
        with ``mapaccum``; if the step's SX Jacobian cannot be formed (e.g. an external RHS without
        a Jacobian), by ``casadi.jacobian`` of the MX segment."""
        nx, nq = self.ode.nx, self.nq
        x, Dn, p = self._symbols(1, 3 * self.n)
        try:
            var = self.variational_function()
        except Exception:  # noqa: BLE001 - any failure: the generic (slower) construction
            var = None
        if var is not None:
            s0 = ca.vertcat(x, ca.vec(ca.DM.eye(nx)), ca.DM.zeros(nq), ca.DM.zeros(nq * nx))
            h = [self.h] if var.n_in() == 4 else []  # the compiled step takes h (one library per model)
            S = accumulate(var, self.n, s0, Dn, p, *h, name="var_acc")[0][:, -1]
            k = nx + nx * nx
            outs = [S[:nx], S[k:k + nq], ca.reshape(S[nx:k], nx, nx), ca.reshape(S[k + nq:], nq, nx)]
        else:
            xe, _, q = self.segment(x, Dn, p)
            J = ca.jacobian(ca.vertcat(xe, q), x)
            outs = [xe, q, J[:nx, :], J[nx:, :]]
        return ca.Function("segment_jac", [x, Dn, p], outs, ["x", "D", "p"], ["x_end", "q", "J", "JQ"])

    def variational_function(self) -> ca.Function:
        """The variational step the segments evaluate (numbers only, never differentiated):
        :meth:`variational_step`, or, when the ODE's ``numeric`` hook names a ``source`` ODE (the
        interpreted twin of a compiled ODE, :func:`birdocp.export.compiled.compiled_ode`), the same
        step built from the source's SX right-hand side and handed to the hook (compiled C: the
        whole step and its Jacobians in one library, not calls of the compiled RHS from the VM), with
        the step h as a fourth input: one library serves every grid. When the whole step has more
        instructions than the hook compiles (its ``max_instructions``), the step is built from four
        calls of the compiled right-hand side with its nx tangents (:meth:`rhs_tangent`, a quarter of
        the size): :meth:`staged_variational_step`.

        Returns
        -------
        casadi.Function
            ``(s, D3, p) -> s_next`` (or ``(s, D3, p, h) -> s_next`` when built for the hook), with
            s = [x; vec(Phi); q; vec(dq/dx0)].
        """
        ode = self.ode
        src = getattr(ode.numeric, "source", None)
        if src is None:
            return self.variational_step()
        twin = RK4Grid(src, self.N, self.S, self._outputs)
        outs = hashlib.sha256("".join(g.serialize() for g in self._outputs).encode()).hexdigest()[:16]
        whole = twin.variational_step(h_input=True)
        limit = getattr(ode.numeric, "max_instructions", None)
        if limit is None or whole.n_instructions() <= limit:
            return ode.fast(whole, f"variational nq={self.nq} outputs={outs}")
        return twin.staged_variational_step(ode.fast(twin.rhs_tangent(), "rhs_tangent"))

    def rhs_tangent(self) -> ca.Function:
        """``(x, d, p, T) -> (f(x, d, p), df/dx T)`` with T nx x nx: the right-hand side and its
        directional derivatives along the nx columns of T (SX, forward AD).

        Returns
        -------
        casadi.Function
            ``(x, d, p, T) -> (f, fT)``.
        """
        ode = self.ode
        x, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", ode.nd), ca.SX.sym("p", ode.np)
        T = ca.SX.sym("T", ode.nx, ode.nx)
        f = ode.rhs(x, d, p)
        return ca.Function("rhs_tangent", [x, d, p, T], [f, ca.jtimes(f, x, T)], ["x", "d", "p", "T"], ["f", "fT"])

    def staged_variational_step(self, tangent: ca.Function) -> ca.Function:
        """The step of :meth:`variational_step` (with h an input) as RK4 on the state and its
        sensitivity together, [x; vec(Phi)]' = [f; vec(df/dx Phi)], each stage one call of
        ``tangent`` (:meth:`rhs_tangent`, e.g. compiled): the same derivative (the stages' tangents
        are those of the RK4 step), the sums in another order (equal to round-off).

        Parameters
        ----------
        tangent : casadi.Function
            ``(x, d, p, T) -> (f(x, d, p), df/dx T)`` (:meth:`rhs_tangent` or a compiled twin).

        Returns
        -------
        casadi.Function
            ``(s, D3, p, h) -> s_next`` with s = [x; vec(Phi); q; vec(dq/dx0)].
        """
        nx, nd, np_, nq = self.ode.nx, self.ode.nd, self.ode.np, self.nq
        s, D3 = ca.SX.sym("s", nx + nx * nx + nq + nq * nx), ca.SX.sym("D3", nd, 3)
        p, h = ca.SX.sym("p", np_), ca.SX.sym("h")
        k = nx + nx * nx

        def f_aug(y, d, pp):
            fx, fT = tangent(y[:nx], d, pp, ca.reshape(y[nx:], nx, nx))
            return ca.vertcat(fx, ca.vec(fT))

        yn, stages = rk4_update(f_aug, s[:k], D3, h, p)
        out = [yn, s[k:k + nq]]
        if nq:
            xs, d, T = ca.SX.sym("x", nx), ca.SX.sym("d", nd), ca.SX.sym("T", nx, nx)
            g = ca.vertcat(*[o(xs, d, p) for o in self._outputs])
            gt = ca.Function("outputs_tangent", [xs, d, p, T], [g, ca.jtimes(g, xs, T)])
            w = (1, 2, 2, 1)
            parts = [gt(y[:nx], D3[:, c], p, ca.reshape(y[nx:], nx, nx)) for y, c in zip(stages, (0, 1, 1, 2))]
            out[1] = out[1] + h / 6 * sum(wi * gi for wi, (gi, _) in zip(w, parts))
            out.append(s[k + nq:] + h / 6 * sum(wi * ca.vec(Gi) for wi, (_, Gi) in zip(w, parts)))
        return ca.Function("rk4_variational_step_staged", [s, D3, p, h], [ca.vertcat(*out)],
                           ["s", "D3", "p", "h"], ["s_next"])

    def variational_step(self, h_input: bool = False) -> ca.Function:
        """One RK4 step of the state, its sensitivity Phi = dx/dx0, the output integrals q and their
        sensitivity dq/dx0, as one SX Function of s = [x; vec(Phi); q; vec(dq/dx0)]:
        Phi+ = A Phi, dq/dx0+ = dq/dx0 + B Phi with A, B the step's Jacobians (the chain rule through
        the same RK4 steps: the exact Jacobian of the discrete segment, as forward AD gives it).
        Measured on the bird (148 steps, 4 segments): 10 ms per segment against 25 ms for
        ``casadi.jacobian`` of the MX segment (forward AD through ``mapaccum``).

        Parameters
        ----------
        h_input : bool
            The step h [s] is a fourth input (``s, D3, p, h``) instead of the grid's constant.

        Returns
        -------
        casadi.Function
            ``(s, D3, p[, h]) -> s_next`` (SX).
        """
        nx, nd, np_, nq = self.ode.nx, self.ode.nd, self.ode.np, self.nq
        s = ca.SX.sym("s", nx + nx * nx + nq + nq * nx)
        D3 = ca.SX.sym("D3", nd, 3)
        p = ca.SX.sym("p", np_)
        x = s[:nx]
        Phi = ca.reshape(s[nx:nx + nx * nx], nx, nx)
        k = nx + nx * nx
        q = s[k:k + nq]
        JQ = ca.reshape(s[k + nq:], nq, nx)
        h = ca.SX.sym("h") if h_input else self.h
        xn, qi = self.step(x, D3, p, h)
        A = ca.jacobian(xn, x)
        out = [xn, ca.vec(ca.mtimes(A, Phi)), q + qi]
        if nq:
            out.append(ca.vec(JQ + ca.mtimes(ca.jacobian(qi, x), Phi)))
        ins, names = ([s, D3, p, h], ["s", "D3", "p", "h"]) if h_input else ([s, D3, p], ["s", "D3", "p"])
        return ca.Function("rk4_variational_step", ins, [ca.vertcat(*out)], names, ["s_next"])

    @functools.cached_property
    def segment_sensitivities(self) -> ca.Function:
        """All segments with their state Jacobians: (X, D, p) -> (X_end, Q, J, JQ), mapped."""
        Xs, D, p = self._symbols(self.S, 3 * self.N)
        Xe, Q, J, JQ = self.segment_jacobian.map(self.S)(Xs, D, p)
        return ca.Function("segment_sensitivities", [Xs, D, p], [Xe, Q, J, JQ],
                           ["X", "D", "p"], ["X_end", "Q", "J", "JQ"])

    @functools.cached_property
    def segment_jacobians(self) -> ca.Function:
        """(X, D, p) -> (X_end, J): the segment ends and their state Jacobians."""
        Xs, D, p = self._symbols(self.S, 3 * self.N)
        Xe, _, J, _ = self.segment_sensitivities(Xs, D, p)
        return ca.Function("segment_jacobians", [Xs, D, p], [Xe, J])

    @functools.cached_property
    def period_jacobian(self) -> ca.Function:
        """(x, D, p) -> (x_T, dx_T/dx): the one-period map and its Jacobian in one go."""
        x, D, p = self._symbols(1, 3 * self.N)
        xi, Jp = x, None
        for Di in column_blocks(D, self.S):
            xi, _, Ji, _ = self.segment_jacobian(xi, Di, p)
            Jp = Ji if Jp is None else ca.mtimes(Ji, Jp)
        return ca.Function("period_jacobian", [x, D, p], [xi, Jp])

    @functools.cached_property
    def period_jacobian_after_first(self) -> ca.Function:
        """(x1, J0, D, p) -> (x_T, dx_T/dx0): the segments 2..S from x1, their state Jacobians chained
        onto J0 (:attr:`period_jacobian` from the first segment's end and Jacobian)."""
        xi, D, p = self._symbols(1, 3 * self.N)
        x1, J0 = xi, ca.MX.sym("J0", self.ode.nx, self.ode.nx)
        Jp = J0
        for Di in column_blocks(D, self.S)[1:]:
            xi, _, Ji, _ = self.segment_jacobian(xi, Di, p)
            Jp = ca.mtimes(Ji, Jp)
        return ca.Function("period_jacobian_after_first", [x1, J0, D, p], [xi, Jp])

    @functools.cached_property
    def period_jacobian_from_first(self) -> PeriodJacobianFromFirst:
        """``(x1, J0, D, p) -> (x_T, dx_T/dx0)``: :attr:`period_jacobian`'s numbers from the first
        segment's end and Jacobian, as a solver has them (the Floquet check of a solve)."""
        return PeriodJacobianFromFirst(self)

    def fd_segment_jacobians(self, X, D, p, floor: float = 1e-3, rel_step: float = 1e-3):
        """Forward-difference segment Jacobians, as the paper computes them (the engine's
        ``derivatives="fd"``): step ``rel_step * x_j``, or ``rel_step * floor`` where ``|x_j| < floor``.

        Parameters
        ----------
        X : (nx, S) array
            The segments' start states.
        D : casadi.DM
            Stage blocks, nd x 3N (:meth:`blocks_numeric`).
        p : array_like
            Parameter vector (np,).
        floor : float
            Below this abs(x_j) the step is ``rel_step * floor`` (the state's units).
        rel_step : float
            Relative step.

        Returns
        -------
        Js : (S, nx, nx) array
            d x_end / d x of each segment.
        dQ : (nq, S, nx) array
            d q / d x of each segment's output integrals.
        """
        X = np.asarray(X, float)
        nx, S = X.shape
        pd = ca.DM(p)
        Xe0, _, Q0 = (np.asarray(v) for v in self.segments(ca.DM(X), D, pd))
        Js = np.zeros((S, nx, nx))
        dQ = np.zeros((self.nq, S, nx))
        for j in range(nx):
            h = np.where(np.abs(X[j]) >= floor, rel_step * X[j], rel_step * floor)
            Xp = X.copy()
            Xp[j] += h
            Xe, _, Q = (np.asarray(v) for v in self.segments(ca.DM(Xp), D, pd))
            Js[:, :, j] = ((Xe - Xe0) / h).T
            if self.nq:
                dQ[:, :, j] = (Q - Q0) / h
        return Js, dQ

    # -- data ---------------------------------------------------------------------------------
    def times(self, t0: float) -> np.ndarray:
        """The data grid's times ``t0 + k h/2``, k = 0..2N (:func:`~birdocp.engine.stage_grid.stage_time_grid`).

        Parameters
        ----------
        t0 : float
            Start of the period (the system's time units).

        Returns
        -------
        ndarray, shape (2N + 1,)
        """
        return stage_time_grid(t0, self.ode.forcing_period, self.N)

    @functools.cached_property
    def data_grid(self) -> ca.Function:
        """``data.map(2N+1)``: (times[1 x 2N+1], p) -> the data grid nd x (2N+1) (built on first use)."""
        return self.ode.data.map(2 * self.N + 1)

    @functools.cached_property
    def _blocks_of_data(self) -> ca.Function:
        # the stage blocks of a data grid, sliced inside a Function (slicing the DM in Python with a
        # list of 3N column indices cost ~13 ms on the bird's 1091 x 297 grid)
        G = ca.MX.sym("G", self.ode.nd, 2 * self.N + 1)
        return ca.Function("stage_blocks", [G], [G[:, self.block_index]])

    @functools.cached_property
    def _blocks_of_pre(self) -> ca.Function:
        # post on the data grid and the stage blocks, one Function: (pre grid, times, p) -> blocks
        ode = self.ode
        L = ca.MX.sym("L", ode.pre.size1_out(0), 2 * self.N + 1)
        tt = ca.MX.sym("t", 1, 2 * self.N + 1)
        p = ca.MX.sym("p", ode.np)
        return ca.Function("stage_blocks_post", [L, tt, p], [self.numeric_post_grid(L, tt, p)[:, self.block_index]])

    @functools.cached_property
    def step_start_data(self) -> ca.Function:
        """(stage blocks nd x 3N) -> the data at the N step starts t0 + k h (nd x N), as a Function
        (slicing the DM in Python cost ~5 ms on the bird)."""
        B = ca.MX.sym("B", self.ode.nd, 3 * self.N)
        return ca.Function("step_start_data", [B], [B[:, 0::3]])

    def blocks_numeric(self, t0: float, p) -> ca.DM:
        """Stage blocks (nd x 3N) evaluated numerically, as a DM (pass DMs, not numpy, to calls).

        Memoised by (the ODE's data Function, N, t0, p) in one process-wide bounded cache, so every grid
        of the same data and step count (shooting, validity, power; an ODE with a compiled RHS and the
        same data) shares the numbers of a gait instead of evaluating the data again.

        Parameters
        ----------
        t0 : float
            Start of the period.
        p : array_like
            Parameter vector (np,).

        Returns
        -------
        casadi.DM
            nd x 3N: the data at (t, t + h/2, t + h) of each step.
        """
        p = np.asarray(p, float).ravel()
        key = ("stage", id(self.ode.data), self.N, float(t0), p.tobytes())
        hit = _DATA_VALUES.get(key)
        if hit is not None and hit[0] is self.ode.data:
            return hit[1]
        ode = self.ode
        if ode.pre is not None:
            # data = post(pre(t, p), t, p): pre (the costly, non-smooth part) depends on a few
            # parameters only (for the bird not on the shoulder joints), so a sweep of the others
            # re-evaluates post alone
            out = self._blocks_of_pre(self.pre_numeric(t0, p), ca.DM(self.times(t0)), ca.DM(p))
        else:
            out = self._blocks_of_data(self.data_grid(ca.DM(self.times(t0)), ca.DM(p)))
        _DATA_VALUES.put(key, (ode.data, out))
        return out

    def pre_numeric(self, t0: float, p) -> ca.DM:
        """pre(t, p) on the data grid (nl x (2N+1)), memoised by (pre, N, t0, the pre parameters'
        values); with ``ode.graph_key`` also kept on disk for later processes
        (:mod:`birdocp.engine.datastore`).

        Parameters
        ----------
        t0 : float
            Start of the period.
        p : array_like
            Parameter vector (np,); only the ``ode.pre_params`` entries matter.

        Returns
        -------
        casadi.DM
            nl x (2N+1), nl the size of pre's output.
        """
        p = np.asarray(p, float).ravel()
        ode = self.ode
        pre_values = p[list(ode.pre_params)]
        key = ("pre", id(ode.pre), self.N, float(t0), pre_values.tobytes())
        hit = _DATA_VALUES.get(key)
        if hit is not None and hit[0] is ode.pre:
            return hit[1]
        disk_key = None
        out = None
        if ode.graph_key:
            disk_key = {"pre": ode.graph_key, "steps": self.N, "period_s": repr(float(ode.forcing_period)),
                        "t0": repr(float(t0)), "pre_params": list(ode.pre_params),
                        "values": [repr(float(v)) for v in pre_values]}
            arr = datastore.load("pre-grid", disk_key)
            if arr is not None and arr.shape == (ode.pre.size1_out(0), 2 * self.N + 1):
                out = ca.DM(arr)
        if out is None:
            if self._pre_grid is None:
                self._pre_grid = ode.pre.map(2 * self.N + 1)
            out = self._pre_grid(ca.DM(self.times(t0)), ca.DM(p))
            if disk_key is not None:
                datastore.store("pre-grid", disk_key, np.asarray(out))
        _DATA_VALUES.put(key, (ode.pre, out))
        return out

    @functools.cached_property
    def numeric_post_grid(self) -> ca.Function:
        """:attr:`post_grid` for numbers only (never differentiated): the ODE's compiled ``post``
        mapped where it offers one (``ODE.numeric``), else :attr:`post_grid` itself."""
        ode = self.ode
        return self.post_grid if ode.numeric is None else ode.fast(ode.post, "post").map(2 * self.N + 1)

    @property
    def post_grid(self) -> ca.Function:
        """post mapped over the data grid: (local[nl x (2N+1)], times, p) -> data grid."""
        if self._post_grid is None:
            self._post_grid = self.ode.post.map(2 * self.N + 1)
        return self._post_grid

    def blocks_symbolic(self, t0: float, p: ca.MX) -> ca.MX:
        """Stage blocks (nd x 3N) as an expression of symbolic parameters (free parameters enter the
        data: the graph carries ``data.map`` on the grid).

        Parameters
        ----------
        t0 : float
            Start of the period.
        p : casadi.MX
            Parameter vector (np).

        Returns
        -------
        casadi.MX
            nd x 3N.
        """
        grid = self.data_grid(ca.DM(self.times(t0)), p)
        return grid[:, self.block_index]


def simulate(ode: ODE, x0, p, steps_per_period: int = 148, n_periods: int = 1, t0: float = 0.0):
    """Plain RK4 from x0 over ``n_periods`` periods. Returns (t[K+1], X[K+1, nx]).

    Parameters
    ----------
    ode : ODE
        System.
    x0 : array_like
        State at ``t0``.
    p : array_like
        Parameters.
    steps_per_period : int
        RK4 steps per period.
    n_periods : int
        Number of periods.
    t0 : float
        Start time [s].

    Returns
    -------
    t : ndarray, shape (K + 1,)
        Times [s].
    X : ndarray, shape (K + 1, nx)
    """
    grid = RK4Grid(ode, steps_per_period, 1)
    D = grid.blocks_numeric(t0, p)
    pd = ca.DM(np.asarray(p, float))
    x = np.asarray(x0, float).ravel()
    out = [x[None, :]]
    for _ in range(n_periods):
        X = np.asarray(grid.period_map(ca.DM(x), D, pd)[1]).T
        out.append(X)
        x = X[-1]
    Xall = np.vstack(out)
    t = t0 + grid.h * np.arange(Xall.shape[0])
    return t, Xall
