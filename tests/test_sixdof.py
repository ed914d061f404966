"""The six-degree-of-freedom bird (birdocp.bird.sixdof) against the planar model and exact properties:
a symmetric cycle is the planar cycle, its monodromy splits into longitudinal and lateral blocks,
the heading adds a multiplier 1, the equations are mirror-symmetric, and for a frozen wing the
cycle's multipliers are the exponentials of the steady glide's eigenvalues."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import Config, param_vector
from birdocp.bird.sixdof import (HEADING, LATERAL, LONGITUDINAL, LateralInertia, embed_planar_state,
                                 sixdof_model)
from birdocp.engine.problem import LimitCycleProblem
from birdocp.engine.shooting import MultipleShooting, floquet, solve
from birdocp.studies.lateral import lateral_trim

LON, LAT = list(LONGITUDINAL), list(LATERAL) + [HEADING]
MIRROR = np.diag([1, -1, 1, -1, 1, -1, -1, 1, -1.0])  # (v, p, r, phi, psi) change sign


@pytest.fixture(scope="module")
def six(default_config):
    return sixdof_model(default_config)


def test_rhs_at_a_symmetric_state_is_the_planar_rhs(six, default_model, default_config):
    p = param_vector(default_config)
    for t in (0.0, 0.031, 0.17):
        d = default_model.data(t, p)
        x4 = [18.1, -1.3, 0.4, -0.1]
        f6 = np.array(six.rhs(embed_planar_state(x4), d, six.params(p))).ravel()
        f4 = np.array(default_model.rhs(x4, d, p)).ravel()
        np.testing.assert_allclose(f6[LON], f4, rtol=0, atol=1e-12)
        assert np.abs(f6[LAT]).max() < 1e-10  # F1 and the roll/yaw moments cancel to round-off


def test_mirror_symmetry_of_the_equations(six, default_model, default_config):
    """A symmetric gait: flipping (v, p, r, phi, psi) flips their derivatives (left and right swap)."""
    p = param_vector(default_config)
    rng = np.random.default_rng(3)
    for t in (0.02, 0.11):
        d = default_model.data(t, p)
        x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7]) + 0.1 * rng.standard_normal(9)
        f = np.array(six.rhs(x, d, six.params(p))).ravel()
        fm = np.array(six.rhs(MIRROR @ x, d, six.params(p))).ravel()
        np.testing.assert_allclose(fm, MIRROR @ f, rtol=1e-12, atol=1e-11)
        assert np.abs(f[LATERAL[0]]) > 1e-3  # sideslip does load the bird


def test_symmetric_cycle_is_the_planar_cycle_and_its_monodromy_splits(default_config, reference_trim):
    res = lateral_trim(default_config)
    assert res.success, res.cycle.message
    np.testing.assert_allclose(res.cycle.x0[LON], reference_trim.x0, rtol=0, atol=1e-9)
    assert np.abs(res.cycle.x0[LAT]).max() < 1e-9
    assert res.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers),
                               np.sort_complex(reference_trim.multipliers), rtol=0, atol=1e-9)
    assert abs(res.heading_multiplier - 1) < 1e-12
    assert len(res.lateral_multipliers) == 4 and len(res.multipliers) == 9
    d = res.to_dict()
    assert {"longitudinal_multipliers", "lateral_multipliers", "heading_multiplier", "lateral_modes"} <= set(d)


def test_frozen_wing_multipliers_are_the_glide_eigenvalues(default_config):
    """Amplitudes 0: the model is autonomous, the cycle is a steady glide and ln(Lambda)/T are the
    eigenvalues of the linearised glide (computed apart, by CasADi's Jacobian of the state equations)."""
    from birdocp.bird.config import with_values

    frozen = with_values(default_config, {f"gait.{j}.amplitude_deg": 0.0 for j in (
        "shoulder_incidence", "shoulder_flap", "shoulder_sweep", "elbow_flex", "hand_twist", "wrist_flex",
        "wrist_spread")})
    six = sixdof_model(frozen)
    p6 = six.params(param_vector(frozen), LateralInertia(roll_inertia_kgm2=0.02))
    d0 = six.planar.data(0.0, param_vector(frozen))
    x = ca.SX.sym("x", 8)
    f8 = six.rhs(ca.vertcat(x, 0), d0, p6)[:8]
    F = ca.Function("f8", [x], [f8, ca.jacobian(f8, x)])
    xe = np.array(embed_planar_state([15.0, 1.0, 0.0, -0.1]))[:8]
    for _ in range(30):  # Newton on the glide (psi drops out: nothing depends on it)
        fv, J = (np.array(v) for v in F(xe))
        xe = xe - np.linalg.solve(J, fv.ravel())
    fv, J = (np.array(v) for v in F(xe))
    assert np.abs(fv).max() < 1e-10
    lam = np.sort_complex(np.append(np.linalg.eigvals(J), 0.0))
    T = six.ode.period_s
    fl = floquet(six.ode, np.append(xe, 0.0), p6, MultipleShooting(points=3, steps_per_period=600))
    ln = np.sort_complex(np.log(fl.multipliers.astype(complex)) / T)
    np.testing.assert_allclose(ln.real, lam.real, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(np.abs(ln.imag), np.abs(lam.imag), rtol=1e-6, atol=1e-6)


def test_planar_terms_not_in_3d_are_refused():
    from birdocp.bird.config import with_values

    with pytest.raises(ValueError, match="tail"):
        sixdof_model(with_values(Config(), {"tail.opening_angle_deg": 30.0}))
    with pytest.raises(ValueError, match="roll_inertia_kgm2"):
        LateralInertia(roll_inertia_kgm2=0.0)


def test_solve_from_an_asymmetric_start_returns_to_the_symmetric_cycle(six, default_config):
    p6 = six.params(param_vector(default_config))
    guess = np.array(embed_planar_state(default_config.solve.initial_guess))
    guess[LATERAL[0]] = 0.3  # a sideslipping start: the periodic orbit is still the symmetric one
    res = solve(LimitCycleProblem(ode=six.ode, p=p6, x_guess=guess), MultipleShooting(points=5, steps_per_period=148))
    assert res.success
    assert np.abs(res.x0[list(LATERAL)]).max() < 1e-8


def test_level_flight_in_six_dof_is_the_planar_level_flight(default_config, coarse):
    from birdocp.studies.level import level

    method = MultipleShooting(**coarse)
    six = lateral_trim(default_config, level=True, method=method)
    planar = level(default_config, **coarse)
    assert six.success and planar.success
    assert abs(six.amplitude_deg - planar.amplitude_deg) < 1e-8
    assert abs(six.mean_vertical_speed_mps) < 1e-9
    np.testing.assert_allclose(np.sort_complex(six.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-8)


def test_trim_cli_with_six_degrees_of_freedom(tmp_path):
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", "trim", "--set", "model.degrees_of_freedom=6",
                           "--points", "3", "--steps", "48", "--json", "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["degrees_of_freedom"] == 6 and len(r["x0"]) == 9 and len(r["multipliers"]) == 9
    assert len(r["lateral_multipliers"]) == 4 and len(r["longitudinal_multipliers"]) == 4
    assert r["state_names"][1] == "v_mps" and r["validity"]["valid"] in (True, False)
    assert {m["label"] for m in r["lateral_modes"]} <= {"spiral", "dutch_roll_like", "roll_subsidence", "lateral_real"}
    assert json.loads((tmp_path / "run" / "result.json").read_text())["heading_multiplier"] == r["heading_multiplier"]


@pytest.mark.slow
def test_lateral_sensitivity_against_central_differences(default_config, coarse):
    """The exact derivative of the spiral multiplier's modulus along the shoulder elevation (dihedral)
    against central differences of re-solved cycles."""
    from birdocp.bird.config import with_values
    from birdocp.studies.lateral import lateral_sensitivities

    method = MultipleShooting(**coarse)
    key = "gait.shoulder_flap.offset_deg"
    res = lateral_trim(default_config, method=method)
    (row,) = lateral_sensitivities(res, default_config, [key])
    spiral = [i for i, lab in enumerate(row["labels"]) if lab == "spiral"]
    assert len(spiral) == 1 and row["labels"].count("heading") == 1

    def modulus(v):
        r = lateral_trim(with_values(default_config, {key: v}), method=method)
        return abs(next(m["multiplier"] for m in r.lateral_modes if m["label"] == "spiral"))

    h = 0.01
    fd = (modulus(h) - modulus(-h)) / (2 * h)
    assert abs(row["d_moduli"][spiral[0]] - fd) < 1e-6 * max(1.0, abs(fd)), (row["d_moduli"][spiral[0]], fd)
    assert row["d_moduli"][row["labels"].index("heading")] == pytest.approx(0.0, abs=1e-12)
