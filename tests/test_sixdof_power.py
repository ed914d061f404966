"""The shoulder power of each wing in six degrees of freedom (:mod:`birdocp.bird.sixdof_power`): the planar
power for a symmetric gait, mirror symmetry, the energy balance (instantaneous and over a beat, RK4's
order), and the power objectives of a turn against central differences and through the CLI."""
from __future__ import annotations

import json
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import Config, get_value, param_vector, with_values

SIX = {"model.degrees_of_freedom": 6}
RIGHT = "gait.right_offset.shoulder_sweep.offset_deg"
ASYM = {RIGHT: -2.0, "gait.left_offset.shoulder_flap.amplitude_deg": 3.0, "gait.right_offset.shoulder_incidence.offset_deg": 1.5}
LATERAL = [1, 3, 5, 6, 8]  # v, p, r, phi, psi


def _powers(cfg, x, t, offsets=None):
    from birdocp.bird.sides import side_vector
    from birdocp.bird.sixdof import LateralInertia, sixdof_model
    from birdocp.bird.sixdof_power import sixdof_power_function

    six = sixdof_model(cfg, sides=True)
    p = ca.DM(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg) if offsets is None else offsets))
    return six, p, np.asarray(sixdof_power_function(six)(x, six.data(t, p), p)).ravel()


@pytest.mark.parametrize("extra", [{}, pytest.param({"aero.section": "stall", "drag.profile_drag_coefficient": 0.02,
                                                      "drag.body_drag_coefficient": 0.1, "tail.opening_angle_deg": 20.0},
                                                     marks=pytest.mark.slow)])
def test_symmetric_gait_is_the_planar_power(extra):
    """Symmetric gait, symmetric state: the two wings' shoulder powers are equal and add up to the planar
    model's flapping power; the power to the air and the body power are the planar ones (round-off),
    also with the stall-aware section, drag and tail."""
    from birdocp.bird.energetics import POWER_NAMES, power_functions
    from birdocp.bird.model import get_model

    cfg = with_values(Config(), SIX | extra)
    m = get_model(cfg)
    pp = ca.DM(param_vector(cfg))
    n_aero = m.ode.nx - 4
    for t, x4 in ((0.03, [17.0, 0.5, 0.3, 0.05]), (0.2, [15.0, -1.0, -0.4, 0.1])):
        xa = list(np.linspace(0.01, 0.02, n_aero))
        x9 = [x4[0], 0.0, x4[1], 0.0, x4[2], 0.0, 0.0, x4[3], 0.0] + xa
        _, _, P = _powers(cfg, x9, t)
        planar = np.asarray(power_functions(m).power(x4 + xa, m.model.data(t, pp), pp)).ravel()
        ref = np.max(np.abs(P))
        assert abs(P[2] - P[3]) < 1e-13 * ref
        assert P[2] + P[3] == pytest.approx(planar[POWER_NAMES.index("flapping_power_W")], abs=1e-13 * ref)
        assert P[0] == pytest.approx(planar[POWER_NAMES.index("aerodynamic_power_W")], abs=1e-13 * ref)
        assert P[1] == pytest.approx(planar[POWER_NAMES.index("body_power_W")], abs=1e-13 * ref)


def test_mirror_swaps_the_wings_and_the_energy_identities():
    """An asymmetric gait at an asymmetric state: swapping the left and right offsets and mirroring the state
    (v, p, r, phi, psi flipped) swaps the two shoulder powers and keeps the power to the air and the body's;
    P_right + P_left = P_aero + P_body to round-off, and along the motion dE_b/dt = P_body - m g W (chain
    rule, exact derivatives) with E_b = m |v|^2 / 2 + omega^T J omega / 2."""
    from birdocp.bird.sides import side_vector, swap_sides

    cfg = with_values(Config(), SIX | ASYM)
    x = np.array([16.0, 0.7, 0.4, 0.3, -0.2, 0.15, 0.12, 0.06, 0.4])
    xm = x.copy()
    xm[LATERAL] *= -1
    for t in (0.04, 0.17):
        six, p, P = _powers(cfg, x, t)
        _, _, Pm = _powers(cfg, xm, t, swap_sides(side_vector(cfg)))
        ref = np.max(np.abs(P))
        assert abs(P[2] - P[3]) > 1e-3 * ref  # the wings differ
        np.testing.assert_allclose(Pm[[0, 1, 3, 2]], P, rtol=0, atol=1e-12 * ref)
        assert P[2] + P[3] - P[0] - P[1] == pytest.approx(0.0, abs=1e-13 * ref)
        # chain rule
        xs = ca.SX.sym("x", 9)
        m, Iyy, g = (float(get_value(cfg, k)) for k in ("body.mass_kg", "body.pitch_inertia_kgm2", "body.gravity_mps2"))
        ixx, izz, ixz = cfg.model.roll_inertia_kgm2, cfg.model.yaw_inertia_kgm2, cfg.model.product_inertia_xz_kgm2
        J = ca.DM([[ixx, 0, -ixz], [0, Iyy, 0], [-ixz, 0, izz]])
        om = xs[3:6]
        E = 0.5 * m * ca.sumsqr(xs[:3]) + 0.5 * ca.mtimes([om.T, J, om])
        dE = float(ca.Function("dE", [xs], [ca.jacobian(E, xs)])(x) @ six.rhs(x, six.data(t, p), p))
        W = x[0] * np.sin(x[7]) - (x[1] * np.sin(x[6]) + x[2] * np.cos(x[6])) * np.cos(x[7])
        assert dE == pytest.approx(P[1] - m * g * W, abs=1e-12 * ref)


