"""Outputs under faults, through the real command: a file-size limit (what a full disk does), an
interrupt while an earlier export is replaced, a closed or broken stdout, read-only targets,
numbers that overflow, a simulation that diverges, values outside their physical range, a broken
plotting backend or stream encoding, a second Ctrl-C during the clean-up.

The promises (docs/troubleshooting.md): an output appears whole or not at all; a write failure is
one line and exit 1; the exit code is the computation's whatever happens to stdout; bad input is
exit 2 before any work; an internal error is exit 3.
"""

from __future__ import annotations

import errno
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from birdocp.bird import config as C
from birdocp.cli.main import main

REPO = Path(__file__).resolve().parents[1]
COARSE = ["--points", "3", "--steps", "60"]
# a guess far from any cycle with the LM solver: a real solve that fails in about a second
FAILING = ["--set", "solve.points=3", "--set", "solve.steps_per_period=60", "--set", "solve.solver=lm",
           "--set", "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]"]
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))
# Runs the CLI after wrapping TARGET ("module:attr") so that its N-th call sends SIGINT to the process
# (the runner of scripts/hostile_cases.py, shared with tests/test_cli_faults.py).
sys.path.insert(0, str(REPO / "scripts"))
from hostile_cases import HOOK  # noqa: E402

sys.path.pop(0)


def _cli(argv, cwd, *, hook=None, env=None, **kw):
    cmd = [sys.executable, "-c", HOOK, *hook] if hook else [sys.executable, "-m", "birdocp"]
    return subprocess.run([*cmd, *argv], cwd=cwd, env=dict(ENV, **(env or {})), capture_output=True, text=True,
                          timeout=300, **kw)


def _size_limit(limit_bytes: int):
    def preexec():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write beyond the limit fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))
    return preexec


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def _temporaries(folder: Path) -> list[str]:
    return [str(p) for p in folder.rglob("*") if p.name.endswith((".tmp", ".old")) or ".stage-" in p.name
            or p.name == ".birdocp.lock"]


def _one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


@pytest.fixture
def earlier_export(tmp_path) -> Path:
    """A complete earlier export (the CLI accepts a folder with bird.h as one) and a user's own file."""
    out = tmp_path / "export"
    out.mkdir()
    for name in ("bird.h", "bird.c", "bird_data.c", "bird_casadi.c", "bird_casadi.h", "main.c", "Makefile"):
        (out / name).write_text(f"/* {name} of the earlier 148-step export */\n")
    (out / "notes.txt").write_text("mine\n")
    return out


# ---------------------------------------------------------------------------------------------
# Written whole: a file-size limit, an interrupt

@pytest.mark.slow
@pytest.mark.parametrize("command", ["export-c", "trim"])
def test_a_file_size_limit_is_one_line_exit_1_and_leaves_nothing_partial(tmp_path, earlier_export, command):
    if command == "export-c":
        argv, target = ["export-c", "--steps", "60", "--out", str(earlier_export)], earlier_export
        before = _snapshot(earlier_export)
    else:
        argv, target = ["trim", *COARSE, "--out", "run"], tmp_path / "run"
    p = _cli([*argv, "--json"], tmp_path, preexec_fn=_size_limit(8_000))
    assert p.returncode == 1, p.stderr
    line = _one_line(p.stderr)
    assert line.startswith("birdocp: error: cannot write") and "file-size limit" in line, line
    res = json.loads(p.stdout)
    assert res["success"] is False and res["status"] == "write_failed"
    if command == "export-c":
        assert _snapshot(earlier_export) == before  # the earlier export, whole; not a mix, not truncated
    else:
        assert not target.exists()  # no config.toml or arrays.npz without result.json
    assert _temporaries(tmp_path) == []


