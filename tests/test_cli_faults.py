"""The CLI under faults, through the real command (subprocesses): Ctrl-C at several moments of a solve,
two runs racing for one folder, output paths the code cannot use, and failures reported the
documented way (exit code, one stderr line, one JSON object with --json).

Interrupts are real SIGINTs: either sent by the test to the child, or sent by the child to itself
from inside a chosen function (model build, IPOPT's constraint callback, the LM solver's residual),
so that each lands where it is meant to, however slow the machine.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
COARSE = ["--points", "3", "--steps", "60"]


def _hook_source() -> str:
    """The CLI runner that sends SIGINT to itself on the N-th call of a function (shared with
    scripts/hostile_cases.py, which holds it)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("hostile_cases", REPO / "scripts" / "hostile_cases.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.HOOK


HOOK = _hook_source()


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])))


def _cli(*argv, cwd, hook=None, timeout=300):
    cmd = [sys.executable, "-c", HOOK, *hook] if hook else [sys.executable, "-m", "birdocp"]
    return subprocess.run([*cmd, *argv], cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout)


def _leftovers(folder: Path) -> list[str]:
    """Temporary or lock files anywhere below ``folder``."""
    return [str(p) for p in folder.rglob("*") if p.name.endswith(".tmp") or p.name == ".birdocp.lock"]


def _one_json(stdout: str) -> dict:
    lines = stdout.strip().splitlines()
    assert len(lines) == 1, stdout
    return json.loads(lines[0])


def _interrupted(p, out: Path | None = None) -> dict:
    assert p.returncode == 130, (p.returncode, p.stderr[-2000:])
    assert p.stderr.strip().splitlines()[-1].startswith("birdocp: interrupted"), p.stderr[-2000:]
    assert "Traceback" not in p.stderr and "NaN detected" not in p.stderr
    res = _one_json(p.stdout)
    assert res["success"] is False and res["status"] == "interrupted"
    return res


# ---------------------------------------------------------------------------------------------
# Ctrl-C

@pytest.mark.parametrize("moment, hook, extra", [
    ("model build", ("birdocp.bird.model:BirdModel.__init__", "1"), []),
    ("inside IPOPT (constraint callback)", ("birdocp.engine.oracle:ConstraintOracle.eval", "3"), []),
    ("inside the LM solver", ("birdocp.engine.shooting:ShootingGraphs.evaluate", "2"), ["--solver", "lm"]),
])
def test_sigint_during_a_trim_exits_130_and_leaves_nothing(tmp_path, moment, hook, extra):
    out = tmp_path / "run"
    p = _cli("trim", *COARSE, *extra, "--out", str(out), "--json", cwd=tmp_path, hook=hook)
    res = _interrupted(p)
    # a trim that finished nothing leaves no folder (and no runs/ entry, no temporary file)
    assert not out.exists(), moment
    assert res["run_dir"] is None
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())
    assert _leftovers(tmp_path) == []


