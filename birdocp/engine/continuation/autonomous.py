"""Continuation of periodic orbits of an autonomous ODE (the period varies along the branch).

The system plugs into :func:`birdocp.engine.continuation.continuation` (same predictor, corrector,
step control and special points as for forced orbits): the unknowns are the shooting points, the
period T (in the place of a free parameter, named ``"period"``) and the continuation parameter; the
equations are continuity, periodicity and the phase condition of :mod:`birdocp.engine.orbits` -- the
Poincare section through the start orbit's x0 orthogonal to the flow there (it stays valid while
the orbits cross that section transversally, i.e. over parameter ranges where the orbit does not
move far from its start; restart from a point of the branch to go further).

Floquet multipliers and test functions: the monodromy of an autonomous orbit always has the trivial
multiplier 1 (eigenvector f(x0)), which would make ``det(I - Mon)`` vanish identically and the
branch-point test meaningless. The system therefore hands the continuation the Jacobian of the
Poincare map on the hyperplane orthogonal to f(x0): ``P = Q^T (I - f n^T / (n . f)) Mon Q`` (Q an
orthonormal basis of n^perp, n = f(x0)/|f(x0)|), whose eigenvalues are the nx - 1 non-trivial
multipliers (exactly, as Mon f = f). Branch points report those multipliers; fold, branch point,
period doubling and Neimark-Sacker are then detected and located exactly as for forced orbits.
``BranchPoint.period`` and ``free_values["period"]`` hold T.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from birdocp.engine.continuation import Branch, ContinuationOptions, collect
from birdocp.engine.continuation.iterate import OrbitBranchIterator
from birdocp.engine.floquet import monodromy_of
from birdocp.engine.ode import ODE
from birdocp.engine.steppers import METHOD_ORDER
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.orbits import orbit_residual_system
from birdocp.engine.problem import OrbitProblem

__all__ = ["AutonomousContinuation", "continue_orbits", "autonomous_branch_iterator", "poincare_map_jacobian"]


def poincare_map_jacobian(monodromy: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """(nx-1) x (nx-1) Jacobian of the Poincare map on the hyperplane through x0 orthogonal to
    f0 = f(x0): its eigenvalues are the non-trivial Floquet multipliers.

    Parameters
    ----------
    monodromy : ndarray, shape (nx, nx)
        Monodromy matrix of the orbit at x0.
    f0 : ndarray, shape (nx,)
        Vector field at x0.

    Returns
    -------
    ndarray, shape (nx - 1, nx - 1)
    """
    nx = f0.size
    n = f0 / np.linalg.norm(f0)
    Q, _ = np.linalg.qr(np.column_stack([n, np.eye(nx)]))
    Q = Q[:, 1:nx]
    proj = np.eye(nx) - np.outer(f0, n) / (n @ f0)
    return Q.T @ proj @ monodromy @ Q


class AutonomousContinuation:
    """The augmented system of a branch of autonomous orbits (duck-types
    :class:`birdocp.engine.continuation.Continuation`).

    Parameters
    ----------
    ode : ODE
        An autonomous ODE.
    param : str or int
        The continuation parameter.
    start : OrbitResult
        A converged orbit (its x0 and f(x0) define the phase section; its period is the start T).
    method : OrbitMethod
        Points, steps per period and integrator of the shooting.
    """

    def __init__(self, ode: ODE, param, start: OrbitResult, method: OrbitMethod):
        if not ode.autonomous:
            raise ValueError("AutonomousContinuation: the ODE must be autonomous")
        self.ode = ode
        self.j = ode.param_index(param)
        self.method = method
        self.start = start
        self.order = METHOD_ORDER[method.integrator]
        self.ev = orbit_residual_system(ode, method, period_free=True, free_idx=(self.j,), n_lin=1, cached=False)
        self.nx, self.S = ode.nx, method.points - 1
        self.nX = self.nx * (self.S + 1)
        self.nz = self.nX + 2
        self.p0 = np.asarray(start.p, float).copy()
        self.T0 = float(start.period)
        x_ref = np.asarray(start.x0, float)
        f_ref = ode.evaluate(x_ref, 0.0, self.p0)
        n = f_ref / np.linalg.norm(f_ref)
        A = np.zeros((1, self.nz))
        A[0, :self.nx] = n
        self.ev.set_context(self.p0, self.T0, 0.0, A, [n @ x_ref])
        self.free_idx = [ode.np]          # the period, stored after the parameters in p_of(z)
        self.lo, self.hi = np.array([0.0]), np.array([np.inf])
        self.nm = 0
        self.mean_names: list = []
        self.evaluations = 0
        self.residual_evaluations = 0

    def refined(self) -> "AutonomousContinuation":
        """The same system (same phase section) on twice the steps per period (for error estimates).

        Returns
        -------
        AutonomousContinuation
        """
        return AutonomousContinuation(self.ode, self.j, self.start,
                                      replace(self.method, steps_per_period=2 * int(self.method.steps_per_period)))

    @property
    def name(self) -> str:
        """The continuation parameter's name."""
        return self.ode.param_names[self.j] if self.ode.param_names else f"p{self.j}"

    @property
    def free_names(self) -> list:
        """``["period"]``: T takes the place of a free parameter."""
        return ["period"]

    def period_of(self, z) -> float:
        """T at unknowns ``z``.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        float
        """
        return float(z[self.nX])

    def p_of(self, z) -> np.ndarray:
        """The parameters at ``z`` followed by the period (so ``free_values`` reports T).

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        p = self.p0.copy()
        p[self.j] = z[-1]
        return np.concatenate([p, [z[self.nX]]])

    def X_of(self, z) -> np.ndarray:
        """The shooting points at ``z`` (nx x (S+1)).

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray, shape (nx, S + 1)
        """
        return np.asarray(z[:self.nX]).reshape(self.S + 1, self.nx).T

    def z_of(self, shooting_points, p) -> np.ndarray:
        """Unknowns from shooting points ((S+1) x nx) and parameters (with the period appended, or
        without it: then the start orbit's period).

        Parameters
        ----------
        shooting_points : array_like, shape (S + 1, nx)
            Shooting points.
        p : array_like
            Parameter vector.

        Returns
        -------
        ndarray
        """
        p = np.asarray(p, float).ravel()
        T = p[self.ode.np] if p.size > self.ode.np else self.T0
        X = np.asarray(shooting_points, float).reshape(self.S + 1, self.nx)
        return np.concatenate([X.ravel(), [T, p[self.j]]])

    def evaluate(self, z, jacobian: bool = True):
        """(G, dG/dz, means (none), Poincare-map Jacobian) at z; only G with ``jacobian=False``.

        Parameters
        ----------
        z : ndarray
            Unknowns.
        jacobian : bool
            Also the Jacobian and the rest.

        Returns
        -------
        tuple
        """
        z = np.asarray(z, float)
        if not jacobian:
            self.residual_evaluations += 1
            return self.ev.g(z), None, None, None
        self.evaluations += 1
        g, J = self.ev.evaluate(z)
        Mon = monodromy_of(self.ev.blocks(z))
        f0 = self.ode.evaluate(z[:self.nx], 0.0, self.p_of(z)[:self.ode.np])
        return g, J, np.zeros(0), poincare_map_jacobian(Mon, f0)


def continue_orbits(orbit: OrbitResult, ode: ODE, param, stop_value: float, *,
                    method: OrbitMethod | None = None, options: ContinuationOptions | None = None,
                    **settings) -> Branch:
    """Follow the autonomous orbit ``orbit`` (converged, e.g. by :func:`~birdocp.engine.orbit_front.solve`)
    as ``param`` goes from its value in ``orbit.p`` to ``stop_value``.

    ``method`` (points, steps_per_period, integrator) defaults to the orbit's own; ``options`` and
    keyword settings are those of :func:`birdocp.engine.continuation.continuation` (``step``,
    ``max_points``, ``detect``, ...). Returns its :class:`~birdocp.engine.continuation.Branch`:
    points with ``period`` and the non-trivial multipliers, special points (fold, branch point,
    period doubling, Neimark-Sacker) located on the arclength.

    Parameters
    ----------
    orbit : OrbitResult
        A converged orbit (the start of the branch).
    ode : ODE
        Its ODE.
    param : str or int
        The continuation parameter (a name of ``ode``'s parameters or an index).
    stop_value : float
        Where the branch should end.
    method : OrbitMethod, optional
        Points, steps per period and integrator (default: the orbit's).
    options : ContinuationOptions, optional
        How the branch is followed.
    **settings
        Fields of :class:`~birdocp.engine.continuation.options.ContinuationOptions` overriding ``options``.

    Returns
    -------
    Branch
        See above.
    """
    return collect(autonomous_branch_iterator(orbit, ode, param, None, stop_value, method=method, options=options,
                                              **settings))


def autonomous_branch_iterator(orbit: OrbitResult, ode: ODE, param, start_value: float | None, stop_value: float, *,
                               method: OrbitMethod | None = None, options: ContinuationOptions | None = None,
                               **settings) -> OrbitBranchIterator:
    """The branch of autonomous orbits through ``orbit`` as an iterator (:func:`continue_orbits`
    collects it; :func:`birdocp.engine.iter_branch` returns it for an ODE and a start orbit).

    Parameters
    ----------
    orbit : OrbitResult
        A converged orbit near ``start_value`` (its x0 and f(x0) define the phase section).
    ode : ODE
        Its ODE (autonomous).
    param : str or int
        The continuation parameter.
    start_value : float or None
        Where the branch starts (the first point is corrected there); None: the orbit's own value.
    stop_value : float
        Where the branch should end.
    method : OrbitMethod, optional
        Points, steps per period and integrator (default: the orbit's).
    options : ContinuationOptions, optional
        How the branch is followed.
    **settings
        Fields of :class:`~birdocp.engine.continuation.options.ContinuationOptions` and the
        keywords of :class:`~birdocp.engine.continuation.iterate.OrbitBranchIterator` (``accept``,
        ``progress``, ``orient``, ``events``).

    Returns
    -------
    OrbitBranchIterator
        Iterate it for the points; its ``branch()`` is the :class:`Branch`.
    """
    if not orbit.success:
        raise ValueError(f"continue_orbits: the start orbit did not converge (status {orbit.status!r})")
    if method is None:
        m = orbit.method
        method = OrbitMethod(points=int(m["points"]), steps_per_period=int(m["steps_per_period"]),
                             integrator=m.get("integrator", "rk4"))
    j = ode.param_index(param)
    sysm = AutonomousContinuation(ode, j, orbit, method)
    opts = options or ContinuationOptions()
    opts = ContinuationOptions(**{**opts.__dict__, "points": method.points,
                                  "steps_per_period": int(method.steps_per_period)})
    problem = OrbitProblem(ode, orbit.p, orbit.x0, period_guess=orbit.period)
    a = float(orbit.p[j]) if start_value is None else float(start_value)
    return OrbitBranchIterator(problem, j, a, float(stop_value), options=opts, start=orbit,
                               system=sysm, **settings)