def test_energy_balance_over_a_beat_has_rk4_order():
    """One wingbeat of an asymmetric gait from an asymmetric start (not a cycle), RK4 with the powers as
    quadrature: the shoulders' work minus the work given to the air equals the change of the body's kinetic
    and potential energy up to RK4's truncation, which falls 16x per halving of the step."""
    from birdocp.bird.sixdof_power import sixdof_power_function
    from birdocp.engine.integrate import RK4Grid

    cfg = with_values(Config(), SIX | ASYM)
    x0 = np.array([16.0, 0.7, 0.4, 0.3, -0.2, 0.15, 0.12, 0.06, 0.0])
    six, p, _ = _powers(cfg, x0, 0.0)
    xs, ds, ps = ca.SX.sym("x", 9), ca.SX.sym("d", six.ode.nd), ca.SX.sym("p", six.ode.np)
    pw = sixdof_power_function(six)(xs, ds, ps)
    W = xs[0] * ca.sin(xs[7]) - (xs[1] * ca.sin(xs[6]) + xs[2] * ca.cos(xs[6])) * ca.cos(xs[7])
    out = ca.Function("balance", [xs, ds, ps], [ca.vertcat(pw[2] + pw[3] - pw[0], W)])
    m, Iyy, g = (float(get_value(cfg, k)) for k in ("body.mass_kg", "body.pitch_inertia_kgm2", "body.gravity_mps2"))
    ixx, izz, ixz = cfg.model.roll_inertia_kgm2, cfg.model.yaw_inertia_kgm2, cfg.model.product_inertia_xz_kgm2
    J = np.array([[ixx, 0, -ixz], [0, Iyy, 0], [-ixz, 0, izz]])
    kinetic = lambda x: 0.5 * m * x[:3] @ x[:3] + 0.5 * x[3:6] @ J @ x[3:6]  # noqa: E731
    res = []
    for N in (40, 80):
        grid = RK4Grid(six.ode, N, 1, outputs=(out,))
        xT, _, q = grid.period_map(ca.DM(x0), grid.blocks_numeric(0.0, np.asarray(p).ravel()), p)
        xT, q = np.asarray(xT).ravel(), np.asarray(q).ravel()
        res.append(q[0] - (kinetic(xT) - kinetic(x0) + m * g * q[1]))
        assert abs(q[0]) > 1.0  # joules of work over the beat
    assert 12 < res[0] / res[1] < 20, res


@pytest.fixture(scope="module")
def turn_power():
    from birdocp.studies.gait_problem import ReducedProblem
    from birdocp.studies.lateral_optimize import reduced_level_cycle

    cfg = with_values(Config(), SIX | {RIGHT: -2.0})
    keys = ["gait.shoulder_sweep.offset_deg", RIGHT]
    rc = reduced_level_cycle(cfg, keys, steps_per_period=12, power=True)
    theta = np.array([float(get_value(cfg, k)) for k in keys])
    return rc, theta, {o: ReducedProblem(rc, o, 14.0, None, (20.0, 70.0), None, -1.0)
                       for o in ("power", "cost-of-transport", "positive-power")}


