"""Wingbeat-to-wingbeat control: exact B against finite differences of the nonlinear map, the LQR
closed loop, the periodic Riccati solution against the lifted-system LQR (scipy), and the nonlinear
simulation (wind, perturbation growth and decay rates)."""

import numpy as np
import casadi as ca
import pytest

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.bird.model import get_model
from birdocp.engine.integrate import RK4Grid
from birdocp.studies.control import (DEFAULT_CONTROLS, closed_loop_monodromy, design_controller,
                                     periodic_lqr, wingbeat_map)
from birdocp.studies.simulate import nonlinear_beat_map, simulate
from birdocp.studies.trim import trim

STEPS = 48  # coarse grid: every derivative is exact for the grid the trim uses


@pytest.fixture(scope="module")
def cycle():
    r = trim(Config(), tol=1e-12, points=3, steps_per_period=STEPS)
    assert r.success
    return r


def _beat_map(cycle, x0, p_per_interval):
    """The nonlinear one-beat map with the parameters of each interval (data recomputed)."""
    return nonlinear_beat_map(cycle.cfg, x0, p_per_interval, STEPS)


def test_B_and_A_match_central_differences_of_the_nonlinear_map(cycle):
    N = 2
    wm = wingbeat_map(cycle, DEFAULT_CONTROLS, N)
    p = np.asarray(cycle.cycle.p, float)
    x0 = np.asarray(cycle.x0, float)
    assert np.allclose(_beat_map(cycle, x0, [p] * N), x0, atol=1e-9)  # the cycle is a fixed point
    h = 1e-3  # deg
    for i in range(N):
        for j, key in enumerate(DEFAULT_CONTROLS):
            out = []
            for s in (1, -1):
                ps = [p.copy() for _ in range(N)]
                ps[i][PARAM_NAMES.index(key)] += s * h
                out.append(_beat_map(cycle, x0, ps))
            fd = (out[0] - out[1]) / (2 * h)
            exact = wm.B_lifted[:, i * len(DEFAULT_CONTROLS) + j]
            assert np.max(np.abs(exact - fd)) < 1e-6 * np.max(np.abs(fd)) + 1e-10, (i, key)
    hx = 1e-6
    fdM = np.column_stack([(_beat_map(cycle, x0 + hx * e, [p] * N) - _beat_map(cycle, x0 - hx * e, [p] * N)) / (2 * hx)
                           for e in np.eye(4)])
    assert np.max(np.abs(wm.M - fdM)) < 1e-6 * np.max(np.abs(fdM))
    assert np.allclose(np.sort(np.abs(wm.multipliers)), np.sort(np.abs(cycle.multipliers)), atol=1e-9)


def test_closed_loop_multipliers_are_the_eigenvalues_of_M_minus_BK(cycle):
    ctl = design_controller(cycle, DEFAULT_CONTROLS, 1)
    wm = ctl.map
    lam = np.linalg.eigvals(wm.M - wm.B[0] @ ctl.K[0])
    cl = ctl.closed_loop_multipliers
    assert np.allclose(sorted(lam, key=lambda z: (-abs(z), -z.imag)), cl, atol=1e-12)
    assert ctl.spectral_radius < 1.0 < np.max(np.abs(wm.multipliers))
    # the gain is the LQR of (M, B): the Riccati equation holds
    P, K, Q, R, M, B = ctl.P[0], ctl.K[0], ctl.Q, ctl.R, wm.M, wm.B[0]
    res = M.T @ P @ M - P - M.T @ P @ B @ np.linalg.solve(R + B.T @ P @ B, B.T @ P @ M) + Q
    assert np.max(np.abs(res)) < 1e-8 * np.max(np.abs(P))
    assert np.allclose(K, np.linalg.solve(R + B.T @ P @ B, B.T @ P @ M), rtol=1e-10, atol=1e-12)
    d = ctl.to_dict()
    assert d["controllable"] == {k: True for k in DEFAULT_CONTROLS}
    # the controller says whether the model holds on the cycle it is designed around, and what re-solves it
    assert d["cycle_validity"] == cycle.validity.to_dict() and d["cycle_valid"] is cycle.validity.valid
    assert d["cycle_amplitude_deg"] == cycle.amplitude_deg and np.array_equal(d["cycle_x0"], cycle.x0)
    for row in d["per_control"]:  # the minimal-energy gain reflects the expanding multiplier to 1/lambda
        stable_rest = np.abs(wm.multipliers[1])
        assert row["min_gain_spectral_radius"] == pytest.approx(max(1 / np.abs(wm.multipliers[0]), stable_rest), rel=1e-7)


