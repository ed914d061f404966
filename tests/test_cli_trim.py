"""The trim/forces/config commands in-process, with stand-ins for the model and the trim study.

The stand-ins keep these tests fast and independent of the solver; they check the CLI's plumbing:
stdout holds exactly one JSON object with --json (even when the solver prints at the C level), the
run folder is complete, exit codes 0/1/2/130, and no empty run folder is left behind on a crash.
"""

from __future__ import annotations

import json
from pathlib import Path
import os
import sys
import types

import numpy as np
import pytest

from birdocp.bird import config as C
from birdocp.cli import main as cli


class FakeResult:
    def __init__(self, cfg, success=True):
        self.cfg = cfg
        self.success = success
        self.status = "Solve_Succeeded" if success else "Maximum_Iterations_Exceeded"
        self.message = "converged" if success else "too many iterations"

    def to_dict(self):
        return {
            "success": self.success, "status": self.status, "message": self.message,
            "multipliers": [[1.2, 0.0], [0.5, 0.3], [0.5, -0.3], [1e-3, 0.0]],
            "moduli": [1.2, 0.583, 0.583, 1e-3],
            "floquet_exponents": [[0.73, 0.0], [-2.16, 2.16], [-2.16, -2.16], [-27.6, 0.0]],
            "doubling_times_s": [0.95, -0.32, -0.32, -0.025],
            "stable": False, "x0": [18.1, 0.4, 0.05, 0.02], "iterations": 7,
            "residual_history": [1.0, 1e-3, 1e-9] if self.success else [1.0, 0.5],
            "max_residual": 1e-9 if self.success else 0.5,
            "mean_vertical_speed_mps": -0.01, "mean_forward_speed_mps": 18.0,
            "flight_path_angle_deg": -0.03, "wall_s": {"build": 0.1, "solve": 0.2},
            "shooting_points": self.cfg.solve.points,
            "trajectory_t": [0.0, 0.125, 0.25], "trajectory_x": [[18.0, 0.4, 0.0, 0.0]] * 3,
            "amplitude_seen": self.cfg.gait.shoulder_flap.amplitude_deg,
            "nan_value": float("nan"),
        }

    def arrays(self):
        return {"t": np.linspace(0, 0.25, 3), "x": np.ones((3, 4)), "monodromy": np.eye(4)}


