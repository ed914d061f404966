"""Unsteady and stall-aware sections: the verification recipes of docs/model_unsteady.md.

Reference values: Theodorsen's C(k) (scipy's Hankel functions, or the table of docs/model_unsteady.md
when scipy is absent), Jones's closed form, Theodorsen's and Garrick's closed forms, the static polar's
closed form; the bird's quasi-steady limits against the default model (an independent code path).
"""

import math

import casadi as ca
import numpy as np
import pytest

from birdocp.bird import stall_section, unsteady
from birdocp.bird.config import Config, ConfigError, param_vector, with_values
from birdocp.bird.model import BirdModel, Structure, graph_key
from birdocp.bird.unsteady_harness import PrescribedWing, first_harmonic, harmonic

RHO, U, C = 1.225, 18.0, 0.2
B = C / 2
# exact Theodorsen C(k) at the recipe's reduced frequencies (H1(2) / (H1(2) + i H0(2)))
THEODORSEN = {0.05: 0.9090 - 0.1306j, 0.14: 0.7834 - 0.1849j, 0.25: 0.6926 - 0.1852j, 0.5: 0.5979 - 0.1507j}


def theodorsen(k):
    try:
        from scipy.special import hankel2
    except ImportError:  # pragma: no cover - the table (4 digits)
        return THEODORSEN[k]
    h1, h0 = hankel2(1, k), hankel2(0, k)
    return h1 / (h1 + 1j * h0)


@pytest.fixture(scope="module")
def strip():
    """A 2-D strip (no trailing wake), wagner, linear section."""
    return PrescribedWing("wagner", "linear", chord_m=C, speed_mps=U, aspect_ratio=None, n=2)


def _harmonic_case(wing, k, mode, amp=math.radians(0.1)):
    om = 2 * k * U / C
    h0 = amp * U / om if mode == "plunge" else 0.0
    th0 = amp if mode == "pitch" else 0.0
    kin, om, T = harmonic(k, U, C, plunge_m=h0, pitch_rad=th0)
    r = wing.periodic(kin, T, steps=400, newton=2)
    H, A = -1j * h0, -1j * th0                      # complex amplitudes of h (up) and theta (nose-up)
    hd, hdd, Ad, Add = 1j * om * H, -om ** 2 * H, 1j * om * A, -om ** 2 * A
    Q = U * A - hd + B * Ad                         # normalwash at the 3/4-chord point
    return r, om, h0, Q, (hd, hdd, Ad, Add)


@pytest.mark.parametrize("k", [0.05, 0.14, 0.25, 0.5])
@pytest.mark.parametrize("mode", ["plunge", "pitch"])
def test_2d_limit_reproduces_jones_and_theodorsen(strip, k, mode):
    """Recipe (a): first harmonic of the circulatory lift over pi rho c U Q equals C_J(k) to 2e-4 and
    Theodorsen's C(k) to 0.015; total lift and quarter-chord moment (added mass included) equal
    Theodorsen's closed form with C_J to 1e-3."""
    r, om, h0, Q, (hd, hdd, Ad, Add) = _harmonic_case(strip, k, mode)
    Cm = first_harmonic(r["t_s"], r["lift_circulatory_Npm"], om) / (math.pi * RHO * C * U * Q)
    CJ = unsteady.jones_transfer(k)
    assert abs(Cm - CJ) <= 2e-4
    assert abs(Cm - theodorsen(k)) <= 0.015
    L = math.pi * RHO * B ** 2 * (-hdd + U * Ad + B / 2 * Add) + math.pi * RHO * C * U * CJ * Q
    M = math.pi * RHO * B ** 2 * (B / 2 * hdd - U * B * Ad - 3 / 8 * B ** 2 * Add)
    Lm = first_harmonic(r["t_s"], r["lift_Npm"], om)
    Mm = first_harmonic(r["t_s"], r["moment_qc_Nmpm"], om)
    assert abs(Lm - L) <= 1e-3 * abs(L)
    assert abs(Mm - M) <= 1e-3 * abs(L) * C


