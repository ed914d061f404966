"""The augmented system of a continuation: unknowns, residual, Jacobian, tangent and test functions."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from birdocp.engine.floquet import monodromy_of
from birdocp.engine.method import OrbitMethod
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.shooting import shooting_graphs

__all__ = ["Continuation", "ContinuationState", "tangent", "test_functions"]


class Continuation:
    """The augmented system of one (problem, continuation parameter, grid).

    The unknowns ``z`` are the shooting points ``X_0 .. X_S``, the problem's free parameters (each
    held by one mean condition) and the continuation parameter ``lam``; the equations ``G =
    [continuity; periodicity; mean conditions]`` are one fewer. The residual and its exact Jacobian
    are the multiple-shooting engine's graphs (:func:`birdocp.engine.shooting.shooting_graphs`,
    cached per configuration) with ``lam`` as one more free parameter than there are mean
    conditions: the segment Jacobians by forward AD in nx directions and one forward direction per
    parameter unknown through the data."""

    def __init__(self, problem: OrbitProblem, param, points: int = 5, steps_per_period: int = 148):
        ode = problem.ode
        self.problem = problem
        self.ode = ode
        if isinstance(param, str):
            if param not in ode.param_names:
                raise ValueError(f"unknown continuation parameter {param!r}")
            self.j = ode.param_names.index(param)
        else:
            self.j = int(param)
            if not 0 <= self.j < ode.np:
                raise ValueError(f"continuation parameter index {self.j} out of range")
        self.free_idx = list(problem.free_indices())
        if self.j in self.free_idx:
            raise ValueError("the continuation parameter is one of the problem's free parameters")
        nm = len(problem.means)
        if nm != len(self.free_idx):
            raise ValueError(f"need one mean condition per free parameter ({len(self.free_idx)} free, {nm} means)")
        if steps_per_period % (points - 1):
            raise ValueError("steps_per_period must be a multiple of points - 1")
        self.lo, self.hi = problem.free_bounds() if self.free_idx else (np.zeros(0), np.zeros(0))
        self.mean_names = problem.mean_names()
        self.targets = np.array([m.target for m in problem.means], float)
        self.pidx = self.free_idx + [self.j]   # parameter unknowns, in the order of z
        self.method = OrbitMethod(points=points, steps_per_period=steps_per_period).resolved(True)
        self.builder, _ = shooting_graphs(problem, self.method, self.pidx)
        self.grid = self.builder.grid
        self.nx, self.S, self.nm = ode.nx, self.grid.S, nm
        b = self.builder
        b.set_context(b.symbolic_context(float(problem.t0), problem.p), problem.p, self.targets)
        self._ctx = b.context
        self.nz = self.nx * (self.S + 1) + len(self.pidx)
        self.evaluations = 0        # residual + Jacobian evaluations
        self.residual_evaluations = 0  # residual only (quasi-Newton steps)

    order = 4
    """The order of the grid's integrator (RK4)."""

    def refined(self) -> "Continuation":
        """The same system on twice the steps per period (same unknowns: for error estimates).

        Returns
        -------
        Continuation
        """
        return Continuation(self.problem, self.j, self.method.points, 2 * int(self.method.steps_per_period))

    @property
    def name(self) -> str:
        """The continuation parameter's name."""
        names = self.ode.param_names
        return names[self.j] if names else f"p{self.j}"

    @property
    def free_names(self) -> list:
        """The free parameters' names, in the order of the unknowns."""
        names = self.ode.param_names
        return [names[i] if names else f"p{i}" for i in self.free_idx]

    def period_of(self, z) -> float:
        """The period of the orbit at ``z`` (the forcing period: fixed for this system).

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        float
        """
        return float(self.ode.forcing_period)

    def p_of(self, z) -> np.ndarray:
        """The full parameter vector at unknowns ``z``.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray
        """
        p = self.problem.p.copy()
        p[self.pidx] = z[self.nx * (self.S + 1):]
        return p

    def X_of(self, z) -> np.ndarray:
        """The shooting points at ``z`` as an nx x (S+1) array.

        Parameters
        ----------
        z : ndarray
            Unknowns.

        Returns
        -------
        ndarray, shape (nx, S + 1)
        """
        return z[: self.nx * (self.S + 1)].reshape(self.S + 1, self.nx).T

    def z_of(self, shooting_points, p) -> np.ndarray:
        """The unknowns of shooting points ((S+1) x nx) and a parameter vector.

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
        X = np.asarray(shooting_points, float).reshape(self.S + 1, self.nx)
        return np.concatenate([X.ravel(), np.asarray(p, float)[self.pidx]])

    def evaluate(self, z, jacobian: bool = True):
        """(G, J = dG/dz, means, monodromy) at z; with ``jacobian=False`` only G (the rest None).

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
        b = self.builder
        if b.context is not self._ctx:  # the cached graphs served another solve in between
            b.set_context(*self._ctx)
            self._ctx = b.context
        if not jacobian:
            self.residual_evaluations += 1
            return b.resid(z), None, None, None
        self.evaluations += 1
        g, J = b.evaluate(z)
        return g, J, b.means_at(z), monodromy_of(b.blocks_at(z))


@dataclass
class ContinuationState:
    """A converged point in scaled unknowns, with what the next step needs."""

    u: np.ndarray       # scaled unknowns
    t: np.ndarray       # unit tangent (scaled)
    g: np.ndarray       # residual
    means: np.ndarray
    Mon: np.ndarray     # monodromy
    iterations: int
    tests: dict         # test functions
    J: np.ndarray       # dG/dz at the point (unscaled): the first Jacobian of the next corrector


def tangent(Ju, t_prev):
    """Unit null vector of ``Ju`` (n x n+1), oriented along ``t_prev`` (or by SVD when ``None``).

    Parameters
    ----------
    Ju : ndarray, shape (n, n + 1)
        Jacobian of the extended system.
    t_prev : ndarray or None
        Previous tangent.

    Returns
    -------
    ndarray, shape (n + 1,)
    """
    if t_prev is None:
        _, _, Vt = np.linalg.svd(Ju)
        t = Vt[-1]
    else:
        A = np.vstack([Ju, t_prev[None, :]])
        b = np.zeros(A.shape[0])
        b[-1] = 1.0
        t = np.linalg.solve(A, b)
    t = t / np.linalg.norm(t)
    if t_prev is not None and t @ t_prev < 0:
        t = -t
    return t


def test_functions(t, Mon, lam_index) -> dict:
    """Special-point test functions at a point (see :mod:`birdocp.engine.continuation`).

    Parameters
    ----------
    t : ndarray
        Tangent at the point.
    Mon : ndarray, shape (nx, nx)
        Monodromy matrix.
    lam_index : int
        Index of the parameter in ``t`` (its component is the fold test).

    Returns
    -------
    dict
        ``fold``, ``branch_point`` (det(I - Mon)), ``period_doubling`` (det(I + Mon)), ``neimark_sacker``.
    """
    nx = Mon.shape[0]
    L = np.linalg.eigvals(Mon)
    ns = 1.0
    for i in range(nx):
        for k in range(i + 1, nx):
            ns *= (L[i] * L[k] - 1.0)
    return {"fold": float(t[lam_index]), "branch_point": float(np.linalg.det(np.eye(nx) - Mon)),
            "period_doubling": float(np.linalg.det(np.eye(nx) + Mon)), "neimark_sacker": float(np.real(ns))}
