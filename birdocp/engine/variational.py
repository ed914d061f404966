"""Exact first- and second-order sensitivities of the one-period RK4 map, by variational equations
integrated step by step in SX (forward mode), for reduced-space optimisation over a few parameters.

For x_T = Phi(x0, D, p) (the RK4 period map of :mod:`birdocp.engine.integrate`) and the period
integrals q of some outputs, :class:`PeriodSensitivities` returns, along ``nx`` state directions and
``n_dir`` parameter directions (each a direction dD of the stage data and dp of the parameters):

* first order: ``J = d(x_T)/d(x0, dirs)`` (nx x (nx + n_dir)) and ``Jq = dq/d(x0, dirs)``;
* second order (optional): the monodromy ``Mon = dx_T/dx0`` and its directional derivatives
  ``dMon`` (column-major vec, nx^2 x (nx + n_dir)) along the same directions.

With ``combined=True`` the directions are only ``n_dir`` combinations of ``n_data`` given data and
parameter directions (``W``, n_data x n_dir) with initial state tangents ``dx0`` (nx x n_dir), no state
directions: e.g. the total derivatives along a reduced space's parameters once ``dx0/dtheta`` is
known from a first-order pass, at a fraction of the second-order cost of all nx + n_data directions.

With ``state_columns=k`` (second order) the state Jacobian is carried on k given columns ``S0`` (nx x k)
instead of the identity: ``Mon`` is then ``M S0`` (nx x k) and ``dMon`` its derivatives (nx k rows), at
about k / nx of the cost -- e.g. a monodromy's derivatives on its dominant invariant subspace, when the
other directions are not needed.

Every RK4 step propagates the state, its tangents and (second order) the tangents of the state
Jacobian as one SX Function (``jtimes`` with a seed matrix; structural zeros pruned), accumulated by
``mapaccum`` over the N steps. Measured on the bird (148 steps, 5 parameter directions, 2 cores):
first order 0.23 s, second order 1.3 s per evaluation, against 0.6-1.9 s and 9.4 s for forward AD
(``jtimes``) through the MX period map and its Jacobian.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine.rk4 import MAPACCUM_CHUNK, column_blocks, rk4_step

__all__ = ["PeriodSensitivities"]


class PeriodSensitivities:
    """Sensitivities of one period of RK4 (see module docstring), built once per
    (ode, steps, outputs, n_dir, second_order).

    Call ``sens(x0, D, p, dD, dp)``: ``D`` the stage blocks (nd x 3N, :meth:`RK4Grid.blocks_numeric`),
    ``dD`` a list of ``n_dir`` stage-block directions (each nd x 3N, DM or numpy), ``dp`` (np x n_dir).
    Returns a dict with ``x_T``, ``q`` (period integrals), ``J``, ``Jq`` and, second order, ``Mon``
    and ``dMon`` (numpy arrays).
    """

    def __init__(self, ode, steps_per_period: int, outputs=(), n_dir: int = 0, second_order: bool = False,
                 combined: bool = False, n_data: int | None = None, state_columns: int | None = None):
        self.ode, self.N, self.n_dir, self.second = ode, int(steps_per_period), int(n_dir), bool(second_order)
        nx, nd, np_ = ode.nx, ode.nd, ode.np
        self.ns = nx if state_columns is None else int(state_columns)  # columns of the carried state Jacobian
        self.nx, self.nd = nx, nd
        self.combined = bool(combined)
        self.n_data = int(n_data if n_data is not None else n_dir)  # directions given per call
        self.n_state = 0 if self.combined else nx                    # identity state directions first
        nz = self.n_state + self.n_dir
        self.h = h = ode.forcing_period / self.N
        step = rk4_step(ode, outputs)
        x = ca.SX.sym("x", nx)
        D3 = ca.SX.sym("D3", nd, 3)
        p = ca.SX.sym("p", np_)
        xn, qi = step(x, D3, p, h)
        self.nq = qi.numel()
        dD3 = ca.SX.sym("dD3", nd, 3 * max(self.n_data, 1))
        dP = ca.SX.sym("dP", np_, max(self.n_data, 1))
        W = ca.SX.sym("W", max(self.n_data, 1), max(self.n_dir, 1))
        if self.combined:
            Bd = ca.horzcat(*[ca.vec(dD3[:, 3 * k:3 * k + 3]) for k in range(self.n_data)])
            seedD, seedP = Bd @ W[:self.n_data, :self.n_dir], dP[:, :self.n_data] @ W[:self.n_data, :self.n_dir]
        else:
            seedD = ca.horzcat(ca.SX.zeros(3 * nd, nx), *[ca.vec(dD3[:, 3 * k:3 * k + 3]) for k in range(self.n_dir)])
            seedP = ca.horzcat(ca.SX.zeros(np_, nx), dP[:, :self.n_dir])
        if self.second:
            S = ca.SX.sym("S", nx, self.ns)                # dx/dx0 (times S0) so far
            if self.ns == nx:
                JS = ca.jacobian(ca.vertcat(xn, qi), x) @ S
            else:  # S's few columns as forward directions: no full step Jacobian to differentiate
                JS = ca.jtimes(ca.vertcat(xn, qi), x, S)
            Y = ca.vertcat(x, ca.vec(S))
            Yn = ca.vertcat(xn, ca.vec(JS[:nx, :]))
            Qn = ca.vertcat(qi, ca.vec(JS[nx:, :]))
        else:
            Y, Yn, Qn = x, xn, qi
        nY = Y.numel()
        dY = ca.SX.sym("dY", nY, nz)
        arg = ca.vertcat(Y, ca.vec(D3), p)
        seeds = ca.vertcat(dY, seedD, seedP)
        dYn = ca.jtimes(Yn, arg, seeds)
        dQn = ca.jtimes(Qn, arg, seeds)
        carry = ca.vertcat(Y, ca.vec(dY))
        acc_q = ca.vertcat(Qn, ca.vec(dQn))
        f = ca.Function("variational_step", [carry, D3, p, ca.vec(dD3), dP, ca.vec(W)],
                        [ca.vertcat(Yn, ca.vec(dYn)), acc_q])
        # q accumulates: carry it too (mapaccum accumulates only fed-back outputs)
        c = ca.MX.sym("c", carry.numel())
        a = ca.MX.sym("a", acc_q.numel())
        Dm = ca.MX.sym("D3", nd, 3)
        pm = ca.MX.sym("p", np_)
        dDm = ca.MX.sym("dD3", dD3.numel())
        dPm = ca.MX.sym("dP", np_, max(self.n_data, 1))
        Wm = ca.MX.sym("W", W.numel())
        cn, an = f(c, Dm, pm, dDm, dPm, Wm)
        g = ca.Function("variational_step_acc", [c, a, Dm, pm, dDm, dPm, Wm], [cn, a + an])
        self._acc = self._chained(g, [c, a, Dm, pm, dDm, dPm, Wm])
        self.nY, self.nz, self.nQ = nY, nz, Qn.numel()
        self._index = None

    def _chained(self, g, syms):
        """N steps of ``g`` as one Function (carry and accumulator fed back; the last column of
        each): ``mapaccum`` over chunks of at most :data:`MAPACCUM_CHUNK` steps, chained (a mapaccum
        of 148 steps took about a second to build, two of 74 a fraction; the same steps in the same
        order)."""
        N = self.N
        k = max(d for d in range(1, min(N, MAPACCUM_CHUNK) + 1) if N % d == 0)
        if k < 8:  # no useful divisor (e.g. a prime count of steps): one piece
            k = N
        acc = g.mapaccum("variational_chunk", k, [0, 1], [0, 1])
        per_step = (2, 4)  # D (3 columns per step) and the directions (1 column per step)
        ins = [ca.MX.sym(f"in{i}", v.size1(), v.size2() * (N if i in per_step else 1)) for i, v in enumerate(syms)]
        c, a, D, p, dD, dP, W = ins
        for Dj, dDj in zip(column_blocks(D, N // k), column_blocks(dD, N // k)):
            cj, aj = acc(c, a, Dj, p, dDj, dP, W)
            c, a = cj[:, -1], aj[:, -1]
        return ca.Function("variational_period", ins, [c, a])

    def _direction_columns(self):
        """Column order turning hstacked directions (nd x 3N n_data) into per-step blocks."""
        if self._index is None:
            N, nv = self.N, self.n_data
            self._index = [v * 3 * N + 3 * k + s for k in range(N) for v in range(nv) for s in range(3)]
        return self._index

    def direction_columns(self, dD):
        """The per-step layout (3 nd n_data x N) of ``n_data`` stage-block directions (each nd x 3N;
        DM, numpy or MX: build it symbolically once to keep the reordering out of Python).

        Parameters
        ----------
        dD : casadi.DM, MX or ndarray
            Stage-block directions.

        Returns
        -------
        casadi.DM or MX
        """
        if isinstance(dD[0], ca.MX):
            return ca.reshape(ca.horzcat(*dD)[:, self._direction_columns()], self.nd * 3 * self.n_data, self.N)
        dDall = np.hstack([np.asarray(d, float) for d in dD])[:, self._direction_columns()]
        return ca.DM(dDall.reshape(self.nd * 3 * self.n_data, self.N, order="F"))

    def __call__(self, x0, D, p, dD=(), dp=None, columns=None, W=None, dx0=None, S0=None) -> dict:
        """Sensitivities at x0; ``dD`` the data directions (list), or ``columns`` their per-step
        layout from :meth:`direction_columns`; ``dp`` (np x n_data) the parameter directions.
        Combined (``combined=True``): direction c is ``sum_v W[v, c]`` (data and parameter direction v)
        with initial state tangent ``dx0[:, c]``. ``S0`` (nx x state_columns, second order): the state
        columns carried (default the identity; needed when ``state_columns`` was given)."""
        nx, nd, N, nv = self.nx, self.nd, self.N, self.n_data
        x0 = np.asarray(x0, float).ravel()
        if S0 is None:
            if self.ns != nx:
                raise ValueError(f"S0 (nx x {self.ns}) is needed: these sensitivities carry {self.ns} state columns")
            S0 = np.eye(nx)
        S0 = np.asarray(S0, float).reshape(nx, self.ns)
        Y0 = np.concatenate([x0, S0.ravel(order="F")]) if self.second else x0
        dY0 = np.zeros((self.nY, self.nz))
        dY0[:nx, :self.n_state] = np.eye(nx)[:, :self.n_state]
        Wv = np.zeros(max(nv, 1) * max(self.n_dir, 1))
        if self.combined:
            dY0[:nx, :] = np.asarray(dx0, float).reshape(nx, self.n_dir)
            Wv = np.asarray(W, float).reshape(nv, self.n_dir).ravel(order="F")
        if nv:
            dDcols = columns if columns is not None else self.direction_columns(list(dD))
            dpm = ca.DM(np.asarray(dp, float).reshape(-1, nv))
        else:
            dDcols = ca.DM.zeros(nd * 3, N)
            dpm = ca.DM.zeros(self.ode.np, 1)
        c0 = np.concatenate([Y0, dY0.ravel(order="F")])
        nY, nz, nq, nQ = self.nY, self.nz, self.nq, self.nQ
        cT, aT = self._acc(c0, ca.DM.zeros(nQ * (1 + nz)), D, ca.DM(np.asarray(p, float)), dDcols, dpm,
                           ca.DM(Wv))
        cT = np.asarray(cT)[:, -1]
        aT = np.asarray(aT)[:, -1]
        YT, dYT = cT[:nY], cT[nY:].reshape(nY, nz, order="F")
        dQ = aT[nQ:].reshape(nQ, nz, order="F")
        out = {"x_T": YT[:nx], "J": dYT[:nx], "q": aT[:nq], "Jq": dQ[:nq]}
        if self.second:
            out["Mon"] = YT[nx:].reshape(nx, self.ns, order="F")
            out["dMon"] = dYT[nx:]
        return out