@pytest.mark.slow
def test_ctrl_c_while_export_c_replaces_an_earlier_export_leaves_it_whole(tmp_path, earlier_export):
    before = _snapshot(earlier_export)
    p = _cli(["export-c", "--steps", "60", "--out", str(earlier_export), "--json"], tmp_path,
             hook=("birdocp.export.codegen:_write_sources", "1"))  # bird_casadi.c written, the rest not yet
    assert p.returncode == 130, p.stderr
    assert json.loads(p.stdout)["status"] == "interrupted" and "Traceback" not in p.stderr
    assert _snapshot(earlier_export) == before
    assert _temporaries(tmp_path) == []


def test_atomic_folder_replaces_a_folder_whole_and_keeps_the_users_files(tmp_path):
    from birdocp.io.files import atomic_folder

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.c").write_text("old")
    (out / "notes.txt").write_text("mine")
    for failure in (KeyboardInterrupt(), OSError(errno.ENOSPC, "No space left on device")):
        with pytest.raises(type(failure)):
            with atomic_folder(out, carry=lambda n: n == "notes.txt") as tmp:
                (tmp / "a.c").write_text("new, half")
                raise failure
        assert _snapshot(out) == {"a.c": b"old", "notes.txt": b"mine"}
    with atomic_folder(out, carry=lambda n: n == "notes.txt") as tmp:
        (tmp / "a.c").write_text("new")
        (tmp / "b.c").write_text("new")
    assert _snapshot(out) == {"a.c": b"new", "b.c": b"new", "notes.txt": b"mine"}
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_run_folder_gets_all_its_files_or_none(tmp_path, monkeypatch):
    from birdocp.io import runs

    real = np.savez

    def full_disk(fh, **arrays):
        real(fh, **arrays)
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez", full_disk)
    with pytest.raises(OSError):
        runs.write_run(tmp_path, C.Config(), {"success": True}, {"x": np.ones(3)}, ["birdocp"], command="trim")
    assert list(tmp_path.iterdir()) == []  # not config.toml without result.json


def test_ctrl_c_during_a_cold_cache_write_leaves_no_temporary_files(tmp_path):
    import casadi as ca

    from birdocp.engine import graphcache

    class Interrupted:
        def serialize(self):
            raise KeyboardInterrupt

    x = ca.SX.sym("x")
    with pytest.raises(KeyboardInterrupt):
        graphcache.store("test", {"k": 1}, {"f": ca.Function("f", [x], [x]), "g": Interrupted()}, directory=tmp_path)
    assert [str(p) for p in tmp_path.rglob("*") if p.is_file() or p.name.startswith(".")] == []


# ---------------------------------------------------------------------------------------------
# The exit code never depends on stdout

@pytest.mark.slow
@pytest.mark.parametrize("command, stdout", [
    (["trim", *FAILING], "broken pipe"),
    (["sweep", "amplitude", "--from", "42", "--to", "42", "--by", "1", *FAILING], "closed"),
    (["control", *FAILING], "broken pipe"),
    (["forces", "--state", "1e300", "1e300", "0", "0", "--time", "0"], "closed"),
])
def test_a_failure_is_exit_1_whatever_happens_to_stdout(tmp_path, command, stdout):
    out = ["--out", "run"] if command[0] != "forces" else []
    argv = [sys.executable, "-m", "birdocp", *command, *out, "--json"]
    if stdout == "closed":  # birdocp ... >&-
        p = subprocess.run(argv, cwd=tmp_path, env=ENV, stderr=subprocess.PIPE, text=True, timeout=300,
                           preexec_fn=lambda: os.close(1))
    else:  # birdocp ... --json | true: the reader exits before the JSON is written
        r, w = os.pipe()
        os.close(r)
        p = subprocess.run(argv, cwd=tmp_path, env=ENV, stdout=w, stderr=subprocess.PIPE, text=True, timeout=300)
        os.close(w)
    assert p.returncode == 1, p.stderr
    assert "Traceback" not in p.stderr and "internal error" not in p.stderr
    if out:
        assert json.loads((tmp_path / "run" / "result.json").read_text())["success"] is False