def test_jones_table():
    """C_J(k) = 0.5 + 0.0075075/(0.0455 + i k) + 0.1005/(0.3 + i k) (recipe table) and within 0.0146 of C(k)."""
    for k in (0.05, 0.1, 0.14, 0.2, 0.3, 0.4, 0.5):
        cj = unsteady.jones_transfer(k)
        assert abs(cj - (0.5 + 0.0075075 / (0.0455 + 1j * k) + 0.1005 / (0.3 + 1j * k))) < 1e-12
        assert abs(cj - theodorsen(k)) < 0.0146


def test_indicial_step_follows_jones(strip):
    """Recipe (b): states at rest, then a constant plunge velocity (1 deg inflow): Gamma(s)/Gamma(inf) equals
    Jones's phi(s) to 1e-8 (RK4, ds = 0.05 semichords)."""
    hd = -U * math.tan(math.radians(1.0))
    Vp = math.hypot(U, hd)
    dt = 0.05 * C / (2 * Vp)
    r = strip.history(lambda t: (hd * t, 0 * t), 400 * dt, 400)
    g_inf = 0.5 * C * 2 * math.pi * Vp * math.atan2(-hd, U)
    for s in (1, 2, 5, 10, 20):
        i = int(round(s / 0.05))
        assert abs(r["gamma_m2ps"][i] / g_inf - unsteady.wagner_indicial_jones(s)) < 1e-8


def test_quasi_steady_homotopy_in_2d():
    """Recipe (c), 2-D: eps = 0 gives Gamma = c C_la q~ / 2 (no lag); kappa scales the reduced frequency:
    |C_m - 1| equals |C_J(kappa k) - 1| at k = 0.14."""
    w0 = PrescribedWing("wagner", "linear", aspect_ratio=None, n=2, eps=0.0)
    r, om, h0, Q, _ = _harmonic_case(w0, 0.14, "pitch")
    Cm = first_harmonic(r["t_s"], r["lift_circulatory_Npm"], om) / (math.pi * RHO * C * U * Q)
    assert abs(Cm - 1) < 2e-6
    for kappa in (1.0, 0.1):
        w = PrescribedWing("wagner", "linear", aspect_ratio=None, n=2, kappa=kappa)
        r, om, h0, Q, _ = _harmonic_case(w, 0.14, "pitch")
        Cm = first_harmonic(r["t_s"], r["lift_circulatory_Npm"], om) / (math.pi * RHO * C * U * Q)
        assert abs(abs(Cm - 1) - abs(unsteady.jones_transfer(kappa * 0.14) - 1)) < 2e-4
    assert abs(abs(unsteady.jones_transfer(0.14) - 1) - 0.274) < 1e-3


STATIC_TABLE = {  # alpha deg: f0, C_l, C_d,sep (docs/model_unsteady.md, recipe (d))
    5: (0.9926, 0.5455, 0.0001), 10: (0.8931, 1.0159, 0.0064), 15: (0.6226, 1.2129, 0.0506),
    20: (0.3430, 1.1746, 0.1537), 30: (0.0935, 1.0926, 0.4533), 45: (0.0200, 1.0785, 0.9800),
    90: (0.0013, 0.0125, 1.9975)}


