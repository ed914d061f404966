"""The method and result types of the forced multiple shooting (:mod:`birdocp.engine.shooting`)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.results import result_dict, serial

__all__ = ["ShootingGrid", "MultipleShooting", "LimitCycleResult", "IPOPT_DEFAULTS"]

IPOPT_DEFAULTS = {
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
    error_estimate
        after a converged solve, re-solve with 2N steps (LM from the result) and estimate the
        error of the multipliers, x0 and the means (:func:`birdocp.engine.shooting.estimate_error`;
        ``LimitCycleResult.error_estimate``). Off by default: it costs a second graph and solve.
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
    error_estimate: bool = False

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
class LimitCycleResult(OrbitResult):
    """Outcome of :func:`solve`. Failures are results (``success=False``), not exceptions.

    An :class:`~birdocp.engine.orbit_result.OrbitResult` (the names every orbit result shares; its
    ``period`` and ``autonomous`` are properties here).

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
    error_estimate
        None, or (``MultipleShooting(error_estimate=True)``) the estimated errors of the result
        (:func:`birdocp.engine.shooting.estimate_error`); not in ``to_dict()`` (callers that compute
        it add it: ``birdocp trim``'s JSON key ``error_estimate``).

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
    error_estimate: dict | None = field(default=None, metadata=serial(skip=True))

    @property
    def period(self) -> float:
        """The forcing period (time units of the system): the span of the shooting times."""
        t = self.shooting_times if len(self.shooting_times) else self.trajectory_t
        return float(t[-1] - t[0]) if len(t) else float("nan")

    @property
    def autonomous(self) -> bool:
        """``False``: the period of a forced orbit is the forcing's."""
        return False

    def to_dict(self) -> dict:
        """JSON-ready dict (see the class docstring)."""
        return result_dict(self)
