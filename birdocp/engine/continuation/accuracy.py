"""Error estimates of continuation points (``ContinuationOptions(error_estimate=True)``).

Each accepted point is re-solved at its parameter value on twice the steps per period (the same
shooting points, free parameters and, for autonomous orbits, phase section; Newton from the point),
and the differences are scaled Richardson-style by ``2^p / (2^p - 1)`` (p the integrator's order,
:func:`birdocp.engine.orbit_checks.richardson_errors`, as for a single orbit). The solver's part is
``|G|_2 / sigma_min(dG/dz)`` at the point (the parameter held; the distance to the exact solution of
the N-step equations), added to every estimate. The keys (:func:`point_error`): ``multipliers``,
``multipliers_relative``, ``x0``, ``means``, ``free_values`` (by name; the period of an autonomous
orbit is ``free_values["period"]``), ``solver``, ``steps_per_period_fine``, ``fine_status``
(``converged`` or ``failed``: then the estimates are NaN) and ``wall_s``.
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.engine.continuation.corrector import Corrector
from birdocp.engine.continuation.system import ContinuationState
from birdocp.engine.floquet import multipliers_info
from birdocp.engine.orbit_checks import richardson_errors, solver_error

__all__ = ["PointError"]


class PointError:
    """Estimates the errors of the points of one continuation (the refined system built once).

    Parameters
    ----------
    system : Continuation or AutonomousContinuation
        The continuation's system (its ``refined()`` is the 2N-step twin).
    scales : numpy.ndarray
        The continuation's scales of the unknowns.
    tol : float
        The corrector tolerance (the fine solve goes to ``min(tol, 1e-10)``).
    max_newton : int
        Newton steps of the fine solve.
    """

    def __init__(self, system, scales: np.ndarray, tol: float, max_newton: int):
        self.system = system
        self.fine = system.refined()
        self.s = scales
        self.corr = Corrector(self.fine, scales, min(tol, 1e-10), max(max_newton, 20), 0.3)
        self.li = system.nz - 1

    def point_error(self, st: ContinuationState) -> dict:
        """The error estimate of the corrected point ``st`` (see the module).

        Parameters
        ----------
        st : ContinuationState
            Corrected point.

        Returns
        -------
        dict
        """
        t = time.perf_counter()
        sysm, s, li = self.system, self.s, self.li
        z = s * st.u
        keep = np.arange(sysm.nz) != li
        e_solver = solver_error(st.J[:, keep], st.g)
        out = {"solver": e_solver, "steps_per_period_fine": int(self.fine.method.steps_per_period)}
        e_l = np.zeros(sysm.nz)
        e_l[li] = 1.0
        res = self.corr.newton(st.u.copy(), e_l, st.u[li])
        nan_out = dict(multipliers=float("nan"), multipliers_relative=float("nan"), x0=float("nan"), means={},
                       free_values={})
        if res is None:
            out.update(fine_status="failed", **nan_out)
        else:
            out.update(fine_status="converged", **self._compare(z, st, s * res[0], res[3], res[4], e_solver))
        out["wall_s"] = time.perf_counter() - t
        return out

    def _compare(self, z, st, zf, means_f, Mon_f, e_solver: float) -> dict:
        """Richardson estimates from the point ``z`` and its 2N-step twin ``zf``."""
        sysm, fine = self.system, self.fine
        lam = multipliers_info(st.Mon, sysm.period_of(z))[0]
        lam_f = multipliers_info(Mon_f, fine.period_of(zf))[0]
        names = list(sysm.mean_names)
        est = richardson_errors(lam, lam_f, sysm.X_of(z)[:, 0], fine.X_of(zf)[:, 0],
                                dict(zip(names, map(float, st.means))), dict(zip(names, map(float, means_f))),
                                e_solver, sysm.order)
        fac = 2.0 ** sysm.order / (2.0 ** sysm.order - 1.0)
        eps = np.finfo(float).eps
        p, pf = sysm.p_of(z), fine.p_of(zf)
        est["free_values"] = {n: float(fac * abs(p[i] - pf[i]) + e_solver + 16 * eps * abs(p[i]))
                              for n, i in zip(sysm.free_names, sysm.free_idx)}
        return est
