"""Power outputs (energetics.md): an independent numpy computation from the same loads and velocities,
the instantaneous identity, the chain rule of the body energy, the cycle balance, positive and
negative work, the Strouhal number's tip excursion, and the optional drag terms (off: bit-identical)."""

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.bird.energetics import POWER_NAMES, power_functions
from birdocp.bird.model import get_model, unpack_data
from birdocp.studies.trim import trim

DRAG = {"drag.body_drag_coefficient": 0.2, "drag.profile_drag_coefficient": 0.02}


def numpy_powers(m, x, t, p):
    """Every power from the data blocks, in numpy: Kutta-Joukowski forces on the elements, profile
    and parasite drag (energetics.md 2, 5), the dot products with the velocities."""
    d = unpack_data(m.data(t, ca.DM(p)))
    b = {k: np.asarray(v, float) for k, v in d.items()}
    P = dict(zip(PARAM_NAMES, p))
    u, w, q = x[0], x[1], x[2]
    r, vk, tau = b["r_m"], b["v_kin_mps"], b["tau"]
    V = np.vstack([-vk[0], w + q * r[2] - vk[1], u - q * r[1] - vk[2]])
    Vp = V - tau * np.sum(tau * V, axis=0)
    Vn = np.linalg.norm(Vp, axis=0)
    alpha = np.arctan2(np.sum(Vp * b["up"], axis=0), np.sum(Vp * b["c_hat"], axis=0))
    qv = Vn * alpha
    Gamma = b["G"] @ qv
    vind = np.vstack([b["Wx"] @ qv, b["Wy"] @ qv, np.zeros(16)])
    rho = P["aero.air_density_kgm3"]
    dF = rho * np.cross((V + vind).T, tau.T).T * Gamma * b["ds_m"].ravel()
    dD = 0.5 * rho * P["drag.profile_drag_coefficient"] * Vp * Vn * b["chord_m"].ravel() * b["ds_m"].ravel()
    Uinf = np.array([0.0, w, u])
    Fpar = 0.5 * rho * P["drag.body_frontal_area_m2"] * P["drag.body_drag_coefficient"] * np.linalg.norm(Uinf) * Uinf
    Fel = dF + dD
    F = Fel.sum(axis=1) + Fpar
    M = np.sum(r[1] * Fel[2] - r[2] * Fel[1])
    Fx, Fz = -F[2], -F[1]
    return {"aerodynamic_power_W": np.sum(Fel * V) + Fpar @ Uinf, "flapping_power_W": -np.sum(Fel * vk),
            "body_power_W": Fx * u + Fz * w + M * q, "induced_power_W": -np.sum(dF * vind),
            "profile_power_W": np.sum(dD * V), "parasite_power_W": Fpar @ Uinf, "loads": np.array([Fx, Fz, M])}


@pytest.mark.parametrize("values", [{}, DRAG])
def test_powers_match_an_independent_numpy_computation(values):
    cfg = with_values(Config(), values)
    m = get_model(cfg)
    pf = power_functions(m)
    rng = np.random.default_rng(3)
    for _ in range(4):
        x = np.array([rng.uniform(14, 20), rng.uniform(-3, 2), rng.uniform(-1, 1), rng.uniform(-0.3, 0.3)])
        t = rng.uniform(0, m.period_s)
        d = m.data(t, ca.DM(m.p0))
        got = dict(zip(POWER_NAMES, np.asarray(pf.power(x, d, m.p0)).ravel()))
        ref = numpy_powers(m, x, t, m.p0)
        scale = np.max(np.abs(ref["loads"])) * 20
        assert np.allclose(np.asarray(m.loads_d(x, d, m.p0)).ravel(), ref["loads"], rtol=0, atol=1e-12 * scale)
        for k in ("aerodynamic_power_W", "flapping_power_W", "body_power_W", "induced_power_W",
                  "profile_power_W", "parasite_power_W"):
            assert abs(got[k] - ref[k]) <= 1e-12 * scale, k
        # the instantaneous identity P_flap = P_aero + P_body, the power split, signs of the losses
        assert abs(got["flapping_power_W"] - got["aerodynamic_power_W"] - got["body_power_W"]) <= 1e-13 * scale
        assert abs(got["aerodynamic_power_W"] - got["induced_power_W"] - got["profile_power_W"]
                   - got["parasite_power_W"]) <= 1e-13 * scale
        assert got["profile_power_W"] >= 0 and got["parasite_power_W"] >= 0
        if not values:
            assert got["profile_power_W"] == 0 and got["parasite_power_W"] == 0


