"""Added mass in a wind (``aero.unsteady = "wagner"``): the non-circulatory load reacts to the
air-relative acceleration, nu' minus the rate of the wind's body-frame components.

Independent pieces: the added-mass matrix M_A is recomputed here in numpy from the geometry blocks of
the data (docs/model_unsteady.md, "Non-circulatory loads": a_j from the unit normal, the element centre
and the chord; m_a = rho pi c^2 ds / 4, m_theta = rho pi (c/2)^4 ds / 8), the body-frame wind rate from
the rotation matrix R(theta) and its derivative; the held-body loads of the calm model (``held_d``) are
the reference. A held-body load in a wind is the model's free-body load plus M_A nu' (nu' from the same
right-hand side): that removes the body's own acceleration and leaves the air's.
"""

import math

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.bird.layout import N_EL, unpack_data
from birdocp.bird.model import air_state, get_model

STATE = np.array([17.5, 0.8, 0.3, 0.12])  # u, w [m/s], q [rad/s], theta [rad]
TIMES = (0.02, 0.11, 0.19)


@pytest.fixture(scope="module")
def bird():
    m = get_model(with_values(Config(), {"aero.unsteady": "wagner"}))
    return m.model, np.asarray(m.p0, float)


def _added_mass_matrix(d, p) -> np.ndarray:
    """M_A (3 x 3 on u, w, q; kg, kg m, kg m^2) from the geometry blocks, in numpy."""
    b = {k: np.array(v) for k, v in unpack_data(ca.DM(d), N_EL).items()}
    n_hat = b["up"] / np.linalg.norm(b["up"], axis=0)
    tau1 = b["tau"][0] / np.linalg.norm(b["tau"], axis=0)
    c, ds, r = b["chord_m"].ravel(), b["ds_m"].ravel(), b["r_m"]
    rho = p[PARAM_NAMES.index("aero.air_density_kgm3")]
    chi = p[PARAM_NAMES.index("aero.added_mass_weight")]
    a = np.vstack([n_hat[2], n_hat[1], r[2] * n_hat[1] - r[1] * n_hat[2] + 0.25 * c * tau1])
    MA = chi * (a * (rho * math.pi * c ** 2 * ds / 4)) @ a.T
    MA[2, 2] += chi * np.sum(rho * math.pi * (c / 2) ** 4 * ds / 8 * tau1 ** 2)
    return MA


