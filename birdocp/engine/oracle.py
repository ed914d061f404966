"""IPOPT constraints as a CasADi Callback around a numeric evaluator.

The evaluator supplies ``nz``, ``ng``, ``jac_sparsity`` (a ``casadi.Sparsity`` of dg/dz), ``g(z)``
(values) and ``jacobian(z)`` (a dense array whose entries outside the sparsity are ignored). Used by
the multiple-shooting NLP (the Jacobian assembled from segment blocks) and by the stability
optimisation (the monodromy's derivatives by forward-over-forward AD).

For IPOPT's exact-Hessian mode the Jacobian oracle can itself be differentiated by forward
differences of the exact Jacobian: CasADi's own finite differences (sequential), or a
:class:`StencilHessian`, which evaluates the ``nz`` perturbed Jacobians itself, in a small thread pool
(CasADi evaluates its Functions without the GIL: a run's CPU time exceeds its wall time) through the evaluator's side-effect-free
``jacobian_near(z_perturbed, z)``, so the Hessian does not depend on thread timing or on the number of
threads.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import casadi as ca
import numpy as np

from birdocp.engine import interrupts

__all__ = ["Evaluator", "ConstraintOracle", "StencilHessian", "FixedHessian", "ipopt_options", "active_bounds",
           "ACTIVE_BOUND_RTOL"]

ACTIVE_BOUND_RTOL = 1e-5
"""A variable counts as at a bound within this fraction of its bound range (hi - lo). IPOPT, an
interior-point method, leaves an active bound's variable slightly inside (the barrier term and
``bound_push``): 5e-6 to 3e-5 deg on 10-25 deg ranges at the committed optima, relative 2e-7 to 3e-6;
an absolute 1e-6 missed them."""


def ipopt_options(**over) -> dict:
    """``nlpsol`` options of every IPOPT solve in birdocp, updated by ``over``.

    Quasi-Newton Hessian (the exact Hessian through the integrator was 10x slower for the same
    iterations), MUMPS (the linear solver shipped in the casadi wheels), no banner or timing output.

    Parameters
    ----------
    **over
        Options replacing the defaults (``ipopt.*`` keys included).

    Returns
    -------
    dict
    """
    opts = {"ipopt.hessian_approximation": "limited-memory", "ipopt.sb": "yes", "ipopt.print_level": 0,
            "print_time": False, "ipopt.linear_solver": "mumps"}
    opts.update(over)
    return opts


def active_bounds(values: dict, bounds: dict, rtol: float = ACTIVE_BOUND_RTOL) -> list:
    """The names whose value sits at its lower or upper bound, as an interior-point optimiser leaves
    it: within ``rtol`` times the bound range of the bound (see :data:`ACTIVE_BOUND_RTOL`).

    Parameters
    ----------
    values : dict
        Name -> value at the optimum.
    bounds : dict
        Name -> (lower, upper); names without bounds (or without a finite range) are never active.
    rtol : float
        Distance to a bound counted as zero, relative to the range upper - lower.

    Returns
    -------
    list of str
        The active names, in the order of ``values``.
    """
    out = []
    for k, v in values.items():
        lo, hi = (float(b) for b in bounds.get(k, (-np.inf, np.inf)))
        tol = rtol * (hi - lo)
        if np.isfinite(tol) and min(abs(float(v) - lo), abs(float(v) - hi)) <= tol:
            out.append(k)
    return out


class Evaluator:
    """Base of the numeric evaluators: a subclass defines ``evaluate(z) -> (g, J)`` (values and the
    dense Jacobian together, as IPOPT asks for both at the same point) and gets :meth:`g` and
    :meth:`jacobian`."""

    def evaluate(self, z):  # pragma: no cover - the contract
        """``(g, dense dg/dz)`` at ``z``.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        g, J : ndarray
        """
        raise NotImplementedError

    def g(self, z):
        """The constraint values at ``z``.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        return self.evaluate(z)[0]

    def jacobian(self, z):
        """The dense constraint Jacobian at ``z``.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        return self.evaluate(z)[1]


@dataclass
class StencilHessian:
    """Second derivatives for IPOPT's exact-Hessian mode as forward differences of the exact Jacobian:
    column k of d(dg/dz)/dz is ``(J(z + h e_k) - J(z)) / h`` (backward, ``J(z) - J(z - h e_k)``, where
    the forward point cannot be evaluated).

    The base Jacobian ``J(z)`` comes from ``ev.jacobian(z)`` (which may update the evaluator's
    warm-start state, in this thread); the ``nz`` perturbed ones from ``ev.jacobian_near(z_k, z)`` if
    the evaluator has it (it must then be side-effect-free and thread-safe: a pure function of
    ``z_k`` and the state ``ev.jacobian(z)`` left), run ``threads`` at a time, else from
    ``ev.jacobian`` one after another.

    h: step in z (the NLP's, possibly scaled, variables); threads: size of the thread pool (1: in
    this thread). The result is the same, to the last bit, for any number of threads.
    After each evaluation ``last`` holds ``(z, columns)``.
    """

    h: float = 1e-6
    threads: int = 2
    last: tuple | None = None

    def columns(self, ev, z) -> np.ndarray:
        """``(nz, ng, nz)`` array: ``[k] = dJ/dz_k`` (dense ng x nz slices) at ``z``.

        Parameters
        ----------
        ev : Evaluator
            Constraint evaluator.
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray, shape (nz, ng, nz)
        """
        z = np.asarray(z, float).ravel()
        J0 = np.asarray(ev.jacobian(z), float)
        near = getattr(ev, "jacobian_near", None)

        def one(k):
            out = None
            for sign in (1.0, -1.0):
                zk = z.copy()
                zk[k] += sign * self.h
                Jk = np.asarray(near(zk, z) if near is not None else ev.jacobian(zk), float)
                if np.all(np.isfinite(Jk)):
                    out = (Jk - J0) / (zk[k] - z[k])
                    break
            return out if out is not None else np.full_like(J0, np.nan)

        ks = range(len(z))
        if near is None or self.threads <= 1:
            cols = np.stack([one(k) for k in ks])
        else:
            with ThreadPoolExecutor(max_workers=int(self.threads)) as pool:
                cols = np.stack(list(pool.map(one, ks)))
        self.last = (z, cols)
        return cols


@dataclass
class FixedHessian:
    """Second derivatives held fixed for IPOPT's exact-Hessian mode: ``values`` (nz, ng, nz),
    ``[k] = d(dg/dz)/dz_k``, e.g. a :class:`StencilHessian`'s ``last`` from a solve of a nearby
    (coarser) problem; IPOPT combines them with its current multipliers (a Newton-like method whose
    rate is the error of the frozen second derivatives)."""

    values: np.ndarray

    def columns(self, ev, z) -> np.ndarray:
        """The fixed ``(nz, ng, nz)`` array (``ev`` and ``z`` unused).

        Parameters
        ----------
        ev : Evaluator
            Unused.
        z : ndarray
            Unused.

        Returns
        -------
        ndarray, shape (nz, ng, nz)
        """
        return self.values


class ConstraintOracle(ca.Callback):
    """g(z) for IPOPT; its Jacobian is a second oracle returning the evaluator's Jacobian.

    ``fd_hessian``: None (the default; a quasi-Newton Hessian is then needed), a
    :class:`StencilHessian` (the Jacobian oracle gets a Jacobian of its own: forward differences of
    the exact Jacobian, the perturbed points evaluated in a thread pool), a :class:`FixedHessian`
    (second derivatives held fixed), or CasADi's
    finite-difference options (e.g. ``{"fd_method": "central", "fd_options": {"h": 1e-5}}``, CasADi
    differentiating the Jacobian oracle itself, one point after another); either way IPOPT can use
    the exact-Hessian mode (one Jacobian per direction and difference point)."""

    def __init__(self, ev, name: str, jac: bool = False, fd_hessian: "dict | StencilHessian | FixedHessian | None" = None):
        ca.Callback.__init__(self)
        self.ev, self.is_jac, self.base_name = ev, jac, name
        self.fd_hessian = fd_hessian
        self._jac = None
        r, c = ev.jac_sparsity.get_triplet()
        self._rows, self._cols = np.asarray(r), np.asarray(c)
        casadi_fd = jac and isinstance(fd_hessian, dict)
        opts = {"enable_fd": True, **fd_hessian} if casadi_fd else {}
        self.construct(f"{name}_jac_g" if jac else f"{name}_g", opts)

    def get_n_in(self):
        return 2 if self.is_jac else 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.ev.nz if i == 0 else self.ev.ng, 1)

    def get_sparsity_out(self, i):
        return self.ev.jac_sparsity if self.is_jac else ca.Sparsity.dense(self.ev.ng, 1)

    def eval(self, arg):
        try:
            return self._eval(arg)
        except KeyboardInterrupt:
            interrupts.note()  # CasADi turns it into a solver status: the caller re-raises it
            raise

    def _eval(self, arg):
        z = np.asarray(arg[0], float).ravel()
        if self.is_jac:
            J = self.ev.jacobian(z)
            return [ca.DM(self.ev.jac_sparsity, J[self._rows, self._cols])]
        return [ca.DM(self.ev.g(z))]

    def has_jacobian(self, *args):
        return not self.is_jac or isinstance(self.fd_hessian, (StencilHessian, FixedHessian))

    def get_jacobian(self, name, inames, onames, opts):
        if self._jac is None:
            self._jac = (_JacobianOfJacobian(self.ev, self.base_name, self.fd_hessian) if self.is_jac
                         else ConstraintOracle(self.ev, self.base_name, True, self.fd_hessian))
        return self._jac


class _JacobianOfJacobian(ca.Callback):
    """The Jacobian of the Jacobian oracle (inputs z, nominal g, nominal dg/dz; outputs
    d vec(dg/dz) / dz and the structurally zero d vec(dg/dz) / d g) from a :class:`StencilHessian` or
    a :class:`FixedHessian`."""

    def __init__(self, ev, name: str, stencil: "StencilHessian | FixedHessian"):
        ca.Callback.__init__(self)
        self.ev, self.stencil = ev, stencil
        r, c = ev.jac_sparsity.get_triplet()
        self._rows, self._cols = np.asarray(r), np.asarray(c)
        lin = self._cols * ev.ng + self._rows  # column-major index of each structural entry of dg/dz
        nnz = len(lin)
        self._sp = ca.Sparsity.triplet(ev.ng * ev.nz, ev.nz, np.tile(lin, ev.nz).tolist(),
                                       np.repeat(np.arange(ev.nz), nnz).tolist())
        self.construct(f"{name}_hess_g", {})

    def get_n_in(self):
        return 3

    def get_n_out(self):
        return 2

    def get_sparsity_in(self, i):
        return [ca.Sparsity.dense(self.ev.nz, 1), ca.Sparsity.dense(self.ev.ng, 1), self.ev.jac_sparsity][i]

    def get_sparsity_out(self, i):
        return self._sp if i == 0 else ca.Sparsity(self.ev.ng * self.ev.nz, self.ev.ng)

    def eval(self, arg):
        try:
            cols = self.stencil.columns(self.ev, np.asarray(arg[0], float).ravel())
        except KeyboardInterrupt:
            interrupts.note()
            raise
        vals = cols[:, self._rows, self._cols]  # nz x nnz: column k of the output, structural entries
        return [ca.DM(self._sp, vals.ravel()), ca.DM(ca.Sparsity(self.ev.ng * self.ev.nz, self.ev.ng))]