def test_turn_power_objectives_against_central_differences(turn_power):
    """The power objectives of a level turn (the cycle eliminated, the per-side offset free) have exact
    gradients: central differences agree; on the level turn the mean shoulder power equals the mean power
    to the air up to RK4's truncation (12 steps), and the wings differ."""
    rc, theta, probs = turn_power
    ev = rc.evaluate(theta)
    m = ev.means
    assert m["flapping_power_W"] == pytest.approx(m["right_shoulder_power_W"] + m["left_shoulder_power_W"], rel=1e-14)
    assert abs(m["flapping_power_W"] - m["aerodynamic_power_W"]) < 1e-4 * m["flapping_power_W"]
    assert abs(m["right_shoulder_power_W"] - m["left_shoulder_power_W"]) > 0.05
    assert m["positive_power_smooth_W"] > m["flapping_power_W"]
    from birdocp.bird.sixdof_power import sampled_wing_powers

    w = sampled_wing_powers(rc.six, ev.x0, rc.pfull(theta, ev.amplitude_deg), rc.N)
    # the exact positive work per wing, from the samples: the smoothing's error is at most eps/2 (0.025 W)
    # beyond the sampling's, and the sampled mean is the quadrature's to the sampling's accuracy
    assert w["mean_positive_power_W"] == pytest.approx(w["mean_right_positive_power_W"] + w["mean_left_positive_power_W"])
    assert abs(w["mean_sampled_shoulder_power_W"] - m["flapping_power_W"]) < 0.02 * m["flapping_power_W"]
    assert abs(w["mean_positive_power_W"] - m["positive_power_smooth_W"]) < 0.03 * m["positive_power_smooth_W"]
    h = 1e-5
    for objective, prob in probs.items():
        z = theta.copy()  # unscaled (sigma 1): the central differences' step is the keys' own
        G, J = prob.both(z)
        for c in range(len(z)):
            e = np.zeros(len(z))
            e[c] = h
            fd = (prob.both(z + e, grads=False)[0] - prob.both(z - e, grads=False)[0]) / (2 * h)
            np.testing.assert_allclose(J[:, c], fd, rtol=2e-5, atol=1e-7 * np.max(np.abs(J)), err_msg=objective)


