"""The one front of the periodic-orbit engine: :func:`solve` (problem + method -> result).

One problem type (:class:`~birdocp.engine.problem.OrbitProblem`), one method type
(:class:`~birdocp.engine.method.OrbitMethod`), one result type
(:class:`~birdocp.engine.orbit_result.OrbitResult`). The problem's ODE selects the formulation
(:data:`FORMULATIONS`), the method's ``solver`` the entry of that formulation's solver table
(:data:`SOLVERS`: IPOPT or the engine's one Levenberg-Marquardt, :mod:`birdocp.engine.lm`).
"""
from __future__ import annotations

from dataclasses import replace

from birdocp.engine import interrupts, orbits, shooting
from birdocp.engine.method import SOLVER_NAMES, OrbitMethod
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.problem import OrbitProblem

__all__ = ["solve", "FORMULATIONS", "SOLVERS"]

FORMULATIONS = {"data_split": shooting.solve_data_split, "time_scaled": orbits.solve_ode}
"""Formulation -> its solve(problem, method, warm_start): ``"data_split"`` for an
:class:`~birdocp.engine.ode.ODE` with a data function (forced, period fixed, free parameters held
by mean conditions; :mod:`birdocp.engine.shooting`), ``"time_scaled"`` for an ODE without data
(time scaled by the period: autonomous or forced; :mod:`birdocp.engine.orbits`)."""

SOLVERS = {"data_split": shooting.SOLVERS, "time_scaled": orbits.SOLVERS}
"""Formulation -> its solver table (name -> run); the names are :data:`~birdocp.engine.method.SOLVER_NAMES`."""


def solve(problem: OrbitProblem, method: OrbitMethod | None = None, *, solver: str | None = None,
          warm_start: OrbitResult | None = None) -> OrbitResult:
    """Find the periodic orbit of ``problem`` (its period when autonomous, its free parameters) and its
    Floquet multipliers.

    ``success`` means converged: the max residual of all equations is finite and at most the
    tolerance, whatever the solver's status says (plus, for an ODE without data, a true orbit of minimal
    period). Failures are results, not exceptions; bad input raises ValueError naming the field; a
    Ctrl-C raises ``KeyboardInterrupt``.

    Parameters
    ----------
    problem : OrbitProblem
        The ODE, its parameters, the guess; free parameters and mean conditions (an ODE with
        data), a period guess (autonomous ODE).
    method : OrbitMethod, optional
        Grid, stepper, solver, tolerances (default ``OrbitMethod()``; ``None`` settings take the
        formulation's defaults, :mod:`birdocp.engine.method`).
    solver : {"ipopt", "lm"}, optional
        Shorthand for ``method.solver`` (overrides it).
    warm_start : OrbitResult, optional
        A previous result whose shooting points (period, free values) start the solve.

    Returns
    -------
    OrbitResult
        The orbit, its multipliers, ``stable``, ``error_estimate`` (when computed), ``formulation``.

    Examples
    --------
    A forced linear oscillator ``x'' + 0.5 x' + x = cos t`` (an ODE with data, ``ODE.from_rhs``): the orbit is
    ``x = 2 sin t`` and the multipliers are ``exp(2 pi eig(A))``, of modulus ``exp(-0.5 pi)``
    (Liouville).

    >>> import casadi as ca, numpy as np
    >>> from birdocp.engine import ODE, OrbitMethod, OrbitProblem, solve
    >>> x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
    >>> f = ca.Function("f", [x, t, p], [ca.vertcat(x[1], -p[0] * x[1] - x[0] + ca.cos(t))])
    >>> res = solve(OrbitProblem(ODE.from_rhs(f, 2 * np.pi), p=[0.5], x_guess=[0, 0]),
    ...             OrbitMethod(points=3, steps_per_period=200))
    >>> res.success, bool(np.allclose(res.x0, [0.0, 2.0], atol=1e-4))
    (True, True)
    >>> bool(np.allclose(np.abs(res.multipliers), np.exp(-0.5 * np.pi), rtol=1e-6))
    True

    An autonomous ODE (the Hopf normal form): the period is an unknown, found from a guess 27 %
    too long.

    >>> ode = ODE.from_function(lambda x, t, p: ca.vertcat(x[0] - x[1] - x[0] * (x[0]**2 + x[1]**2),
    ...                                                    x[0] + x[1] - x[1] * (x[0]**2 + x[1]**2)), 2)
    >>> orbit = solve(OrbitProblem(ode, [], [1.0, 0.0], period_guess=8.0))
    >>> orbit.status, round(orbit.period, 5), orbit.covers
    ('converged', 6.28319, 1)
    """
    if not isinstance(problem, OrbitProblem):
        raise TypeError(f"solve: problem must be an OrbitProblem, got {type(problem).__name__}")
    method = OrbitMethod() if method is None else method
    if not isinstance(method, OrbitMethod):
        raise TypeError(f"solve: method must be an OrbitMethod, got {type(method).__name__}")
    if solver is not None:
        if solver not in SOLVER_NAMES:
            raise ValueError(f"solve: solver must be one of {SOLVER_NAMES}, got {solver!r}")
        method = replace(method, solver=solver)
    formulation = "data_split" if problem.data_split else "time_scaled"
    with interrupts.interruptible():  # a Ctrl-C that CasADi caught inside a solver is raised, never a status
        return FORMULATIONS[formulation](problem, method, warm_start)