@pytest.fixture
def fake_studies(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    mod = types.ModuleType("birdocp.studies.trim")
    mod.calls = []
    mod.compiled = []
    mod.behaviour = {"success": True, "raise": None}

    def trim(cfg, x_guess=None, warm_start=None, compiled=False):
        mod.calls.append(cfg)
        mod.compiled.append(compiled)
        print("IPOPT-like progress on Python stdout")
        os.write(1, b"IPOPT-like progress on fd 1\n")
        if mod.behaviour["raise"] is not None:
            raise mod.behaviour["raise"]
        return FakeResult(cfg, mod.behaviour["success"])

    mod.trim = trim
    monkeypatch.setitem(sys.modules, "birdocp.studies.trim", mod)
    return mod


@pytest.fixture
def fake_model(monkeypatch):
    mod = types.ModuleType("birdocp.bird.model")

    class Model:
        p0 = np.zeros(3)

        def evaluate(self, state, t, p=None):
            u, w, q, th = state
            return {"Fx_N": np.array([[1.5]]), "Fz_N": -11.0 - u, "My_Nm": 0.25 * t,
                    "xdot": np.array([0.1, 0.2, 0.3, q])}

    mod.get_model = lambda cfg: Model()
    monkeypatch.setitem(sys.modules, "birdocp.bird.model", mod)
    return mod


def _run_dirs(base):
    return sorted(p for p in (base / "runs").iterdir()) if (base / "runs").exists() else []


def test_trim_json_is_the_only_stdout_and_the_run_folder_is_complete(fake_studies, tmp_path, capfd):
    code = cli.main(["trim", "--json", "--amplitude", "30", "--points", "3", "--steps", "150"])
    out, err = capfd.readouterr()
    assert code == 0, err
    assert out.count("\n") == 1
    res = json.loads(out)
    assert "IPOPT-like progress on fd 1" in err and "IPOPT-like progress on Python stdout" in err
    assert res["success"] is True and res["amplitude_seen"] == 30.0 and res["shooting_points"] == 3
    assert res["nan_value"] is None
    assert res["wall_s"]["total"] > 0 and res["wall_s"]["solve"] == 0.2
    (run,) = _run_dirs(tmp_path)
    assert res["run_dir"] == str(run.relative_to(tmp_path))
    assert "-trim-" in run.name
    assert sorted(p.name for p in run.iterdir()) == ["arrays.npz", "config.toml", "result.json"]
    cfg = C.load(run / "config.toml")
    assert cfg == fake_studies.calls[0]
    assert cfg.gait.shoulder_flap.amplitude_deg == 30.0 and cfg.solve.steps_per_period == 150
    stored = json.loads((run / "result.json").read_text())
    prov = stored.pop("provenance")
    assert stored == res
    assert prov["command"] == "trim"
    assert prov["command_line"][:2] == ["birdocp", "trim"]
    assert prov["config"] == C.to_dict(cfg)
    with np.load(run / "arrays.npz") as z:
        assert np.array_equal(z["monodromy"], np.eye(4))


def test_trim_table(fake_studies, tmp_path, capfd):
    code = cli.main(["trim", "--out", "here"])
    out, err = capfd.readouterr()
    assert code == 0, err
    assert "IPOPT-like" not in out
    for text in ("Floquet multipliers", "modulus", "doubles in 0.95 s", "halves in 0.32 s",
                 "unstable", "18.0000 m/s", "flight path angle", "iterations", "max residual",
                 "wall time", "here"):
        assert text in out, text
    assert (tmp_path / "here" / "result.json").is_file()


def test_not_converged_exits_1_and_still_writes(fake_studies, tmp_path, capfd):
    fake_studies.behaviour["success"] = False
    code = cli.main(["trim", "--json"])
    out, err = capfd.readouterr()
    assert code == 1
    res = json.loads(out)
    assert res["success"] is False
    last = err.strip().splitlines()[-1]
    assert last.startswith("birdocp: trim did not converge")
    assert "Maximum_Iterations_Exceeded" in last and "5.000e-01" in last
    (run,) = _run_dirs(tmp_path)
    assert (run / "result.json").is_file() and str(run.relative_to(tmp_path)) in last


def test_out_refuses_a_non_empty_folder_and_a_previous_run(fake_studies, tmp_path, capfd):
    assert cli.main(["trim", "--out", "r1"]) == 0
    capfd.readouterr()
    assert cli.main(["trim", "--out", "r1"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and "previous 'trim' run" in err
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("x")
    assert cli.main(["trim", "--out", "other"]) == 2
    assert "not empty" in capfd.readouterr().err
    (tmp_path / "empty").mkdir()
    assert cli.main(["trim", "--out", "empty"]) == 0
    assert len(fake_studies.calls) == 2  # the refused runs never reached the solver


def test_unexpected_error_one_line_exit_3_naming_the_log_and_no_empty_run_folder(fake_studies, tmp_path, capfd,
                                                                                 monkeypatch):
    monkeypatch.setenv("BIRDOCP_LOG_DIR", str(tmp_path / "logs"))
    fake_studies.behaviour["raise"] = RuntimeError("boom\nsecond line")
    assert cli.main(["trim"]) == 3
    err = capfd.readouterr().err
    last = err.strip().splitlines()[-1]
    prefix = "birdocp: internal error: RuntimeError: boom second line; the traceback is in "
    assert last.startswith(prefix), last
    log = Path(last[len(prefix):])
    assert log.parent == tmp_path / "logs"
    text = log.read_text()
    assert "Traceback (most recent call last)" in text and "RuntimeError: boom" in text and "birdocp trim" in text
    assert "Traceback" not in err
    assert _run_dirs(tmp_path) == []


def test_keyboard_interrupt_exits_130(fake_studies, tmp_path, capfd):
    fake_studies.behaviour["raise"] = KeyboardInterrupt()
    assert cli.main(["trim"]) == 130
    assert capfd.readouterr().err.strip().splitlines()[-1] == "birdocp: interrupted"
    assert _run_dirs(tmp_path) == []


def test_forces_json_and_table(fake_model, capfd):
    assert cli.main(["forces", "--state", "18", "0.5", "0.1", "0.01", "--time", "0.1", "--json"]) == 0
    out = capfd.readouterr().out
    res = json.loads(out)
    assert list(res) == ["Fx_N", "Fz_N", "My_Nm", "xdot", "success", "status"]
    assert res == {"Fx_N": 1.5, "Fz_N": -29.0, "My_Nm": 0.025, "xdot": [0.1, 0.2, 0.3, 0.1], "success": True,
                   "status": "ok"}
    assert cli.main(["forces", "--state", "18", "0.5", "0.1", "0.01", "--time", "0.1"]) == 0
    out = capfd.readouterr().out
    for text in ("Fx", "1.5 N", "-29 N", "0.025 N m", "du/dt", "m/s^2", "rad/s^2", "dtheta/dt"):
        assert text in out, text


def test_config_resolution_order(tmp_path, capfd):
    f = tmp_path / "c.toml"
    f.write_text("[gait.shoulder_flap]\namplitude_deg = 20.0\n[body]\nmass_kg = 1.5\n")
    argv = ["config", str(f), "--set", "gait.shoulder_flap.amplitude_deg=25", "--set", "body.mass_kg=1.4",
            "--amplitude", "35", "--json"]
    assert cli.main(argv) == 0
    d = json.loads(capfd.readouterr().out)
    assert d["gait"]["shoulder_flap"]["amplitude_deg"] == 35.0  # flag beats --set beats file
    assert d["body"]["mass_kg"] == 1.4  # --set beats file
    assert d["wing"]["root_ahead_m"] == C.Config().wing.root_ahead_m  # default
    # the TOML output round-trips
    assert cli.main(["config", str(f)]) == 0
    text = capfd.readouterr().out
    assert C.loads(text) == C.load(f)


def test_a_partial_table_in_a_config_file_keeps_the_other_defaults(tmp_path, capfd):
    """A file that sets one key of a joint means the same as --set of that key: the joint's other
    values stay the reference gait's (they were reset to Joint()'s zeros: phase 180 -> 0)."""
    f = tmp_path / "c.toml"
    f.write_text("[gait.shoulder_flap]\namplitude_deg = 45.0\n[gait.shoulder_incidence]\nphase_deg = -80.0\n")
    assert cli.main(["config", str(f), "--json"]) == 0
    from_file = json.loads(capfd.readouterr().out)
    assert cli.main(["config", "--json", "--set", "gait.shoulder_flap.amplitude_deg=45",
                     "--set", "gait.shoulder_incidence.phase_deg=-80"]) == 0
    from_set = json.loads(capfd.readouterr().out)
    assert from_file == from_set
    ref = C.Config().gait
    assert from_file["gait"]["shoulder_flap"] == {"offset_deg": ref.shoulder_flap.offset_deg, "amplitude_deg": 45.0,
                                                  "phase_deg": ref.shoulder_flap.phase_deg}
    assert from_file["gait"]["shoulder_incidence"]["offset_deg"] == ref.shoulder_incidence.offset_deg != 0


def test_a_config_file_with_a_byte_order_mark_is_read(tmp_path, capfd):
    """Windows editors start UTF-8 files with a BOM; TOML parsers refused it ('Invalid statement')."""
    f = tmp_path / "bom.toml"
    f.write_bytes("\ufeff[body]\nmass_kg = 1.3\n".encode("utf-8"))
    assert cli.main(["config", str(f), "--json"]) == 0
    assert json.loads(capfd.readouterr().out)["body"]["mass_kg"] == 1.3
    assert C.load(f).body.mass_kg == 1.3


def test_forces_with_the_real_model(tmp_path):
    """Smoke test of the real model through ``python -m birdocp`` (catches drift of the model API)."""
    import subprocess
    from pathlib import Path

    pytest.importorskip("birdocp.bird.model")
    repo = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(repo), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-m", "birdocp", "forces", "--state", "18", "0.5", "0.1", "0.01",
                           "--time", "0.05", "--json"], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(proc.stdout)
    assert list(res) == ["Fx_N", "Fz_N", "My_Nm", "xdot", "success", "status"] and len(res["xdot"]) == 4
    assert all(np.isfinite(v) for v in [res["Fx_N"], res["Fz_N"], res["My_Nm"], *res["xdot"]])
    assert res["xdot"][3] == pytest.approx(0.1)  # dtheta/dt = q
