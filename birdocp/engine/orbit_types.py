"""The problem, method and result types of the periodic-orbit solver (:mod:`birdocp.engine.orbits`)."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from birdocp.engine.ode import ODE
from birdocp.engine.problem import finite_vector
from birdocp.engine.results import result_dict, serial
from birdocp.engine.shooting_types import ShootingGrid
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.steppers import METHOD_ORDER

__all__ = ["OrbitMethod", "OrbitProblem", "PeriodicOrbit", "PHASE_CONDITIONS"]

PHASE_CONDITIONS = ("moving", "fixed")


@dataclass(frozen=True)
class OrbitMethod(ShootingGrid):
    """How to compute a periodic orbit.

    Attributes
    ----------
    points, steps_per_period
        M and N of the grid (:class:`~birdocp.engine.shooting.ShootingGrid`). N None (default):
        chosen by doubling from ``min_steps`` until the error estimate is below ``accuracy``
        (no fixed default that ignores the period and the stiffness of the system).
    integrator
        "rk4" | "radau" (stiff systems) | "gauss".
    solver
        "lm" (Levenberg-Marquardt / damped Newton on the exact shooting matrix) | "ipopt"
        (feasibility NLP through the same exact Jacobian). LM is the default: on the
        Rossler orbit it took 7 iterations (18 ms) against IPOPT's 11 (70 ms), and it
        converged with the Radau integrator where IPOPT's line search wandered off.
    tol
        max |residual| for success (absolute, all equations).
    accuracy
        relative error tolerance of period, x0 and multipliers (error estimate).
    error_estimate
        re-solve with 2N steps to estimate the discretisation error.
    min_amplitude
        relative amplitude below which a solution is an equilibrium (failure).
    period_bounds
        (lo, hi) as factors of the period guess (autonomous).
    max_iter
        iterations of the solver per grid.
    min_steps, max_steps_per_period
        the first and the largest N when N is chosen by refinement.
    ipopt_options
        extra IPOPT options (``solver="ipopt"``).
    phase
        "moving" (default): the Poincare section is re-anchored at the current iterate's X_0,
        orthogonal to the flow there, before every Newton step (the step is orthogonal to the
        flow at X_0; the equation always has a solution). "fixed": one section through the
        phase point (the problem's ``phase_point``, else the first guess point) for the whole
        solve (used by continuation, where the previous orbit fixes it).
    period_search
        Before the first Newton step from a single guess point, look for the trajectory's
        closest return to the section through that point between ``1/1.6`` and 1.6 times the
        period guess and start from that return time when it closes better than the guess.
    min_period_check
        After convergence, test whether the orbit is a k-fold cover of a shorter one (it
        returns to X_0 at T/k) and reduce it to the minimal period (``covers`` = k).
    max_refinements_after_failure
        With ``steps_per_period=None``: how many grid doublings a *failed* solve is retried
        on (a failure for lack of resolution is cured by one or two; a structural one by none).
    time_limit_s
        Wall-clock budget of one solve (all grids), or None; the result says so when hit.
    """

    integrator: str = "rk4"
    solver: str = "lm"
    tol: float = 1e-10
    max_iter: int = 100
    accuracy: float = 1e-6
    error_estimate: bool = True
    min_amplitude: float = 1e-6
    min_steps: int = 32
    max_steps_per_period: int = 16384
    period_bounds: tuple = (1e-2, 1e2)
    ipopt_options: dict = field(default_factory=dict)
    phase: str = "moving"
    period_search: bool = True
    min_period_check: bool = True
    max_refinements_after_failure: int = 2
    time_limit_s: float | None = None

    def validate(self) -> None:
        """Raise ValueError on the first invalid field (named)."""
        self.validate_grid()
        if self.integrator not in METHOD_ORDER:
            raise ValueError(f"OrbitMethod.integrator must be one of {sorted(METHOD_ORDER)}, got {self.integrator!r}")
        if self.solver not in ("ipopt", "lm"):
            raise ValueError(f"OrbitMethod.solver must be 'ipopt' or 'lm', got {self.solver!r}")
        if not self.tol > 0 or not self.accuracy > 0:
            raise ValueError("OrbitMethod.tol and accuracy must be positive")
        if not isinstance(self.max_iter, (int, np.integer)) or self.max_iter < 0:
            raise ValueError(f"OrbitMethod.max_iter must be a non-negative integer, got {self.max_iter!r}")
        if not isinstance(self.min_steps, (int, np.integer)) or self.min_steps < 1:
            raise ValueError(f"OrbitMethod.min_steps must be a positive integer, got {self.min_steps!r}")
        if self.phase not in PHASE_CONDITIONS:
            raise ValueError(f"OrbitMethod.phase must be one of {PHASE_CONDITIONS}, got {self.phase!r}")
        if self.time_limit_s is not None and not self.time_limit_s > 0:
            raise ValueError(f"OrbitMethod.time_limit_s must be positive or None, got {self.time_limit_s!r}")
        lo, hi = (float(v) for v in self.period_bounds)
        if not 0 < lo <= 1 <= hi:
            raise ValueError(f"OrbitMethod.period_bounds must be factors (lo, hi) with 0 < lo <= 1 <= hi, "
                             f"got {self.period_bounds!r}")


@dataclass(eq=False)
class OrbitProblem:
    """A periodic orbit of ``ode`` at parameters ``p``.

    Attributes
    ----------
    ode
        the system (:class:`~birdocp.engine.ode.ODE`).
    p
        its parameters (np,).
    x_guess
        a point near the orbit (nx,), or guesses of the shooting points (M or M-1, nx).
    period_guess
        the period guess (autonomous: an unknown; forced: the period itself, default
        ``ode.forcing_period``; give a multiple for subharmonic orbits).
    t0
        the start time of the period (forced systems; it fixes the phase).
    phase_point
        the point a *fixed* Poincare section passes through (autonomous): given, it fixes the
        section for the whole solve (``OrbitMethod.phase`` is then "fixed"); the section is
        orthogonal to f there.
    """

    ode: ODE
    p: np.ndarray
    x_guess: np.ndarray
    period_guess: float | None = None
    t0: float = 0.0
    phase_point: np.ndarray | None = None

    def __post_init__(self):
        self.p = finite_vector(self.p, "OrbitProblem.p", self.ode.np, f"the ODE has np={self.ode.np}")
        self.x_guess = np.asarray(self.x_guess, float)
        if self.x_guess.shape[-1:] != (self.ode.nx,) or self.x_guess.ndim > 2:
            raise ValueError(f"OrbitProblem.x_guess: shape {self.x_guess.shape}, expected ({self.ode.nx},) or (M, {self.ode.nx})")
        finite_vector(self.x_guess, "OrbitProblem.x_guess")
        if self.phase_point is not None:
            self.phase_point = finite_vector(self.phase_point, "OrbitProblem.phase_point", self.ode.nx,
                                             f"the ODE has nx={self.ode.nx}")
        self.t0 = float(finite_vector(self.t0, "OrbitProblem.t0", 1)[0])
        if self.period_guess is None:
            if self.ode.autonomous or self.ode.forcing_period is None:
                raise ValueError("OrbitProblem.period_guess is required (autonomous system or no forcing_period)")
            self.period_guess = float(self.ode.forcing_period)
        if not (np.isfinite(self.period_guess) and self.period_guess > 0):
            raise ValueError(f"OrbitProblem.period_guess must be positive, got {self.period_guess!r}")


@dataclass
class PeriodicOrbit(OrbitResult):
    """Result of :func:`solve_orbit` (failures are results with ``success=False``).

    An :class:`~birdocp.engine.orbit_result.OrbitResult` (the names every orbit result shares; its
    ``means`` is a property here, always empty).

    Attributes
    ----------
    status
        ``"converged"`` (max residual <= tol, a true orbit), ``"equilibrium"`` (the equations hold
        but the solution is a constant), ``"not_converged"`` (residual above tol), ``"nan"``
        (non-finite iterate), ``"bad_phase_point"`` (f = 0 at the section's point), ``"bad_period"``
        (T <= 0), ``"multiple_cover"`` (see ``covers``). ``solver_status`` keeps what the solver said (IPOPT's return status, or the LM's
        ``"converged"`` / ``"max_iter"`` / ``"stalled"`` / ``"nan"``).
    period, x0, shooting_points
        T (time units of the system); X_0; the shooting points (M x nx).
    multipliers
        All Floquet multipliers, largest modulus first (autonomous: the trivial one included);
        ``trivial_multiplier`` (autonomous) is the one closest to 1 and ``trivial_multiplier_error``
        = abs(it - 1) (an accuracy measure: exactly 0 for the exact flow); ``stable`` is decided on
        the other multipliers only.
    amplitude, arc_length
        max_t of the largest abs(x(t) - x0) component; the integral of the norm of f over the period
        (polygon of the steps).
    error_estimate
        ``{"period", "x0", "multipliers"}`` absolute estimates: the discretisation error
        (Richardson, from a re-solve with 2N steps) plus the solver-tolerance error (``"solver"``:
        ``|g|_2 / sigma_min(J)``, the distance to the exact discrete solution), never a bare 0
        (at least round-off of the value); ``accurate``: every relative estimate <= the method's
        accuracy.
    covers, reduced_from_period
        k > 1 when the solve converged on a k-fold cover of the orbit (its period k times the
        minimal one) and the result was reduced to the minimal period (``reduced_from_period``
        holds the converged multiple; status "converged") -- or could not be (status
        ``"multiple_cover"``, success False).
    free_values
        the free parameters' values by name (``free_params`` is a deprecated alias).
    wall_s
        Seconds: build, solve, error_estimate, total (this grid); ``all_grids`` (with
        ``steps_per_period=None``: every grid tried).
    """

    success: bool
    status: str
    message: str
    solver_status: str
    iterations: int
    residual_history: np.ndarray
    max_residual: float
    period: float
    x0: np.ndarray
    p: np.ndarray
    shooting_points: np.ndarray
    trajectory_t: np.ndarray
    trajectory_x: np.ndarray
    amplitude: float
    arc_length: float
    autonomous: bool
    monodromy: np.ndarray | None = None
    multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    trivial_multiplier: complex | None = field(default=None, metadata=serial(complex=True))
    trivial_multiplier_error: float = float("nan")
    nontrivial_multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    stable: bool | None = None
    error_estimate: dict = field(default_factory=dict)
    accurate: bool | None = None
    method: dict = field(default_factory=dict)
    wall_s: dict = field(default_factory=dict)
    phase_point: np.ndarray | None = None
    free_values: dict = field(default_factory=dict)
    covers: int = 1
    reduced_from_period: float | None = None

    @property
    def means(self) -> dict:
        """Period means of outputs: none (an orbit problem has no mean conditions); ``{}``."""
        return {}

    @property
    def free_params(self) -> dict:
        """Deprecated alias of :attr:`free_values` (the name of every other result type)."""
        warnings.warn("PeriodicOrbit.free_params is deprecated; use free_values", DeprecationWarning, stacklevel=2)
        return self.free_values

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): complex numbers as [re, im]
        pairs, multipliers largest modulus first, NaN as null."""
        return result_dict(self)
