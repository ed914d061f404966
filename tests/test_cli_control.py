"""birdocp control / simulate: documented --json keys, run folders, and bad input (exit 2, one line,
no traceback) or a failed result with a status."""

import json

import pytest

from birdocp.cli.main import main

FAST = ["--set", "solve.steps_per_period=48", "--set", "solve.points=3"]


def _run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


@pytest.fixture(scope="module")
def controller_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("ctl") / "run"


def test_control_and_simulate_json(capsys, controller_dir, tmp_path):
    code, out, err = _run(capsys, ["control", *FAST, "--json", "--out", str(controller_dir)])
    assert code == 0, err
    r = json.loads(out)
    for key in ("success", "status", "open_loop_multipliers", "closed_loop_multipliers", "controls", "gain",
                "controllable"):
        assert key in r
    assert r["success"] and len(r["gain"]) == len(r["controls"]) == 3 and len(r["gain"][0]) == 4
    ol = [complex(*z) for z in r["open_loop_multipliers"]]
    cl = [complex(*z) for z in r["closed_loop_multipliers"]]
    assert abs(ol[0]) > 1 > abs(cl[0]) and all(abs(a) >= abs(b) for a, b in zip(cl, cl[1:]))
    assert (controller_dir / "result.json").exists() and (controller_dir / "multipliers.png").exists()

    code, out, err = _run(capsys, ["simulate", *FAST, "--beats", "6", "--perturb", "w=0.01", "--gust",
                                   "vertical=1:1", "--controller", str(controller_dir), "--json",
                                   "--out", str(tmp_path / "sim")])
    assert code == 0, err
    s = json.loads(out)
    for key in ("success", "status", "deviation_per_beat", "final_deviation", "saturated", "run_dir"):
        assert key in s
    assert len(s["deviation_per_beat"]) == 7 and s["deviation_per_beat"][0] == pytest.approx(0.01)
    assert s["closed_loop"] and s["final_deviation"] == s["deviation_per_beat"][-1]
    assert (tmp_path / "sim" / "simulation.png").exists() and (tmp_path / "sim" / "arrays.npz").exists()

    # another configuration than the controller's: refused before any computation
    code, out, err = _run(capsys, ["simulate", *FAST, "--amplitude", "40", "--beats", "2", "--controller",
                                   str(controller_dir), "--out", str(tmp_path / "other")])
    assert code == 2 and "--controller" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "other").exists()


def test_gust_making_the_simulation_diverge_is_a_failed_result(capsys, tmp_path):
    code, out, err = _run(capsys, ["simulate", *FAST, "--beats", "3", "--gust", "vertical=60:1", "--json",
                                   "--out", str(tmp_path / "g")])
    assert code == 1
    s = json.loads(out)
    assert s["success"] is False and s["status"] in ("diverged", "left_validity")
    assert s["status"] != "diverged" or s["diverged_beat"] in (1, 2, 3)
    assert json.loads((tmp_path / "g" / "result.json").read_text())["status"] == s["status"]


@pytest.mark.parametrize("argv, field", [
    (["control", "--controls", "gait.shoulder_flap.amplitud_deg"], "--controls"),
    (["control", "--controls", "body.mass_kg"], "--controls"),
    (["control", "--updates-per-beat", "0"], "--updates-per-beat"),
    (["control", "--updates-per-beat", "5"], "--updates-per-beat"),  # does not divide 148 steps
    (["simulate", "--beats", "0"], "--beats"),
    (["simulate", "--beats", "2", "--perturb", "v=1"], "--perturb"),
    (["simulate", "--beats", "2", "--gust", "sideways=1:1"], "--gust"),
    (["simulate", "--beats", "2", "--gust", "vertical=1:0"], "--gust"),
    (["simulate", "--beats", "2", "--controller", "/nonexistent/folder"], "--controller"),
])
def test_bad_input_exit_2_one_line(capsys, tmp_path, argv, field):
    out_dir = tmp_path / "never"
    code, out, err = _run(capsys, [*argv, "--out", str(out_dir)])
    assert code == 2
    assert field in err and len(err.strip().splitlines()) == 1
    assert not out_dir.exists()


def test_a_control_without_effect_is_a_failed_result(capsys, tmp_path):
    # wrist_spread has zero amplitude: its phase moves nothing, the expanding mode stays
    code, out, err = _run(capsys, ["control", *FAST, "--controls", "gait.wrist_spread.phase_deg", "--json",
                                   "--out", str(tmp_path / "c")])
    assert code == 1
    r = json.loads(out)
    assert r["success"] is False and r["status"] == "not_stabilised"
    assert r["controllable"] == {"gait.wrist_spread.phase_deg": False}
    assert abs(complex(*r["closed_loop_multipliers"][0])) > 1
