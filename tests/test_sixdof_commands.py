"""``forces``, ``optimize-stability`` and ``optimize-gait`` with ``model.degrees_of_freedom = 6``: the
body-axis loads against the planar ones and mirror symmetry; the lateral block of the reduced gait
optimisers (its exact derivative against central differences) and the JSON split."""
from __future__ import annotations

import json

import numpy as np
import pytest

from birdocp.bird.config import Config, ConfigError, get_value, with_values
from birdocp.cli import main as cli

SIX = {"model.degrees_of_freedom": 6}
KEYS = ["gait.shoulder_sweep.offset_deg", "gait.shoulder_incidence.offset_deg"]


def _forces(capfd, state, *extra):
    assert cli.main(["forces", "--state", *map(str, state), "--time", "0.05", "--json", *extra]) == 0
    return json.loads(capfd.readouterr().out)


def test_forces_six_dof_symmetric_state_is_the_planar_one(capfd):
    """A symmetric gait at a symmetric state (v = p = r = phi = 0): side force, roll and yaw moments and
    the lateral rates vanish to round-off, the longitudinal loads and rates are the planar model's."""
    u, w, q, th = 18.0, 0.5, 0.1, 0.01
    six = _forces(capfd, [u, 0, w, 0, q, 0, 0, th, 0.3], "--set", "model.degrees_of_freedom=6")
    planar = _forces(capfd, [u, w, q, th])
    assert list(six)[:7] == ["Fx_N", "Fy_N", "Fz_N", "Mx_Nm", "My_Nm", "Mz_Nm", "xdot"]
    assert six["state_names"][1] == "v_mps" and six["degrees_of_freedom"] == 6 and six["success"]
    scale = abs(six["Fz_N"])
    for k in ("Fy_N", "Mx_Nm", "Mz_Nm"):
        assert abs(six[k]) < 1e-12 * scale, k
    for k in ("Fx_N", "Fz_N", "My_Nm"):
        assert six[k] == pytest.approx(planar[k], rel=1e-12, abs=1e-12)
    xd = np.array(six["xdot"])
    np.testing.assert_allclose(xd[[0, 2, 4, 7]], planar["xdot"], rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(xd[[1, 3, 5, 6, 8]])) < 1e-10


def test_forces_six_dof_mirror_symmetry(capfd):
    """Mirroring the state (v, p, r, phi, psi -> -) flips Fy, Mx, Mz and keeps Fx, Fz, My."""
    x = np.array([18.0, 0.7, 0.5, 0.3, 0.1, -0.2, 0.05, 0.01, 0.1])
    m = x * np.array([1, -1, 1, -1, 1, -1, -1, 1, -1])
    a = _forces(capfd, x, "--set", "model.degrees_of_freedom=6")
    b = _forces(capfd, m, "--set", "model.degrees_of_freedom=6")
    assert abs(a["Fy_N"]) > 1e-3 and abs(a["Mx_Nm"]) > 1e-3  # sideslip and roll rate do load the bird
    for k, sign in (("Fx_N", 1), ("Fy_N", -1), ("Fz_N", 1), ("Mx_Nm", -1), ("My_Nm", 1), ("Mz_Nm", -1)):
        assert b[k] == pytest.approx(sign * a[k], rel=1e-10, abs=1e-12), k


def test_forces_state_count_follows_the_model(capfd):
    assert cli.main(["forces", "--state", "18", "0.5", "0.1", "0.01", "--time", "0",
                     "--set", "model.degrees_of_freedom=6"]) == 2
    assert "--state: takes 9 values" in capfd.readouterr().err


@pytest.fixture(scope="module")
def lateral_problem():
    from birdocp.studies.lateral_optimize import reduced_level_cycle
    from birdocp.studies.gait_problem import ReducedProblem

    cfg = with_values(Config(), SIX)
    rc = reduced_level_cycle(cfg, KEYS, steps_per_period=12, second_order=True)
    prob = ReducedProblem(rc, "stability", None, None, (20.0, 70.0))
    theta = np.array([float(get_value(cfg, k)) for k in KEYS])
    return rc, prob, theta


def test_lateral_block_and_its_derivative(lateral_problem):
    """The reduced NLP of a 6-DOF stability objective has ten Jury rows (planar and lateral blocks);
    its Jacobian (the lateral block's exact derivative, the cycle's change included) matches central
    differences of the constraint values, and the lateral multipliers are those of a 6-DOF trim."""
    from birdocp.studies.lateral import lateral_trim

    rc, prob, theta = lateral_problem
    assert type(rc).__name__ == "LateralLevelCycle" and prob.ng == 1 + 1 + 10
    ev = rc.evaluate(theta)
    r = 1.1 * float(np.max(np.abs(ev.multipliers)))
    z = np.append(theta, r)
    G, J = prob.both(z)
    h = 1e-5
    for c in range(len(KEYS)):
        e = np.zeros(len(z))
        e[c] = h
        fd = (prob.both(z + e, grads=False)[0] - prob.both(z - e, grads=False)[0]) / (2 * h)
        np.testing.assert_allclose(J[7:, c], fd[7:], rtol=1e-4, atol=1e-6 * np.max(np.abs(J[7:])))
    assert np.max(np.abs(J[7:, :2])) > 1e-3  # the lateral Jury rows do move with the gait
    split = rc.multiplier_split(ev)
    tr = lateral_trim(with_values(rc.cfg, {"gait.shoulder_flap.amplitude_deg": ev.amplitude_deg}),
                      steps_per_period=12, points=3, x_guess=[ev.x0[0], 0, ev.x0[1], 0, ev.x0[2], 0, 0, ev.x0[3], 0])
    lat = np.array([complex(*p) for p in split["lateral_multipliers"]])
    assert np.max(np.abs(np.sort_complex(lat) - np.sort_complex(tr.lateral_multipliers))) < 1e-8
    assert split["lateral_radius"] == pytest.approx(np.max(np.abs(tr.lateral_multipliers)), rel=1e-8)
    assert len(ev.multipliers) == 8
    from birdocp.studies.gait_problem import ReducedProblem

    bounded = ReducedProblem(rc, "power", 18.0, 1.2, (20.0, 70.0))  # optimize-gait --max-multiplier 1.2
    assert bounded.names[-5:] == [f"jury{i}_block1" for i in range(5)] and bounded.ng == 1 + 2 + 10


