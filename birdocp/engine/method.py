"""The one method type of the periodic-orbit engine: :class:`OrbitMethod` (grid, stepper, solver, tolerances).

One method object serves both formulations of :func:`birdocp.engine.orbit_front.solve` (which one is
used follows from the problem's ODE, see :class:`~birdocp.engine.problem.OrbitProblem`); a setting
left ``None`` takes the default of that formulation (:meth:`OrbitMethod.resolved`), so the numbers of
every solve are those of its formulation's own defaults:

============================  =====================================  ==================================
setting                       ``"data_split"`` (ODE with data)       ``"time_scaled"`` (ODE, no data)
============================  =====================================  ==================================
``steps_per_period=None``     148 (the paper's grid)                 refined until ``accuracy`` is met
``solver=None``               ``"ipopt"``                            ``"lm"``
``tol=None``                  1e-10 (ipopt, newton-picard);          1e-10
                              1e-5 (lm, the paper's)
``error_estimate=None``       False (it costs a second solve)        True
``integrator``                ``"rk4"`` only                         ``"rk4"``, ``"radau"``, ``"gauss"``
============================  =====================================  ==================================
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from birdocp.engine.steppers import METHOD_ORDER

__all__ = ["OrbitMethod", "IPOPT_DEFAULTS", "PHASE_CONDITIONS", "SOLVER_NAMES", "CHORDS", "PAPER_STEPS_PER_PERIOD"]

PHASE_CONDITIONS = ("moving", "fixed")
SOLVER_NAMES = ("ipopt", "lm", "newton-picard")
CHORDS = ("subspace", "monodromy")
"""The chords of the ``"newton-picard"`` solver (``OrbitMethod.chord``)."""
"""The solvers of the engine's solver table (:data:`birdocp.engine.orbit_front.SOLVERS`)."""
PAPER_STEPS_PER_PERIOD = 148
"""RK4 steps per period of an ODE with data by default: the paper's grid (M = 5: 37 per segment)."""

IPOPT_DEFAULTS = {
    # Full (undamped) Newton-type steps, like the paper's LM which accepts every step. Measured on a
    # forced Duffing oscillator from a poor guess (max residual 1.2): IPOPT's filter line search
    # ended in Infeasible_Problem_Detected for M = 2, 3, 9 (and with an exact Hessian, or a
    # regularisation objective 1e-8..1e-2, for all M) while full steps converged in 7-18 iterations.
    # When this first attempt fails, the ODE solve retries once with IPOPT's filter line
    # search (OrbitMethod.ipopt_fallback).
    "ipopt.accept_every_trial_step": "yes",
}


