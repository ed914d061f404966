"""Limit-cycle engine on a linear periodic system x' = A x + b(t): exact answers.

Monodromy = expm(A T); the periodic orbit comes from the frequency-domain closed form
x(t) = sum_k Re/Im((i k w I - A)^-1 c_k e^{i k w t}) for the sinusoidal forcing terms plus
-A^-1 b0 for the constant one (independent of the RK4 discretisation)."""
import json

import casadi as ca
import numpy as np
import pytest
import scipy.linalg as sl

from birdocp.engine.shooting import floquet
from birdocp.engine.problem import OrbitProblem, MeanCondition
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, solve

T = 1.7
W = 2 * np.pi / T


def make_A(unstable: bool) -> np.ndarray:
    """4x4, coupled: a complex pair -0.3 +- 2i and real modes -0.5 and -1.2 (or +0.4 if unstable)."""
    B = np.array([[-0.3, 2.0, 0, 0], [-2.0, -0.3, 0, 0], [0, 0, -0.5, 0], [0, 0, 0, 0.4 if unstable else -1.2]])
    Q = np.array([[1.0, 0.2, 0.1, 0.0], [0.3, 1.0, 0.0, 0.2], [0.0, 0.1, 1.0, 0.3], [0.2, 0.0, 0.1, 1.0]])
    return Q @ B @ np.linalg.inv(Q)


def forcing(t, p, lib):
    # p[0]: amplitude of the sin(w t) term on x1, p[1]: constant forcing on x4
    return [p[0] * lib.sin(W * t), lib.cos(W * t), lib.sin(2 * W * t), p[1]]


def exact_x0(A, p):
    n = A.shape[0]
    I = np.eye(n)
    R1 = np.linalg.inv(1j * W * I - A)
    R2 = np.linalg.inv(2j * W * I - A)
    e = I
    x = -np.linalg.solve(A, p[1] * e[3])
    x = x + p[0] * (R1 @ e[0]).imag + (R1 @ e[1]).real + (R2 @ e[2]).imag
    return x


def exact_mean(A, p):
    return -np.linalg.solve(A, p[1] * np.eye(4)[3])


def linear_ode_plain(A):
    x = ca.SX.sym("x", 4)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 2)
    f = ca.Function("f", [x, t, p], [ca.mtimes(ca.DM(A), x) + ca.vertcat(*forcing(t, p, ca))])
    return ODE.from_rhs(f, T, state_names=("a", "b", "c", "d"), param_names=("amp", "bias"))


def linear_ode_split(A):
    """Same ODE with a non-trivial data function d(t, p) = [sin wt, cos wt, sin 2wt]."""
    x = ca.SX.sym("x", 4)
    d = ca.SX.sym("d", 3)
    p = ca.SX.sym("p", 2)
    t = ca.SX.sym("t")
    rhs = ca.Function("rhs", [x, d, p], [ca.mtimes(ca.DM(A), x) + ca.vertcat(p[0] * d[0], d[1], d[2], p[1])])
    data = ca.Function("data", [t, p], [ca.vertcat(ca.sin(W * t), ca.cos(W * t), ca.sin(2 * W * t))])
    return ODE(rhs, data, T, param_names=("amp", "bias"))


ODES = {u: linear_ode_plain(make_A(u)) for u in (False, True)}
P = np.array([1.3, 0.7])

METHODS = [
    OrbitMethod(points=5, steps_per_period=400),
    OrbitMethod(points=5, steps_per_period=400, solver="lm", tol=1e-11),
    OrbitMethod(points=5, steps_per_period=400, solver="lm", derivatives="fd", tol=1e-11),
]