def _rotation(theta):
    """R(theta) (inertial X, Z -> body x', z') and dR/dtheta."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]]), np.array([[-s, -c], [c, -s]])


def _held_in_wind(m, x, d, p, wind, rate, MA):
    """Loads with the body's acceleration held at zero, in a wind: free-body loads + M_A nu'."""
    nudot = np.array(m.rhs_wind(x, d, p, wind, rate)).ravel()[:3]
    return np.array(m.loads_wind(x, d, p, wind, rate)).ravel() + MA @ nudot


def _air(x, wind):
    return np.concatenate([np.array(air_state(x[:4], wind)).ravel(), x[4:]])


@pytest.mark.parametrize("q", [0.0, STATE[2]])
def test_galilean_steady_wind(bird, q):
    """(a) A steady uniform wind W is the body moving with -W in calm air: the loads equal the calm
    model's at the air-relative state, and the air-relative state moves as the calm model's,
    d/dt (nu - W_b) = nu'_calm (W_b = R(theta) W turns at q dR/dtheta W), to round-off; on a
    non-rotating body (q = 0) and on a pitching one."""
    m, p = bird
    _, dR = _rotation(STATE[3])
    for t in TIMES:
        d = m.data(t, p)
        x = m.complete_state(np.array([STATE[0], STATE[1], q, STATE[3]]), p, t)
        for wind in ([4.0, -1.5], [-3.0, 2.0]):
            xa = _air(x, wind)
            L, L0 = (np.array(v).ravel() for v in (m.loads_wind(x, d, p, wind, [0, 0]), m.loads_d(xa, d, p)))
            f, f0 = (np.array(v).ravel() for v in (m.rhs_wind(x, d, p, wind, [0, 0]), m.rhs(xa, d, p)))
            f[:2] -= q * dR @ np.array(wind)
            assert np.max(np.abs(L - L0)) <= 1e-12 * np.max(np.abs(L0))
            assert np.max(np.abs(f - f0)) <= 1e-12 * np.max(np.abs(f0))


def test_gust_ramp_adds_minus_added_mass_times_rate(bird):
    """(b) A vertical gust ramp (W_up rising at R m/s^2, theta = q = 0): the held-body load changes by
    M_A (0, -R, 0), i.e. the vertical non-circulatory force by -M_A,ww R (down positive), to 1e-10; the
    free body then accelerates by (M_b + M_A)^-1 M_A (0, -R, 0)."""
    m, p = bird
    mass, inertia = (p[PARAM_NAMES.index(k)] for k in ("body.mass_kg", "body.pitch_inertia_kgm2"))
    for t in TIMES:
        d = m.data(t, p)
        x = m.complete_state(np.array([STATE[0], STATE[1], 0.0, 0.0]), p, t)
        MA = _added_mass_matrix(d, p)
        assert 0.010 < MA[1, 1] < 0.03  # kg: docs/model_unsteady.md's 0.015-0.025 on the cycle
        wind = [1.0, -2.0]  # X forward, Z down: 2 m/s up
        for R in (30.0, -12.0):
            rate = [0.0, -R]
            held = _held_in_wind(m, x, d, p, wind, rate, MA)
            calm = np.array(m.held_d(_air(x, wind), d, p)[1]).ravel()
            expected = MA @ np.array([0.0, -R, 0.0])
            assert abs(held[1] - calm[1] - (-MA[1, 1] * R)) <= 1e-10 * MA[1, 1] * abs(R)
            assert np.max(np.abs(held - calm - expected)) <= 1e-10 * np.max(np.abs(expected))
            dnu = (np.array(m.rhs_wind(x, d, p, wind, rate)).ravel()
                   - np.array(m.rhs_wind(x, d, p, wind, [0, 0])).ravel())[:3]
            want = np.linalg.solve(np.diag([mass, mass, inertia]) + MA, expected)
            assert np.max(np.abs(dnu - want)) <= 1e-10 * np.max(np.abs(want))


def test_steady_wind_turns_with_the_pitch_rate(bird):
    """(c) A steady inertial wind seen from a body pitching at q: its body-frame components change at
    q dR/dtheta W (= -omega x W_b); the held-body load differs from the calm model's by M_A times that.
    An inertial wind rate R^T (-q dR/dtheta W) cancels it (the air then keeps its body-frame velocity)."""
    m, p = bird
    for t in TIMES:
        d = m.data(t, p)
        x = m.complete_state(STATE, p, t)
        MA = _added_mass_matrix(d, p)
        R, dR = _rotation(STATE[3])
        for wind in ([5.0, 0.0], [-2.0, 3.0]):
            W_dot_b = STATE[2] * dR @ np.array(wind)
            calm = np.array(m.held_d(_air(x, wind), d, p)[1]).ravel()
            expected = MA @ np.append(W_dot_b, 0.0)
            held = _held_in_wind(m, x, d, p, wind, [0, 0], MA)
            assert np.max(np.abs(held - calm - expected)) <= 1e-10 * np.max(np.abs(expected))
            still = _held_in_wind(m, x, d, p, wind, R.T @ -W_dot_b, MA)
            assert np.max(np.abs(still - calm)) <= 1e-12 * np.max(np.abs(calm))


def test_without_added_mass_the_wind_rate_is_unused():
    """Without ``wagner`` the wind rate builds no term: rhs_wind does not depend on it."""
    m = get_model(Config()).model
    jac = m.rhs_wind.sparsity_jac(4, 0)
    assert jac.nnz() == 0


def test_simulation_gust_rate_is_the_gust_slope_times_the_speed():
    """The simulation's wind rate along the path: the 1 - cos gust's analytic slope
    A pi / L sin(2 pi s) times X' (frozen gusts: no own time rate), zero outside the gust and for a
    constant wind."""
    from birdocp.studies.simulate import planar_wind

    X, X_dot, g = ca.SX.sym("X"), ca.SX.sym("X_dot"), ca.SX.sym("g", 8)
    f = ca.Function("w", [X, X_dot, g], list(planar_wind(X, X_dot, g)))
    # constant (1.0 forward, 0.5 up), gusts 1.5 m/s forward over 3..5 m and 2 m/s up over 5..6.1 m
    G = [1.0, 0.5, 1.5, 2.0, 3.0, 2.0, 5.0, 1.1]
    for x_m in (2.9, 3.3, 4.6, 5.2, 5.9, 6.2):
        wind, rate = (np.array(v).ravel() for v in f(x_m, 18.0, G))
        s_h, s_v = (x_m - 3.0) / 2.0, (x_m - 5.0) / 1.1
        inside_h, inside_v = 0 < s_h < 1, 0 < s_v < 1
        want_w = [1.0 + inside_h * 0.75 * (1 - math.cos(2 * math.pi * s_h)),
                  -(0.5 + inside_v * 1.0 * (1 - math.cos(2 * math.pi * s_v)))]
        want_r = [inside_h * 1.5 * math.pi / 2.0 * math.sin(2 * math.pi * s_h) * 18.0,
                  -inside_v * 2.0 * math.pi / 1.1 * math.sin(2 * math.pi * s_v) * 18.0]
        assert np.allclose(wind, want_w, rtol=1e-14, atol=1e-14)
        assert np.allclose(rate, want_r, rtol=1e-13, atol=1e-12)
