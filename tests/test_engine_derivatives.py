"""How the engine gets its derivatives cheaply, checked against a second method: the discrete
variational step against CasADi's derivative of the chained steps (through the implicit stages'
rootfinder), the one-period Jacobian of the Floquet check from the solver's first segment against
the one computed in one go (bit for bit), and the steps of a refined orbit solve built once."""
import casadi as ca
import numpy as np
import pytest

from birdocp.engine import ODE, OrbitMethod, OrbitProblem, solve
from birdocp.engine import orbit_system
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.steppers import make_step, make_variational_step


def _brusselator_rhs():
    """A stiff-ish Brusselator with a forcing term (depends on t) and two parameters (x, t, q)."""
    x, t, q = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("q", 2)
    f = ca.vertcat(q[0] - (q[1] + 1) * x[0] + x[0] ** 2 * x[1] + 0.1 * ca.sin(t), q[1] * x[0] - x[0] ** 2 * x[1])
    return ca.Function("f", [x, t, q], [f])


@pytest.mark.parametrize("method", ["rk4", "radau", "gauss"])
def test_variational_step_is_the_exact_jacobian_of_the_steps(method):
    f = _brusselator_rhs()
    step, var = make_step(f, method), make_variational_step(f, method)
    n, h, t0 = 6, 0.15, 0.3
    x0, q0 = np.array([1.2, 2.9]), np.array([1.0, 3.0])
    # second method: CasADi's forward AD of the chained MX steps (rootfinder: implicit function theorem)
    xm, qm = ca.MX.sym("x", 2), ca.MX.sym("q", 2)
    xe = xm
    for k in range(n):
        xe = step(xe, t0 + k * h, qm, h)
    ref = ca.Function("ref", [xm, qm], [xe, ca.jacobian(xe, xm), ca.jacobian(xe, qm)])(x0, q0)
    a = np.concatenate([x0, np.eye(2).ravel(order="F"), np.zeros(4)])
    for k in range(n):
        a = np.asarray(var(a, t0 + k * h, q0, h)).ravel()
    P = a[2:].reshape(2, 4, order="F")
    assert np.array_equal(a[:2], np.asarray(ref[0]).ravel())  # the same steps
    assert np.max(np.abs(P[:, :2] - np.asarray(ref[1]))) < 1e-12 * np.max(np.abs(P[:, :2]))
    assert np.max(np.abs(P[:, 2:] - np.asarray(ref[2]))) < 1e-12 * np.max(np.abs(P[:, 2:]))


def test_period_jacobian_from_the_first_segment_is_the_one_in_one_go():
    # a forced Duffing oscillator with one period-mean output (the grid then has a state-only twin)
    x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 2)
    rhs = ca.Function("duffing", [x, t, p], [ca.vertcat(x[1], -p[0] * x[1] - x[0] - p[1] * x[0] ** 3 + ca.cos(t))])
    ode = ODE.from_rhs(rhs, 2 * np.pi)
    out = ca.Function("energy", [x, t, p], [x[0] ** 2 + x[1] ** 2])
    grid = RK4Grid(ode, 64, 4, (out,))
    pd = ca.DM([0.3, 0.5])
    D = grid.blocks_numeric(0.0, [0.3, 0.5])
    X = np.array([[0.4, 1.1], [0.9, -0.3], [-0.6, -0.8], [-0.2, 0.7]]).T  # any points: the check's own inputs
    Xe, Jcat = grid.segment_jacobians(ca.DM(X), D, pd)
    xT, J = grid.period_jacobian(ca.DM(X[:, 0]), D, pd)
    for _ in range(6):  # the first four calls on the grid itself, then on its state-only twin
        xT2, J2 = grid.period_jacobian_from_first(Xe[:, 0], Jcat[:, :2], D, pd)
        assert np.array_equal(np.asarray(J2), np.asarray(J)) and np.array_equal(np.asarray(xT2), np.asarray(xT))
    assert sorted(grid.period_jacobian_from_first._functions) == [False, True]  # both were used


def test_a_refined_solve_builds_its_steps_once(monkeypatch):
    built = []
    for name in ("make_step", "make_variational_step"):
        fn = getattr(orbit_system, name)
        monkeypatch.setattr(orbit_system, name, lambda *a, _fn=fn, _n=name, **k: built.append(_n) or _fn(*a, **k))
    hopf = ODE.from_function(lambda x, t, p: ca.vertcat(x[0] - x[1] - x[0] * (x[0] ** 2 + x[1] ** 2),
                                                        x[0] + x[1] - x[1] * (x[0] ** 2 + x[1] ** 2)), 2)
    r = solve(OrbitProblem(hopf, [], [1.0, 0.0], period_guess=6.0), OrbitMethod(accuracy=1e-9))
    assert r.success and r.accurate and abs(r.period - 2 * np.pi) < 1e-8, r.message
    assert r.method["steps_per_period"] > 32  # several grids and their error-estimate grids
    assert sorted(built) == ["make_step", "make_variational_step"]
