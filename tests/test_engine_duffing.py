"""Limit-cycle engine on a forced damped Duffing oscillator x'' + c x' + k x + beta x^3 = F cos(w t):
RK4 convergence order of the multipliers, invariance to the number of shooting points, monodromy
against finite differences of the period map, and the failure paths."""
import casadi as ca
import numpy as np
import pytest

from birdocp.engine.shooting import floquet
from birdocp.engine.integrate import RK4Grid, simulate
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, solve

OMEGA = 1.3
T = 2 * np.pi / OMEGA


def duffing():
    x = ca.SX.sym("x", 2)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 4)  # c, k, beta, F
    c, k, beta, F = p[0], p[1], p[2], p[3]
    xdot = ca.vertcat(x[1], -c * x[1] - k * x[0] - beta * x[0] ** 3 + F * ca.cos(OMEGA * t))
    return ODE.from_rhs(ca.Function("duffing", [x, t, p], [xdot]), T, ("x", "v"), ("c", "k", "beta", "F"))


FORCED_ODE = duffing()
P = np.array([0.25, 1.0, 0.8, 0.6])
PROB = OrbitProblem(FORCED_ODE, P, np.array([0.5, 0.0]))


def test_rk4_order_of_multipliers():
    ref = solve(PROB, OrbitMethod(points=5, steps_per_period=2048))
    assert ref.success, ref.message
    errs, xerrs = [], []
    Ns = (32, 64, 128)
    for N in Ns:
        r = solve(PROB, OrbitMethod(points=5, steps_per_period=N), warm_start=ref)
        assert r.success, r.message
        errs.append(np.max(np.abs(r.multipliers - ref.multipliers)))
        xerrs.append(np.max(np.abs(r.x0 - ref.x0)))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    xorders = np.log2(np.array(xerrs[:-1]) / np.array(xerrs[1:]))
    print("multiplier errors", errs, "orders", orders, "x0 orders", xorders)
    assert np.all((orders > 3.5) & (orders < 4.5)), orders
    assert np.all((xorders > 3.5) & (xorders < 4.5)), xorders
    assert errs[-1] < 1e-6


def test_invariance_to_number_of_shooting_points():
    N = 144
    # tol 1e-12 (one Newton iteration more than the default 1e-10) puts the differences at round-off;
    # at the default tol they are ~3e-11 (x0) and ~1.5e-11 (multipliers)
    res = {M: solve(PROB, OrbitMethod(points=M, steps_per_period=N, tol=1e-12)) for M in (2, 3, 5, 9)}
    assert all(r.success for r in res.values()), {M: r.status for M, r in res.items()}
    base = res[2]
    for M, r in res.items():
        dl = np.max(np.abs(r.multipliers - base.multipliers))
        dx = np.max(np.abs(r.x0 - base.x0))
        print(f"M={M}: |dmult|={dl:.2e} |dx0|={dx:.2e} iters={r.iterations}")
        assert dl < 1e-12 and dx < 1e-12
        assert r.monodromy_vs_full_period_jacobian < 1e-13


def test_monodromy_against_finite_differences():
    m = OrbitMethod(points=5, steps_per_period=200, tol=1e-12)
    r = solve(PROB, m)
    assert r.success
    grid = RK4Grid(FORCED_ODE, 200, 1)
    D = grid.blocks_numeric(0.0, r.p)
    pd = ca.DM(r.p)

    def phi(x):
        return np.asarray(grid.period_map(ca.DM(x), D, pd)[0]).ravel()

    eps = 1e-6
    Jfd = np.column_stack([(phi(r.x0 + eps * e) - phi(r.x0 - eps * e)) / (2 * eps) for e in np.eye(2)])
    assert np.max(np.abs(Jfd - r.monodromy)) < 1e-6
    assert r.monodromy_vs_full_period_jacobian < 1e-12
    # periodicity of the solution under the plain integrator
    assert np.max(np.abs(phi(r.x0) - r.x0)) < 1e-9
    t, X = simulate(FORCED_ODE, r.x0, r.p, steps_per_period=200, n_periods=2)
    assert np.max(np.abs(X[200] - r.x0)) < 1e-9 and np.max(np.abs(X[400] - r.x0)) < 1e-8
    assert np.allclose(X[:201], r.trajectory_x, atol=1e-9)
    # the standalone analysis, shooting points from integrating forward
    fr = floquet(FORCED_ODE, r.x0, r.p, m)
    assert np.max(np.abs(fr.monodromy - r.monodromy)) < 1e-9


