"""scripts/iterate_claims.py: the capped optimiser rows it re-verifies, and one re-solve from a committed
gait against the committed re-verification (the level cycle at that gait is a converged solve from fixed
inputs, so it reproduces to the solver's tolerance)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import iterate_claims  # noqa: E402
from result_compare import compare  # noqa: E402, F401  (imported here while scripts/ is on the path)

sys.path.pop(0)


def test_it_takes_every_capped_row_with_a_cycle_and_no_converged_one():
    rows = iterate_claims.capped_rows()
    assert rows, "no capped row found"
    for p in rows:
        assert json.loads(p.read_text())["optimum"]["status"] == "Maximum_Iterations_Exceeded"
    names = {p.name for p in rows}
    assert "opt_free_speed_wagner_fd_reached.json" not in names and "opt_at_speed_wagner.json" not in names
    committed = json.loads((ROOT / "results/aero/iterate_claims/result.json").read_text())
    assert [r["source"] for r in committed["rows"]] == [p.relative_to(ROOT).as_posix() for p in rows]


def test_its_results_are_compared_by_their_numbers():
    """The re-solves are converged solves from fixed inputs: the checker's rules compare every number of
    them (they are not capped solves, whatever the status of the row they come from)."""
    committed = json.loads((ROOT / "results/aero/iterate_claims/result.json").read_text())
    changed = json.loads(json.dumps(committed))
    changed["rows"][0]["level"]["solved"]["lambda1"] *= 1 + 1e-6
    assert compare(committed, changed, unconverged_statements=True)[0][0] == "/rows/0/level/solved/lambda1"
    flipped = json.loads(json.dumps(committed))
    flipped["rows"][-1]["level"]["solved"]["valid"] = not flipped["rows"][-1]["level"]["solved"]["valid"]
    assert compare(committed, flipped, unconverged_statements=True)


def test_claim_is_the_resolved_cycle_beside_the_recorded_one():
    c = iterate_claims._claim({"lambda1": 0.97, "success": True}, {"success": True, "lambda1": 0.9702, "wall_s": 3.0})
    assert c["solved"] == {"success": True, "lambda1": 0.9702} and abs(c["lambda1_difference"] - 2e-4) < 1e-12
    assert iterate_claims._claim(None, {"success": False, "lambda1": None})["lambda1_difference"] is None


@pytest.mark.slow
def test_a_capped_row_level_cycle_is_solved_again_as_committed():
    src = ROOT / "results/aero/valid/cases/opt_free_speed_wagner.json"
    row = iterate_claims.verify_row(src)
    committed = next(r for r in json.loads((ROOT / "results/aero/iterate_claims/result.json").read_text())["rows"]
                     if r["source"] == src.relative_to(ROOT).as_posix())
    new, old = row["level"]["solved"], committed["level"]["solved"]
    assert new["success"] and new["valid"] == old["valid"]
    assert new["lambda1"] == pytest.approx(old["lambda1"], rel=1e-8)
    assert new["amplitude_deg"] == pytest.approx(old["amplitude_deg"], rel=1e-8)
