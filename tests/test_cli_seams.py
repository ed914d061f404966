"""The command line's seams (issue 27): one ``--bounds KEY=LO:HI`` form, unambiguous option names,
solver settings as ``[solve]`` keys with the flags as shorthands, ``compiled=`` as a parameter (the
environment variable only a CLI shorthand) and no module-level CLI state."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from birdocp.cli import common
from birdocp.cli import main as cli
from test_cli_trim import fake_studies  # noqa: F401 (the fixture: trim replaced by a recorder)

ENV = {**os.environ, "PYTHONWARNINGS": "ignore"}


@pytest.mark.parametrize("argv", [
    ["level", "--bounds", "20", "70"],
    ["level", "--points", "3", "--bounds", "-10", "10", "--free", "gait.shoulder_sweep.offset_deg"],
    ["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04", "--level", "--bounds", "20", "70"],
])
def test_the_old_bounds_form_is_refused_with_one_line_naming_the_new_one(tmp_path, monkeypatch, capfd, argv):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    out, err = capfd.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert "--bounds KEY=LO:HI" in err and "--bounds LO HI" in err, err
    assert not (tmp_path / "runs").exists()


def test_bounds_of_another_key_than_the_free_one_are_refused(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["level", "--bounds", "root_ahead_m=-0.1:0.2"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "wing.root_ahead_m" in err and "gait.shoulder_flap.amplitude_deg=LO:HI" in err


def test_the_new_bounds_form_reaches_level_with_aliases_resolved():
    from birdocp.bird.config import Config
    from birdocp.cli.level import level_kwargs

    args = cli.build_parser().parse_args(["level", "--free", "root_ahead_m", "--bounds", "root-ahead=-0.1:0.2"])
    assert level_kwargs(args, Config())["bounds"] == (-0.1, 0.2)
    args = cli.build_parser().parse_args(["continue", "x", "--from", "0", "--to", "1", "--bounds", "amplitude=25:60"])
    assert common.bounds_of(args.bounds, "gait.shoulder_flap.amplitude_deg") == (25.0, 60.0)


def test_sweep_by_and_continue_first_step_with_the_old_spellings_as_hidden_aliases():
    parser = cli.build_parser()
    new = parser.parse_args(["sweep", "amplitude", "--from", "40", "--to", "41", "--by", "0.5", "--steps", "60"])
    old = parser.parse_args(["sweep", "amplitude", "--from", "40", "--to", "41", "--step", "0.5", "--steps", "60"])
    assert new.step == old.step == 0.5 and new.steps == old.steps == 60
    cont = parser.parse_args(["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04", "--first-step", "0.001"])
    assert cont.step == 0.001
    for command in ("sweep", "continue"):
        text = parser._subparsers._group_actions[0].choices[command].format_help()
        assert "--step " not in text and "--step\n" not in text, f"{command} --help still shows --step"


@pytest.mark.parametrize("argv, key, value", [
    (["trim", "--set", "solve.max_iter=3"], "max_iter", 3),
    (["trim", "--max-iter", "7"], "max_iter", 7),
    (["level", "--tol", "1e-6"], "tol", 1e-6),
    (["sweep", "amplitude", "--from", "40", "--to", "41", "--by", "1", "--set", "solve.tol=1e-7"], "tol", 1e-7),
])
def test_solver_flags_are_shorthands_of_the_solve_keys(argv, key, value):
    from birdocp.studies.trim import method_of

    cfg = common.resolve_config(cli.build_parser().parse_args(argv))
    assert getattr(cfg.solve, key) == value
    assert getattr(method_of(cfg), key) == value


def test_solve_keys_are_checked_and_their_defaults_are_the_engines():
    from birdocp.bird.config import Config, ConfigError, with_values
    from birdocp.studies.trim import method_of

    m = method_of(Config())
    assert (m.max_iter, m.tol) == (100, None)  # the engine's own defaults: the results stay the same
    for values in ({"solve.max_iter": 0}, {"solve.tol": -1e-3}, {"solve.tol": 1.0}):
        with pytest.raises(ConfigError, match=next(iter(values))):
            with_values(Config(), values)


def test_set_solve_max_iter_takes_effect_in_a_trim(tmp_path):
    """An iteration limit of 2 stops IPOPT before the residual meets the tolerance: exit 1, the
    result written, the method recording the limit."""
    argv = ["trim", "--points", "3", "--steps", "60", "--set", "solve.max_iter=2", "--out", "run", "--json"]
    p = subprocess.run([sys.executable, "-m", "birdocp", *argv], cwd=tmp_path, env=ENV, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 1, p.stderr
    d = json.loads(p.stdout)
    assert d["method"]["max_iter"] == 2 and not d["success"] and d["max_residual"] > 1e-9
    assert "Maximum_Iterations_Exceeded" in d["status"]
    assert json.loads((tmp_path / "run" / "result.json").read_text())["method"]["max_iter"] == 2


def test_compiled_is_a_parameter_and_the_library_reads_no_environment(monkeypatch, default_model):
    import birdocp.export.compiled as compiled_mod
    from birdocp.studies.trim import solver_ode

    calls = []
    monkeypatch.setattr(compiled_mod, "compiled_ode", lambda ode, **kw: calls.append(ode) or None)
    monkeypatch.setenv("BIRDOCP_COMPILED", "1")
    assert solver_ode(default_model) is default_model.ode and calls == []  # the variable is ignored
    assert solver_ode(default_model, compiled=True) is default_model.ode  # compiling "failed": interpreted
    assert calls == [default_model.ode]


@pytest.mark.parametrize("flag, env, expected", [([], None, False), (["--compiled"], None, True),
                                                 ([], "1", True), ([], "0", False)])
def test_the_cli_passes_compiled_explicitly(fake_studies, monkeypatch, flag, env, expected):  # noqa: F811
    if env is None:
        monkeypatch.delenv("BIRDOCP_COMPILED", raising=False)
    else:
        monkeypatch.setenv("BIRDOCP_COMPILED", env)
    assert cli.main(["trim", *flag, "--out", "run"]) == 0
    assert fake_studies.compiled == [expected]
    assert os.environ.get("BIRDOCP_COMPILED") == env  # the command does not set it


def test_no_module_level_cli_state_between_runs(fake_studies, capfd):  # noqa: F811
    """Each run carries its own Context: a failure after an earlier run names no folder of that run."""
    assert not hasattr(common, "STATE")
    assert cli.main(["trim", "--out", "first", "--json"]) == 0
    capfd.readouterr()
    fake_studies.behaviour["raise"] = KeyboardInterrupt()
    assert cli.main(["trim", "--json"]) == 130
    out, err = capfd.readouterr()
    assert json.loads(out)["run_dir"] is None and "first" not in err


def test_continue_refuses_the_solve_settings_it_does_not_use(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["continue", "root_ahead_m", "--from", "0.05", "--to", "0.04", "--tol", "1e-6"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "solve.tol" in err and not (tmp_path / "runs").exists()
