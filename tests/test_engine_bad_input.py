"""Bad input to the engine's public API is a ValueError naming the argument, raised before any solve
(not a CasADi traceback, a solver status that hides the cause, or a silently broadcast answer)."""

import casadi as ca
import numpy as np
import pytest

from birdocp.engine.continuation import continuation
from birdocp.engine.equilibria import find_equilibrium
from birdocp.engine.lyapunov import lyapunov_exponents
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from birdocp.engine.problem import MeanCondition

x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
FORCED = ODE.from_rhs(ca.Function("f", [x, t, p], [ca.vertcat(x[1], -0.3 * x[1] - x[0] + p * ca.cos(t))]),
                              2 * np.pi, ("x", "v"), ("F",))
VDP = ODE.from_function(lambda x, t, p: ca.vertcat(x[1], p[0] * (1 - x[0] ** 2) * x[1] - x[0]), nx=2, params=("mu",))


@pytest.mark.parametrize("kwargs, match", [
    ({"x_guess": [np.nan, 0.0]}, r"OrbitProblem\.x_guess must be finite"),
    ({"x_guess": [np.inf, 0.0]}, r"OrbitProblem\.x_guess must be finite"),
    ({"p": [np.nan]}, r"OrbitProblem\.p must be finite"),
    ({"x_guess": ["a", 0.0]}, r"OrbitProblem\.x_guess: expected numbers"),
    ({"t0": np.nan}, r"OrbitProblem\.t0 must be finite"),
    ({"free": {"F": (2.0, 0.0)}}, r"OrbitProblem\.free\['F'\]: lower bound 2.0 above upper bound"),
    ({"free": {"F": (0.0, np.nan)}}, r"OrbitProblem\.free\['F'\]"),
    ({"free": {"F": 3.0}}, r"OrbitProblem\.free\['F'\]: expected \(lower, upper\)"),
])
def test_limit_cycle_problem_refuses_bad_input(kwargs, match):
    args = {"ode": FORCED, "p": [0.5], "x_guess": [0.0, 0.0], **kwargs}
    with pytest.raises(ValueError, match=match):
        OrbitProblem(**args)


@pytest.mark.parametrize("kwargs, match", [
    ({"x_guess": [np.nan, 0.0]}, r"OrbitProblem\.x_guess must be finite"),
    ({"p": [np.nan]}, r"OrbitProblem\.p must be finite"),
    ({"phase_point": [1.0, 2.0, 3.0]}, r"OrbitProblem\.phase_point: size 3, the ODE has nx=2"),
    ({"phase_point": [np.nan, 0.0]}, r"OrbitProblem\.phase_point must be finite"),
])
def test_orbit_problem_refuses_bad_input(kwargs, match):
    args = {"ode": VDP, "p": [1.0], "x_guess": [2.0, 0.0], "period_guess": 6.6, **kwargs}
    with pytest.raises(ValueError, match=match):
        OrbitProblem(**args)


@pytest.mark.parametrize("kwargs, match", [
    ({"max_iter": -1}, r"OrbitMethod\.max_iter"),
    ({"min_steps": 0}, r"OrbitMethod\.min_steps"),
    ({"period_bounds": (2.0, 1.0)}, r"OrbitMethod\.period_bounds"),
])
def test_orbit_method_refuses_bad_settings(kwargs, match):
    problem = OrbitProblem(VDP, [1.0], [2.0, 0.0], period_guess=6.6)
    with pytest.raises(ValueError, match=match):
        solve(problem, OrbitMethod(points=5, steps_per_period=100, **kwargs))


def test_ode_sizes_are_checked_not_broadcast():
    # CasADi broadcasts a 1-vector to nx entries: find_equilibrium from [0.1] "converged" for nx=2
    with pytest.raises(ValueError, match=r"find_equilibrium x_guess: size 1, the ODE has nx=2"):
        find_equilibrium(VDP, [1.0], [0.1])
    with pytest.raises(ValueError, match=r"find_equilibrium p: size 2, the ODE has np=1"):
        find_equilibrium(VDP, [1.0, 2.0], [0.1, 0.1])
    with pytest.raises(ValueError, match=r"find_equilibrium x_guess must be finite"):
        find_equilibrium(VDP, [1.0], [np.nan, 0.1])
    with pytest.raises(ValueError, match=r"ODE\.evaluate: x has 1 entries"):
        VDP.evaluate([0.1], 0.0, [1.0])
    with pytest.raises(ValueError, match=r"params must be a number >= 0"):
        ODE.from_function(lambda x, t, p: x, nx=1, params=-1)
    eq = find_equilibrium(VDP, [1.0], [0.1, 0.1])  # the right sizes still work
    assert eq.success and np.allclose(eq.x, 0.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"x0": [1.0, 1.0]}, r"lyapunov_exponents x0: size 2, the ODE has nx=3"),
    ({"x0": [np.nan, 1.0, 1.0]}, r"lyapunov_exponents x0 must be finite"),
    ({"p": [1.0]}, r"lyapunov_exponents p: size 1, the ODE has np=0"),
    ({"n_blocks": 0}, r"n_blocks must be a positive integer"),
])
def test_lyapunov_refuses_bad_input(kwargs, match):
    lorenz = ODE.from_function(lambda x, t, p: ca.vertcat(10 * (x[1] - x[0]), x[0] * (28 - x[2]) - x[1],
                                                          x[0] * x[1] - 8 / 3 * x[2]), nx=3)
    args = {"x0": [1.0, 1.0, 1.0], "p": [], "t_total": 1.0, "t_transient": 0.0, **kwargs}
    with pytest.raises(ValueError, match=match):
        lyapunov_exponents(lorenz, **args)