def test_a_success_is_exit_0_into_a_broken_pipe(tmp_path):
    r, w = os.pipe()
    os.close(r)
    p = subprocess.run([sys.executable, "-m", "birdocp", "config"], cwd=tmp_path, env=ENV, stdout=w,
                       stderr=subprocess.PIPE, text=True, timeout=120)
    os.close(w)
    assert p.returncode == 0 and p.stderr == ""


# ---------------------------------------------------------------------------------------------
# Checked before any work

def _cycle_folder(folder: Path) -> Path:
    """A trim run folder holding a cycle (what animate and plot read), written through write_run."""
    from birdocp.io.runs import write_run

    t = np.linspace(0.0, 0.25, 9)
    x = np.column_stack([18 + 0.1 * np.sin(8 * np.pi * t), 0.5 + 0 * t, 0.1 + 0 * t, 0.01 + 0 * t])
    write_run(folder, C.Config(), {"success": True, "status": "Solve_Succeeded", "x0": x[0].tolist()},
              {"trajectory_t_s": t, "trajectory_x": x}, ["birdocp", "trim"], command="trim")
    return folder


def test_read_only_targets_are_exit_2_before_drawing(tmp_path, monkeypatch, capfd):
    """A read-only file system (simulated with EROFS on the probe write: the tests may run as root, for
    whom permission bits do not stop a write) for animate --out and for plot's run folder."""
    import tempfile

    from birdocp.plots import animation

    monkeypatch.chdir(tmp_path)
    run = _cycle_folder(tmp_path / "run")
    (tmp_path / "ro").mkdir()
    real = tempfile.mkstemp

    def read_only(*a, dir=None, **k):
        if dir is not None and Path(dir).name in ("ro", "run"):
            raise OSError(errno.EROFS, "Read-only file system", str(dir))
        return real(*a, dir=dir, **k)

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    drawn = []
    monkeypatch.setattr(animation, "save_animation", lambda *a, **k: drawn.append(a))
    for argv, key in ((["animate", str(run), "--out", "ro/a.gif"], "--out"), (["animate", str(run)], "RUN_DIR"),
                      (["plot", str(run)], "RUN_DIR")):
        assert main(argv) == 2, argv
        line = _one_line(capfd.readouterr().err)
        assert line.startswith(f"birdocp: error: {key}:") and "read-only" in line, line
    assert drawn == [] and sorted(p.name for p in run.iterdir()) == ["arrays.npz", "config.toml", "result.json"]


@pytest.mark.parametrize("argv, key", [
    (["simulate", "--beats", "2", "--perturb", "u=1e308"], "--perturb"),
    (["simulate", "--beats", "2", "--perturb", "q=1e5"], "--perturb"),
    (["simulate", "--beats", "2", "--gust", "vertical=1e9:1"], "--gust"),
    (["simulate", "--beats", "2", "--gust", "vertical=3:1e-300"], "--gust"),
    (["simulate", "--beats", "2", "--gust", "horizontal=3:1e300m"], "--gust"),
    (["simulate", "--beats", "2", "--gust", "vertical=3:1", "--gust-start", "1e300"], "--gust-start"),
    (["simulate", "--beats", "2", "--wind", "vertical=1e300"], "--wind"),
    (["animate", "RUN", "--fps", "1e-300"], "--fps"),
    (["animate", "RUN", "--fps", "1e300"], "--fps"),
    (["animate", "RUN", "--frames", "100000000000000000000"], "--frames"),
    (["trim", "--set", "body.gravity_mps2=0"], "body.gravity_mps2"),
    (["trim", "--set", "aero.air_density_kgm3=0"], "aero.air_density_kgm3"),
    (["trim", "--set", "body.mass_kg=1e300"], "body.mass_kg"),
    (["trim", "--set", "body.mass_kg=1" + "0" * 400], "body.mass_kg"),
    (["trim", "--set", "solve.initial_guess=[1e300, 0.0, 0.0, 0.0]"], "solve.initial_guess.0"),
    (["optimize-stability", "--free", "body.mass_kg", "--bounds", "body.mass_kg=-1:2"], "body.mass_kg"),
])
def test_overflowing_and_unphysical_values_are_exit_2_before_any_work(tmp_path, monkeypatch, capfd, argv, key):
    import birdocp.bird.model as model

    monkeypatch.chdir(tmp_path)
    if "RUN" in argv:
        argv = [str(_cycle_folder(tmp_path / "run")) if a == "RUN" else a for a in argv]
    # (the class, not get_model: a module imported meanwhile would keep a patched function for good)
    monkeypatch.setattr(model.BirdModel, "__init__", lambda *a, **k: pytest.fail("a model was built"))
    assert main([*argv, "--json"] if argv[0] != "animate" else argv) == 2
    out, err = capfd.readouterr()
    assert out == ""
    line = _one_line(err)
    assert line.startswith(f"birdocp: error: {key}:"), line
    assert not (tmp_path / "runs").exists()


