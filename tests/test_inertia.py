"""Wings with mass (issue 18, spec inertia.md): exact physics of the equations of motion.

Expected values come from conservation laws (no external force: centre of mass at rest, zero linear
and angular momentum; energy theorem), a closed-form solution (one mass moving along z' through G_b),
the massless model (bit for bit) and central finite differences. The conserved quantities are
computed by brute force from the individual mass points (inertial positions and velocities), not
from the sums the equations use.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from birdocp.bird import inertia
from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, with_values
from birdocp.bird.model import N_DATA, N_MASS, get_model, unpack_mass
from birdocp.engine.ode import ODE
from birdocp.engine.integrate import simulate

WING = 0.086  # kg per wing (spec inertia.md 8)


def _idx(name):
    return PARAM_NAMES.index(name)


@pytest.fixture(scope="module")
def heavy():
    return get_model(with_values(Config(), {"wing.mass_kg": WING}))


# --------------------------------------------------------------------------------------------
# (a) massless limit


def test_massless_config_keeps_todays_functions():
    m0 = get_model(Config())
    assert get_model(with_values(Config(), {"wing.mass_kg": 0.0})).model is m0.model
    assert m0.ode.nd == N_DATA and m0.model.wing_power_d is None


def test_mass_zero_rhs_bit_identical():
    m0 = get_model(Config())
    m1 = get_model(with_values(Config(), {"wing.inertial_terms": True}))
    assert m1.ode.nd == N_DATA + N_MASS
    rng = np.random.default_rng(1)
    for _ in range(20):
        t = rng.uniform(0, 0.25)
        x = np.array([16.0, 0.0, 0.0, 0.0]) + rng.normal(size=4) * (3, 1, 1, 0.3)
        d0, d1 = m0.data(t, m0.p0), m1.data(t, m1.p0)
        assert np.array_equal(np.array(d0), np.array(d1[:N_DATA]))
        assert np.array_equal(np.array(m0.rhs(x, d0, m0.p0)), np.array(m1.rhs(x, d1, m1.p0)))


@pytest.mark.slow
def test_mass_zero_cycle_and_multipliers_identical():
    from birdocp.studies.trim import trim

    r0 = trim(Config())
    r1 = trim(with_values(Config(), {"wing.inertial_terms": True}))
    assert r0.success and r1.success
    assert np.max(np.abs(r0.x0 - r1.x0)) <= 1e-12
    assert np.max(np.abs(r0.multipliers - r1.multipliers)) <= 1e-12
    assert r1.wing_power["peak_inertial_power_W"] == 0.0


# --------------------------------------------------------------------------------------------
# (b), (d) no aerodynamics: conservation laws and the energy theorem, by brute force


def _augmented(m, p):
    """The model's ODE augmented with X, Z (inertial, Z up) and the integral of the shoulder power."""
    x = ca.SX.sym("x", 7)
    d = ca.SX.sym("d", m.ode.nd)
    ps = ca.SX.sym("p", len(PARAM_NAMES))
    xs = x[:4]
    u, w, th = x[0], x[1], x[3]
    P_sh = m.wing_power_d(xs, d, ps)[1]
    rhs = ca.Function("rhs_aug", [x, d, ps], [ca.vertcat(m.rhs(xs, d, ps), u * ca.cos(th) + w * ca.sin(th),
                                                         u * ca.sin(th) - w * ca.cos(th), P_sh)])
    return ODE(rhs, m.data, m.ode.forcing_period)


def _brute(m, p, t, y):
    """Whole-bird centre of mass (X, Z), momentum (P_X, P_Z), angular momentum about C, kinetic and
    potential energy from the individual mass points."""
    r, v, _, mm = (np.array(a) for a in m.mass_points(t, p))
    mm = mm.ravel()
    M, Ib, g = p[_idx("body.mass_kg")], p[_idx("body.pitch_inertia_kgm2")], p[_idx("body.gravity_mps2")]
    mb = M - mm.sum()
    u, w, q, th, X, Z = y[:6]
    c, s = math.cos(th), math.sin(th)
    xs, zs = r[0], r[2]
    vx, vy, vz = u + q * zs + v[0], v[1], w - q * xs + v[2]        # body-frame absolute velocities
    PX, PZ = xs * c + zs * s + X, xs * s - zs * c + Z               # inertial positions (Z up)
    VX, VZ = vx * c + vz * s, vx * s - vz * c
    VbX, VbZ = u * c + w * s, u * s - w * c
    C = np.array([mb * X + mm @ PX, mb * Z + mm @ PZ]) / M
    P = np.array([mb * VbX + mm @ VX, mb * VbZ + mm @ VZ])
    H_O = Ib * q + mb * (X * VbZ - Z * VbX) + mm @ (PX * VZ - PZ * VX)
    H_C = H_O - (C[0] * P[1] - C[1] * P[0])
    T = 0.5 * mb * (u * u + w * w) + 0.5 * Ib * q * q + 0.5 * mm @ (vx ** 2 + vy ** 2 + vz ** 2)
    return C, P, H_C, T, M * g * C[1]