def test_periodic_riccati_equals_recursion_and_lifted_lqr():
    from scipy.linalg import solve_discrete_are

    rng = np.random.default_rng(3)
    N, n, m = 3, 3, 1
    A = rng.normal(size=(N, n, n))
    A[0] *= 1.5
    B = rng.normal(size=(N, n, m))
    Q = np.diag([1.0, 2.0, 0.5])
    R = np.array([[0.7]])
    P, K = periodic_lqr(A, B, Q, R)
    Phi = closed_loop_monodromy(A, np.zeros_like(B), K)
    assert np.max(np.abs(np.linalg.eigvals(Phi))) > 1  # an unstable periodic system
    assert np.max(np.abs(np.linalg.eigvals(closed_loop_monodromy(A, B, K)))) < 1
    # (1) the backward periodic Riccati recursion iterated to convergence
    Pi = [np.zeros((n, n)) for _ in range(N)]
    for _ in range(3000):
        for i in reversed(range(N)):
            Pn = Pi[(i + 1) % N]
            G = np.linalg.solve(R + B[i].T @ Pn @ B[i], B[i].T @ Pn @ A[i])
            Pi[i] = Q + A[i].T @ Pn @ A[i] - A[i].T @ Pn @ B[i] @ G
    for i in range(N):
        assert np.allclose(P[i], Pi[i], rtol=1e-8, atol=1e-10)
    # (2) the lifted (one-period) LQR: x_{k+1} = Phi x_k + Gamma U_k with the intermediate states' cost
    Phis, Gams = [np.eye(n)], [np.zeros((n, N * m))]
    for i in range(N):
        G = A[i] @ Gams[-1]
        G[:, i * m:(i + 1) * m] += B[i]
        Phis.append(A[i] @ Phis[-1])
        Gams.append(G)
    Ql = sum(Ph.T @ Q @ Ph for Ph in Phis[:N])
    S = sum(Ph.T @ Q @ G for Ph, G in zip(Phis[:N], Gams[:N]))
    Rl = np.kron(np.eye(N), R) + sum(G.T @ Q @ G for G in Gams[:N])
    Pl = solve_discrete_are(Phis[N], Gams[N], Ql, Rl, s=S)
    Kl = np.linalg.solve(Rl + Gams[N].T @ Pl @ Gams[N], Gams[N].T @ Pl @ Phis[N] + S.T)
    assert np.allclose(P[0], Pl, rtol=1e-8, atol=1e-10)
    assert np.allclose(K[0], Kl[:m], rtol=1e-7, atol=1e-10)


