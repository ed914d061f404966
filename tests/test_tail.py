"""The optional tail: exactly zero at opening angle 0, continuous in it, physically signed, and its
Biot-Savart induced velocity against closed forms."""

import math

import casadi as ca
import numpy as np

from birdocp.bird import tail
from birdocp.bird.config import Config, with_values
from birdocp.bird.model import get_model

STATES = [([15.0, 0.5, 0.0, 0.1], 0.0), ([16.0, -0.3, 0.2, -0.05], 0.1), ([18.0, -2.0, -0.1, -0.1], 0.17)]


def _xdot(cfg, state, t):
    return np.array(get_model(cfg).evaluate(state, t)["xdot"])


def test_tail_is_exactly_zero_at_opening_angle_zero():
    base, on = Config(), with_values(Config(), {"tail.enabled": True})
    assert get_model(on).rhs.n_instructions() > get_model(base).rhs.n_instructions()  # the terms are there
    for state, t in STATES:
        assert np.array_equal(_xdot(base, state, t), _xdot(on, state, t))


def test_tail_loads_continuous_in_the_opening_angle():
    for state, t in STATES:
        ref = _xdot(Config(), state, t)
        prev = None
        for beta in (1e-6, 1e-4, 1e-2):
            d = np.max(np.abs(_xdot(with_values(Config(), {"tail.opening_angle_deg": beta}), state, t) - ref))
            assert d < 1e-3 * beta  # the friction drag is linear in the span, the lift quadratic
            if prev is not None:
                assert d >= prev  # grows with the angle
            prev = d


def test_tail_stabilises_pitch():
    """d My'/d w < 0 (a gust from below pitches the nose down) and d My'/d q < 0 (damping) grow
    with the opening angle."""
    x = ca.MX.sym("x", 4)
    slopes = []
    for beta in (0.0, 20.0, 40.0):
        m = get_model(with_values(Config(), {"tail.enabled": True, "tail.opening_angle_deg": beta}))
        J = ca.Function("J", [x], [ca.jacobian(m.f(x, 0.05, m.p0)[2], x)])
        slopes.append(np.array(J([17.0, 0.0, 0.0, 0.0])).ravel())
    assert slopes[0][1] > slopes[1][1] > slopes[2][1]   # dq'/dw
    assert slopes[0][2] > slopes[1][2] > slopes[2][2]   # dq'/dq


def test_biot_savart_straight_segment_and_semi_infinite_filament():
    P = ca.DM([0.0, 0.3, 0.0])
    # A long segment along e1 through the origin: the infinite line's Gamma / (2 pi d)
    v = np.array(tail._segment_velocity(P, ca.DM([-1e4, 0, 0]), ca.DM([1e4, 0, 0]), 2.0)).ravel()
    assert np.allclose(v, [0, 0, 2.0 / (2 * math.pi * 0.3)], rtol=1e-7)  # dl x r = e1 x e2 = e3
    # A semi-infinite filament seen from its starting plane: half the infinite line
    v = np.array(tail._semi_infinite_velocity(P, ca.DM([0, 0, 0]), ca.DM([0, 0, 1]), 2.0)).ravel()
    assert np.allclose(v, [-2.0 / (4 * math.pi * 0.3), 0, 0], rtol=1e-12)
    # ... and far downstream, the whole infinite line
    Pd = ca.DM([0.0, 0.3, 1e5])
    v = np.array(tail._semi_infinite_velocity(Pd, ca.DM([0, 0, 0]), ca.DM([0, 0, 1]), 2.0)).ravel()
    assert np.allclose(v, [-2.0 / (2 * math.pi * 0.3), 0, 0], rtol=1e-8)


