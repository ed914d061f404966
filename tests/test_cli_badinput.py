"""Bad input through the real CLI (``python -m birdocp``): exit 2, one line on stderr naming the key.

Every case must be rejected before the model is touched: the second test runs the same table with
``birdocp.bird.model``, ``birdocp.studies.trim`` and ``casadi`` made unimportable.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

FILES = {
    "sens/result.json": '{"success": true, "status": "ok", "provenance": {"command": "sensitivity"}}',
    "bad.toml": "[body]\nmass_kg = \n",
    "unknown.toml": '[aero]\ncirculaton = "exact"\n',
    "a_file": "not a folder\n",
}

# (id, argv, key that must be named, other text that must appear)
CASES = [
    ("unknown-set-key", ["trim", "--set", "body.mas_kg=1.3"], "body.mas_kg", "did you mean 'body.mass_kg'"),
    ("wrong-type", ["trim", "--set", "body.mass_kg=heavy"], "body.mass_kg", "expected a number"),
    ("nan-amplitude", ["trim", "--amplitude", "nan"], "gait.shoulder_flap.amplitude_deg", "--amplitude"),
    ("inf-root-ahead", ["forces", "--state", "18", "0.5", "0", "0", "--time", "0", "--root-ahead", "inf"],
     "wing.root_ahead_m", "finite"),
    ("negative-mass", ["trim", "--set", "body.mass_kg=-1"], "body.mass_kg", "> 0"),
    ("steps-not-multiple", ["trim", "--points", "4", "--steps", "100"], "solve.steps_per_period", "points - 1 = 3"),
    ("steps-not-multiple-set", ["trim", "--set", "solve.points=4", "--set", "solve.steps_per_period=100"],
     "solve.steps_per_period", "multiple"),
    ("missing-config", ["trim", "missing.toml"], "CONFIG", "missing.toml"),
    ("malformed-toml", ["trim", "bad.toml"], "bad.toml", "not valid TOML"),
    ("unknown-key-in-file", ["trim", "unknown.toml"], "aero.circulaton", "did you mean 'aero.circulation'"),
    ("points-below-2", ["trim", "--points", "1"], "solve.points", ">= 2"),
    ("unknown-key-no-suggestion", ["trim", "--set", "zzz=1"], "zzz", "'birdocp config' prints every key"),
    ("sweep-level-option-without-level", ["sweep", "amplitude", "--from", "40", "--to", "41", "--by", "1",
                                          "--bounds", "amplitude=20:70"], "--bounds", "add --level"),
    ("level-climb-rate-with-forward-speed", ["level", "--constrain", "forward_speed_mps", "--target", "18",
                                             "--climb-rate", "1"], "--climb-rate", "drop --climb-rate"),
    ("level-target-and-climb-rate", ["level", "--climb-rate", "1", "--target", "2"], "--target", "one of them"),
    ("sensitivity-level-amplitude", ["sensitivity", "--level", "--param", "amplitude"], "--param", "drop it"),
    ("sensitivity-unknown-param", ["sensitivity", "--param", "zzz"], "--param", "a model parameter"),
    ("out-empty", ["trim", "--out", ""], "--out", "not a usable path"),   # was taken for no --out: runs/...
    ("export-out-empty", ["export-c", "--out", ""], "--out", "not a usable path"),
    ("plot-a-run-it-cannot-draw", ["plot", "sens"], "RUN_DIR", "plot draws trim, level"),
    ("unrecognized-option", ["sensitivity", "--steps", "60"], "--steps", "see 'birdocp sensitivity --help'"),
    ("fd-needs-lm", ["trim", "--derivatives", "fd"], "solve.derivatives", "--solver lm"),  # was an internal error
    ("level-negative-forward-speed", ["level", "--constrain", "forward_speed_mps", "--target", "-5"], "--target",
     "> 0 m/s"),  # was a failed solve (exit 1) after ~20 s
    ("negative-list-index", ["config", "--set", "wing.feather_lengths_m.-1=0.3"], "wing.feather_lengths_m.-1",
     "index must be 0..6"),  # set the last feather
    ("jobs-and-scheduler", ["sweep", "amplitude", "--from", "41", "--to", "42", "--by", "1", "--rows",
                            "root_ahead_m=0.04:0.05:0.01", "--jobs", "2", "--scheduler", "tcp://127.0.0.1:1"],
     "--scheduler", "give one of them"),  # --jobs was silently ignored
    ("circulation-typo", ["trim", "--set", "aero.circulation=exat"], "aero.circulation", "exact, relaxed"),
    ("set-without-equals", ["config", "--set", "body.mass_kg"], "--set", "KEY=VALUE"),
    ("nan-state", ["forces", "--state", "18", "nan", "0", "0", "--time", "0"], "--state", "finite"),
    ("inf-time", ["forces", "--state", "18", "0.5", "0", "0", "--time", "inf"], "--time", "finite"),
    ("out-is-a-file", ["trim", "--out", "a_file"], "--out", "existing file"),
    ("argparse-bad-int", ["trim", "--points", "four"], "--points", "invalid int"),
    ("argparse-bad-choice", ["trim", "--solver", "newton"], "--solver", "invalid choice"),
    ("config-cmd-bad-set", ["config", "--set", "gait.shoulder_flap.amplitude_deg=200"],
     "gait.shoulder_flap.amplitude_deg", "[-180, 180]"),
    ("six-dof-value", ["trim", "--set", "model.degrees_of_freedom=5"], "model.degrees_of_freedom", "4 or 6"),
    ("six-dof-forces-state-count", ["forces", "--state", "18", "0", "0", "0", "--time", "0", "--set",
                                    "model.degrees_of_freedom=6"], "--state", "9 values u v w p q r phi theta psi"),
    ("forces-state-count", ["forces", "--state", "18", "0", "0", "--time", "0"], "--state", "4 values u w q theta"),
    ("six-dof-unsteady-wing-mass", ["trim", "--set", "model.degrees_of_freedom=6", "--set", "aero.unsteady=wagner",
                                    "--set", "wing.mass_kg=0.1"], "aero.unsteady", "wing masses"),
    ("six-dof-level-free", ["level", "--set", "model.degrees_of_freedom=6", "--free", "root_ahead_m"], "--free",
     "amplitude only"),
    ("six-dof-inertia", ["trim", "--set", "model.product_inertia_xz_kgm2=0.5"], "model.product_inertia_xz_kgm2",
     "sqrt(I_xx I_zz)"),
]

# Rejected before any computation, but after casadi is imported (the command's key resolution uses it).
LATE_IMPORT_CASES = [
    ("continue-climb-rate-without-level", ["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04",
                                           "--climb-rate", "1"], "--climb-rate", "add --level"),
    ("optimize-free-amplitude", ["optimize-stability", "--free", "amplitude"], "--free", "free other keys"),
    ("six-dof-simulate-wagner-step-gust", ["simulate", "--beats", "2", "--side-gust", "step=2", "--set",
                                           "model.degrees_of_freedom=6", "--set", "aero.unsteady=wagner"],
     "--side-gust", "use a pulse"),
    ("simulate-gust-start-without-gust", ["simulate", "--beats", "2", "--gust-start", "3"], "--gust-start",
     "add --gust"),
    # checked on the model (get_model) before the run folder is claimed (runs/ was created, then emptied)
    ("optimize-value-outside-bounds", ["optimize-stability", "--bounds", "gait.shoulder_sweep.offset_deg=1:2"],
     "gait.shoulder_sweep.offset_deg", "widen --bounds"),
    ("optimize-free-reshapes-the-wing", ["optimize-stability", "--free", "gait.elbow_flex.offset_deg", "--bounds",
                                         "gait.elbow_flex.offset_deg=0:40"], "gait.elbow_flex.offset_deg", "free shoulder"),
]

BLOCK = (
    "import runpy, sys\n"
    "for name in ('casadi', 'birdocp.bird.model', 'birdocp.studies.trim'):\n"
    "    sys.modules[name] = None  # importing it now raises ImportError\n"
    "sys.argv[0] = 'birdocp'\n"
    "runpy.run_module('birdocp', run_name='__main__', alter_sys=True)\n"
)


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


@pytest.fixture
def workdir(tmp_path):
    for name, text in FILES.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    return tmp_path


def _check(proc, key: str, text: str) -> None:
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert proc.stdout == ""
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    line = lines[0]
    assert line.startswith("birdocp: error: "), line
    assert key in line, line
    assert text in line, line


@pytest.mark.parametrize("argv,key,text", [c[1:] for c in CASES + LATE_IMPORT_CASES],
                         ids=[c[0] for c in CASES + LATE_IMPORT_CASES])
def test_bad_input_exits_2_with_one_line(workdir, argv, key, text):
    proc = subprocess.run([sys.executable, "-m", "birdocp", *argv], cwd=workdir, env=_env(),
                          capture_output=True, text=True, timeout=60)
    _check(proc, key, text)
    assert not (workdir / "runs").exists()  # nothing written, not even an empty runs/


@pytest.mark.parametrize("argv,key,text", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_rejected_before_the_model_is_imported(workdir, argv, key, text):
    proc = subprocess.run([sys.executable, "-c", BLOCK, *argv], cwd=workdir, env=_env(),
                          capture_output=True, text=True, timeout=60)
    _check(proc, key, text)


def test_an_unreachable_scheduler_is_bad_input(workdir):
    """It was 'internal error: OSError: Timed out ...' (exit 1) after claiming the run folder."""
    pytest.importorskip("distributed")
    env = dict(_env(), DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT="1s")
    proc = subprocess.run([sys.executable, "-m", "birdocp", "sweep", "amplitude", "--from", "41", "--to", "42",
                           "--by", "1", "--rows", "root_ahead_m=0.04:0.05:0.01", "--scheduler", "tcp://127.0.0.1:1"],
                          cwd=workdir, env=env, capture_output=True, text=True, timeout=120)
    _check(proc, "--scheduler", "cannot reach 'tcp://127.0.0.1:1'")
    assert not (workdir / "runs").exists()


def test_debug_shows_the_traceback(workdir):
    proc = subprocess.run([sys.executable, "-m", "birdocp", "trim", "--debug", "--set", "body.mass_kg=-1"],
                          cwd=workdir, env=_env(), capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "Traceback" in proc.stderr
    assert proc.stderr.strip().splitlines()[-1].startswith("birdocp: error: body.mass_kg")


def test_help_works_without_the_model(workdir):
    for argv in ([], ["forces"], ["trim"], ["config"]):
        proc = subprocess.run([sys.executable, "-c", BLOCK, *argv, "--help"], cwd=workdir, env=_env(),
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0, proc.stderr
        assert "usage: birdocp" in proc.stdout


def test_negative_numbers_in_scientific_notation_are_values():
    """``--time -1e-3`` and ``--to -3.25e1`` are numbers, not unknown options (argparse's own pattern
    knows only -1 and -0.5); a word after a dash is still an option."""
    from birdocp.cli.main import build_parser

    p = build_parser()
    assert p.parse_args(["forces", "--state", "18", "-5e-1", "0", "0", "--time", "-1e-3"]).time == -1e-3
    a = p.parse_args(["continue", "stability_margin", "--from", "-2.5e1", "--to", "-3.25E1"])
    assert (a.start, a.stop) == (-25.0, -32.5)
    with pytest.raises(SystemExit):
        p.parse_args(["forces", "--state", "18", "0", "0", "0", "--time", "-x"])
