"""Property test: for random linear systems x' = A x + c sin(w t) + b0 the engine's monodromy equals
expm(A T) and its orbit the frequency-domain closed form (independent of RK4)."""
import casadi as ca
import numpy as np
import scipy.linalg as sl
from hypothesis import given, settings
from hypothesis import strategies as st

from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, solve

T = 1.0
W = 2 * np.pi / T


@settings(max_examples=12, deadline=None)
@given(
    eig=st.lists(st.floats(-2.0, 1.0).filter(lambda v: abs(v) > 0.05), min_size=3, max_size=3),
    seed=st.integers(0, 2**16),
    M=st.sampled_from([2, 3, 5]),
    solver=st.sampled_from(["ipopt", "lm"]),
)
def test_random_linear_system(eig, seed, M, solver):
    rng = np.random.default_rng(seed)
    Q = np.eye(3) + 0.3 * rng.standard_normal((3, 3))
    A = Q @ np.diag(eig) @ np.linalg.inv(Q)
    c = rng.standard_normal(3)
    b0 = rng.standard_normal(3)
    x = ca.SX.sym("x", 3)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 0)
    f = ca.Function("f", [x, t, p], [ca.mtimes(ca.DM(A), x) + ca.DM(c) * ca.sin(W * t) + ca.DM(b0)])
    ode = ODE.from_rhs(f, T)
    r = solve(OrbitProblem(ode, np.zeros(0), np.zeros(3)),
              OrbitMethod(points=M, steps_per_period=240, solver=solver, tol=1e-11))
    assert r.success, r.message
    assert np.max(np.abs(r.monodromy - sl.expm(A * T))) < 1e-7 * max(1.0, np.max(np.abs(sl.expm(A * T))))
    x0 = -np.linalg.solve(A, b0) + (np.linalg.solve(1j * W * np.eye(3) - A, c)).imag
    assert np.max(np.abs(r.x0 - x0)) < 1e-7 * max(1.0, np.max(np.abs(x0)))
    assert r.stable == bool(max(eig) < 0)
