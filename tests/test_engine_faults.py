"""Engine under faults: a solver status is never convergence by itself, and a Ctrl-C inside IPOPT
or the LM solver is raised, not turned into a status and retried."""

import os
import signal
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

from birdocp.engine import interrupts, oracle, shooting
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, solve

T = 1.0


def stiff_ode(k: float = 50.0):
    """x' = -k x^3 + k cos(2 pi t / T): one stable periodic orbit, stiff for large k."""
    x = ca.SX.sym("x", 1)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    f = ca.Function("f", [x, t, p], [-p[0] * x ** 3 + p[0] * ca.cos(2 * np.pi * t / T)])
    return ODE.from_rhs(f, T, state_names=("x",), param_names=("k",)), np.array([k])


FORCED_ODE, P = stiff_ode()
PROBLEM = OrbitProblem(FORCED_ODE, P, np.array([0.3]))


def test_loose_ipopt_success_with_a_large_residual_is_not_converged():
    # IPOPT told to accept a constraint violation of 10 says Solve_Succeeded at once from shooting
    # points that are off the orbit (max residual ~1): that must be a failure whose status says so,
    # because converged means the shooting residual is below the method's tolerance (1e-10)
    loose = {"ipopt.tol": 10.0, "ipopt.constr_viol_tol": 10.0, "ipopt.dual_inf_tol": 1e3,
             "ipopt.compl_inf_tol": 1e3}
    method = OrbitMethod(points=3, steps_per_period=60, ipopt_options=loose)
    off_orbit = SimpleNamespace(p=P, shooting_points=np.array([[0.3], [-0.6], [0.9]]), x0=np.array([0.3]))
    r = solve(PROBLEM, method, warm_start=off_orbit)
    assert r.max_residual > 0.1  # far from the tolerance
    assert r.success is False
    assert r.status == "residual_above_tol"
    assert "Solve_Succeeded" in r.message and "not converged" in r.message
    # the same problem with the default options converges, below the tolerance
    good = solve(PROBLEM, OrbitMethod(points=3, steps_per_period=60))
    assert good.success and good.max_residual <= 1e-10 and np.all(np.isfinite(good.multipliers))
    # the orbit is stable (the flow contracts: d/dx (-k x^3) < 0 except at x = 0)
    assert good.stable is True


def test_non_finite_problem_is_never_success():
    # a non-finite parameter is bad input, refused before any solve ...
    with pytest.raises(ValueError, match=r"OrbitProblem\.p must be finite"):
        OrbitProblem(FORCED_ODE, np.array([np.inf]), np.array([0.3]))
    # ... and a problem whose flow blows up within the period (x' = 50 x^3 - ..., from x = 3) is a
    # failure, never a success
    r = solve(OrbitProblem(FORCED_ODE, np.array([-50.0]), np.array([3.0])), OrbitMethod(points=3, steps_per_period=60))
    assert r.success is False and r.status != "Solve_Succeeded"


def _sigint_on_call(monkeypatch, cls, name, n):
    orig = getattr(cls, name)
    calls = {"n": 0}

    def wrapped(self, *a, **k):
        calls["n"] += 1
        if calls["n"] == n:
            os.kill(os.getpid(), signal.SIGINT)  # a real SIGINT, delivered inside the solver
        return orig(self, *a, **k)

    monkeypatch.setattr(cls, name, wrapped)
    return calls


@pytest.mark.parametrize("solver, cls, name", [("ipopt", oracle.ConstraintOracle, "_eval"),
                                               ("lm", shooting.ShootingGraphs, "evaluate")])
def test_sigint_inside_the_solver_raises_and_is_not_retried(monkeypatch, solver, cls, name):
    shooting.clear_cache()
    calls = _sigint_on_call(monkeypatch, cls, name, 2)
    runs = []
    orig_run = shooting._run_ipopt
    monkeypatch.setattr(shooting, "_run_ipopt", lambda *a: runs.append(1) or orig_run(*a))
    with pytest.raises(KeyboardInterrupt):
        solve(PROBLEM, OrbitMethod(points=3, steps_per_period=60, solver=solver))
    assert calls["n"] >= 2
    assert len(runs) <= 1  # IPOPT never retried after the interrupt (fallback attempt not started)
    assert not interrupts.pending()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # handler restored
