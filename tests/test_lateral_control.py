"""Lateral feedback (birdocp.studies.lateral_control, lateral_simulate) on the coarse 6-DOF cycle:
the exact 8-state wingbeat map against the nonlinear 6-DOF simulation, the LQR's closed-loop
multipliers inside the unit circle and mirror-symmetric gains, open loop growing, closed loop decaying."""
from __future__ import annotations

import numpy as np
import pytest

from birdocp.bird.config import ConfigError, Config, with_values
from birdocp.studies.lateral_control import (LATERAL_CONTROLS, design_lateral_controller, lateral_reference_cycle,
                                             resolve_lateral_controls, sides_parameters)
from birdocp.studies.lateral_simulate import SideGust, parse_lateral_perturbation, parse_side_gust, simulate_lateral

LAT8 = np.array([1, -1, 1, -1, 1, -1, -1, 1.0])  # (v, p, r, phi) change sign in the mirror image


@pytest.fixture(scope="module")
def design(coarse):
    cfg = with_values(Config(), {"model.degrees_of_freedom": 6, "solve.points": coarse["points"],
                                 "solve.steps_per_period": coarse["steps_per_period"]})
    res, cfg = lateral_reference_cycle(cfg)
    assert res.success
    return cfg, res, design_lateral_controller(res, cfg)


@pytest.mark.slow
def test_closed_loop_is_stable_and_the_gains_are_mirror_symmetric(design):
    _, res, ctl = design
    assert np.max(np.abs(ctl.map.multipliers)) > 1.0  # the open-loop cycle is unstable
    assert ctl.spectral_radius < 1.0
    np.testing.assert_allclose(np.sort(np.abs(ctl.map.multipliers))[-7:],
                               np.sort(np.abs([z for z in res.multipliers if abs(z - 1) > 1e-9]))[-7:],
                               rtol=1e-7)  # the map's monodromy is the trim's (heading excluded)
    K = ctl.K[0]  # rows: right amplitude, sweep, incidence, then the left wing's
    np.testing.assert_allclose(K[3:], K[:3] * LAT8, rtol=1e-6, atol=1e-6 * np.abs(K).max())
    d = ctl.to_dict()
    assert d["state_names"][1] == "v_mps" and len(d["gain"][0]) == 8 and d["success"]


@pytest.mark.slow
def test_the_map_predicts_the_nonlinear_beat(design):
    """One beat of the nonlinear simulation from a small roll and side-slip deviation: its change is
    A dx (open loop) and (A - B K) dx (closed loop) to second order."""
    cfg, res, ctl = design
    p = sides_parameters(res.cycle.p)
    x0 = np.asarray(res.cycle.x0)[:8]
    dx = np.zeros(9)
    dx[[1, 6]] = [0.02, 0.004]
    for c, M in ((None, ctl.map.M), (ctl, ctl.closed_loop_monodromy)):
        s = simulate_lateral(cfg, x0, p, 1, perturbation=dx, controller=c)
        end = s.states[-1, :8] - x0
        lin = M @ dx[:8]
        assert np.linalg.norm(end - lin) < 2e-2 * np.linalg.norm(lin), (end, lin)


@pytest.mark.slow
def test_roll_perturbation_and_side_gust_decay_in_closed_loop_only(design):
    cfg, res, ctl = design
    p = sides_parameters(res.cycle.p)
    dx = parse_lateral_perturbation(["phi=0.1"])
    gust = parse_side_gust("pulse=2:1")
    for kw in ({"perturbation": dx}, {"side_gust": gust}):
        op = simulate_lateral(cfg, res.cycle.x0, p, 12, **kw)
        cl = simulate_lateral(cfg, res.cycle.x0, p, 12, controller=ctl, **kw)
        assert op.success and cl.success and not cl.saturated
        assert op.deviation_per_beat[-1] > 2 * op.deviation_per_beat[5]  # open loop: the unstable modes grow
        assert cl.deviation_per_beat[-1] < 0.1 * max(cl.deviation_per_beat)  # closed loop: it dies out
    assert np.abs(op.position_m[:, 1]).max() > 0.1  # the gust blew the bird sideways


