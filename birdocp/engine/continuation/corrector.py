"""The corrector: quasi-Newton on the square system [G(s u); row . u - rhs] = 0."""
from __future__ import annotations

import numpy as np

from birdocp.engine.continuation.system import Continuation, ContinuationState, tangent, test_functions

__all__ = ["Corrector"]


class Corrector:
    """Corrects predicted points of one continuation in scaled unknowns ``u = z / s``.

    The quasi-Newton iteration starts from the Jacobian of the point the prediction comes from,
    evaluates only residuals and updates the Jacobian by Broyden's rank-one formula; the Jacobian is
    evaluated afresh where a step reduces the residual by less than ``chord_contraction`` or where a
    step from a non-exact Jacobian would move u by more than half the predictor's step (a stale
    Jacobian proposing a correction as large as the step itself is not trusted, e.g. where dG/dlam
    vanishes at the base point). The converged point's Jacobian (tangent, monodromy) is always
    evaluated at it.

    Parameters
    ----------
    system : Continuation
        The augmented system.
    scales : numpy.ndarray
        ``s``, one scale per unknown (unknowns are ``z = s u``).
    tol : float
        Tolerance on max |G| (and on the arclength row).
    max_newton : int
        Steps allowed.
    chord_contraction : float
        Required residual reduction per quasi-Newton step.
    """

    def __init__(self, system: Continuation, scales: np.ndarray, tol: float, max_newton: int,
                 chord_contraction: float):
        self.system = system
        self.s = scales
        self.tol = tol
        self.max_newton = max_newton
        self.chord_contraction = chord_contraction
        self.li = system.nz - 1   # index of lam in z

    def scaled_jacobian(self, J):
        """dG/du from dG/dz.

        Parameters
        ----------
        J : ndarray
            dG/dz.

        Returns
        -------
        ndarray
        """
        return J * self.s[None, :]

    def newton(self, u_pred, row, rhs, J0=None, reach=None):
        """Solve ``[G(s u); row . u - rhs] = 0`` from ``u_pred``.

        ``J0``: the Jacobian to start with (else one is evaluated at ``u_pred``); ``reach``: the
        predictor's step (scaled norm). Returns ``(u, g, J, means, Mon, steps)`` or ``None``.

        Parameters
        ----------
        u_pred : ndarray
            Predicted scaled unknowns.
        row : ndarray
            Row of the arclength condition.
        rhs : float
            Its right-hand side.
        J0 : ndarray, optional
            Jacobian to start with.
        reach : float, optional
            Predictor step (scaled norm).

        Returns
        -------
        tuple or None
        """
        sysm, s, tol = self.system, self.s, self.tol
        u = u_pred.copy()
        A, full, prev, du = None, None, None, None
        try:
            for it in range(self.max_newton + 1):
                z = s * u
                if A is None and J0 is None:
                    full = sysm.evaluate(z)
                    g = full[0]
                else:
                    g = sysm.evaluate(z, jacobian=False)[0]
                    full = None
                r = np.concatenate([g, [row @ u - rhs]])
                if not np.all(np.isfinite(r)):
                    return None
                nr = float(np.max(np.abs(r)))
                if nr < tol:
                    break
                if it == self.max_newton:
                    return None
                if full is None and prev is not None and nr > self.chord_contraction * prev:
                    full = sysm.evaluate(z)
                if full is None:
                    if A is None:
                        A = np.vstack([self.scaled_jacobian(J0), row[None, :]])
                    else:  # Broyden: A du = -r_prev, so the secant correction is r (the new residual)
                        A = A + np.outer(r, du) / (du @ du)
                    du = np.linalg.solve(A, -r)
                    if reach is not None and not np.linalg.norm(du) <= 0.5 * reach:
                        full = sysm.evaluate(z)
                if full is not None:
                    if not np.all(np.isfinite(full[1])):
                        return None
                    A = np.vstack([self.scaled_jacobian(full[1]), row[None, :]])
                    du = np.linalg.solve(A, -r)
                prev = nr
                if not np.all(np.isfinite(du)):
                    return None
                u = u + du
            if full is None:
                full = sysm.evaluate(s * u)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        g, J, means, Mon = full
        if not (np.all(np.isfinite(J)) and np.max(np.abs(g)) < tol):
            return None
        return u, g, J, means, Mon, it

    def state(self, result, t_prev) -> ContinuationState:
        """The :class:`ContinuationState` of a :meth:`newton` result (tangent oriented by ``t_prev``).

        Parameters
        ----------
        result : tuple
            A :meth:`newton` result.
        t_prev : ndarray or None
            Tangent that orients the new one.

        Returns
        -------
        ContinuationState
        """
        u, g, J, means, Mon, it = result
        t = tangent(self.scaled_jacobian(J), t_prev)
        return ContinuationState(u, t, g, means, Mon, it, test_functions(t, Mon, self.li), J)

    def along(self, base: ContinuationState, ds: float) -> ContinuationState | None:
        """The point at scaled arclength ``ds`` from ``base`` along its tangent, or ``None``.

        Parameters
        ----------
        base : ContinuationState
            Start of the step.
        ds : float
            Scaled arclength of the step.

        Returns
        -------
        ContinuationState or None
        """
        pred = base.u + ds * base.t
        res = self.newton(pred, base.t, base.t @ base.u + ds, base.J, abs(ds))
        if res is None:  # again from a Jacobian evaluated at the predictor
            res = self.newton(pred, base.t, base.t @ base.u + ds, None, abs(ds))
        return None if res is None else self.state(res, base.t)

    def at_parameter(self, a: ContinuationState, b: ContinuationState, lam: float,
                     s_lam: float) -> ContinuationState | None:
        """The point with the parameter fixed at ``lam`` between ``a`` and ``b`` (linear predictor).

        Parameters
        ----------
        a, b : ContinuationState
            States on either side of ``lam``.
        lam : float
            Parameter value.
        s_lam : float
            Scale of the parameter.

        Returns
        -------
        ContinuationState or None
        """
        li = self.li
        la, lb = s_lam * a.u[li], s_lam * b.u[li]
        w = (lam - la) / (lb - la) if lb != la else 1.0
        e_l = np.zeros(self.system.nz)
        e_l[li] = 1.0
        res = self.newton(a.u + w * (b.u - a.u), e_l, lam / s_lam, a.J if abs(w) < 0.5 else b.J,
                          float(np.linalg.norm(b.u - a.u)))
        return None if res is None else self.state(res, b.t)