@pytest.mark.parametrize("method", [OrbitMethod(points=3, steps_per_period=60, solver="lm", tol=1e-12),
                                    OrbitMethod(points=3, steps_per_period=60, solver="lm", derivatives="fd",
                                                tol=1e-12)], ids=["exact", "fd"])
def test_lm_agrees_with_ipopt_on_nonlinear(method):
    ri = solve(PROB, OrbitMethod(points=3, steps_per_period=60))
    rl = solve(PROB, method)
    assert ri.success and rl.success, (ri.message, rl.message)
    assert np.max(np.abs(ri.x0 - rl.x0)) < 1e-9
    assert np.max(np.abs(ri.multipliers - rl.multipliers)) < 1e-9
    assert rl.residual_history[-1] < 1e-12 and len(rl.residual_history) == rl.iterations + 1


def _nan_ode():
    x = ca.SX.sym("x", 2)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    return ODE.from_rhs(ca.Function("bad", [x, t, p], [ca.vertcat(ca.sqrt(x[0]) , -x[1] + ca.cos(t))]), T)


@pytest.mark.parametrize("solver", ["ipopt", "lm"])
def test_nan_rhs_is_a_failed_result(solver):
    prob = OrbitProblem(_nan_ode(), np.zeros(1), np.array([-1.0, 0.0]))
    r = solve(prob, OrbitMethod(points=3, steps_per_period=30, solver=solver))
    assert not r.success
    assert isinstance(r.status, str) and r.status
    assert r.message


@pytest.mark.parametrize("solver,fallback,iters", [("ipopt", False, 1), ("ipopt", True, 2), ("lm", True, 1)])
def test_max_iter_is_a_failed_result(solver, fallback, iters):
    r = solve(PROB, OrbitMethod(points=3, steps_per_period=60, solver=solver, max_iter=1, tol=1e-14,
                                ipopt_fallback=fallback))
    assert not r.success
    assert r.status in ("Maximum_Iterations_Exceeded", "max_iter")
    assert r.iterations == iters  # the ipopt fallback (filter line search) adds its own iteration
    assert ("retried" in r.message) == (solver == "ipopt" and fallback)
    r.to_dict()


def test_error_estimate_of_a_forced_orbit_tracks_the_true_error():
    # estimate at N = 64 (Richardson from 128 steps + solver error) against a 2048-step reference
    ref = solve(PROB, OrbitMethod(points=5, steps_per_period=2048))
    r = solve(PROB, OrbitMethod(points=5, steps_per_period=64, error_estimate=True), warm_start=ref)
    e = r.error_estimate
    assert r.success and e["fine_status"] == "converged" and e["steps_per_period_fine"] == 128, e
    true_lam = np.max(np.abs(np.sort_complex(r.multipliers) - np.sort_complex(ref.multipliers)))
    assert 0.3 * true_lam <= e["multipliers"] <= 3 * true_lam, (true_lam, e)
    assert 0.3 * np.max(np.abs(r.x0 - ref.x0)) <= e["x0"] <= 3 * np.max(np.abs(r.x0 - ref.x0)) + 1e-12, e
    plain = solve(PROB, OrbitMethod(points=5, steps_per_period=64), warm_start=ref)
    assert plain.error_estimate is None and np.array_equal(plain.multipliers, r.multipliers)
    assert "error_estimate" not in r.to_dict()  # the caller adds it (birdocp trim)


def test_staged_variational_step_equals_the_whole_step():
    """RK4 on [x; vec(Phi)] with the right-hand side's tangents (the compiled path's step for large
    models) gives the whole step's state, sensitivity, output integral and its sensitivity to round-off."""
    xs, ds, ps = ca.SX.sym("x", 2), ca.SX.sym("d", 1), ca.SX.sym("p", 4)
    out = ca.Function("energy", [xs, ds, ps], [ca.vertcat(xs[0] ** 2 * ps[1] + xs[1] ** 4, ca.sin(ds) * xs[1])])
    grid = RK4Grid(FORCED_ODE, 40, 1, outputs=(out,))
    whole = grid.variational_step(h_input=True)
    staged = grid.staged_variational_step(grid.rhs_tangent())
    rng = np.random.default_rng(3)
    for _ in range(3):
        s0 = np.concatenate([rng.normal(size=2), rng.normal(size=4), rng.normal(size=2), rng.normal(size=4)])
        D3, h = ca.DM(rng.uniform(0, T, size=(1, 3))), 0.05
        a, b = np.asarray(whole(s0, D3, P, h)).ravel(), np.asarray(staged(s0, D3, P, h)).ravel()
        assert np.max(np.abs(a - b)) < 1e-14 * max(1.0, np.max(np.abs(a)))
        assert np.max(np.abs(a - s0)) > 1e-3  # a real step