def test_chain_rule_of_the_body_energy_with_drag_and_tail():
    """d/dt (m (u^2 + w^2)/2 + I q^2/2) + m g W = P_body along the equations of motion."""
    cfg = with_values(Config(), DRAG | {"tail.opening_angle_deg": 40.0})
    m = get_model(cfg)
    pf = power_functions(m)
    p = m.p0
    mass, I, g = (p[PARAM_NAMES.index(k)] for k in ("body.mass_kg", "body.pitch_inertia_kgm2", "body.gravity_mps2"))
    rng = np.random.default_rng(5)
    for _ in range(4):
        x = np.array([rng.uniform(14, 20), rng.uniform(-3, 2), rng.uniform(-1, 1), rng.uniform(-0.3, 0.3)])
        d = m.data(rng.uniform(0, m.period_s), ca.DM(p))
        xd = np.asarray(m.rhs(x, d, p)).ravel()
        pw = np.asarray(pf.power(x, d, p)).ravel()
        W = pw[-1]
        dE = mass * (x[0] * xd[0] + x[1] * xd[1]) + I * x[2] * xd[2]
        assert abs(dE + mass * g * W - pw[2]) <= 1e-12 * (abs(pw[2]) + mass * g * abs(W) + 1)
        assert abs(pw[1] - pw[0] - pw[2]) <= 1e-12 * (abs(pw[1]) + 1)


@pytest.fixture(scope="module")
def reference_trim():
    return trim(Config(), points=5, steps_per_period=148)


def test_cycle_balance_positive_work_and_strouhal(reference_trim):
    tr = reference_trim
    assert tr.success
    e = tr.energetics
    mass_g = 1.2 * 9.81
    # mean P_body = m g mean W (a descending cycle), to the RK4 truncation
    assert abs(e["mean_body_power_W"] - mass_g * tr.mean_vertical_speed_mps) < 1e-6
    # mean P_flap = mean P_aero + mean P_body, to round-off (the same RK4 stages)
    assert abs(e["mean_flapping_power_W"] - e["mean_aerodynamic_power_W"] - e["mean_body_power_W"]) < 1e-12
    # induced power only, positive on average
    assert e["mean_aerodynamic_power_W"] > 0
    assert e["mean_induced_power_W"] == pytest.approx(e["mean_aerodynamic_power_W"], abs=1e-12)
    # positive - negative work = the sampled mean, to round-off; sampled ~ quadrature mean
    assert e["mean_positive_power_W"] - e["mean_negative_power_W"] == pytest.approx(
        e["mean_sampled_shoulder_power_W"], abs=1e-12)
    assert e["mean_sampled_shoulder_power_W"] == pytest.approx(e["mean_shoulder_power_W"], rel=2e-3)
    assert e["mean_positive_power_W"] >= e["mean_shoulder_power_W"]
    # tip height at T/4 and 3T/4 from the fixture geometry (energetics.md 4): -0.418 m, +0.366 m
    s = e["samples"]
    T = 0.25
    for tq, h in ((T / 4, -0.418), (3 * T / 4, 0.366)):
        assert s["wingtip_height_m"][np.argmin(np.abs(s["t_s"] - tq))] == pytest.approx(h, abs=2e-3)
    assert e["wingtip_excursion_m"] >= 0.418 + 0.366 - 1e-3
    U = tr.mean_forward_speed_mps
    assert e["strouhal_number"] == pytest.approx(4.0 * e["wingtip_excursion_m"] / U, rel=1e-12)
    assert e["cost_of_transport"] == pytest.approx(e["mean_shoulder_power_W"] / (mass_g * U), rel=1e-12)
    d = tr.to_dict()
    for k in ("mean_aerodynamic_power_W", "mean_positive_power_W", "cost_of_transport", "strouhal_number"):
        assert np.isfinite(d[k])