@pytest.mark.parametrize("argv, field", [
    (["--turn-rate", "2"], "--turn-rate"),  # a turn needs six degrees of freedom
    (["--set", "model.degrees_of_freedom=6", "--set", f"{RIGHT}=-1", "--set", "aero.unsteady=wagner"], "aero.unsteady"),
])
def test_turn_power_refusals_one_line_exit_2(tmp_path, argv, field):
    """What optimize-gait cannot do with a turn is refused before any computation: one line naming the
    field, exit 2, nothing written (Wagner's added mass: its power is not split per wing)."""
    proc = subprocess.run([sys.executable, "-m", "birdocp", "optimize-gait", "--speed", "15", *argv, "--out",
                           str(tmp_path / "run")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and not (tmp_path / "run").exists(), proc.stderr
    assert field in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_optimize_gait_turn_through_the_cli(tmp_path, capfd, monkeypatch):
    """A small power-optimal turn through the CLI (two IPOPT iterations on 12 steps): one JSON object with
    both wings' shoulder powers adding up to the objective, the heading change held, the validity of both
    wings and the 6-DOF trim's check."""
    from birdocp.cli import main as cli

    monkeypatch.chdir(tmp_path)
    code = cli.main(["optimize-gait", "--speed", "14", "--set", "model.degrees_of_freedom=6",
                     "--set", "solve.steps_per_period=12", "--free", "gait.shoulder_sweep.offset_deg", "--free", RIGHT,
                     "--bounds", f"{RIGHT}=-5:5", "--turn-rate", "-1", "--out", "run", "--json", "--quiet"])
    assert code in (0, 1)
    d = json.loads(capfd.readouterr().out)
    assert d["symmetric"] is False and len(d["multipliers"]) == 8
    assert d["mean_right_shoulder_power_W"] + d["mean_left_shoulder_power_W"] == pytest.approx(d["objective_value"])
    assert "stalled_fraction_left" in d["validity"] and d["verification"]["trim_success"]
    assert d["mean_positive_power_W"] > d["objective_value"] and len(d["wing_power_samples"]["t_s"]) == 12


@pytest.mark.slow
def test_wing_masses_symmetric_is_planar_and_vacuum_energy_balance():
    """Wings with mass. A symmetric gait at a symmetric state: equal wings whose shoulder powers add up to the
    planar model's (aerodynamic + inertial). No air, with gravity, an asymmetric gait from a tumbling start:
    the two shoulders' work over a beat equals the change of the kinetic energy of body plus wings (summed
    over the mass points from their positions and velocities, not from the sums) plus the potential energy
    of the whole bird, to RK4's truncation (16x per halving of the step)."""
    from birdocp.bird.energetics import power_functions
    from birdocp.bird.model import get_model
    from birdocp.bird.sides import side_parameters, side_vector
    from birdocp.bird.sixdof import LateralInertia, sixdof_model
    from birdocp.bird.sixdof_power import power_ode, sixdof_power_function
    from birdocp.engine.integrate import RK4Grid

    mass = {"wing.mass_kg": 0.086, "model.roll_inertia_kgm2": 0.0015, "model.product_inertia_xz_kgm2": 0.004}
    cfg = with_values(Config(), SIX | mass)
    six = sixdof_model(cfg, sides=True)
    p = ca.DM(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg)))
    m = get_model(cfg)
    pp = ca.DM(param_vector(cfg))
    x4 = [17.0, 0.5, 0.3, 0.05]
    P = np.asarray(sixdof_power_function(six)([x4[0], 0, x4[1], 0, x4[2], 0, 0, x4[3], 0], power_ode(six).data(0.07, p),
                                              p)).ravel()
    pl = power_functions(m)
    planar = np.asarray(pl.power(x4, m.model.data(0.07, pp), pp)).ravel()
    ref = float(planar[1] + planar[pl.names.index("shoulder_inertial_power_W")])
    assert abs(P[2] - P[3]) < 1e-13 * abs(ref) and P[2] + P[3] == pytest.approx(ref, rel=1e-13)

    from birdocp.bird.config import PARAM_NAMES

    cfg = with_values(Config(), SIX | mass | ASYM)
    six = sixdof_model(cfg, sides=True)
    pv = np.asarray(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg)), float)
    pv[PARAM_NAMES.index("aero.air_density_kgm3")] = 0.0  # no air (the configuration refuses it)
    ode = power_ode(six)
    xs, ds, ps = ca.SX.sym("x", 8), ca.SX.sym("d", ode.nd), ca.SX.sym("p", ode.np)
    pw = sixdof_power_function(six, 8)(xs, ds, ps)
    W = xs[0] * ca.sin(xs[7]) - (xs[1] * ca.sin(xs[6]) + xs[2] * ca.cos(xs[6])) * ca.cos(xs[7])
    out = ca.Function("balance", [xs, ds, ps], [ca.vertcat(pw[2] + pw[3], W)])
    M, g = float(get_value(cfg, "body.mass_kg")), float(get_value(cfg, "body.gravity_mps2"))
    J = np.array([[0.0015, 0, -0.004], [0, float(get_value(cfg, "body.pitch_inertia_kgm2")), 0],
                  [-0.004, 0, cfg.model.yaw_inertia_kgm2]])
    pr, pleft = side_parameters(pv[:len(param_vector(cfg))], pv[-len(side_vector(cfg)):])

    def energy(x, t):
        """Kinetic energy of body plus wings (mass point by mass point) and the part g_b . S of the potential."""
        rr, vr, _, mr = (np.asarray(a) for a in six.planar.mass_points(t, pr))
        rl, vl, _, ml = (np.asarray(a) for a in six.planar.mass_points(t, pleft))
        h = rr.shape[1] // 2
        r, v, mw = np.hstack([rr[:, :h], rl[:, h:]]), np.hstack([vr[:, :h], vl[:, h:]]), np.r_[mr[:h, 0], ml[h:, 0]]
        vel, om = x[:3], x[3:6]
        va = vel[:, None] + np.cross(om, r.T).T + v
        T = 0.5 * (M - mw.sum()) * vel @ vel + 0.5 * om @ J @ om + 0.5 * np.sum(mw * np.sum(va ** 2, axis=0))
        gb = g * np.array([-np.sin(x[7]), np.sin(x[6]) * np.cos(x[7]), np.cos(x[6]) * np.cos(x[7])])
        return T, gb @ (r @ mw)

    x0 = np.array([3.0, 0.5, -0.4, 1.0, -0.7, 0.5, 0.3, 0.2])
    res = []
    for N in (40, 80):
        grid = RK4Grid(ode, N, 1, outputs=(out,))
        xT, _, q = grid.period_map(ca.DM(x0), grid.blocks_numeric(0.0, pv), ca.DM(pv))
        xT, q = np.asarray(xT).ravel(), np.asarray(q).ravel()
        (T0, G0), (T1, G1) = energy(x0, 0.0), energy(xT, six.period_s)
        res.append(q[0] - (T1 - T0 + M * g * q[1] - (G1 - G0)))
    assert 12 < res[0] / res[1] < 20 and abs(res[1]) < 1e-7, res
    # the same balance at an instant, to round-off: d/dt (T - g_b . S) + M g W = P_right + P_left along the
    # motion, with T and S summed over the mass points as functions of (x, t) (exact derivatives)
    t = ca.SX.sym("t")
    x = ca.SX.sym("x", 8)
    rr, vr, _, mr = six.planar.mass_points(t, ca.DM(pr))
    rl, vl, _, ml = six.planar.mass_points(t, ca.DM(pleft))
    h = rr.shape[1] // 2
    r, v, mw = ca.horzcat(rr[:, :h], rl[:, h:]), ca.horzcat(vr[:, :h], vl[:, h:]), ca.vertcat(mr[:h], ml[h:])
    vel, om = x[:3], x[3:6]
    va = ca.repmat(vel, 1, r.shape[1]) + ca.horzcat(*[ca.cross(om, r[:, i]) for i in range(r.shape[1])]) + v
    gb = g * ca.vertcat(-ca.sin(x[7]), ca.sin(x[6]) * ca.cos(x[7]), ca.cos(x[6]) * ca.cos(x[7]))
    E = (0.5 * (M - ca.sum1(mw)) * ca.dot(vel, vel) + 0.5 * ca.dot(om, ca.DM(J) @ om)
         + 0.5 * ca.dot(ca.sum1(va * va).T, mw) - ca.dot(gb, r @ mw))
    d = ca.SX.sym("d", ode.nd)
    W = x[0] * ca.sin(x[7]) - (x[1] * ca.sin(x[6]) + x[2] * ca.cos(x[6])) * ca.cos(x[7])
    rate = ca.Function("rate", [x, t, d], [ca.jtimes(E, x, ode.rhs(x, d, ca.DM(pv))) + ca.jacobian(E, t) + M * g * W
                                           - ca.sum1(sixdof_power_function(six, 8)(x, d, ca.DM(pv))[2:4])])
    for tk in (0.02, 0.13):
        P = np.asarray(sixdof_power_function(six, 8)(x0, ode.data(tk, ca.DM(pv)), ca.DM(pv))).ravel()
        assert abs(P[2] - P[3]) > 0.1 and max(abs(P[2]), abs(P[3])) > 1.0  # watts, the wings differ
        assert abs(float(rate(x0, tk, ode.data(tk, ca.DM(pv))))) < 1e-12 * max(abs(P[2]), abs(P[3]))


