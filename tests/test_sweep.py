"""Sweeps: warm starts give the cold-start cycles; an interrupted sweep resumes to the same table."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import birdocp.studies.trim
from birdocp.bird.config import Config, ConfigError
from birdocp.studies.sweep import read_points, sweep, sweep_values

VALUES = [42.5, 43.0, 43.5, 44.0]
REPO = Path(__file__).resolve().parents[1]


def _points(folder):
    pts = read_points(folder)
    return [pts[i] for i in sorted(pts)]


def test_sweep_values():
    assert sweep_values(40, 41, 0.5) == [40.0, 40.5, 41.0]
    assert sweep_values(41, 40, 0.5) == [41.0, 40.5, 40.0]
    assert sweep_values(40, 46, 0.5)[-1] == 46.0 and len(sweep_values(40, 46, 0.5)) == 13
    for bad in ((40, 41, 0), (40, float("nan"), 1), (40, 41, -1)):
        with pytest.raises(ConfigError):
            sweep_values(*bad)


def test_warm_started_sweep_gives_the_cold_start_cycles(tmp_path, coarse):
    warm = sweep(Config(), "amplitude", VALUES[:3], out_dir=tmp_path / "warm", progress=False, **coarse)
    cold = sweep(Config(), "amplitude", VALUES[:3], warm=False, out_dir=tmp_path / "cold", progress=False, **coarse)
    assert [r["success"] for r in warm + cold] == [True] * 6
    assert [r["warm_from"] for r in warm] == [None, 0, 1]
    assert [r["warm_from"] for r in cold] == [None, None, None]
    for pw, pc in zip(_points(tmp_path / "warm"), _points(tmp_path / "cold")):
        xw = np.asarray(pw["result"]["shooting_points"])
        xc = np.asarray(pc["result"]["shooting_points"])
        assert np.max(np.abs(xw - xc)) < 1e-8
        for k in range(4):
            assert pw["row"][f"modulus{k}"] == pytest.approx(pc["row"][f"modulus{k}"], abs=1e-8)
    assert sum(r["iterations"] for r in warm[1:]) <= sum(r["iterations"] for r in cold[1:])
    # W increases with the amplitude over this range (descending -> climbing)
    w = [r["mean_vertical_speed_mps"] for r in warm]
    assert w[0] < 0 < w[2]


def _table(folder):
    with open(folder / "sweep.csv") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r.pop("wall_s")
    return rows


def test_interrupted_sweep_resumes_to_the_same_table(tmp_path, monkeypatch, coarse):
    full = tmp_path / "full"
    part = tmp_path / "part"
    rows_full = sweep(Config(), "amplitude", VALUES, out_dir=full, progress=False, **coarse)

    real_trim = birdocp.studies.trim.trim
    calls = []

    def trim_then_interrupt(*a, **k):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(1)
        return real_trim(*a, **k)

    monkeypatch.setattr(birdocp.studies.trim, "trim", trim_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        sweep(Config(), "amplitude", VALUES, out_dir=part, progress=False, **coarse)
    monkeypatch.setattr(birdocp.studies.trim, "trim", real_trim)
    assert sorted(read_points(part)) == [0, 1]
    assert len(_table(part)) == 2

    with pytest.raises(ConfigError, match="already holds a sweep"):
        sweep(Config(), "amplitude", VALUES, out_dir=part, progress=False, **coarse)
    with pytest.raises(ConfigError, match="differs in values"):
        sweep(Config(), "amplitude", VALUES[:3], out_dir=part, resume=True, progress=False, **coarse)

    solved = []
    monkeypatch.setattr(birdocp.studies.trim, "trim", lambda *a, **k: solved.append(1) or real_trim(*a, **k))
    rows_resumed = sweep(Config(), "amplitude", VALUES, out_dir=part, resume=True, progress=False, **coarse)
    assert len(solved) == 2  # only the missing points
    assert _table(part) == _table(full)
    strip = [{k: v for k, v in r.items() if k != "wall_s"} for r in rows_full]
    assert [{k: v for k, v in r.items() if k != "wall_s"} for r in rows_resumed] == strip


BLOCKED = (
    "import runpy, sys\n"
    "for name in ('casadi', 'birdocp.bird.model', 'birdocp.studies.trim'):\n"
    "    sys.modules[name] = None\n"
    "sys.argv[0] = 'birdocp'\n"
    "runpy.run_module('birdocp', run_name='__main__', alter_sys=True)\n"
)


@pytest.mark.parametrize("argv, key, text", [
    (["sweep", "amplitud", "--from", "40", "--to", "41", "--by", "0.5"], "KEY", "did you mean 'amplitude'"),
    (["sweep", "amplitude", "--from", "40", "--to", "41", "--by", "0"], "--by", "positive"),
    (["sweep", "amplitude", "--from", "40", "--to", "inf", "--by", "1"], "--to", "finite"),
    (["sweep", "amplitude", "--from", "170", "--to", "190", "--by", "10"], "gait.shoulder_flap.amplitude_deg",
     "sweep value 190"),
    (["sweep", "root-ahead", "--from", "0", "--to", "0.1", "--by", "0.05", "--level", "--free", "root_ahead_m"],
     "KEY", "free parameter"),
    (["sweep", "amplitude", "--from", "40", "--to", "41", "--by", "1", "--resume"], "--resume", "--out"),
    (["level", "--free", "gait.shoulder_flap.amplitud"], "--free", "did you mean"),
    (["level", "--free", "body.mass_kg"], "--bounds", "no default range"),
    (["level", "--climb-rate", "nan"], "--climb-rate", "finite"),
])
def test_cli_bad_input_exits_2_before_the_model_is_imported(tmp_path, argv, key, text):
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", BLOCKED, *argv], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith(f"birdocp: error: {key}: "), lines[0]
    assert text in lines[0]
    assert p.stdout == ""
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())