# ---------------------------------------------------------------------------------------------
# Failures reported, the environment worked around

def test_a_diverging_simulation_is_exit_1_with_the_beat_and_the_result_written(tmp_path, capfd):
    code = main(["simulate", "--set", "solve.points=3", "--set", "solve.steps_per_period=48", "--beats", "3",
                 "--perturb", "u=300", "--json", "--out", str(tmp_path / "sim")])
    out, err = capfd.readouterr()
    assert code == 1, err
    res = json.loads(out)
    assert res["status"] == "diverged" and res["success"] is False and res["diverged_beat"] == 1
    assert json.loads((tmp_path / "sim" / "result.json").read_text())["diverged_beat"] == 1
    with np.load(tmp_path / "sim" / "arrays.npz") as z:
        assert np.all(np.isfinite(z["states"]))  # the history up to the last state in range
    assert "diverged in beat 1" in err.strip().splitlines()[-1]


@pytest.mark.slow
def test_a_bad_plotting_backend_and_an_ascii_terminal_do_not_fail_a_command(tmp_path):
    """MPLBACKEND misspelt (matplotlib refuses it at import, after the computation) and
    PYTHONIOENCODING=ascii with a non-ASCII folder name in the output: both at once, one run."""
    run = _cycle_folder(tmp_path / "lauf-\u00e9t\u00e9")
    p = _cli(["plot", str(run)], tmp_path, env={"MPLBACKEND": "no-such-backend", "PYTHONIOENCODING": "ascii"})
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr and (run / "states.png").is_file()
    assert "lauf-\\xe9t\\xe9" in p.stdout or "lauf-\\u00e9" in p.stdout, p.stdout


def test_a_second_ctrl_c_during_the_clean_up_exits_130_quietly(tmp_path):
    runner = (
        "import os, signal, sys, time, runpy\n"
        "import birdocp.studies.trim as T, birdocp.cli.output as C\n"
        "def trim(cfg, **kw):\n"
        "    os.kill(os.getpid(), signal.SIGINT); time.sleep(5)\n"
        "T.trim = trim\n"
        "orig = C._remove_if_empty\n"
        "def clean_up(*a, **k):\n"
        "    os.kill(os.getpid(), signal.SIGINT); time.sleep(0.2)\n"
        "    return orig(*a, **k)\n"
        "C._remove_if_empty = clean_up\n"
        "sys.argv[0] = 'birdocp'\n"
        "runpy.run_module('birdocp', run_name='__main__', alter_sys=True)\n")
    p = subprocess.run([sys.executable, "-c", runner, "trim", "--out", "run", "--json"], cwd=tmp_path, env=ENV,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 130, p.stderr
    assert "Traceback" not in p.stderr and "KeyboardInterrupt" not in p.stderr
    assert json.loads(p.stdout)["status"] == "interrupted"
    assert not (tmp_path / "run").exists()