def test_zero_wind_is_the_cycle_exactly_and_a_constant_wind_shifts_the_velocity(cycle):
    m = get_model(cycle.cfg)
    p = np.asarray(cycle.cycle.p, float)
    rng = np.random.default_rng(0)
    for t in (0.013, 0.11, 0.2):
        d = m.data(t, p)
        x = np.array([15.0, 0.7, 0.3, 0.1]) + rng.normal(size=4) * 0.1
        assert np.array_equal(np.array(m.rhs_wind(x, d, p, [0, 0], [0, 0])), np.array(m.rhs(x, d, p)))
        assert np.array_equal(np.array(m.loads_wind(x, d, p, [0, 0], [0, 0])), np.array(m.loads_d(x, d, p)))
    # the simulation with a zero constant wind is the engine's open-loop RK4 cycle
    grid = RK4Grid(m.ode, STEPS, 1)
    X = np.asarray(grid.period_map(ca.DM(cycle.x0), grid.blocks_numeric(0.0, p), ca.DM(p))[1]).T
    s = simulate(cycle.cfg, cycle.x0, 1, steps_per_period=STEPS, wind_mps=(0.0, 0.0))
    assert s.success and np.max(np.abs(s.states[1:] - X)) <= 1e-13 * np.max(np.abs(X))
    # the simulation's validity measures on the cycle are those of birdocp.bird.validity
    v = cycle.validity.to_dict()
    d = s.to_dict()
    assert d["max_stalled_fraction_per_beat"] == pytest.approx(v["stalled_fraction"], rel=1e-9)
    assert d["max_airflow_body_angle_deg"] == pytest.approx(v["max_airflow_body_angle_deg"], rel=1e-9)
    assert d["min_air_forward_speed_mps"] == pytest.approx(v["min_forward_speed_mps"], rel=1e-9)
    # Galilean invariance: a constant wind W and the inertial velocity shifted by W (body frame)
    # give the same air-relative motion, so u - cos(theta) W_X == u_cycle along the whole beat
    Wh, Wv = 2.0, -1.0  # horizontal (along the flight), vertical (up) [m/s]
    WX, WZ = Wh, -Wv
    th0 = cycle.x0[3]
    x0 = np.asarray(cycle.x0, float) + [np.cos(th0) * WX - np.sin(th0) * WZ, np.sin(th0) * WX + np.cos(th0) * WZ, 0, 0]
    s = simulate(cycle.cfg, x0, 1, steps_per_period=STEPS, wind_mps=(Wh, Wv))
    th = s.states[1:, 3]
    air = s.states[1:].copy()
    air[:, 0] -= np.cos(th) * WX - np.sin(th) * WZ
    air[:, 1] -= np.sin(th) * WX + np.cos(th) * WZ
    assert np.max(np.abs(air - X)) < 1e-6


def test_closed_loop_converges_at_its_spectral_radius_open_loop_diverges(cycle):
    ctl = design_controller(cycle, DEFAULT_CONTROLS, 1)
    lam1 = np.max(np.abs(ctl.map.multipliers))
    dx = np.array([1e-4, 0, 0, 0])
    beats = 14
    ol = simulate(cycle.cfg, cycle.x0, beats, steps_per_period=STEPS, perturbation=dx)
    cl = simulate(cycle.cfg, cycle.x0, beats, steps_per_period=STEPS, perturbation=dx, controller=ctl)
    assert ol.success and cl.success and not cl.saturated
    rate = lambda d: (d[-1] / d[-5]) ** 0.25  # noqa: E731
    assert rate(ol.deviation_per_beat) == pytest.approx(lam1, rel=0.01)
    assert rate(cl.deviation_per_beat) == pytest.approx(ctl.spectral_radius, rel=0.02)
    assert cl.final_deviation < 1e-5 < ol.final_deviation


@pytest.mark.parametrize("x0, perturbation, match", [
    ([18.0, 0.0, 0.0], None, r"simulate x0_cycle: size 3"),  # was a CasADi call error
    ([np.nan, 0.0, 0.0, 0.0], None, r"simulate x0_cycle must be finite"),  # was a 'non_finite' run
    ([18.0, 0.0, 0.0, 0.0], [1e-3], r"simulate perturbation: size 1"),  # was broadcast to every state
])
def test_simulate_refuses_a_bad_start_state_before_integrating(x0, perturbation, match):
    with pytest.raises(ValueError, match=match):
        simulate(Config(), x0, 1, steps_per_period=STEPS, perturbation=perturbation)