def test_static_polar_table():
    """Recipe (d): the static polar at alpha1 = 17 deg, C_D90 = 2; C_l,max 1.216 near 15.9 deg; f0 is C1 (smooth)."""
    a1 = math.radians(17.0)
    for deg, (f0, cl, cd) in STATIC_TABLE.items():
        a = math.radians(deg)
        f = float(unsteady.separation_point(a, a1))
        assert abs(f - f0) < 6e-5
        assert abs(float(unsteady.lift_coefficient(a, f, 2 * math.pi, 2.0)) - cl) < 6e-5
        assert abs(float(unsteady.separated_drag_coefficient(a, f, 2.0)) - cd) < 6e-5
    a = np.radians(np.linspace(0, 40, 4001))
    cls = np.array([float(unsteady.lift_coefficient(x, unsteady.separation_point(x, a1), 2 * math.pi, 2.0))
                    for x in a])
    assert abs(cls.max() - 1.2160) < 5e-4 and abs(math.degrees(a[cls.argmax()]) - 15.9) < 0.1
    assert float(unsteady.separation_point(0.0, a1)) == 1.0


def test_stall_newton_converges_on_a_twisted_wing():
    """Recipe (d): Newton on a 16-element wing twisted from 2 deg (root) to 45 deg (tips), `none` + `stall`:
    the relative residual falls quadratically and is below 1e-10 after 5 steps."""
    w = PrescribedWing("none", "stall", aspect_ratio=6.9, n=16)
    n = 16
    twist = np.radians(2 + 43 * np.abs(w.yc) / np.abs(w.yc).max())
    one = ca.DM.ones(1, n)
    th = ca.DM(twist).T
    base = {"r": ca.vertcat(ca.DM(w.yc).T, 0 * one, 0 * one), "v_kin": ca.DM.zeros(3, n),
            "c_hat": ca.vertcat(0 * one, -ca.sin(th), ca.cos(th)), "up": ca.vertcat(0 * one, ca.cos(th), ca.sin(th)),
            "tau": ca.vertcat(one, 0 * one, 0 * one), "ds": ca.DM(w.ds), "chord": C * ca.DM.ones(n, 1)}
    res = []
    nu = ca.SX.sym("nu", 3)
    for steps in range(6):
        s = unsteady.section_loads({"unsteady": "none", "section": "stall", "newton_steps": steps},
                                   nu, ca.SX.zeros(0, 1), base, {}, w.wake, w.prm)
        res.append(float(ca.Function("r", [nu], [s["newton_residual"]])(ca.DM([U, 0, 0]))))
    assert res[5] < 1e-10 and res[0] > 1e-2
    assert all(b < a for a, b in zip(res[:4], res[1:5]))


def test_detached_newton_iterates_keep_values_and_derivatives(monkeypatch):
    """The stall circulation with the Newton iterates before the last two detached from AD
    (stall_section.INLINE_NEWTON_STEPS) and the last two steps' matrix held fixed (FROZEN_NEWTON_MATRIX)
    against every step inline and differentiated: the same circulation, first and second derivatives
    along the body velocities equal to round-off, a smaller derivative graph (each saving alone too).
    A wing twisted from 2 to 30 deg (stalled tips) at 18 m/s."""
    w = PrescribedWing("none", "stall", aspect_ratio=6.9, n=8)
    n = 8
    th = ca.DM(np.radians(2 + 28 * np.abs(w.yc) / np.abs(w.yc).max())).T
    one = ca.DM.ones(1, n)
    base = {"r": ca.vertcat(ca.DM(w.yc).T, 0 * one, 0 * one), "v_kin": ca.DM.zeros(3, n),
            "c_hat": ca.vertcat(0 * one, -ca.sin(th), ca.cos(th)), "up": ca.vertcat(0 * one, ca.cos(th), ca.sin(th)),
            "tau": ca.vertcat(one, 0 * one, 0 * one), "ds": ca.DM(w.ds), "chord": C * ca.DM.ones(n, 1)}
    nu = ca.SX.sym("nu", 3)

    def gamma_and_derivatives():
        s = unsteady.section_loads({"unsteady": "none", "section": "stall", "newton_steps": 5},
                                   nu, ca.SX.zeros(0, 1), base, {}, w.wake, w.prm)
        J = ca.jacobian(s["Gamma"], nu)
        f = ca.Function("g", [nu], [s["Gamma"], J, ca.jacobian(J[:, 1], nu)])
        return [np.asarray(v) for v in f(ca.DM([U, 0.5, 0.3]))], ca.Function("j", [nu], [J]).n_instructions()

    (g, J, H), cost = gamma_and_derivatives()
    monkeypatch.setattr(stall_section, "FROZEN_NEWTON_MATRIX", False)
    (g1, J1, H1), cost1 = gamma_and_derivatives()
    monkeypatch.setattr(stall_section, "INLINE_NEWTON_STEPS", 99)
    (g0, J0, H0), cost0 = gamma_and_derivatives()
    # the same operations: equal to the last bit up to the strip's constant chords, which fold differently
    # (on the bird, whose chords and wake are data, bit for bit)
    for gv, Jv, Hv in ((g, J, H), (g1, J1, H1)):
        assert np.max(np.abs(gv - g0)) <= 4e-16 * np.max(np.abs(g0))
        assert np.max(np.abs(Jv - J0)) < 1e-12 * np.max(np.abs(J0))
        assert np.max(np.abs(Hv - H0)) < 1e-9 * np.max(np.abs(H0))
    assert cost < 0.7 * cost1 and cost1 < 0.7 * cost0


