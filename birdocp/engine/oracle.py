"""IPOPT constraints as a CasADi Callback around a numeric evaluator.

The evaluator supplies ``nz``, ``ng``, ``jac_sparsity`` (a ``casadi.Sparsity`` of dg/dz), ``g(z)``
(values) and ``jacobian(z)`` (a dense array whose entries outside the sparsity are ignored). Used by
the multiple-shooting NLP (the Jacobian assembled from segment blocks) and by the stability
optimisation (the monodromy's derivatives by forward-over-forward AD).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine import interrupts

__all__ = ["Evaluator", "ConstraintOracle", "ipopt_options"]


def ipopt_options(**over) -> dict:
    """``nlpsol`` options of every IPOPT solve in birdocp, updated by ``over``.

    Quasi-Newton Hessian (the exact Hessian through the integrator was 10x slower for the same
    iterations), MUMPS (the linear solver shipped in the casadi wheels), no banner or timing output.
    """
    opts = {"ipopt.hessian_approximation": "limited-memory", "ipopt.sb": "yes", "ipopt.print_level": 0,
            "print_time": False, "ipopt.linear_solver": "mumps"}
    opts.update(over)
    return opts


class Evaluator:
    """Base of the numeric evaluators: a subclass defines ``evaluate(z) -> (g, J)`` (values and the
    dense Jacobian together, as IPOPT asks for both at the same point) and gets :meth:`g` and
    :meth:`jacobian`."""

    def evaluate(self, z):  # pragma: no cover - the contract
        """``(g, dense dg/dz)`` at ``z``."""
        raise NotImplementedError

    def g(self, z):
        """The constraint values at ``z``."""
        return self.evaluate(z)[0]

    def jacobian(self, z):
        """The dense constraint Jacobian at ``z``."""
        return self.evaluate(z)[1]


class ConstraintOracle(ca.Callback):
    """g(z) for IPOPT; its Jacobian is a second oracle returning the evaluator's Jacobian.

    ``fd_hessian``: None (the default; a quasi-Newton Hessian is then needed), or CasADi's
    finite-difference options (e.g. ``{"fd_method": "central", "fd_options": {"h": 1e-5}}``) under
    which the Jacobian oracle is differentiated by finite differences of the exact Jacobian, so that
    IPOPT can use the exact-Hessian mode (one Jacobian per direction and difference point)."""

    def __init__(self, ev, name: str, jac: bool = False, fd_hessian: dict | None = None):
        ca.Callback.__init__(self)
        self.ev, self.is_jac, self.base_name = ev, jac, name
        self.fd_hessian = fd_hessian
        self._jac = None
        r, c = ev.jac_sparsity.get_triplet()
        self._rows, self._cols = np.asarray(r), np.asarray(c)
        opts = {"enable_fd": True, **fd_hessian} if (jac and fd_hessian is not None) else {}
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
        return not self.is_jac

    def get_jacobian(self, name, inames, onames, opts):
        if self._jac is None:
            self._jac = ConstraintOracle(self.ev, self.base_name, True, self.fd_hessian)
        return self._jac