@pytest.mark.parametrize("unstable", [False, True])
@pytest.mark.parametrize("method", METHODS, ids=["ipopt", "lm-exact", "lm-fd"])
def test_linear_monodromy_and_orbit_exact(unstable, method):
    A = make_A(unstable)
    prob = OrbitProblem(ODES[unstable], P, np.zeros(4))
    r = solve(prob, method)
    assert r.success, r.message
    assert r.max_residual < 1e-10
    Mex = sl.expm(A * T)
    assert np.max(np.abs(r.monodromy - Mex)) < 1e-8
    assert np.max(np.abs(r.x0 - exact_x0(A, P))) < 1e-8
    lam_ex = np.linalg.eigvals(Mex)
    lam_ex = lam_ex[np.argsort(-np.abs(lam_ex))]
    assert np.allclose(np.abs(r.multipliers), np.abs(lam_ex), atol=1e-8)
    assert np.all(np.diff(np.abs(r.multipliers)) <= 1e-12)  # largest first
    assert r.stable == (not unstable)
    # exponents: Re = eigenvalue real parts of A; doubling times signed
    re_ex = np.sort(np.linalg.eigvals(A).real)[::-1]
    assert np.allclose(r.floquet_exponents.real, re_ex, atol=1e-7)
    assert np.allclose(r.doubling_times_s, np.log(2) / r.floquet_exponents.real)
    assert r.monodromy_vs_full_period_jacobian < 1e-12
    # the trajectory is periodic and its grid consistent
    assert r.trajectory_x.shape == (401, 4) and np.allclose(r.trajectory_x[-1], r.x0, atol=1e-10)
    assert np.isclose(r.trajectory_t[-1] - r.trajectory_t[0], T)
    assert r.shooting_points.shape == (5, 4)
    json.dumps(r.to_dict())
    assert set(r.wall_s) == {"build", "data", "solve", "floquet", "total"}


def test_linear_free_parameter_mean_condition():
    """Free 'bias' so that the period mean of x1 hits a target. The mean is linear in the bias:
    two fixed-parameter solves + a secant give the answer independently; also the closed form."""
    A = make_A(False)
    ode = ODES[False]
    x1 = ca.SX.sym("x", 4)
    dd = ca.SX.sym("d", 1)
    pp = ca.SX.sym("p", 2)
    out = ca.Function("x1", [x1, dd, pp], [x1[0]])
    target = 0.25
    method = OrbitMethod(points=3, steps_per_period=300)
    means = []
    for bias in (0.0, 1.0):
        r = solve(OrbitProblem(ode, np.array([P[0], bias]), np.zeros(4), outputs={"x1": out}), method)
        assert r.success
        means.append(r.means["x1"])
    bias_secant = (target - means[0]) / (means[1] - means[0])
    bias_exact = target / exact_mean(A, [0, 1.0])[0]
    prob = OrbitProblem(ode, P, np.zeros(4), free={"bias": (-50.0, 50.0)},
                        means=[MeanCondition(out, target, "x1")], outputs={"x1_again": out})
    for m in (method, OrbitMethod(points=3, steps_per_period=300, solver="lm", tol=1e-11),
              OrbitMethod(points=3, steps_per_period=300, solver="lm", derivatives="fd", tol=1e-11)):
        r = solve(prob, m)
        assert r.success, r.message
        assert abs(r.free_values["bias"] - bias_secant) < 1e-9
        assert abs(r.free_values["bias"] - bias_exact) < 1e-7
        assert abs(r.means["x1"] - target) < 1e-10
        assert abs(r.means["x1_again"] - target) < 1e-10
        assert r.p[1] == r.free_values["bias"] and r.p[0] == P[0]
        assert np.max(np.abs(r.x0 - exact_x0(A, r.p))) < 1e-7
    # index key works as well as the name
    r2 = solve(OrbitProblem(ode, P, np.zeros(4), free={1: (-50.0, 50.0)}, means=[MeanCondition(out, target)]),
               method)
    assert abs(r2.p[1] - bias_secant) < 1e-9


