"""The segment Jacobians from the stage Jacobians in batch (engine/step_jacobians.py) are the
variational pass's (RK4Grid.segment_jacobians), to round-off: a second method for the same exact
derivative of the discrete map, on a system whose right-hand side Jacobian is built by forward AD and
one where reverse AD has fewer instructions (pairwise interactions)."""
import casadi as ca
import numpy as np
import pytest

from birdocp.engine.integrate import RK4Grid
from birdocp.engine.ode import ODE
from birdocp.engine.step_jacobians import batched_segment_jacobians, frozen_monodromy, stage_jacobians

OMEGA = 1.3


def duffing_with_lags(n=4, coupled=False):
    """A forced Duffing oscillator with n lags driven by it and feeding back on it; ``coupled``: the
    lags also interact pairwise (``sum_j sin(y_i - y_j)``: nodes of two states that each reach one
    equation, where reverse AD has fewer instructions than forward AD)."""
    x, t, p = ca.SX.sym("x", 2 + n), ca.SX.sym("t"), ca.SX.sym("p", 2)
    y = x[2:]
    acc = -p[0] * x[1] - x[0] - x[0] ** 3 - 0.3 * ca.sum1(y) + p[1] * ca.cos(OMEGA * t)
    ydot = [-(3.0 + i) * (y[i] - x[0]) for i in range(n)]
    if coupled:
        ydot = [v + sum(0.2 * ca.sin(y[i] - y[j]) * ca.cos(y[j]) for j in range(n) if j != i) for i, v in enumerate(ydot)]
    return ODE.from_rhs(ca.Function("f", [x, t, p], [ca.vertcat(x[1], acc, *ydot)]), 2 * np.pi / OMEGA)


@pytest.mark.parametrize("coupled", [False, True])
def test_batched_segment_jacobians_are_the_variational_passes(coupled):
    ode = duffing_with_lags(6, coupled)
    grid = RK4Grid(ode, 120, 4)
    p = np.array([0.25, 0.6])
    D = grid.blocks_numeric(0.0, p)
    x0 = np.linspace(-0.4, 0.5, ode.nx)
    X = np.asarray(grid.period_map(ca.DM(x0), D, ca.DM(p))[1])
    # segment starts slightly off the trajectory (as shooting points before convergence), each
    # segment's trajectory integrated from its own start
    pts = np.column_stack([x0] + [X[:, grid.n * (i + 1) - 1] + 1e-3 for i in range(grid.S - 1)])
    _, Xt, _ = (np.asarray(v) for v in grid.segments(ca.DM(pts), D, ca.DM(p)))
    new = batched_segment_jacobians(grid, pts, Xt, D, p)
    Jcat = np.asarray(grid.segment_jacobians(ca.DM(pts), D, ca.DM(p))[1])
    old = [Jcat[:, i * ode.nx:(i + 1) * ode.nx] for i in range(grid.S)]
    assert len(new) == grid.S
    for a, b in zip(new, old):
        assert np.max(np.abs(a - b)) <= 1e-12 * max(1.0, np.max(np.abs(b)))
    assert np.max(np.abs(np.linalg.eigvals(np.linalg.multi_dot(new[::-1]))
                         - np.linalg.eigvals(np.linalg.multi_dot(old[::-1])))) < 1e-12
    assert stage_jacobians(grid) is stage_jacobians(grid)  # built once per grid


def test_the_two_systems_cover_forward_and_reverse_ad():
    """The cheaper AD mode differs between the two systems above (so both branches are exercised)."""
    cheaper = []
    for coupled in (False, True):
        ode = duffing_with_lags(6, coupled)
        x, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", 1), ca.SX.sym("p", 2)
        f = ode.rhs(x, d, p)
        fwd = ca.Function("fwd", [x, d, p], [ca.jacobian(f, x)]).n_instructions()
        rev = ca.Function("rev", [x, d, p], [ca.jtimes(f, x, ca.DM.eye(ode.nx), True)]).n_instructions()
        cheaper.append("reverse" if rev < fwd else "forward")
    assert cheaper == ["forward", "reverse"]


def _exact_monodromy(grid, x0, D, p):
    """The variational pass's one-period Jacobian from x0 (RK4Grid.segment_jacobians, multiplied)."""
    X = np.asarray(grid.period_map(ca.DM(x0), D, ca.DM(p))[1])
    pts = np.column_stack([x0] + [X[:, grid.n * (i + 1) - 1] for i in range(grid.S - 1)])
    Jcat = np.asarray(grid.segment_jacobians(ca.DM(pts), D, ca.DM(p))[1])
    nx = len(x0)
    return np.linalg.multi_dot([Jcat[:, i * nx:(i + 1) * nx] for i in range(grid.S)][::-1]), X


def test_frozen_monodromy_is_exact_for_a_linear_system():
    # x' = A x: the right-hand side's Jacobian does not change along a step, and RK4's step matrix is
    # I + hA + (hA)^2/2 + (hA)^3/6 + (hA)^4/24 exactly
    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.3, 0.5], [0.4, 0.0, -3.0]])
    x, t, p = ca.SX.sym("x", 3), ca.SX.sym("t"), ca.SX.sym("p", 1)
    ode = ODE.from_rhs(ca.Function("f", [x, t, p], [ca.mtimes(ca.DM(A), x) + p * ca.cos(t)]), 2 * np.pi)
    grid = RK4Grid(ode, 60, 3)
    D = grid.blocks_numeric(0.0, [0.2])
    x0 = np.array([0.3, -0.1, 0.2])
    exact, X = _exact_monodromy(grid, x0, D, [0.2])
    assert np.max(np.abs(frozen_monodromy(grid, x0, X, D, [0.2]) - exact)) < 1e-13


def test_frozen_monodromy_error_is_first_order_in_the_step():
    # nonlinear: the Jacobian frozen at each step's start errs by O(h) (h times its change along the
    # step); halving h halves the error
    ode = duffing_with_lags(4, True)
    p, x0 = np.array([0.25, 0.6]), np.linspace(-0.4, 0.5, 6)
    errs = []
    for N in (80, 160):
        grid = RK4Grid(ode, N, 4)
        D = grid.blocks_numeric(0.0, p)
        exact, X = _exact_monodromy(grid, x0, D, p)
        errs.append(np.max(np.abs(frozen_monodromy(grid, x0, X, D, p) - exact)) / np.max(np.abs(exact)))
    assert 1e-5 < errs[0] < 1e-1 and 1.7 < errs[0] / errs[1] < 2.3, errs