def test_bad_controls_and_gusts_are_refused():
    assert resolve_lateral_controls(["right_amplitude", "left_sweep"]) == [LATERAL_CONTROLS[0], LATERAL_CONTROLS[4]]
    with pytest.raises(ConfigError, match="--controls"):
        resolve_lateral_controls(["rigth_amplitude"])
    with pytest.raises(ConfigError, match="--side-gust"):
        parse_side_gust("gusty=3")
    with pytest.raises(ConfigError, match="--side-gust"):
        SideGust(2.0, length_beats=0.0)
    with pytest.raises(ConfigError, match="--perturb"):
        parse_lateral_perturbation(["yaw=1"])


def _cli(*argv, tmp_path=None):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "birdocp", *argv], capture_output=True, text=True, timeout=300)


SIX = ["--set", "model.degrees_of_freedom=6", "--set", "solve.points=3", "--set", "solve.steps_per_period=48"]


@pytest.mark.slow
def test_control_and_simulate_cli_in_six_degrees_of_freedom(tmp_path):
    import json

    ctl_dir = tmp_path / "ctl"
    proc = _cli("control", *SIX, "--controls", "right_sweep", "left_sweep", "--json", "--out", str(ctl_dir))
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["controls"] == [LATERAL_CONTROLS[1], LATERAL_CONTROLS[4]] and r["closed_loop_spectral_radius"] < 1
    assert np.asarray(r["gains"]).shape == (1, 2, 8) and len(r["cycle_x0"]) == 8 and r["degrees_of_freedom"] == 6
    proc = _cli("simulate", *SIX, "--controller", str(ctl_dir), "--beats", "6", "--side-gust", "pulse=1.5:1",
                "--perturb", "phi=0.05", "--json", "--out", str(tmp_path / "sim"))
    assert proc.returncode == 0, proc.stderr
    s = json.loads(proc.stdout)
    assert s["closed_loop"] and s["side_gust"]["amplitude_mps"] == 1.5 and len(s["deviation_per_beat"]) == 7
    assert s["deviation_per_beat"][-1] < s["peak_deviation"] and (tmp_path / "sim" / "simulation.png").stat().st_size


@pytest.mark.parametrize("argv, flag", [
    (["simulate", "--beats", "2", "--side-gust", "pulse=1:1"], "--side-gust"),
    (["simulate", *SIX, "--beats", "2", "--gust", "vertical=1:1", "--gust", "vertical=2:1"], "--gust"),
    (["simulate", *SIX, "--beats", "2", "--wind", "sideways=1"], "--wind"),
    (["simulate", *SIX, "--beats", "2", "--perturb", "yaw=1"], "--perturb"),
    (["control", *SIX, "--controls", "right_amplitude", "right_amplitude"], "--controls"),
])
def test_bad_six_dof_simulate_and_control_input_exits_2(argv, flag, tmp_path):
    proc = _cli(*argv, "--out", str(tmp_path / "run"))
    assert proc.returncode == 2 and flag in proc.stderr and not (tmp_path / "run").exists(), proc.stderr


@pytest.mark.slow
def test_control_cli_with_wing_masses_in_six_degrees_of_freedom(tmp_path):
    """``birdocp control`` with wing masses (0.086 kg per wing, their 3-D inertial terms): the 8-state
    map's monodromy holds the planar wing-mass cycle's multipliers (the masses are in the model), the
    closed loop M - B K (recomputed from the JSON) is the reported one and inside the unit circle while
    the open loop is not, and the gains are mirror-symmetric."""
    import json

    from birdocp.studies.trim import trim

    proc = _cli("control", *SIX, "--set", "wing.mass_kg=0.086", "--json", "--out", str(tmp_path / "ctl"))
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["success"] and r["degrees_of_freedom"] == 6 and r["cycle_symmetric"]
    M, B, K = (np.asarray(r[k]) for k in ("monodromy", "B_lifted", "gains"))
    assert r["open_loop_spectral_radius"] > 1.0 > r["closed_loop_spectral_radius"]
    assert np.max(np.abs(np.linalg.eigvals(M - B @ K[0]))) == pytest.approx(r["closed_loop_spectral_radius"], abs=1e-9)
    planar = trim(with_values(Config(), {"wing.mass_kg": 0.086}), points=3, steps_per_period=48)
    lam = np.linalg.eigvals(M)
    for z in planar.multipliers:
        assert np.min(np.abs(lam - z)) < 1e-7, (z, lam)
    np.testing.assert_allclose(K[0][3:], K[0][:3] * LAT8, rtol=0, atol=1e-9 * np.abs(K).max())
