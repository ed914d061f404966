"""Every subcommand in table and in JSON mode, on small problems (issue 13).

For each command the same arguments are run twice: with ``--json`` stdout must be exactly one JSON
object carrying ``success`` and ``status`` (``config --json`` prints the configuration itself), and
without it stdout is a human-readable table (not JSON); both runs end with the same exit code, 0 when
the JSON says ``success`` and 1 when it does not, and with no traceback on stderr. The commands'
own tests check what the numbers mean; this one checks that no command lacks a mode.
"""
from __future__ import annotations

import json

import pytest

from birdocp.cli.main import COMMAND_MODULES, build_parser, main

COARSE = ["--set", "solve.points=3", "--set", "solve.steps_per_period=48"]


def _commands(trim_run: str) -> dict:
    """argv (without --json and --out) of every subcommand, and its --out: "out" a folder, ".gif" a
    file, None none."""
    return {
        "forces": (["forces", "--state", "18", "0.5", "0.1", "0.01", "--time", "0.01"], None),
        "trim": (["trim", *COARSE], "out"),
        "level": (["level", *COARSE], "out"),
        "sweep": (["sweep", "amplitude", "--from", "41", "--to", "42", "--by", "1", "--quiet", *COARSE], "out"),
        "continue": (["continue", "root_ahead_m", "--from", "0.05", "--to", "0.049", "--first-step", "0.0005",
                      "--max-points", "3", "--quiet", *COARSE], "out"),
        "plot": (["plot", trim_run], None),
        "sensitivity": (["sensitivity", "--param", "wing.root_ahead_m", *COARSE], "out"),
        "optimize-stability": (["optimize-stability", "--free", "gait.shoulder_sweep.offset_deg", "--max-iter", "2",
                                *COARSE], "out"),
        "optimize-gait": (["optimize-gait", "--speed", "18", "--free", "gait.shoulder_sweep.offset_deg",
                           "--set", "solve.steps_per_period=24"], "out"),
        "control": (["control", *COARSE], "out"),
        "simulate": (["simulate", "--beats", "2", "--perturb", "w=0.01", *COARSE], "out"),
        "animate": (["animate", trim_run, "--frames", "8", "--dpi", "20"], ".gif"),
        "export-c": (["export-c", "--steps", "24"], "out"),
        "config": (["config"], None),
    }


@pytest.fixture(scope="module")
def trim_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("matrix") / "trim"
    assert main(["trim", *COARSE, "--json", "--out", str(d)]) == 0
    return str(d)


def test_every_command_is_in_the_matrix(trim_run):
    """A new subcommand must be added here (and so get both modes tested)."""
    import argparse

    names = set(_commands(trim_run))
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert len(COMMAND_MODULES) >= len(names) - 1
    assert set(sub.choices) == names, set(sub.choices) ^ names


def test_every_command_takes_the_common_output_options():
    """README: every command takes --verbose and --debug; --json and --quiet too (animate lacked
    --verbose, plot --quiet: exit 2 for a flag the README promises)."""
    import argparse

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, parser in sub.choices.items():
        flags = {o for a in parser._actions for o in a.option_strings}
        assert {"--json", "--debug", "--verbose", "--quiet"} <= flags, (name, sorted(flags))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["forces", "trim", "level", "sweep", "continue", "plot", "sensitivity",
                                  "optimize-stability", "optimize-gait", "control", "simulate", "animate",
                                  "export-c", "config"])
def test_table_and_json(name, trim_run, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv, out = _commands(trim_run)[name]
    codes = {}
    for mode in ("json", "table"):
        extra = ["--json"] if mode == "json" else []
        if out:
            extra += ["--out", str(tmp_path / (mode + (out if out.startswith(".") else "")))]
        codes[mode] = main([*argv, *extra])
        cap = capsys.readouterr()
        assert "Traceback" not in cap.err, cap.err[-2000:]
        assert codes[mode] in (0, 1), (mode, codes[mode], cap.err[-500:])
        text = cap.out.strip()
        assert text, f"{name} {mode}: nothing on stdout"
        if mode == "json":
            doc = json.loads(text)  # exactly one JSON object, nothing else
            assert isinstance(doc, dict)
            if name != "config":  # config --json prints the configuration itself
                assert {"success", "status"} <= set(doc), sorted(doc)[:20]
                assert codes[mode] == (0 if doc["success"] else 1)
        else:
            with pytest.raises(ValueError):
                json.loads(text)
    assert codes["json"] == codes["table"]