def _rest_state(m, p, t0):
    """nu0 = -𝕄^-1 (S'_x, S'_z, h): zero linear and angular momentum at t0 (spec 7b)."""
    s = {k: float(v) for k, v in unpack_mass(m.data(t0, p)).items()}
    M, Ib = p[_idx("body.mass_kg")], p[_idx("body.pitch_inertia_kgm2")]
    MM = np.array([[M, 0, s["S_z_kgm"]], [0, M, -s["S_x_kgm"]],
                   [s["S_z_kgm"], -s["S_x_kgm"], Ib + s["I_w_kgm2"]]])
    return -np.linalg.solve(MM, [s["dS_x_kgmps"], s["dS_z_kgmps"], s["h_kgm2ps"]])


def _run(m, p, theta0, steps, periods=5):
    ode = _augmented(m, p)
    y0 = np.r_[_rest_state(m, p, 0.0), theta0, 0.0, 0.0, 0.0]
    t, Y = simulate(ode, y0, p, steps_per_period=steps, n_periods=periods)
    return t, Y


def _errors(m, p, t, Y, g):
    C0, P0, H0, T0, V0 = _brute(m, p, t[0], Y[0])
    err = {"C": 0.0, "P": 0.0, "H": 0.0, "E": 0.0}
    moved = 0.0
    for k in range(0, len(t), 7):
        C, P, H, T, V = _brute(m, p, t[k], Y[k])
        fall = np.array([0.0, -0.5 * g * (t[k] - t[0]) ** 2])
        vfall = np.array([0.0, -g * (t[k] - t[0])])
        err["C"] = max(err["C"], np.max(np.abs(C - C0 - fall)))
        err["P"] = max(err["P"], np.max(np.abs(P - P0 - p[_idx("body.mass_kg")] * vfall)))
        err["H"] = max(err["H"], abs(H - H0))
        err["E"] = max(err["E"], abs(Y[k, 6] - (T + V - T0 - V0)))
        moved = max(moved, math.hypot(Y[k, 4] - Y[0, 4], Y[k, 5] - Y[0, 5]))
    return err, moved, (P0, H0)


@pytest.mark.parametrize("gravity", [0.0, 9.81])
def test_no_aerodynamics_conservation_and_energy(heavy, gravity):
    """rho = 0: centre of mass at rest (g = 0) or in free fall (g on), total momentum zero (plus M g t),
    angular momentum about C zero, and the work of the shoulder = change of T + V, over 5 beats; the
    RK4 error drops ~16x per halving of the step."""
    p = np.array(heavy.p0, float)
    p[_idx("aero.air_density_kgm3")] = 0.0
    p[_idx("body.gravity_mps2")] = gravity
    res = []
    for steps in (100, 200):
        t, Y = _run(heavy, p, 0.2, steps)
        res.append(_errors(heavy, p, t, Y, gravity))
    (e1, moved, (P0, H0)), (e2, _, _) = res
    assert np.max(np.abs(P0)) < 1e-14 and abs(H0) < 1e-14   # the start has zero momentum
    assert moved > 5e-3                                    # the body moves (G_b ~ |S|/M)
    for k in e2:
        assert e2[k] < 1e-7, (k, e2)
        if e1[k] > 1e-12:
            assert 8.0 < e1[k] / e2[k] < 32.0, (k, e1[k], e2[k])


# --------------------------------------------------------------------------------------------
# (c) closed form: one mass moving along z' through G_b