def _loop(wing):
    kin, om, T = harmonic(0.1, U, C, pitch_rad=math.radians(10), mean_pitch_rad=math.radians(10))
    r = wing.periodic(kin, T, steps=400, newton=6)
    # recipe (f): P_flap = P_aero + P_body at every sample, separated forces at mid-chord included
    gap = r["flapping_power_Wpm"] - r["aerodynamic_power_Wpm"] - r["body_power_Wpm"]
    assert np.max(np.abs(gap)) < 1e-12 * np.max(np.abs(r["flapping_power_Wpm"]))
    a = r["alpha_geo_rad"]
    cl = r["lift_Npm"] / (0.5 * RHO * U ** 2 * C)
    up = np.cos(om * r["t_s"]) > 0
    i = int(np.argmax(cl))

    def split(deg):
        out = []
        for m in (up, ~up):
            o = np.argsort(a[m])
            out.append(np.interp(math.radians(deg), a[m][o], cl[m][o]))
        return out[0] - out[1]

    return cl[i], bool(up[i]), float(np.sum(0.5 * (cl + np.roll(cl, -1)) * (np.roll(a, -1) - a))), split(15), split(18)


def test_dynamic_stall_hysteresis():
    """Recipe (e): pitch 10 + 10 sin(wt) deg at k = 0.1, wagner + dynamic-stall: C_l,max > 1.1 x 1.216 on the
    upstroke, a clockwise loop (closed integral of C_l d alpha > 0), upstroke above downstroke at 15 and 18 deg;
    a static stall section without lag has no loop."""
    clmax, up, loop, d15, d18 = _loop(PrescribedWing("wagner", "dynamic-stall", aspect_ratio=None, n=2))
    assert clmax > 1.1 * 1.216 and up and loop > 0 and d15 > 0 and d18 > 0
    clmax, up, loop, d15, d18 = _loop(PrescribedWing("none", "stall", aspect_ratio=None, n=2))
    assert abs(clmax - 1.216) < 2e-3 and abs(loop) < 1e-6


@pytest.mark.parametrize("k", [0.14, 0.25])
def test_2d_plunge_energy_matches_garrick(strip, k):
    """Recipe (f): 2-D plunge, mean flapping power pi rho b U w^2 h0^2 Re C_J and mean thrust
    pi rho b w^2 h0^2 |C_J|^2 (Garrick with C_J); mean P_aero / P_flap = 1 - efficiency."""
    r, om, h0, Q, _ = _harmonic_case(strip, k, "plunge")
    CJ = unsteady.jones_transfer(k)
    Pf, Th = np.mean(r["flapping_power_Wpm"]), np.mean(r["thrust_Npm"])
    assert abs(Pf / (math.pi * RHO * B * U * om ** 2 * h0 ** 2 * CJ.real) - 1) < 1e-5
    assert abs(Th / (math.pi * RHO * B * om ** 2 * h0 ** 2 * abs(CJ) ** 2) - 1) < 1e-5
    assert abs(np.mean(r["aerodynamic_power_Wpm"]) / Pf - (1 - Th * U / Pf)) < 1e-9
    assert abs(Th * U / Pf - {0.14: 0.8304, 0.25: 0.7564}[k]) < 1e-4