def test_wing_vortex_system_against_midpoint_quadrature():
    """The induced velocity at the tail's neutral point equals a brute-force Biot-Savart quadrature
    of the same vortex lines (bound segments, trailing legs truncated far downstream)."""
    from birdocp.bird.model import unpack_data
    m = get_model(with_values(Config(), {"tail.enabled": True}))
    nodes = np.array(unpack_data(m.data(0.03, m.p0))["nodes_m"])
    gamma = np.array(m.aero_detail([15.0, 0.5, 0.0, 0.1], 0.03, m.p0)[0]).ravel()
    P = np.array([0.0, 0.0, 0.30 + 2 / 3 * 0.25])
    exact = np.array(tail.induced_velocity(ca.DM(P), ca.DM(nodes), ca.DM(gamma))).ravel()

    def line(A, B, strength, n):
        s = (np.arange(n) + 0.5) / n
        X = A[None, :] + s[:, None] * (B - A)[None, :]
        dl = (B - A) / n
        r = P[None, :] - X
        return strength / (4 * math.pi) * np.sum(np.cross(dl, r) / np.linalg.norm(r, axis=1)[:, None] ** 3, axis=0)

    v = np.zeros(3)
    for j in range(16):
        v += line(nodes[:, j], nodes[:, j + 1], gamma[j], 2000)
    for k in range(17):
        strength = (gamma[k - 1] if k else 0.0) - (gamma[k] if k < 16 else 0.0)
        A = nodes[:, k]
        for a, b, n in ((0.0, 2.0, 40000), (2.0, 2000.0, 40000)):
            v += line(A + [0, 0, a], A + [0, 0, b], strength, n)
    assert np.allclose(exact, v, atol=2e-4 * np.max(np.abs(exact)))


def test_tail_incidence_zero_is_today_bit_for_bit():
    """``tail.incidence_deg = 0`` is the model without the incidence term, to the last bit: the
    right-hand side with the tail at 20 deg equals, bit for bit, the graph in which the incidence is
    the constant 0 (CasADi then drops the term: today's expression); and the trim with the tail's
    terms built (incidence 0, opening angle 0) is the default trim to the last bit."""
    from birdocp.bird.config import PARAM_NAMES
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), {"tail.opening_angle_deg": 20.0, "tail.incidence_deg": 0.0})
    m = get_model(cfg)
    rhs = m.rhs   # the model's SX right-hand side (x, d, p) -> xdot
    x = ca.SX.sym("x", 4)
    d = ca.SX.sym("d", rhs.size1_in(1))
    p = ca.SX.sym("p", len(PARAM_NAMES))
    full = rhs(x, d, p)
    k = PARAM_NAMES.index("tail.incidence_deg")
    without = ca.substitute(full, p[k], ca.SX(0.0))
    f_full = ca.Function("f", [x, d, p], [full])
    f_without = ca.Function("g", [x, d, p], [without])
    assert f_without.n_instructions() < f_full.n_instructions()   # the term is gone
    for state, t in STATES:
        D = m.model.ode.data(t, m.p0)
        assert np.array_equal(np.array(f_full(state, D, m.p0)), np.array(f_without(state, D, m.p0)))
    a = trim(Config(), points=3, steps_per_period=48)
    b = trim(with_values(Config(), {"tail.enabled": True, "tail.incidence_deg": 0.0}), points=3, steps_per_period=48)
    assert a.success and b.success
    assert np.array_equal(a.x0, b.x0) and np.array_equal(a.multipliers, b.multipliers)


def test_tail_incidence_is_a_shift_of_the_flow_angle():
    """Without induced velocity and pitch rate, the loads at incidence i and flow angle a equal those
    at incidence 0 and flow angle a + i (same speed); a positive incidence lifts the tail and pitches
    the nose down."""
    nodes = ca.DM(np.vstack([np.linspace(-0.8, 0.8, 17), np.full(17, 0.05), np.zeros(17)]))  # no circulation:
    gamma = ca.DM.zeros(16)                                                                    # no induced velocity
    args = (1.2, 30.0, 0.3, 0.25, 1.5e-5, 15.0)
    V, a, i = 16.0, math.radians(3.0), 5.0
    shifted = tail.tail_loads(ca.DM([V * math.cos(a), V * math.sin(a), 0, 0]), nodes, gamma, *args, incidence_deg=i)
    a2 = a + math.radians(i)
    direct = tail.tail_loads(ca.DM([V * math.cos(a2), V * math.sin(a2), 0, 0]), nodes, gamma, *args)
    assert np.allclose([float(v) for v in shifted], [float(v) for v in direct], rtol=1e-12, atol=0)
    level = [float(v) for v in tail.tail_loads(ca.DM([V, 0, 0, 0]), nodes, gamma, *args, incidence_deg=0.0)]
    up = [float(v) for v in tail.tail_loads(ca.DM([V, 0, 0, 0]), nodes, gamma, *args, incidence_deg=i)]
    assert level[0] == 0 and up[0] > 0 and up[2] < 0   # lift up behind G: nose-down moment
