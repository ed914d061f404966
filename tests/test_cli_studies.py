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


def test_optimize_stability_json_and_table_on_a_small_problem(tmp_path, capsys, monkeypatch):
    """Three IPOPT iterations on the coarse grid: not converged (exit 1), but the result is complete,
    printed as one JSON object or as the table (the table once crashed on a missing verification key),
    and verified by an independent trim at the point reached."""
    monkeypatch.chdir(tmp_path)
    args = ["optimize-stability", "--free", "gait.shoulder_sweep.offset_deg", "--max-iter", "3", *COARSE]
    assert main([*args, "--json", "--out", "j"]) == 1
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["success"] is False and doc["status"] == "Maximum_Iterations_Exceeded"
    assert set(doc["free"]) == {"gait.shoulder_sweep.offset_deg"}
    v = doc["verification"]
    assert v["trim_success"] is True and v["max_multiplier_difference"] < 1e-6
    assert abs(v["trim_mean_vertical_speed_mps"]) < 1e-6   # level flight held at the point reached
    assert json.loads((tmp_path / "j" / "result.json").read_text())["multipliers"] == doc["multipliers"]

    assert main([*args, "--out", "t"]) == 1
    cap = capsys.readouterr()
    assert "check: trim at the optimum converged" in cap.out
    assert "did not converge" in cap.err and "internal error" not in cap.err
    assert f"KKT residual {doc['kkt_residual']:.2e}" in cap.err  # the failure line names the residual