def test_continuation_refuses_a_nan_end():
    problem = OrbitProblem(FORCED, [0.5], [0.0, 0.0])
    with pytest.raises(ValueError, match="start_value and stop_value must be finite"):
        continuation(problem, "F", 0.5, float("nan"), points=3, steps_per_period=60)


def test_free_parameters_need_one_mean_condition_each():
    # a free parameter without a condition was 'converged' at whatever value the solver stopped at
    # (F = 0.195 with IPOPT, 0.150 with LM from 0.3); a condition without a free parameter ran into
    # IPOPT's Not_Enough_Degrees_Of_Freedom or the LM's max_iter
    xs, ds, ps = ca.SX.sym("x", 2), ca.SX.sym("d", 1), ca.SX.sym("p", 1)
    cond = MeanCondition(ca.Function("x2", [xs, ds, ps], [xs[0] ** 2]), 0.5, "x2")
    with pytest.raises(ValueError, match=r"OrbitProblem\.means: 0 mean condition\(s\) for 1 free"):
        OrbitProblem(FORCED, [0.5], [0.0, 0.0], free={"F": (0.0, 5.0)})
    with pytest.raises(ValueError, match=r"OrbitProblem\.means: 1 mean condition\(s\) for 0 free"):
        OrbitProblem(FORCED, [0.5], [0.0, 0.0], means=[cond])
    OrbitProblem(FORCED, [0.5], [0.0, 0.0], free={"F": (0.0, 5.0)}, means=[cond])  # square: accepted


def test_floquet_hopf_and_branch_starts_refuse_bad_input():
    from birdocp.engine.continuation.autonomous import continue_orbits
    from birdocp.engine.equilibria import continue_equilibria, orbit_from_hopf
    from birdocp.engine import OrbitMethod
    from birdocp.engine.shooting import floquet

    m = OrbitMethod(points=3, steps_per_period=60)
    with pytest.raises(ValueError, match=r"floquet x0: size 1, the ODE has nx=2"):  # was a numpy concat error
        floquet(FORCED, [0.0], [0.5], m)
    with pytest.raises(ValueError, match=r"floquet p: size 2, the ODE has np=1"):  # was a CasADi call error
        floquet(FORCED, [0.0, 0.0], [0.5, 1.0], m)
    with pytest.raises(ValueError, match=r"forcing_period must be a positive number, got 'abc'"):
        ODE.from_rhs(FORCED.rhs, "abc")
    sl = ODE.from_function(lambda x, t, p: ca.vertcat(p[0] * x[0] - x[1] - x[0] * (x[0] ** 2 + x[1] ** 2),
                                                      x[0] + p[0] * x[1] - x[1] * (x[0] ** 2 + x[1] ** 2)),
                           nx=2, params=("mu",))
    hopf = continue_equilibria(sl, [-0.5], "mu", [0.0, 0.0], 0.5).hopf[0]
    with pytest.raises(ValueError, match="amplitude must be a non-zero finite number"):  # was 'bad_phase_point'
        orbit_from_hopf(sl, hopf, 0.0)
    with pytest.raises(ValueError, match="stop must be a finite"):  # was a 'corrector_failed' branch
        continue_equilibria(sl, [-0.5], "mu", [0.0, 0.0], float("nan"))
    failed = solve(OrbitProblem(sl, [0.5], [0.0, 0.0], period_guess=6.0), OrbitMethod(points=5, steps_per_period=100))
    assert not failed.success
    with pytest.raises(ValueError, match="the start orbit did not converge"):  # was KeyError: 'points'
        continue_orbits(failed, sl, "mu", 1.0)
