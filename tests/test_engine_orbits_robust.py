"""Robustness of the orbit solver (issue 27): the reference toolbox's examples from its own starting
guesses, a 30 % period error, multiple covers, error estimates that are never a silent 0, failures
that come quickly and say why.

References are independent: exact orbits (the Hopf normal form's unit circle, period 2 pi; the torus
example's invariant circle, period 8 pi) and scipy's DOP853 at rtol 1e-12 (the orbit found must close
under scipy's integration over the period found)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from birdocp.engine.lm import levenberg_marquardt
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve

HOPF = ODE.from_function(lambda x, t, p: ca.vertcat(x[0] - x[1] - x[0] * (x[0] ** 2 + x[1] ** 2),
                                                    x[0] + x[1] - x[1] * (x[0] ** 2 + x[1] ** 2)), 2)


def _torus(x, t, p):
    r = x[2] + 0.2 * (1 - x[2] ** 2)
    return ca.vertcat((p[0] - 3) * x[0] - 0.25 * x[1] + x[0] * r, 0.25 * x[0] + (p[0] - 3) * x[1] + x[1] * r,
                      p[0] * x[2] - (x[0] ** 2 + x[1] ** 2 + x[2] ** 2))


def _isothermal(x, t, p):
    return ca.vertcat(x[0] * (30 - 0.25 * x[0] - x[1] - x[2]) + 0.001 * x[1] ** 2 + 0.1,
                      x[1] * (x[0] - 0.001 * x[1] - p[0]) + 0.1, x[2] * (16.5 - x[0] - 0.5 * x[2]) + 0.1)


def _goodwin(x, t, p):
    return ca.vertcat(0.7 / (1 + x[2] ** 7) - 0.45 * x[0] / (1 + x[0]), 0.7 * x[0] - 0.35 * x[1] / (1 + x[1]),
                      0.7 * x[1] - 0.35 * x[2] / (1 + x[2]))


def _lorenz(x, t, p):
    return ca.vertcat(p[0] * (x[1] - x[0]), x[0] * (p[1] - x[2]) - x[1], x[0] * x[1] - p[2] * x[2])


TORUS = ODE.from_function(_torus, 3, ("lam",))
ISOTHERMAL = ODE.from_function(_isothermal, 3, ("lam",))
GOODWIN = ODE.from_function(_goodwin, 3)
LORENZ = ODE.from_function(_lorenz, 3, ("sigma", "r", "beta"))


def _closes_under_scipy(ode, orbit, rtol=1e-12):
    """max |x(T) - x0| / (1 + |x0|) of scipy's DOP853 from the orbit's x0 over its period."""
    f = lambda t, x: ode.evaluate(x, t, orbit.p)  # noqa: E731
    s = solve_ivp(f, (0.0, orbit.period), orbit.x0, method="DOP853", rtol=rtol, atol=1e-12)
    return float(np.max(np.abs(s.y[:, -1] - orbit.x0)) / (1 + np.max(np.abs(orbit.x0))))


@pytest.mark.parametrize("factor", [1.3, 0.7])
def test_a_30_percent_period_error_from_a_point_on_the_orbit(factor):
    r = solve(OrbitProblem(HOPF, [], [1.0, 0.0], period_guess=2 * np.pi * factor),
              OrbitMethod(points=5, steps_per_period=200))
    assert r.success and r.covers == 1, r.message
    assert abs(r.period - 2 * np.pi) < 1e-6
    assert abs(np.linalg.norm(r.x0) - 1) < 1e-6


def test_without_the_period_search_lm_alone_takes_a_30_percent_error():
    r = solve(OrbitProblem(HOPF, [], [1.0, 0.0], period_guess=2 * np.pi * 1.3),
              OrbitMethod(points=5, steps_per_period=200, period_search=False))
    assert r.success and abs(r.period - 2 * np.pi) < 1e-6, r.message


@pytest.mark.parametrize("k", [2, 3])
def test_a_multiple_of_the_period_is_reduced_to_the_minimal_period(k):
    r = solve(OrbitProblem(HOPF, [], [1.0, 0.0], period_guess=2 * np.pi * k),
              OrbitMethod(points=7, steps_per_period=420, period_search=False))
    assert r.success and r.covers == k and "loops" in r.message, r.message
    assert abs(r.reduced_from_period - k * 2 * np.pi) < 1e-4
    assert abs(r.period - 2 * np.pi) < 1e-6
    lam = np.sort(np.abs(r.multipliers))  # the one-loop map: e^{-2 * 2 pi}, not its k-th power
    assert abs(lam[0] - np.exp(-4 * np.pi)) < 1e-6


def test_torus_example_from_the_reference_guess_is_one_loop_not_eight():
    r = solve(OrbitProblem(TORUS, [2.0], [0.9, 0.9, 0.9], period_guess=200.0), OrbitMethod(points=5))
    assert r.success and r.covers == 8, r.message
    assert abs(r.period - 8 * np.pi) < 1e-6 and r.error_estimate["period"] < 1e-6
    assert abs(r.period - 8 * np.pi) <= 3 * r.error_estimate["period"]  # the estimate bounds the true error
    assert _closes_under_scipy(TORUS, r) < 1e-8


@pytest.mark.parametrize("ode, p, x, T, points", [
    (ISOTHERMAL, [11.0], [40.0, 20.0, 20.0], 0.5, 5),   # the guess lies in the basin of an equilibrium
    (GOODWIN, [], [0.1, 1.0, 1.0], 23.0, 5),
], ids=["isothermal", "goodwin"])
def test_reference_examples_from_the_reference_guesses(ode, p, x, T, points):
    r = solve(OrbitProblem(ode, p, x, period_guess=T), OrbitMethod(points=points))
    assert r.success and r.accurate and r.covers == 1, r.message
    assert _closes_under_scipy(ode, r) < 1e-6  # the default accuracy (relative)


def test_unstable_lorenz_orbit_from_a_rounded_guess():
    # r = 21: the unstable orbit around C+ (multiplier ~1.26); the guess is a point of it rounded to 0.1
    r = solve(OrbitProblem(LORENZ, [10.0, 21.0, 8 / 3], [11.2, 8.5, 27.6], period_guess=0.82),
              OrbitMethod(points=9))
    assert r.success and r.accurate, r.message
    assert not r.stable and abs(abs(r.nontrivial_multipliers[0]) - 1.2609) < 1e-3
    assert _closes_under_scipy(LORENZ, r) < 1e-5  # accuracy 1e-6 (the default)
    # the period with accuracy 1e-9 (this solver, 512 steps; its orbit closes under DOP853 to 3.5e-8
    # absolute, |f| ~ 100 there): the error estimate of the default accuracy bounds the true error
    assert abs(r.period - 0.81622236152) <= 3 * r.error_estimate["period"] < 1e-6


def test_error_estimate_is_never_a_silent_zero():
    # started on the exact orbit: the 2N re-solve has next to nothing to do; the estimate still
    # holds the discretisation and solver errors and bounds the true error
    r = solve(OrbitProblem(HOPF, [], [1.0, 0.0], period_guess=2 * np.pi),
              OrbitMethod(points=5, steps_per_period=40, period_search=False))
    e = r.error_estimate
    assert r.success and all(e[k] > 0 for k in ("period", "x0", "multipliers", "solver")), e
    assert abs(r.period - 2 * np.pi) <= 3 * e["period"]
    assert e["solver"] < 1e-9


def test_a_fixed_section_that_misses_the_orbit_fails_and_says_why():
    # the section through (3, 0) orthogonal to the flow there is the line x = 3 + y/8: it never
    # meets the unit circle, so no solution exists; the moving section converges from the same point
    pr = OrbitProblem(HOPF, [], [3.0, 0.0], period_guess=6.0, phase_point=[3.0, 0.0])
    r = solve(pr, OrbitMethod(points=5, steps_per_period=100))
    assert not r.success and "does not meet" in r.message, r.message
    ok = solve(OrbitProblem(HOPF, [], [3.0, 0.0], period_guess=6.0), OrbitMethod(points=5, steps_per_period=100))
    assert ok.success and abs(ok.period - 2 * np.pi) < 1e-5, ok.message


def test_no_orbit_fails_early_without_refining_forever():
    # Lorenz at r = 10: both non-trivial equilibria are stable foci, there is no periodic orbit nearby
    r = solve(OrbitProblem(LORENZ, [10.0, 10.0, 8 / 3], [5.0, 5.0, 10.0], period_guess=0.8),
              OrbitMethod(points=9, phase="fixed"))
    assert not r.success
    assert "not retried on finer grids" in r.message and r.method["steps_per_period"] <= 4 * 128, r.message


def test_one_levenberg_marquardt_with_two_rules():
    class Rosenbrock:  # g = (10 (y - x^2), 1 - x): the root (1, 1) at the end of a curved valley
        def evaluate(self, z):
            return (np.array([10 * (z[1] - z[0] ** 2), 1 - z[0]]), np.array([[-20 * z[0], 10.0], [-1.0, 0.0]]))
    for rule in ("decrease", "always"):
        out = levenberg_marquardt(Rosenbrock(), [-1.2, 1.0], tol=1e-12, max_iter=200, accept=rule)
        assert out.status == "converged" and np.allclose(out.z, 1.0, atol=1e-10), (rule, out)
    with pytest.raises(ValueError, match="accept"):
        levenberg_marquardt(Rosenbrock(), [0.0, 0.0], tol=1e-9, max_iter=5, accept="sometimes")


def test_free_values_is_the_one_name():
    r = solve(OrbitProblem(HOPF, [], [1.0, 0.0], period_guess=2 * np.pi),
              OrbitMethod(points=3, steps_per_period=60, error_estimate=False))
    assert "free_values" in r.to_dict() and "free_params" not in r.to_dict()
    assert not hasattr(r, "free_params")  # the deprecated alias was removed with PeriodicOrbit
