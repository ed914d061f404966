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