# ------------------------------------------------------------------------------------- the bird

FIXTURE_STATE = np.array([17.5, 0.8, 0.3, 0.02])


def _model(values):
    cfg = with_values(Config(), values)
    return BirdModel(Structure.of(cfg), use_cache=False), param_vector(cfg)


@pytest.fixture(scope="module")
def default_bird(default_model):
    return default_model.model, default_model.p0


LAG_ONLY = {"aero.unsteady": "wagner", "aero.pitch_rate_weight": 0.0, "aero.added_mass_weight": 0.0}


@pytest.fixture(scope="module")
def lag_bird():
    from birdocp.bird.model import get_model

    m = get_model(with_values(Config(), LAG_ONLY))
    return m.model, m.p0


def test_default_builds_no_new_term(default_bird):
    """The defaults: 4 states, no unsteady data, no dependence on the new parameters."""
    m, p = default_bird
    assert m.ode.nx == 4 and not m.structure.aero_extra and m.section_d is None
    jac = m.rhs.sparsity_jac(2, 0)
    from birdocp.bird.config import PARAM_NAMES, UNSTEADY_PARAMS
    cols = set(jac.get_col())
    assert not cols & {PARAM_NAMES.index(f"aero.{k}") for k in UNSTEADY_PARAMS}


def test_structural_options_change_graph_key():
    base = graph_key(Structure.of(Config()))
    keys = {str(graph_key(Structure.of(with_values(Config(), v)))) for v in (
        {"aero.unsteady": "wagner"}, {"aero.section": "stall"}, {"aero.section": "dynamic-stall"},
        {"aero.section": "stall", "aero.newton_steps": 4})}
    assert len(keys) == 4 and str(base) not in keys
    # numbers are not structural
    assert graph_key(Structure.of(with_values(Config(), {"aero.wagner_weight": 0.5}))) == base


@pytest.mark.parametrize("eps", [0.0, 1.0])
def test_bird_quasi_steady_limit_loads(default_bird, lag_bird, eps):
    """Recipe (c): wagner with chi_w = chi_nc = 0 and eps = 0 (z = 0), or eps = 1 with z on the quasi-steady
    manifold, gives today's loads to 1e-12 relative."""
    m0, p0 = default_bird
    m, p = lag_bird
    p = p.copy()
    from birdocp.bird.config import PARAM_NAMES
    p[PARAM_NAMES.index("aero.wagner_weight")] = eps
    for t in np.linspace(0.0, 0.25, 6):
        x = m.complete_state(FIXTURE_STATE, p, t)
        assert x.size == 36
        a = np.array(m.loads_d(x, m.data(t, p), p)).ravel()
        b = np.array(m0.loads_d(FIXTURE_STATE, m0.data(t, p0), p0)).ravel()
        assert np.max(np.abs(a - b) / np.abs(b)) < 1e-12