def test_optimize_stability_six_dof_json_keys(tmp_path, capfd, monkeypatch):
    """A tiny 6-DOF optimize-stability through the CLI: one JSON object with the split and both radii,
    its multipliers the eight (the radii the largest moduli of each block)."""
    monkeypatch.chdir(tmp_path)
    code = cli.main(["optimize-stability", "--set", "model.degrees_of_freedom=6", "--set", "solve.steps_per_period=12",
                     "--free", KEYS[0], "--max-iter", "2", "--out", "run", "--json", "--quiet"])
    assert code in (0, 1)
    d = json.loads(capfd.readouterr().out)
    for k in ("degrees_of_freedom", "longitudinal_multipliers", "lateral_multipliers", "longitudinal_radius",
              "lateral_radius", "lateral_stable", "multipliers", "radius", "validity", "verification"):
        assert k in d, k
    assert d["degrees_of_freedom"] == 6 and len(d["multipliers"]) == 8
    moduli = sorted(abs(complex(*z)) for z in d["multipliers"])
    assert max(d["longitudinal_radius"], d["lateral_radius"]) == pytest.approx(moduli[-1], rel=1e-12)
    assert (tmp_path / "run" / "result.json").exists()


def test_six_dof_optimisers_refuse_what_they_cannot_solve(capfd):
    assert cli.main(["optimize-stability", "--set", "model.degrees_of_freedom=6", "--method", "full"]) == 2
    assert "--method" in capfd.readouterr().err
    from birdocp.studies.lateral_optimize import LateralLevelCycle

    asym = with_values(Config(), SIX | {"gait.right_offset.shoulder_sweep.offset_deg": 2.0})
    with pytest.raises(ConfigError, match="symmetric gait"):
        LateralLevelCycle(asym, KEYS, steps_per_period=12)


def test_lateral_block_two_ways(lateral_problem):
    """The lateral block and its derivative from the SX variational equations on the planar data equal
    those of forward AD through the 9-state period map (the path taken with wing masses)."""
    import casadi as ca

    from birdocp.studies.sensitivity import SecondOrderMaps

    rc, _, theta = lateral_problem
    ev = rc.evaluate(theta)
    M, dM = rc._lateral(ev, True)
    rc.so6 = SecondOrderMaps.get(rc.six, rc.N, rc.six.flight_outputs()["vertical_speed_mps"])
    rc._times6 = ca.DM(rc.so6.grid.times(0.0)).reshape((1, -1))
    M2, dM2 = rc._lateral_wing_masses(ev, True)
    np.testing.assert_allclose(M, M2, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(dM, dM2, rtol=1e-9, atol=1e-10 * np.max(np.abs(dM)))


def test_lateral_level_cycle_with_wing_masses():
    """With wing masses (the 6-DOF data has 3-D mass sums) the lateral block is that of a 6-DOF trim."""
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.lateral_optimize import reduced_level_cycle

    cfg = with_values(Config(), SIX | {"wing.mass_kg": 0.05})
    rc = reduced_level_cycle(cfg, KEYS[:1], steps_per_period=12)
    assert not rc.shared_data
    ev = rc.evaluate(np.array([float(get_value(cfg, KEYS[0]))]))
    tr = lateral_trim(with_values(cfg, {"gait.shoulder_flap.amplitude_deg": ev.amplitude_deg}), steps_per_period=12,
                      points=3, x_guess=[ev.x0[0], 0, ev.x0[1], 0, ev.x0[2], 0, 0, ev.x0[3], 0])
    lat = np.array([complex(*p) for p in rc.multiplier_split(ev)["lateral_multipliers"]])
    assert np.max(np.abs(np.sort_complex(lat) - np.sort_complex(tr.lateral_multipliers))) < 1e-8


def test_optimize_gait_refuses_an_asymmetric_gait_in_four_dof_naming_the_offset(tmp_path):
    """optimize-gait takes an asymmetric gait in six degrees of freedom (a turn: tests/test_sixdof_power.py);
    with four it is refused before any computation, naming the offset."""
    import subprocess
    import sys

    key = "gait.left_offset.shoulder_sweep.offset_deg"
    for command, extra in (("optimize-gait", ["--speed", "17"]),):
        proc = subprocess.run([sys.executable, "-m", "birdocp", command, *extra,
                               "--set", f"{key}=-1", "--out", str(tmp_path / command)],
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2 and not (tmp_path / command).exists(), proc.stderr
        assert key in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