def test_data_split_identical():
    A = make_A(False)
    plain, split = ODES[False], linear_ode_split(A)
    for m in (OrbitMethod(points=5, steps_per_period=200),
              OrbitMethod(points=5, steps_per_period=200, solver="lm", tol=1e-11)):
        ra = solve(OrbitProblem(plain, P, np.zeros(4)), m)
        rb = solve(OrbitProblem(split, P, np.zeros(4)), m)
        assert ra.success and rb.success
        assert np.max(np.abs(ra.x0 - rb.x0)) < 1e-12
        assert np.max(np.abs(ra.monodromy - rb.monodromy)) < 1e-13
        assert np.max(np.abs(ra.trajectory_x - rb.trajectory_x)) < 1e-12
    # with a free parameter too (symbolic data path)
    x = ca.SX.sym("x", 4)
    pp = ca.SX.sym("p", 2)
    cond_a = MeanCondition(ca.Function("g", [x, ca.SX.sym("d", 1), pp], [x[0]]), 0.1)
    cond_b = MeanCondition(ca.Function("g", [x, ca.SX.sym("d", 3), pp], [x[0]]), 0.1)
    m = OrbitMethod(points=3, steps_per_period=120)
    ra = solve(OrbitProblem(plain, P, np.zeros(4), free={"bias": (-9, 9)}, means=[cond_a]), m)
    rb = solve(OrbitProblem(split, P, np.zeros(4), free={"bias": (-9, 9)}, means=[cond_b]), m)
    assert ra.success and rb.success
    assert abs(ra.p[1] - rb.p[1]) < 1e-11
    assert np.max(np.abs(ra.multipliers - rb.multipliers)) < 1e-12


def test_floquet_standalone_matches_solve():
    make_A(True)
    prob = OrbitProblem(ODES[True], P, np.zeros(4))
    m = OrbitMethod(points=3, steps_per_period=200)
    r = solve(prob, m)
    fr = floquet(ODES[True], r.x0, r.p, m)
    assert np.max(np.abs(fr.monodromy - r.monodromy)) < 1e-12
    assert np.max(np.abs(fr.multipliers - r.multipliers)) < 1e-12
    assert not fr.stable


def test_warm_start_and_graph_reuse():
    ode = ODES[False]
    m = OrbitMethod(points=5, steps_per_period=200)
    r1 = solve(OrbitProblem(ode, P, np.zeros(4)), m)
    r2 = solve(OrbitProblem(ode, P * 1.01, np.zeros(4)), m, warm_start=r1)
    assert r2.success and r2.wall_s["build"] == 0.0  # cached graphs
    assert np.max(np.abs(r2.x0 - exact_x0(make_A(False), P * 1.01))) < 1e-8


def test_invalid_fields_raise_valueerror():
    prob = OrbitProblem(ODES[False], P, np.zeros(4))
    with pytest.raises(ValueError, match="steps_per_period"):
        solve(prob, OrbitMethod(points=4, steps_per_period=100))
    with pytest.raises(ValueError, match="solver"):
        solve(prob, OrbitMethod(solver="newton"))
    with pytest.raises(ValueError, match="derivatives"):
        solve(prob, OrbitMethod(derivatives="fd"))
    with pytest.raises(ValueError, match="points"):
        solve(prob, OrbitMethod(points=1))
    with pytest.raises(ValueError, match="free"):
        OrbitProblem(ODES[False], P, np.zeros(4), free={"nope": (0, 1)})
    with pytest.raises(ValueError, match="x_guess"):
        OrbitProblem(ODES[False], P, np.zeros(3))


def test_doubling_time_is_ln2_over_rate_not_e_folding():
    """The one doubling-time function: a mode growing as exp(a t) doubles in ln2/a (not 1/a, the
    e-folding time); from a multiplier Λ over period T, in T ln2 / ln|Λ|; halving times negative."""
    from birdocp.engine.floquet import doubling_time_s, multiplier_doubling_time_s

    a, T = 0.7, 0.25
    lam = np.exp(a * T)
    assert doubling_time_s(a) == pytest.approx(np.log(2) / a, rel=1e-15)
    assert multiplier_doubling_time_s(lam, T) == pytest.approx(np.log(2) / a, rel=1e-12)
    # x(t) = exp(a t) reaches 2 at the doubling time
    assert np.exp(a * multiplier_doubling_time_s(lam, T)) == pytest.approx(2.0, rel=1e-12)
    assert multiplier_doubling_time_s(1 / lam, T) == pytest.approx(-np.log(2) / a, rel=1e-12)
    assert doubling_time_s(0.0) == np.inf
    assert np.array_equal(doubling_time_s(np.array([np.log(2), -np.log(2)])), [1.0, -1.0])