@dataclass(frozen=True)
class OrbitMethod:
    """How to compute a periodic orbit (multiple shooting): the grid, the stepper, the solver.

    ``None`` means "the default of the problem's formulation" (table in :mod:`birdocp.engine.method`).

    Attributes
    ----------
    points
        M, shooting points INCLUDING the closing one (M-1 segments), M >= 2.
    steps_per_period
        N, integrator steps over the period, a multiple of points-1. None: 148 for an ODE with
        data; without, chosen by doubling from ``min_steps`` until the error estimate is below
        ``accuracy``.
    integrator
        The stepper: "rk4" | "radau" (stiff systems) | "gauss" (an ODE with data: "rk4" only).
    solver
        "ipopt" (feasibility NLP through the exact Jacobian) | "lm" (Levenberg-Marquardt on the exact
        shooting matrix) | "newton-picard" (an ODE with data only: Newton on the states
        ``newton_states``, Picard iteration on the others, which must be strongly contracting;
        :mod:`birdocp.engine.newton_picard`; free parameters join the Newton subspace,
        :mod:`birdocp.engine.newton_picard_free`); None: "ipopt" for an ODE with data, "lm" without.
    derivatives
        "exact" (CasADi AD) | "fd" (forward differences of the segment flow, relative step
        1e-3*x_j, absolute step 1e-3*fd_floor when abs(x_j) < fd_floor; an ODE with data and lm only).
    tol
        Max abs(residual) for success (absolute, all equations); None: see the module table.
    max_iter
        Iterations of the solver (per grid).
    accuracy
        Relative error tolerance of period, x0 and multipliers (without data: the error estimate's target).
    error_estimate
        Re-solve with 2N steps and estimate the discretisation error plus the solver-tolerance error
        (``OrbitResult.error_estimate``); None: False for an ODE with data, True without.
    ipopt_options
        Extra IPOPT options (merged over the defaults).
    fd_floor
        See ``derivatives``.
    regularization
        ODE with data and ipopt: objective weight w in w/2 abs(z - z_guess)^2 (default 0: pure
        feasibility; measured: no weight in 1e-8..1e-2 helped IPOPT converge).
    ipopt_fallback
        ODE with data: if the first IPOPT attempt (full steps) fails, retry once with IPOPT's
        filter line search; iterations and histories are concatenated.
    min_amplitude
        ODE without data: relative amplitude below which a solution is an equilibrium (failure).
    min_steps, max_steps_per_period
        ODE without data: the first and the largest N when N is chosen by refinement.
    period_bounds
        Autonomous ODE: (lo, hi) as factors of the period guess.
    phase
        Autonomous ODE: "moving" (default; the Poincare section is re-anchored at the current
        iterate's X_0, orthogonal to the flow there, before every Newton step: the equation always
        has a solution) | "fixed" (one section through the phase point for the whole solve).
    period_search
        Autonomous ODE: before the first Newton step from a single guess point, start from the
        trajectory's closest return to the section through it (between 1/1.6 and 1.6 times the
        period guess) when it closes better than the guess.
    min_period_check
        Autonomous ODE: test whether the converged orbit is a k-fold cover of a shorter one and
        reduce it to the minimal period (``covers`` = k).
    max_refinements_after_failure
        ODE without data, ``steps_per_period=None``: how many grid doublings a failed solve is retried on.
    time_limit_s
        ODE without data: wall-clock budget of one solve (all grids) in seconds, or None.
    newton_states
        ``solver="newton-picard"``: the indices of the states of the Newton subspace (the dominant,
        slowly decaying or growing directions, e.g. a flier's rigid-body states); required with it.
    picard_max_rate
        ``solver="newton-picard"``: the largest growth per period of the Picard complement along its
        current direction that is accepted; above it on two iterations in a row the complement is
        not contracting and the full Newton (``"lm"``) takes over from the last iterate.
    chord
        ``solver="newton-picard"``: how the Newton matrix is formed. ``"subspace"`` (default): along
        the ``newton_states`` only, the complement by Picard sweeps
        (:mod:`birdocp.engine.newton_picard`); ``"monodromy"``: the whole one-period Jacobian at the
        start, from the stage Jacobians in batch, Broyden-updated along the steps, every state by
        Newton (:mod:`birdocp.engine.newton_picard_chord`; cheaper when the stage Jacobians cost less
        than about ten passes of the state; without free parameters: with them the subspace chord).
    """

    points: int = 5
    steps_per_period: int | None = None
    integrator: str = "rk4"
    solver: str | None = None
    derivatives: str = "exact"
    tol: float | None = None
    max_iter: int = 100
    accuracy: float = 1e-6
    error_estimate: bool | None = None
    ipopt_options: dict = field(default_factory=dict)
    fd_floor: float = 1e-3
    regularization: float = 0.0
    ipopt_fallback: bool = True
    min_amplitude: float = 1e-6
    min_steps: int = 32
    max_steps_per_period: int = 16384
    period_bounds: tuple = (1e-2, 1e2)
    phase: str = "moving"
    period_search: bool = True
    min_period_check: bool = True
    max_refinements_after_failure: int = 2
    time_limit_s: float | None = None
    newton_states: tuple | None = None
    picard_max_rate: float = 0.5
    chord: str = "subspace"

    def resolved(self, data_split: bool) -> "OrbitMethod":
        """This method with every ``None`` default filled in for the formulation, validated.

        Parameters
        ----------
        data_split : bool
            True for a problem of an ODE with data (the data-split formulation), False without.

        Returns
        -------
        OrbitMethod
            A copy (or ``self`` when nothing was left open) whose ``solver``, ``tol`` and
            ``error_estimate`` are set (``steps_per_period`` too with data).
        """
        solver = self.solver or ("ipopt" if data_split else "lm")
        tol = self.tol if self.tol is not None else (1e-5 if solver == "lm" and data_split else 1e-10)
        est = bool(self.error_estimate) if self.error_estimate is not None else not data_split
        n = self.steps_per_period
        if data_split and n is None:
            n = PAPER_STEPS_PER_PERIOD
        out = self if (solver, tol, est, n) == (self.solver, self.tol, self.error_estimate, self.steps_per_period) \
            else replace(self, solver=solver, tol=float(tol), error_estimate=est, steps_per_period=n)
        out.validate()
        if data_split and out.integrator != "rk4":
            raise ValueError(f"OrbitMethod.integrator must be 'rk4' for an ODE with data, got {out.integrator!r}")
        if out.derivatives == "fd" and not (data_split and out.solver == "lm"):
            raise ValueError("OrbitMethod.derivatives='fd' is only available with solver='lm' on an ODE with data")
        if out.solver == "newton-picard" and not data_split:
            raise ValueError("OrbitMethod.solver='newton-picard' is only available for an ODE with data; use 'lm' or 'ipopt'")
        if out.solver == "newton-picard" and not out.newton_states:
            raise ValueError("OrbitMethod.newton_states must name the Newton states (indices) for solver='newton-picard'")
        return out

    def validate(self) -> None:
        """Raise ValueError on the first invalid field (named)."""
        self._validate_grid()
        if self.integrator not in METHOD_ORDER:
            raise ValueError(f"OrbitMethod.integrator must be one of {sorted(METHOD_ORDER)}, got {self.integrator!r}")
        if self.solver is not None and self.solver not in SOLVER_NAMES:
            raise ValueError(f"OrbitMethod.solver must be one of {SOLVER_NAMES}, got {self.solver!r}")
        if self.derivatives not in ("exact", "fd"):
            raise ValueError(f"OrbitMethod.derivatives must be 'exact' or 'fd', got {self.derivatives!r}")
        if self.tol is not None and not self.tol > 0:
            raise ValueError(f"OrbitMethod.tol must be positive, got {self.tol!r}")
        if not self.accuracy > 0:
            raise ValueError(f"OrbitMethod.accuracy must be positive, got {self.accuracy!r}")
        if not isinstance(self.max_iter, (int, np.integer)) or self.max_iter < 0:
            raise ValueError(f"OrbitMethod.max_iter must be a non-negative integer, got {self.max_iter!r}")
        if not isinstance(self.min_steps, (int, np.integer)) or self.min_steps < 1:
            raise ValueError(f"OrbitMethod.min_steps must be a positive integer, got {self.min_steps!r}")
        if self.phase not in PHASE_CONDITIONS:
            raise ValueError(f"OrbitMethod.phase must be one of {PHASE_CONDITIONS}, got {self.phase!r}")
        if self.time_limit_s is not None and not self.time_limit_s > 0:
            raise ValueError(f"OrbitMethod.time_limit_s must be positive or None, got {self.time_limit_s!r}")
        if self.chord not in CHORDS:
            raise ValueError(f"OrbitMethod.chord must be one of {CHORDS}, got {self.chord!r}")
        if not 0 < self.picard_max_rate < 1:
            raise ValueError(f"OrbitMethod.picard_max_rate must lie in (0, 1), got {self.picard_max_rate!r}")
        lo, hi = (float(v) for v in self.period_bounds)
        if not 0 < lo <= 1 <= hi:
            raise ValueError(f"OrbitMethod.period_bounds must be factors (lo, hi) with 0 < lo <= 1 <= hi, "
                             f"got {self.period_bounds!r}")

    def _validate_grid(self) -> None:
        """M >= 2 and N a positive multiple of M-1 (or None)."""
        n = self.steps_per_period
        if not isinstance(self.points, (int, np.integer)) or self.points < 2:
            raise ValueError(f"OrbitMethod.points must be an integer >= 2, got {self.points!r}")
        if n is None:
            return
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"OrbitMethod.steps_per_period must be a positive integer, got {n!r}")
        if n % (self.points - 1):
            raise ValueError(f"OrbitMethod.steps_per_period={n} must be a multiple of points-1={self.points - 1}")