def test_single_mass_along_z_closed_form():
    m_pt, m_b, I_b, a, om, th0 = 0.2, 1.0, 0.05, 0.03, 2 * math.pi * 3.0, 0.4
    M = m_pt + m_b
    t = ca.SX.sym("t")
    zeta = a * ca.sin(om * t) + 0.5 * a * ca.cos(2 * om * t)
    r = ca.vertcat(0, 0, zeta)
    v = ca.jtimes(r, t, ca.SX(1))
    acc = ca.jtimes(v, t, ca.SX(1))
    sums = inertia.mass_sums([0.5 * m_pt], [r], [v], [acc])  # one mirror pair on the axis = one mass
    x = ca.SX.sym("x", 4)
    u, w, q = x[0], x[1], x[2]
    f_today = ca.vertcat(-q * w, q * u, 0)                     # no loads, no gravity
    nud = inertia.accelerations(x, f_today, sums, M, I_b, 0.0)
    y = ca.SX.sym("y", 6)
    f = ca.Function("f", [t, y], [ca.vertcat(ca.substitute(ca.vertcat(nud, q), x, y[:4]),
                                             y[0] * ca.cos(y[3]) + y[1] * ca.sin(y[3]),
                                             y[0] * ca.sin(y[3]) - y[1] * ca.cos(y[3]))])
    Z = ca.Function("zeta", [t], [zeta, v[2]])
    z0, zd0 = (float(v_) for v_ in Z(0.0))
    sol = solve_ivp(lambda tt, yy: np.array(f(tt, yy)).ravel(), (0, 1.0), [0, -m_pt * zd0 / M, 0, th0, 0, 0],
                    method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    kappa = m_pt / M
    for tt in np.linspace(0, 1.0, 23):
        yy = sol.sol(tt)
        zt, zdt = (float(v_) for v_ in Z(tt))
        assert abs(yy[0]) < 1e-12 and abs(yy[2]) < 1e-12 and abs(yy[3] - th0) < 1e-12
        assert abs(yy[1] + m_pt * zdt / M) < 1e-11
        dz = zt - z0
        assert abs(yy[4] - (-kappa * dz * math.sin(th0))) < 1e-11
        assert abs(yy[5] - (kappa * dz * math.cos(th0))) < 1e-11


# --------------------------------------------------------------------------------------------
# (e) derivatives against central finite differences


def test_time_derivatives_of_the_sums_by_ad(heavy):
    """S', S'', J_w, k and P_rel (AD in t through the skeleton) against central differences."""
    dt = 1e-5
    for t in (0.013, 0.1, 0.21):
        s = {k: float(v) for k, v in unpack_mass(heavy.data(t, heavy.p0)).items()}
        sp = {k: float(v) for k, v in unpack_mass(heavy.data(t + dt, heavy.p0)).items()}
        sm = {k: float(v) for k, v in unpack_mass(heavy.data(t - dt, heavy.p0)).items()}

        def fd(k):
            return (sp[k] - sm[k]) / (2 * dt)

        for val, ref in ((s["dS_x_kgmps"], fd("S_x_kgm")), (s["dS_z_kgmps"], fd("S_z_kgm")),
                         (s["ddS_x_kgmps2"], fd("dS_x_kgmps")), (s["ddS_z_kgmps2"], fd("dS_z_kgmps")),
                         (2 * s["J_w_kgm2ps"], fd("I_w_kgm2")), (s["k_kgm2ps2"], fd("h_kgm2ps")),
                         (s["P_rel_W"], fd("T_rel_J"))):
            assert abs(val - ref) <= 1e-6 * max(1.0, abs(ref)), (t, val, ref)


def test_rhs_and_data_jacobians_against_finite_differences(heavy):
    x0 = np.array([15.8, -1.8, -0.1, -0.06])
    p = np.array(heavy.p0, float)
    d = np.array(heavy.data(0.07, p)).ravel()
    x, ds = ca.SX.sym("x", 4), ca.SX.sym("d", heavy.ode.nd)
    J = ca.Function("J", [x, ds], [ca.jacobian(heavy.rhs(x, ds, p), ca.vertcat(x, ds[N_DATA:]))])
    Jad = np.array(J(x0, d))
    Jfd = np.zeros_like(Jad)
    for j in range(4 + N_MASS):
        h = 1e-6 * max(1.0, abs(x0[j] if j < 4 else d[N_DATA + j - 4]))
        xp, xm, dp_, dm_ = x0.copy(), x0.copy(), d.copy(), d.copy()
        if j < 4:
            xp[j] += h
            xm[j] -= h
        else:
            dp_[N_DATA + j - 4] += h
            dm_[N_DATA + j - 4] -= h
        Jfd[:, j] = (np.array(heavy.rhs(xp, dp_, p)) - np.array(heavy.rhs(xm, dm_, p))).ravel() / (2 * h)
    assert np.max(np.abs(Jad - Jfd)) <= 1e-6 * max(1.0, np.max(np.abs(Jad)))
    # the mass sums along the flapping amplitude (a decision variable of level flight)
    ia = _idx("gait.shoulder_flap.amplitude_deg")
    a = ca.SX.sym("a")
    ps = ca.vertcat(*[a if i == ia else float(v) for i, v in enumerate(p)])
    dmass = heavy.data(0.07, ps)[N_DATA:]
    g = ca.Function("g", [a], [dmass, ca.jacobian(dmass, a)])
    ad = np.array(g(p[ia])[1]).ravel()
    fd = (np.array(g(p[ia] + 1e-4)[0]) - np.array(g(p[ia] - 1e-4)[0])).ravel() / 2e-4
    assert np.max(np.abs(ad - fd)) <= 1e-6 * max(1.0, np.max(np.abs(ad)))


def test_momentum_form_agrees(heavy):
    """Spec 4.4: the generalised momenta p = 𝕄 nu + (S'_x, S'_z, h) obey the momentum balance."""
    p = np.array(heavy.p0, float)
    x0 = np.array([15.8, -1.8, -0.3, -0.06])
    t = 0.05
    d = heavy.data(t, p)
    s = {k: float(v) for k, v in unpack_mass(d).items()}
    nud = np.array(heavy.rhs(x0, d, p)).ravel()[:3]
    Fx, Fz, My = np.array(heavy.loads_d(x0, d, p)).ravel()
    M, Ib, g = p[_idx("body.mass_kg")], p[_idx("body.pitch_inertia_kgm2")], p[_idx("body.gravity_mps2")]
    Sx, Sz, dSx, dSz = s["S_x_kgm"], s["S_z_kgm"], s["dS_x_kgmps"], s["dS_z_kgmps"]
    MM = np.array([[M, 0, Sz], [0, M, -Sx], [Sz, -Sx, Ib + s["I_w_kgm2"]]])
    dMM = np.array([[0, 0, dSz], [0, 0, -dSx], [dSz, -dSx, 2 * s["J_w_kgm2ps"]]])
    u, w, q, th = x0
    nu = x0[:3]
    mom = MM @ nu + [dSx, dSz, s["h_kgm2ps"]]
    dmom = dMM @ nu + MM @ nud + [s["ddS_x_kgmps2"], s["ddS_z_kgmps2"], s["k_kgm2ps2"]]
    res = [dmom[0] + q * mom[1] - (Fx - M * g * math.sin(th)),
           dmom[1] - q * mom[0] - (Fz + M * g * math.cos(th)),
           dmom[2] - (My - g * (Sz * math.sin(th) + Sx * math.cos(th)) - (w * mom[0] - u * mom[1]))]
    assert np.max(np.abs(res)) < 1e-11 * max(1.0, abs(Fz))


# --------------------------------------------------------------------------------------------
# configuration, studies and export with massive wings


def test_config_validation():
    for key, val in (("wing.mass_kg", -0.01), ("wing.mass_kg", 0.6), ("wing.mass_share_arm", 0.6),
                     ("wing.mass_share_hand", -0.1)):
        with pytest.raises(ConfigError) as e:
            with_values(Config(), {key: val})
        assert e.value.key.startswith("wing.mass")
    cfg = with_values(Config(), {"wing.mass_kg": WING})
    assert abs(cfg.body.mass_kg - 2 * WING - 1.028) < 1e-12


def test_cli_config_and_bad_mass(capsys):
    from birdocp.cli.main import main

    assert main(["config", "--set", "wing.mass_kg=0.05", "--json"]) == 0
    import json
    out = json.loads(capsys.readouterr().out)
    assert out["wing"]["mass_kg"] == 0.05 and out["wing"]["mass_share_arm"] == 0.5
    assert main(["trim", "--set", "wing.mass_kg=-1", "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "wing.mass_kg" in err


@pytest.mark.slow
def test_trim_and_level_with_massive_wings(tmp_path, capsys):
    import json

    from birdocp.cli.main import main
    from birdocp.studies.level import level

    assert main(["trim", "--set", f"wing.mass_kg={WING}", "--json", "--out", str(tmp_path / "t")]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["success"] and r["wing_mass_kg"] == WING
    assert abs(r["mean_inertial_power_W"]) < 1e-9 * r["peak_inertial_power_W"]   # dT_rel/dt averages to 0
    assert r["mean_positive_inertial_power_W"] > 1.0
    hist = r["wing_power_history"]
    assert len(hist["t_s"]) == len(hist["shoulder_inertial_power_W"]) == 149
    lv = level(with_values(Config(), {"wing.mass_kg": WING}))
    l0 = level(Config())
    assert lv.success and l0.success
    assert abs(lv.mean_vertical_speed_mps) < 1e-8
    assert abs(lv.amplitude_deg - l0.amplitude_deg) > 0.1   # the wings' inertia changes the level gait


@pytest.mark.slow
def test_export_c_with_massive_wings(tmp_path):
    import subprocess

    from birdocp.engine.integrate import RK4Grid
    from birdocp.export.codegen import export_c
    from birdocp.export.compiled import find_compiler

    cc = find_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    cfg = with_values(Config(), {"wing.mass_kg": WING})
    info = export_c(cfg, tmp_path / "c")
    assert info.n_data == N_DATA + N_MASS
    d = tmp_path / "c"
    assert "S_x_kgm" in (d / "bird.h").read_text()
    subprocess.run(cc + ["-O1", "-o", "bird_period", "main.c", "bird.c", "bird_casadi.c", "bird_data.c", "-lm"],
                   cwd=d, check=True, capture_output=True)
    x0 = (16.0, -1.0, -0.1, -0.05)
    out = subprocess.run([str(d / "bird_period"), *map(repr, x0)], capture_output=True, text=True,
                         check=True).stdout.split("\n")
    xT_c = np.array(out[0].split(), float)
    m = get_model(cfg)
    grid = RK4Grid(m.ode, cfg.solve.steps_per_period, 1)
    xT = np.asarray(grid.period_map(ca.DM(x0), grid.blocks_numeric(0.0, m.p0), ca.DM(m.p0))[0]).ravel()
    assert np.max(np.abs(xT_c - xT)) < 1e-10


def test_hold_mean_com_root_places_the_shoulder_ahead_of_the_mean_com():
    from birdocp.studies.inertia import config_with_wing_mass, hold_mean_com_root, mean_com_offset_m

    cfg = config_with_wing_mass(Config(), 0.12)
    assert abs(cfg.wing.mass_kg - 0.072) < 1e-15
    root = hold_mean_com_root(cfg, 0.05)
    moved = with_values(cfg, {"wing.root_ahead_m": root})
    xc, _ = mean_com_offset_m(moved)
    assert abs((root - xc) - 0.05) < 1e-12 and root > 0.05
    # the mean by the trapezoidal rule has converged (smooth periodic motion)
    assert abs(mean_com_offset_m(moved, n=32)[0] - xc) < 1e-12
    assert hold_mean_com_root(config_with_wing_mass(Config(), 0.0), 0.05) == 0.05


@pytest.mark.slow
def test_cycle_summary_carries_the_cycle_validity():
    """The inertia study's row summary re-integrates one period from x0: its validity is the trim's
    (measured on the solver's own trajectory)."""
    from birdocp.studies.inertia import config_with_wing_mass, cycle_summary
    from birdocp.studies.trim import trim

    cfg = config_with_wing_mass(Config(), 0.143)
    r = trim(cfg, points=3, steps_per_period=48)
    s = cycle_summary(cfg, r.x0, r.cycle.p, steps_per_period=48)
    v, ref = s["validity"], r.validity.to_dict()
    assert s["valid"] is ref["valid"] is v["valid"] and v["reasons"] == ref["reasons"]
    for k in ("stalled_fraction", "min_forward_speed_mps", "max_abs_pitch_deg", "max_airflow_body_angle_deg"):
        assert v[k] == pytest.approx(ref[k], abs=1e-8), k