@pytest.mark.slow
def test_turn_power_at_zero_offsets_is_the_symmetric_optimisers():
    """With the per-side offsets at 0 the turn's power outputs (a per-side offset free) are the symmetric
    gait optimiser's (the planar level cycle): mean shoulder power, power to the air and the smoothed
    positive-work power (per wing with eps/2: exactly the planar smoothing of the sum), and their gradients
    along the symmetric keys; along the right offset half the symmetric key's (mirror symmetry)."""
    from birdocp.studies.lateral_optimize import reduced_level_cycle

    keys = ["gait.shoulder_sweep.offset_deg", "gait.shoulder_incidence.offset_deg"]
    cfg = with_values(Config(), SIX)
    rc0 = reduced_level_cycle(cfg, keys, steps_per_period=12)
    rc1 = reduced_level_cycle(cfg, keys + [RIGHT], turn=True, steps_per_period=12, power=True)
    assert type(rc0).__name__ == "LateralLevelCycle" and type(rc1).__name__ == "TurnLevelCycle"
    th = np.array([float(get_value(cfg, k)) for k in keys])
    ev0, ev1 = rc0.evaluate(th), rc1.evaluate(np.append(th, 0.0))
    for k in ("flapping_power_W", "aerodynamic_power_W", "positive_power_smooth_W", "forward_speed_mps"):
        assert ev1.means[k] == pytest.approx(ev0.means[k], rel=1e-8), k
        np.testing.assert_allclose(ev1.grads[k][:2], ev0.grads[k], rtol=1e-6, atol=1e-9 * np.max(np.abs(ev0.grads[k])))
        assert ev1.grads[k][2] == pytest.approx(0.5 * ev0.grads[k][0], rel=1e-6, abs=1e-9 * np.max(np.abs(ev0.grads[k])))
    assert ev1.means["right_shoulder_power_W"] == pytest.approx(ev1.means["left_shoulder_power_W"], rel=1e-9)
