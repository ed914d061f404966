"""The study commands through the CLI, in table and in JSON mode: what they print is what they write."""
from __future__ import annotations

import json

from birdocp.cli.main import main

COARSE = ["--set", "solve.points=3", "--set", "solve.steps_per_period=48"]


def test_sensitivity_json_and_table(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    args = ["sensitivity", "--param", "gait.shoulder_sweep.offset_deg", "--param", "wing.root_ahead_m", *COARSE]
    assert main([*args, "--json", "--out", "j"]) == 0
    out = capsys.readouterr().out
    doc = json.loads(out)  # exactly one JSON object
    assert doc["success"] is True and doc["parameters"] == ["gait.shoulder_sweep.offset_deg", "wing.root_ahead_m"]
    ranked = doc["ranked_expanding"]
    assert {r["parameter"] for r in ranked} == set(doc["parameters"])
    mods = [abs(r["d_modulus_per_unit"]) for r in ranked]
    assert mods == sorted(mods, reverse=True)  # ranked by the size of the derivative
    assert json.loads((tmp_path / "j" / "result.json").read_text())["ranked_expanding"] == ranked
    assert doc["validity"]["valid"] in (True, False)

    assert main([*args, "--out", "t"]) == 0
    table = capsys.readouterr().out
    for r in ranked:  # every ranked parameter is a row of the table, in the same order
        assert r["parameter"] in table
    assert table.index(ranked[0]["parameter"]) < table.index(ranked[1]["parameter"])
    assert "model validity" in table
