"""The engine: periodic orbits of any ODE, their Floquet multipliers, branches and equilibria.

It knows nothing of birds (casadi, numpy and the standard library only). The names below are
importable from here (``from birdocp.engine import OrbitProblem, solve``), loaded on first use
(PEP 562), so importing the package costs nothing. One problem type (:class:`OrbitProblem`, of an
:class:`ODE`, forced or autonomous), one method type (:class:`OrbitMethod`), one front
(:func:`solve`), one result type (:class:`OrbitResult`).

Examples
--------
A forced linear oscillator ``x'' + c x' + x = cos(t)``: its periodic orbit is known in closed form,
and its multipliers are ``exp(eig(A) T)``.

>>> import casadi as ca, numpy as np
>>> from birdocp.engine import OrbitMethod, OrbitProblem, ODE, solve
>>> x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
>>> f = ca.Function("f", [x, t, p], [ca.vertcat(x[1], -p[0] * x[1] - x[0] + ca.cos(t))])
>>> res = solve(OrbitProblem(ODE.from_rhs(f, 2 * np.pi), p=[0.5], x_guess=[0, 0]),
...             OrbitMethod(points=3, steps_per_period=60))
>>> bool(res.success), bool(res.stable)
(True, True)
>>> bool(np.allclose(res.x0, [0.0, 2.0], atol=1e-4))   # x = 2 sin t when c = 0.5
True
"""

# name -> module; strings resolved on attribute access (the package imports nothing at start-up);
# tests/test_architecture.py checks that every target is a module of the engine. A function named
# like one of the engine's modules cannot be a face name (the module attribute that the import system
# sets would shadow it): shooting.floquet and continuation.continuation stay in their modules.
API = {
    "problems": {"OrbitProblem": "birdocp.engine.problem",
                 "ODE": "birdocp.engine.ode", "MeanCondition": "birdocp.engine.problem"},
    "orbits": {"solve": "birdocp.engine.orbit_front", "OrbitMethod": "birdocp.engine.method",
               "OrbitResult": "birdocp.engine.orbit_result", "FloquetResult": "birdocp.engine.floquet"},
    "solvers": {"levenberg_marquardt": "birdocp.engine.lm", "run_ipopt": "birdocp.engine.nlp"},
    "continuation": {"ContinuationOptions": "birdocp.engine.continuation.options",
                     "Branch": "birdocp.engine.continuation.branch",
                     "BranchPoint": "birdocp.engine.continuation.branch",
                     "SpecialPoint": "birdocp.engine.continuation.branch",
                     "continue_orbits": "birdocp.engine.continuation.autonomous",
                     "iter_branch": "birdocp.engine.continuation.front",
                     "ContinuationStep": "birdocp.engine.continuation.step"},
    "equilibria": {"find_equilibrium": "birdocp.engine.equilibria", "continue_equilibria": "birdocp.engine.equilibria",
                   "orbit_from_hopf": "birdocp.engine.equilibria", "Equilibrium": "birdocp.engine.equilibria",
                   "HopfPoint": "birdocp.engine.equilibria"},
    "Lyapunov exponents": {"lyapunov_exponents": "birdocp.engine.lyapunov",
                           "largest_lyapunov_exponent": "birdocp.engine.lyapunov"},
    "executors": {"get_executor": "birdocp.engine.executors"},
}
_TARGETS = {name: module for group in API.values() for name, module in group.items()}
__all__ = list(_TARGETS)


def __getattr__(name: str):
    """Import a public name's module on first access (PEP 562) and keep the name."""
    module = _TARGETS.get(name)
    if module is None:
        raise AttributeError(f"module 'birdocp.engine' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_TARGETS))