def test_bird_energy_identity_with_every_term(lag_bird):
    """Recipe (f), bird: P_flap = P_aero + P_body at every evaluation with wagner (shed-wake velocity, added
    mass and couples, relative 1e-12); the separated forces at mid-chord are checked in 2-D (test_2d_*)."""
    from birdocp.bird.energetics import PowerFunctions
    from birdocp.bird.config import PARAM_NAMES

    m, p = lag_bird
    p = p.copy()
    for k in ("aero.pitch_rate_weight", "aero.added_mass_weight"):
        p[PARAM_NAMES.index(k)] = 1.0
    pf = PowerFunctions(m)
    rows = pf.names
    for t in (0.0, 0.07, 0.16):
        x = m.complete_state(FIXTURE_STATE, p, t)
        x[4:20] *= 1.3  # off the manifold: lag states arbitrary
        P = np.array(pf.power(x, m.data(t, p), p)).ravel()
        Pa, Pf, Pb = (P[rows.index(k)] for k in ("aerodynamic_power_W", "flapping_power_W", "body_power_W"))
        assert abs(Pf - Pa - Pb) < 1e-12 * (abs(Pf) + abs(Pa) + abs(Pb))
    assert PARAM_NAMES.index("aero.wagner_weight") >= 0


def test_bad_combinations_are_config_errors():
    for values, key in (({"aero.unsteady": "wagner", "aero.circulation": "relaxed"}, "aero.circulation"),
                        ({"aero.section": "stall", "aero.circulation": "relaxed"}, "aero.circulation"),
                        ({"aero.unsteady": "theodorsen"}, "aero.unsteady"),
                        ({"aero.section": "kirchhoff"}, "aero.section"),
                        ({"aero.wagner_weight": 1.5}, "aero.wagner_weight"),
                        ({"aero.separation_angle_deg": -3.0}, "aero.separation_angle_deg"),
                        ({"aero.unsteady": "wagner", "wing.mass_kg": 0.05}, "aero.unsteady")):
        with pytest.raises(ConfigError) as e:
            with_values(Config(), values)
        assert key in str(e.value)


def test_default_trim_bit_for_bit_as_committed(reference_trim):
    """The defaults build no new term: the default trim reproduces the committed Experiment 1 (a) cycle
    (results/experiment1/result.json, written by the code before the unsteady options): the cycle x0 to
    the last bit; the multipliers (LAPACK's eigenvalues of the monodromy, whose last bits depend on the
    LAPACK build numpy ships: 1.4090296047509427 with numpy 2.4.6's OpenBLAS 0.3.31 against the committed
    ...432) to 4 ulp."""
    import json
    from pathlib import Path

    ref = json.loads((Path(__file__).resolve().parents[1] / "results" / "experiment1" / "result.json").read_text())
    a = ref["variants"]["a"]
    assert a["config_values"] in ({}, "{}") and a["method"]["points"] == 5
    assert np.asarray(reference_trim.x0).tolist() == a["x0"]
    ours = np.array([[z.real, z.imag] for z in reference_trim.multipliers])
    np.testing.assert_allclose(ours, a["multipliers"], rtol=4 * np.finfo(float).eps, atol=1e-15)


def test_held_bird_cycle_quasi_steady_limit(lag_bird, default_model):
    """The held-body harness: with eps = 0 the lag model's cycle-mean lift and thrust equal the quasi-steady
    model's (an independent code path) to 1e-9; with eps = 1 the lag changes them and the lag states are
    periodic."""
    from birdocp.bird.unsteady_harness import held_bird_cycle

    body = [17.8, 0.5, 0.0, -0.1]
    qs = held_bird_cycle(Config(), body, steps=48)
    lag0 = held_bird_cycle(with_values(Config(), dict(LAG_ONLY, **{"aero.wagner_weight": 0.0})), body, steps=48)
    lag1 = held_bird_cycle(with_values(Config(), LAG_ONLY), body, steps=48)
    for k in ("mean_lift_N", "mean_thrust_N"):
        assert abs(lag0[k] - qs[k]) < 1e-9 * abs(qs["mean_lift_N"])
    assert abs(lag1["mean_lift_N"] - qs["mean_lift_N"]) > 1e-3
    assert lag1["periodicity_residual"] < 1e-10
    assert 0.0 <= lag1["lift_peak_phase_deg"] < 360.0