def test_zero_drag_terms_leave_todays_cycle_unchanged(reference_trim):
    """drag.enabled with zero coefficients builds the terms (exact zeros): the cycle, the multipliers
    and the loads are bit-identical to the paper's model."""
    cfg = with_values(Config(), {"drag.enabled": True})
    m0, m1 = get_model(Config()), get_model(cfg)
    assert m1.model is not m0.model and m1.structure.drag and not m0.structure.drag
    tr = trim(cfg, points=5, steps_per_period=148)
    ref = reference_trim
    assert np.array_equal(tr.x0, ref.x0)
    assert np.array_equal(tr.multipliers, ref.multipliers)
    assert np.array_equal(tr.trajectory_x, ref.trajectory_x)
    x, t = ref.x0, 0.0123
    assert np.array_equal(np.asarray(m1.loads(x, t, m1.p0)), np.asarray(m0.loads(x, t, m0.p0)))


@pytest.mark.slow
def test_drag_costs_power_in_level_flight():
    """With drag on, a level cycle still balances (mean P_flap = mean P_aero) and costs more."""
    from birdocp.studies.level import level

    small = {"drag.body_drag_coefficient": 0.1, "drag.profile_drag_coefficient": 0.005}
    base = level(Config(), points=2, steps_per_period=48)
    drag = level(with_values(Config(), small), points=2, steps_per_period=48, bounds=(20, 89), warm_start=base)
    assert base.success and drag.success
    e0, e1 = base.energetics, drag.energetics
    for e in (e0, e1):
        assert abs(e["mean_flapping_power_W"] - e["mean_aerodynamic_power_W"]) < 1e-4  # RK4 truncation at 48 steps
    assert e1["mean_profile_power_W"] > 0 and e1["mean_parasite_power_W"] > 0
    assert e1["mean_aerodynamic_power_W"] > e0["mean_aerodynamic_power_W"] + e1["mean_parasite_power_W"] * 0.5
    # parasite power = 1/2 rho S C_D |U_inf|^3 averaged over the cycle, bounded by the speeds seen
    X = np.asarray(drag.trajectory_x)
    spd = np.hypot(X[:, 0], X[:, 1])
    k = 0.5 * 1.225 * 0.0092 * 0.1
    assert k * spd.min() ** 3 <= e1["mean_parasite_power_W"] <= k * spd.max() ** 3


def test_committed_power_curve_rows_carry_validity_and_optima_over_valid_rows():
    """results/energetics/power_curve.json (scripts/energetics_study.py --only power-curve): every
    converged row carries its exact validity, ``valid`` and the cycle to re-solve it; the stored
    minimum-power and maximum-range speeds are those of the valid rows only (recomputed here)."""
    import json
    from pathlib import Path

    from birdocp.studies.power_curves import curve_optima

    pc = json.loads((Path(__file__).resolve().parents[1] / "results" / "energetics" / "power_curve.json").read_text())
    ok = [r for r in pc["rows"] if r["success"]]
    assert len(ok) >= 3
    for r in ok:
        assert r["valid"] == r["validity"]["valid"] and len(r["x0"]) == 4 and "amplitude_deg" in r and pc["key"] in r
    again = curve_optima(pc["rows"])
    for k in ("minimum_power", "maximum_range", "minimum_power_all_rows"):
        # the optima come from a least-squares fit (LAPACK): its last bits depend on the LAPACK build
        assert again[k].keys() == pc[k].keys(), k
        for f, v in again[k].items():
            if isinstance(v, float):
                assert v == pytest.approx(pc[k][f], rel=1e-12, abs=1e-12), (k, f)
            else:
                assert v == pc[k][f], (k, f)
    valid_U = [r["speed_mps"] for r in ok if r["valid"]]
    assert min(valid_U) <= pc["minimum_power"]["speed_mps"] <= max(valid_U)