@pytest.mark.slow
def test_sigint_in_a_sweep_keeps_finished_points_and_resumes(tmp_path):
    out = tmp_path / "sweep"
    argv = ["sweep", "amplitude", "--from", "42", "--to", "42.5", "--by", "0.5", *COARSE, "--quiet", "--out", str(out)]
    # the first point takes 19 constraint evaluations (measured): the 24th is inside IPOPT on the second
    p = _cli(*argv, "--json", cwd=tmp_path, hook=("birdocp.engine.oracle:ConstraintOracle.eval", "24"))
    res = _interrupted(p)
    assert res["run_dir"] == str(out)
    points = sorted((out / "points").glob("point-*.json"))
    assert len(points) == 1
    for f in points:  # nothing half-written
        assert json.loads(f.read_text())["row"]["success"] is True
    assert _leftovers(out) == [] and not (out / "result.json").exists()
    p = _cli(*argv, "--resume", "--json", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    res = _one_json(p.stdout)
    assert res["success"] is True and [r["value"] for r in res["points"]] == [42.0, 42.5]


@pytest.mark.slow
def test_sigint_in_a_continuation_keeps_the_points_so_far(tmp_path):
    out = tmp_path / "branch"
    p = _cli("continue", "root_ahead_m", "--from", "0.05", "--to", "0.046", "--points", "3", "--steps", "48",
             "--out", str(out), "--quiet", "--json", cwd=tmp_path,
             hook=("birdocp.engine.continuation.corrector:Corrector.along", "3"))
    res = _interrupted(p)
    assert res["run_dir"] == str(out)
    branch = json.loads((out / "branch.json").read_text())
    assert branch["end_reason"] == "interrupted" and len(branch["points"]) >= 1
    params = [pt["parameter"] for pt in branch["points"]]
    assert params[0] == pytest.approx(0.05) and all(0.046 <= v <= 0.05 for v in params)
    result = json.loads((out / "result.json").read_text())
    assert result["success"] is False and result["status"] == "interrupted"
    assert result["n_points"] == len(params) and _leftovers(out) == []
    # continue --resume goes on from the points kept (points/, written as each was accepted)
    p = _cli("continue", "root_ahead_m", "--from", "0.05", "--to", "0.046", "--points", "3", "--steps", "48",
             "--out", str(out), "--quiet", "--json", "--resume", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    res = _one_json(p.stdout)
    assert res["status"] == "reached_to" and res["resumed_points"] == len(params)
    resumed = [pt["parameter"] for pt in res["branch"]["points"]]
    assert resumed[:len(params)] == params and resumed[-1] == pytest.approx(0.046) and len(resumed) > len(params)


def _workers_of(pid: int) -> list[int]:
    """Pool worker processes (not the resource tracker) whose parent is ``pid``."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        ppid = int(stat.rsplit(")", 1)[1].split()[1])
        if ppid == pid and "spawn_main" in cmd:
            out.append(int(d.name))
    return out


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc to find the worker processes")
def test_sigint_in_a_grid_with_jobs_stops_the_workers_and_resumes(tmp_path):
    out = tmp_path / "grid"
    argv = ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--rows", "root_ahead_m=0.04:0.05:0.005",
            "--jobs", "2", "--points", "3", "--steps", "48", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "birdocp", *argv, "--json"], cwd=tmp_path, env=_env(),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    workers: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None:
        workers = _workers_of(proc.pid) or workers
        if list((out / "rows").glob("row-*.json")) if (out / "rows").is_dir() else []:
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the grid ended before it could be interrupted"
    assert workers, "no worker processes seen"
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    p = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    _interrupted(p)
    time.sleep(1.0)
    alive = [w for w in workers if Path(f"/proc/{w}").exists()
             and "Z" not in (Path(f"/proc/{w}/stat").read_text().rsplit(")", 1)[1].split()[:1] or [""])]
    assert alive == [], "worker processes outlived the interrupted command"
    rows = sorted((out / "rows").glob("row-*.json"))
    assert 1 <= len(rows) < 3
    for f in rows:
        json.loads(f.read_text())
    assert _leftovers(out) == [] and not (out / "grid.csv").exists()
    p = _cli(*argv, "--resume", "--json", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    res = _one_json(p.stdout)
    assert res["success"] is True and len(res["points"]) == 6
    timing = json.loads((out / "timing.json").read_text())
    assert timing["rows_from_disk"] == [int(f.name[4:8]) for f in rows]  # finished rows not solved again


# ---------------------------------------------------------------------------------------------
# Two runs, one folder

FAKE_TRIM = (
    "import sys, time, types, runpy\n"
    "sys.path.insert(0, sys.argv.pop(1))\n"
    "from fake_trim import install\n"
    "install()\n"
    "sys.argv[0] = 'birdocp'\n"
    "runpy.run_module('birdocp', run_name='__main__', alter_sys=True)\n"
)

FAKE_MODULE = '''
import sys, time, types
import numpy as np

class Result:
    success, status, message = True, "Solve_Succeeded", "converged"
    def to_dict(self):
        return {"success": True, "status": self.status, "message": self.message, "max_residual": 1e-12,
                "x0": [18.0, 0.5, 0.0, 0.0], "wall_s": {"total": 0.5}}
    def arrays(self):
        return {"x": np.ones((3, 4))}

def install():
    mod = types.ModuleType("birdocp.studies.trim")
    def trim(cfg, **kw):
        time.sleep(0.3)  # the winner is still solving while the loser tries the folder
        return Result()
    mod.trim = trim
    sys.modules["birdocp.studies.trim"] = mod
'''


def test_two_runs_racing_for_one_folder_exactly_one_wins(tmp_path):
    (tmp_path / "fake_trim.py").write_text(FAKE_MODULE)
    for attempt in range(3):
        out = tmp_path / f"race{attempt}"
        procs = [subprocess.Popen([sys.executable, "-c", FAKE_TRIM, str(tmp_path), "trim", "--out", str(out), "--json"],
                                  cwd=tmp_path, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                 for _ in range(2)]
        done = [(p.wait(timeout=120), *p.communicate()) for p in procs]
        codes = sorted(code for code, _, _ in done)
        assert codes == [0, 2], done
        code, stdout, stderr = next(d for d in done if d[0] == 2)
        assert stdout == "" and len(stderr.strip().splitlines()) == 1, stderr
        assert stderr.startswith("birdocp: error: --out: ") and str(out) in stderr
        assert sorted(p.name for p in out.iterdir()) == ["arrays.npz", "config.toml", "result.json"]


def test_claims_from_many_threads_one_winner_per_folder(tmp_path):
    import threading

    from birdocp.io import runs
    from birdocp.io.errors import ConfigError

    wins, lock = [], threading.Lock()

    def claim(i):
        for k in range(10):
            try:
                runs.claim_out_dir(tmp_path / f"f{k}", "trim")
            except ConfigError:
                continue
            with lock:
                wins.append(k)

    threads = [threading.Thread(target=claim, args=(i,)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(wins) == list(range(10))  # every folder claimed exactly once
    for k in range(10):
        runs.release_out_dir(tmp_path / f"f{k}")
    assert _leftovers(tmp_path) == []


def test_a_lock_left_by_a_killed_run_is_taken_over(tmp_path):
    from birdocp.io import runs

    folder = tmp_path / "sweep"
    folder.mkdir()
    (folder / runs.LOCK_NAME).write_text("999999 elsewhere\n")  # no process holds it
    (folder / "sweep.json").write_text("{}")
    assert runs.claim_out_dir(folder, "sweep", resume_file="sweep.json") == folder
    runs.release_out_dir(folder)
    assert not (folder / runs.LOCK_NAME).exists()


# ---------------------------------------------------------------------------------------------
# Output paths and absurd values: refused before any computation (in-process, with a trim, a level
# solve and a model that fail the test if they are ever called)

@pytest.fixture
def no_solver(monkeypatch, tmp_path):
    import types

    monkeypatch.chdir(tmp_path)

    def never(*a, **k):
        raise AssertionError("bad input reached the solver")

    for name, attrs in (("birdocp.studies.trim", ("trim",)), ("birdocp.studies.level", None),
                        ("birdocp.bird.model", ("get_model",))):
        if attrs is None:  # keep the module (its key checks are used), stop its solver
            import importlib

            monkeypatch.setattr(importlib.import_module(name), "level", never)
            continue
        mod = types.ModuleType(name)
        for a in attrs:
            setattr(mod, a, never)
        monkeypatch.setitem(sys.modules, name, mod)
    return tmp_path


def _refused(capfd, argv, key, text):
    from birdocp.cli import main as cli

    assert cli.main(argv) == 2, argv
    out, err = capfd.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"birdocp: error: {key}: "), err
    assert text in lines[0], lines[0]
    assert out == ""


def test_output_path_classes_exit_2_before_computing(no_solver, capfd):
    tmp_path = no_solver
    (tmp_path / "a_file").write_text("x")
    os.symlink(tmp_path / "nowhere", tmp_path / "dangling")
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("x")
    cases = [
        (["trim", "--out", "dangling"], "--out", "dangling symbolic link"),
        (["trim", "--out", "x" * 300], "--out", "bytes long"),
        (["trim", "--out", "a_file/run"], "--out", "is a file"),
        (["trim", "--out", "a_file"], "--out", "existing file"),
        (["trim", "--out", "busy"], "--out", "not empty"),
        (["level", "--out", "dangling"], "--out", "dangling symbolic link"),
        (["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--out", "dangling"], "--out", "dangling"),
        (["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--out", "busy", "--resume"], "--out",
         "no sweep.json"),
        (["export-c", "--out", "dangling"], "--out", "dangling symbolic link"),
    ]
    for argv, key, text in cases:
        _refused(capfd, argv, key, text)
    assert os.path.islink(tmp_path / "dangling") and not (tmp_path / "nowhere").exists()
    assert not (tmp_path / "runs").exists() and _leftovers(tmp_path) == []


def test_read_only_locations_exit_2(tmp_path, monkeypatch, capfd):
    """A read-only folder and a read-only runs/ (simulated with EROFS: the tests may run as root, for
    whom permission bits do not stop a write)."""
    import errno

    from birdocp.cli import main as cli

    monkeypatch.chdir(tmp_path)
    real_mkdir = os.mkdir

    def read_only_mkdir(path, *a, **k):
        if "ro" in Path(path).parts or "runs" in Path(path).parts:
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real_mkdir(path, *a, **k)

    monkeypatch.setattr(os, "mkdir", read_only_mkdir)
    assert cli.main(["trim", "--out", "ro/run"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and "read-only" in err and "ro/run" in err
    assert cli.main(["trim"]) == 2  # the default runs/ folder cannot be created
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "runs" in err and "read-only" in err and "--out DIR" in err


@pytest.mark.parametrize("argv, key, text", [
    (["level", "--bounds", "amplitude=60:30"], "--bounds", "LO < HI"),
    (["sweep", "amplitude", "--from", "40", "--to", "42", "--by", "5"], "--by", "larger than the range"),
    (["sweep", "amplitude", "--from", "0", "--to", "100", "--by", "1e-6"], "--by", "at most 10000"),
    (["trim", "--steps", "1000000", "--points", "3"], "solve.steps_per_period", "<= 10000"),
    (["trim", "--points", "100000", "--steps", "99999"], "solve.points", "<= 500"),
    (["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", "--rows", "root_ahead_m=0.04:0.05:0.005",
      "--jobs", "100000"], "--jobs", "<= 256"),
    (["optimize-stability", "--threads", "0"], "--threads", "[1, 64]"),
])
def test_absurd_values_exit_2(no_solver, capfd, argv, key, text):
    _refused(capfd, argv, key, text)
    assert not (no_solver / "runs").exists()


@pytest.mark.parametrize("argv, key, text", [
    (["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04", "--level", "--bounds", "amplitude=70:20"], "--bounds",
     "LO < HI"),
    (["optimize-stability", "--free", "gait.shoulder_sweep.offset_deg", "--bounds",
      "gait.shoulder_sweep.offset_deg=10:-10"], "--bounds", "LO < HI"),
])
def test_inverted_bounds_exit_2_before_computing(tmp_path, monkeypatch, capfd, argv, key, text):
    monkeypatch.chdir(tmp_path)
    _refused(capfd, argv, key, text)
    assert not (tmp_path / "runs").exists()


def test_sweep_end_is_inclusive_off_the_step_grid():
    from birdocp.studies.sweep import sweep_values

    assert sweep_values(40, 43, 2) == [40.0, 42.0, 43.0]  # last interval shorter, end included
    assert sweep_values(43, 40, 2) == [43.0, 41.0, 40.0]
    assert sweep_values(42, 42, 5) == [42.0]


# ---------------------------------------------------------------------------------------------
# Failures, the documented way

@pytest.mark.slow
def test_nan_flood_goes_to_the_log_one_line_on_the_terminal(tmp_path):
    # a guess far from any cycle: IPOPT meets NaN in the shooting residual and gives up
    argv = ["trim", *COARSE, "--set", "solve.initial_guess=[200.0, 0.0, 0.0, 0.0]", "--out", "run", "--json"]
    p = _cli(*argv, cwd=tmp_path)
    assert p.returncode == 1, p.stderr
    res = _one_json(p.stdout)
    assert res["success"] is False and res["status"] != "Solve_Succeeded"
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith("birdocp: trim did not converge (status: ") and "run" in lines[0]
    assert "solver.log" in lines[0]
    log = (tmp_path / "run" / "solver.log").read_text()
    assert "NaN detected" in log


def test_noise_filter_routes_casadi_warnings_only(tmp_path, capsys):
    from birdocp.cli.common import noise_summary, solver_noise

    log = tmp_path / "solver.log"
    with solver_noise(log) as noise:
        sys.stderr.write("sweep [###.....] 1/3\r")  # a progress line passes at once
        sys.stderr.write("CasADi - 2026-01-01 00:00:00 WARNING(\"f:nlp_g failed: NaN detected\")")
        sys.stderr.write(" [core.cpp:1]\n")
        print("IPOPT-like line on stdout")
    err = capsys.readouterr().err
    assert "NaN detected" not in err and "1/3" in err and "IPOPT-like line on stdout" in err
    assert noise.count == 1 and "NaN detected" in log.read_text() and "solver.log" in noise_summary(noise)
    with solver_noise(tmp_path / "other.log", verbose=True) as noise:  # --verbose: everything shown
        sys.stderr.write("CasADi - WARNING(\"NaN detected\")\n")
    assert noise is None and "NaN detected" in capsys.readouterr().err
    assert not (tmp_path / "other.log").exists()


def test_forces_with_non_finite_loads_is_a_failure(tmp_path):
    p = _cli("forces", "--state", "1e300", "1e300", "0", "0", "--time", "0", "--json", cwd=tmp_path)
    assert p.returncode == 1, p.stderr
    res = _one_json(p.stdout)
    assert res["success"] is False and res["status"] == "non_finite" and res["Fx_N"] is None
    assert len(p.stderr.strip().splitlines()) == 1 and "non-finite" in p.stderr


@pytest.mark.parametrize("content", ["[1, 2, 3]", '"a string"', '{"provenance": 5}', "{}"])
def test_plot_on_a_folder_that_holds_no_result_exits_2(tmp_path, monkeypatch, capfd, content):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "result.json").write_text(content)
    _refused(capfd, ["plot", "run", "--json"], "RUN_DIR", "run")


class _Failed:
    success, status, message = False, "Maximum_Iterations_Exceeded", "too many iterations"
    max_residual, amplitude_deg = 0.25, 42.0


def test_json_on_failed_sensitivity_internal_error_and_bad_input(tmp_path, monkeypatch, capfd):
    import types

    from birdocp.cli import main as cli

    monkeypatch.chdir(tmp_path)
    fake = types.ModuleType("birdocp.studies.trim")
    fake.trim = lambda cfg, **kw: _Failed()
    monkeypatch.setitem(sys.modules, "birdocp.studies.trim", fake)
    assert cli.main(["sensitivity", "--json", "--out", "sens"]) == 1
    out, err = capfd.readouterr()
    res = _one_json(out)
    assert res["success"] is False and res["status"] == "Maximum_Iterations_Exceeded"
    assert err.strip().splitlines()[-1].startswith("birdocp: sensitivity: the cycle did not converge")
    assert json.loads((tmp_path / "sens" / "result.json").read_text())["success"] is False

    def boom(cfg, **kw):
        raise RuntimeError("disk on fire")

    fake.trim = boom
    monkeypatch.setenv("BIRDOCP_LOG_DIR", str(tmp_path / "logs"))
    assert cli.main(["trim", "--json"]) == 3
    out, err = capfd.readouterr()
    res = _one_json(out)
    assert res == {"success": False, "status": "internal_error", "message": "RuntimeError: disk on fire",
                   "run_dir": None}
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())

    assert cli.main(["trim", "--json", "--points", "1"]) == 2  # bad input: no JSON
    out, err = capfd.readouterr()
    assert out == "" and err.count("\n") == 1


def test_result_files_follow_the_umask(tmp_path):
    (tmp_path / "fake_trim.py").write_text(FAKE_MODULE)
    old = os.umask(0o027)
    try:
        p = subprocess.run([sys.executable, "-c", FAKE_TRIM, str(tmp_path), "trim", "--out", "run"], cwd=tmp_path,
                           env=_env(), capture_output=True, text=True, timeout=120)
    finally:
        os.umask(old)
    assert p.returncode == 0, p.stderr
    modes = {f.name: f.stat().st_mode & 0o777 for f in (tmp_path / "run").iterdir()}
    assert modes == {"arrays.npz": 0o640, "config.toml": 0o640, "result.json": 0o640}


def test_provenance_git_is_recorded_at_build_time():
    """In a checkout the revision is read live; the build-time record (setuptools-scm) is the fallback
    for an installed copy and holds the same commit when the package was built from this checkout."""
    from birdocp.io import provenance as P

    live = P.git_revision()
    if live is None:
        pytest.skip("not a git checkout")
    rev = P.source_revision()
    assert rev is not None and len(rev["commit"]) == 40
    built = P.build_revision()
    if built is not None:  # built (pip install -e .) from this checkout, maybe some commits ago
        assert len(built["commit"]) == 40 and all(c in "0123456789abcdef" for c in built["commit"])
