"""The comparison behind scripts/check_results.py (committed results against a re-run): tolerances,
ignored timing/host keys, and that a real difference is reported with both values. No study is run."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import check_results  # noqa: E402
from result_compare import compare, compare_text, is_ignored, unconverged  # noqa: E402

sys.path.pop(0)

RESULT = {"period_s": 0.25, "steps": 7, "iterations": 7, "status": "Solve_Succeeded", "multipliers": [[1.4, 0.0], [1e-18, 0.0]],
          "wall_s": 3.1, "provenance": {"hostname": "a"}, "max_residual": 1e-13,
          "message": "max|g| = 3.983e-12 <= tol = 1.0e-10", "lyapunov": {"exponents": [0.069, -5.39]}}


def _changed(**kw):
    return {**RESULT, **kw}


def test_identical_and_float_within_rtol():
    assert compare(RESULT, dict(RESULT)) == []
    assert compare(RESULT, _changed(period_s=0.25 * (1 + 5e-10))) == []
    assert compare(RESULT, _changed(period_s=0.25 * (1 + 5e-9))) == [("/period_s", 0.25, 0.25 * (1 + 5e-9))]
    assert compare(RESULT, _changed(period_s=0.25 * (1 + 5e-9)), rtol=1e-8) == []


def test_integers_and_strings_exact():
    assert compare(RESULT, _changed(steps=8)) == [("/steps", 7, 8)]
    assert compare(RESULT, _changed(status="Maximum_Iterations_Exceeded"))[0][0] == "/status"
    assert compare({"ok": True}, {"ok": 1}) == [("/ok", True, 1)]  # a bool is not a number


def test_solver_work_counts_are_effort_not_results():
    assert compare(RESULT, _changed(iterations=8, evaluations={"full": 9, "residual": 17})) == []
    msg = "IPOPT: Solve_Succeeded; coarse stage (32 steps): Solve_Succeeded, 85 iterations"
    assert compare({"message": msg}, {"message": msg.replace("85", "115")}) == []
    assert compare({"message": msg}, {"message": msg.replace("(32", "(48")})[0][0] == "/message"


def test_timing_host_and_provenance_keys_ignored():
    assert compare(RESULT, _changed(wall_s=99.0, provenance={"hostname": "b", "git": "x"})) == []
    for key in ("wall_s", "trim_wall_s", "cpu_total", "load_average_start", "timestamp_utc", "casadi_version",
                "git_revision", "hostname"):
        assert is_ignored(key), key
    for key in ("period_s", "t_s", "shooting_times_s", "doubling_time_s", "multipliers", "residual"):
        assert not is_ignored(key), key


def test_vector_relative_tolerance_and_round_off_zero():
    # a multiplier of 1e-18 beside one of 1.4 is a round-off zero; the large one still must agree
    assert compare(RESULT, _changed(multipliers=[[1.4, 0.0], [-3e-18, 0.0]])) == []
    assert compare(RESULT, _changed(multipliers=[[1.4001, 0.0], [1e-18, 0.0]]))[0][0] == "/multipliers/0/0"


def test_noise_keys_and_numbers_in_messages():
    assert compare(RESULT, _changed(max_residual=4e-13)) == []            # both far below any tolerance
    assert compare(RESULT, _changed(max_residual=1e-6))[0][0] == "/max_residual"
    assert compare(RESULT, _changed(message="max|g| = 3.981e-12 <= tol = 1.0e-10")) == []
    assert compare(RESULT, _changed(message="max|g| = 3.9e-08 <= tol = 1.0e-10"))[0][0] == "/message"
    assert compare(RESULT, _changed(lyapunov={"exponents": [0.0746, -5.40]})) == []   # a chaotic statistic
    assert compare(RESULT, _changed(lyapunov={"exponents": [0.2, -5.40]}))[0][0] == "/lyapunov/exponents/0"
    assert compare(RESULT, _changed(max_residual=4e-13), overrides={})[0][0] == "/max_residual"


def test_structure_differences_reported():
    new = {k: v for k, v in RESULT.items() if k != "period_s"} | {"index": 0}
    assert compare(RESULT, new) == [("/period_s", 0.25, "<missing>"), ("/index", "<missing>", 0)]
    assert compare({"p": [1, 2]}, {"p": [1, 2, 3]}) == [("/p/len", 2, 3)]
    assert compare({"x": float("nan")}, {"x": float("nan")}) == []


def test_checker_compares_a_scratch_run(tmp_path, monkeypatch):
    committed = tmp_path / "results"
    (committed / "study").mkdir(parents=True)
    (committed / "study" / "result.json").write_text('{"period_s": 0.25, "wall_s": 1.0}')
    monkeypatch.setattr(check_results, "RESULTS", committed)
    e = check_results.entry("study", "scripts/study.py", "study", ["study/result.json"])
    run = tmp_path / "run"
    (run / "study").mkdir(parents=True)
    (run / "study" / "result.json").write_text('{"period_s": 0.25, "wall_s": 9.0}')
    assert [f["status"] for f in check_results.compare_files(e, run, 1e-9)] == ["identical"]
    (run / "study" / "result.json").write_text('{"period_s": 0.2501, "wall_s": 9.0}')
    (row,) = check_results.compare_files(e, run, 1e-9)
    assert row["status"] == "differs" and row["differences"][0]["key"] == "/period_s"
    assert row["differences"][0]["relative"] == pytest.approx(0.0001 / 0.2501)
    loose = check_results.entry("study", "scripts/study.py", "study", ["study/result.json"], rtol=1e-3)
    assert [f["status"] for f in check_results.compare_files(loose, run, 1e-9)] == ["identical"]


def test_eigenvector_up_to_a_unit_factor_and_log_of_small_multiplier():
    vec = {"v_mps": [-0.449, -0.155], "p_radps": [1.0, 0.0], "r_radps": [0.325, 0.248]}
    flipped = {k: [-x for x in v] for k, v in vec.items()}
    assert compare({"eigenvector": vec}, {"eigenvector": flipped}) == []
    assert compare({"vector": vec}, {"vector": flipped})                      # only eigenvectors are rephased
    other = {**flipped, "r_radps": [-0.3, -0.248]}
    assert compare({"eigenvector": vec}, {"eigenvector": other})[0][0] == "/eigenvector/r_radps/0"
    assert compare({"beats_to_double": -0.0268764596}, {"beats_to_double": -0.0268764476}) == []
    assert compare({"beats_to_double": 2.5}, {"beats_to_double": 2.6})
    assert compare({"beats_to_double": 0.0}, {"beats_to_double": -0.0195}) == []   # |Lambda| ~ 4e-16 vs 0
    assert compare({"beats_to_double": -0.05}, {"beats_to_double": -0.0195})


TABLE = ("| problem | start; Hessian; iterations | status | r / |L1| | KKT | valid |\n|---|---|---|---|---|---|\n"
         "| tail | point reached; exact (FD); 8 | Solve_Succeeded | 1.0549 / 1.0161 | 3.2e-01 | True |\n")


def test_text_results_line_by_line():
    assert compare_text(TABLE, TABLE) == []
    assert compare_text(TABLE, TABLE.replace("1.0161", "1.0162")) == []          # printed rounding
    assert compare_text(TABLE, TABLE.replace("3.2e-01", "3.3e-01"))[0][0] == "line 3"   # 3 %, more than noise
    assert compare_text(TABLE, TABLE.replace("True", "False")) == [("line 3", TABLE.splitlines()[2],
                                                                    TABLE.replace("True", "False").splitlines()[2])]
    assert compare_text(TABLE, TABLE.replace("Solve_Succeeded", "Maximum_Iterations_Exceeded"))[0][0] == "line 3"
    assert compare_text(TABLE, TABLE + "\nLevel flight there.\n")[0] == ("lines", 3, 5)


def test_checker_compares_a_markdown_table_as_text(tmp_path, monkeypatch):
    committed = tmp_path / "results"
    (committed / "study").mkdir(parents=True)
    (committed / "study" / "table.md").write_text(TABLE)
    monkeypatch.setattr(check_results, "RESULTS", committed)
    e = check_results.entry("study", "scripts/study.py", "study", ["study/table.md"])
    run = tmp_path / "run"
    (run / "study").mkdir(parents=True)
    (run / "study" / "table.md").write_text(TABLE.replace("1.0549", "1.0548"))
    assert [f["status"] for f in check_results.compare_files(e, run, 1e-9)] == ["identical"]
    (run / "study" / "table.md").write_text(TABLE.replace("| 8 |", "| 40 |").replace("1.0549", "0.9580"))
    (row,) = check_results.compare_files(e, run, 1e-9)
    assert row["status"] == "differs" and row["differences"][0]["key"] == "line 3"


def _capped_row(r: float, lam: float, valid: bool = True, status: str = "Maximum_Iterations_Exceeded") -> dict:
    return {"gait": "tail", "label": "fd", "quasi_steady_radius": 0.9129, "active_limits": ["stalled_fraction"] if r < 0.9 else [],
            "optimum": {"status": status, "objective_value": r, "x0": [r, 2 * r],
                        "validity": {"valid": valid, "stalled_fraction": r / 10}},
            "fine_grid_trim": {"success": True, "lambda1": lam, "mean_forward_speed_mps": 18 * r}}


def _cap(old, new, **kw):
    return compare(old, new, unconverged_statements=True, **kw)


def test_an_iterate_at_its_iteration_cap_is_compared_by_what_it_is():
    # what it found (numbers, active set, flags, the cycles at its gait, its rounds) is the path's
    assert _cap(_capped_row(0.940, 0.97), _capped_row(0.710, 1.02, valid=False), rtol=1e-6) == []
    rounds = {"validity_rounds": [{"status": "Maximum_Iterations_Exceeded", "success": False}]}
    two = {"validity_rounds": rounds["validity_rounds"] * 2, "wall_s": {"start": 4.1}}
    assert _cap(_capped_row(0.94, 0.97) | rounds, _capped_row(0.94, 0.97) | two) == []
    # ... but only for the scripts registered as capped: elsewhere every number counts
    assert compare(_capped_row(0.940, 0.97), _capped_row(0.710, 0.97))
    # what it is is compared: problem, start (also a number of its start), cap, status, and its keys
    assert _cap(_capped_row(0.94, 0.97), {**_capped_row(0.94, 0.97), "label": "fd96"}) == [("/label", "fd", "fd96")]
    assert _cap(_capped_row(0.94, 0.97), {**_capped_row(0.94, 0.97), "quasi_steady_radius": 0.95})
    missing = {k: v for k, v in _capped_row(0.94, 0.97).items() if k != "fine_grid_trim"}
    assert _cap(_capped_row(0.94, 0.97), missing) == [("/fine_grid_trim", _capped_row(0.94, 0.97)["fine_grid_trim"],
                                                       "<missing>")]
    # a converged row on one side is a status difference (and two converged rows are compared by numbers)
    assert _cap(_capped_row(0.94, 0.97), _capped_row(0.94, 0.97, status="Solve_Succeeded")) == [
        ("/status", "Maximum_Iterations_Exceeded", "Solve_Succeeded")]
    converged = _capped_row(0.94, 0.97, status="Solve_Succeeded")
    assert _cap(converged, _capped_row(0.95, 0.97, status="Solve_Succeeded"), rtol=1e-6)
    assert _cap(converged, _capped_row(0.94, 0.97, valid=False, status="Solve_Succeeded"))
    # how it failed is the path's too (a failed multi-start row: iteration cap, then infeasibility detected)
    failed = {"start": {"a": 1.0}, "success": False, "status": "Maximum_Iterations_Exceeded", "radius": 1.52}
    other = {**failed, "status": "Infeasible_Problem_Detected", "radius": 1.12}
    assert _cap({"rows": [failed]}, {"rows": [other]}) == []
    assert _cap({"rows": [failed]}, {"rows": [{**other, "start": {"a": 2.0}}]}) == [("/rows/0/start/a", 1.0, 2.0)]
    # the engine's own status of a failed trim, inside a list of rows
    trim = {"status": "max_iter", "success": False, "max_residual": 1e-3, "lambda1": 0.99}
    assert _cap({"rows": [trim]}, {"rows": [{**trim, "max_residual": 2e-3, "lambda1": 0.995}]}) == []
    assert _cap({"rows": [trim]}, {"rows": [{**trim, "status": "converged", "success": True}]})


def test_a_line_about_a_capped_solve_is_compared_by_what_it_says_the_solve_is():
    row = ("| tail | wagner | point reached; exact (FD); 8 | 48 | Maximum_Iterations_Exceeded | 0.9568 / 0.9591 | "
           "True |\n")
    assert compare_text(row, row.replace("0.9568", "0.7100").replace("True", "False"), unconverged_statements=True) == []
    assert compare_text(row, row.replace("0.9568", "0.7100"))               # not a capped script: numbers count
    for cell in ("| tail |", "| wagner |", "exact (FD); 8", "| 48 |"):
        changed = row.replace(cell, {"| tail |": "| at_speed |", "| wagner |": "| today |",
                                     "exact (FD); 8": "SR1; 60", "| 48 |": "| 96 |"}[cell])
        assert compare_text(row, changed, unconverged_statements=True), cell
    line = "| tail | fd, an iterate at its iteration cap | converged | 6.4e-11 | 0.9697 | True |\n"
    assert compare_text(line, line.replace("0.9697", "1.0590").replace("True", "False"), unconverged_statements=True) == []
    plain = line.replace(", an iterate at its iteration cap", "")
    assert compare_text(plain, plain.replace("0.9697", "0.9590"), unconverged_statements=True)
    assert compare_text(line, plain, unconverged_statements=True)
    sentence = "Level flight there (tail, fd, an iterate at its iteration cap; amplitude solved): |L1| 0.9696."
    assert compare_text(sentence, sentence.replace("0.9696", "1.0100"), unconverged_statements=True) == []
    assert compare_text(sentence, sentence.replace("(tail", "(free_speed"), unconverged_statements=True)


def test_an_optimum_verification_block_is_compared_at_the_optimum_error():
    v = {"status": "Solve_Succeeded", "verification": {"trim_x0_difference": 1.47e-7, "trim_mean_vertical_speed_mps": -6e-8,
                                                        "power_difference_W": -7.2e-7, "trim_mean_shoulder_power_W": 8.2083786,
                                                        "trim_multipliers": [[0.9694013, 0.0029679], [0.2840549, 0.0]]}}
    w = {"status": "Solve_Succeeded", "verification": {"trim_x0_difference": 1.84e-7, "trim_mean_vertical_speed_mps": 8e-8,
                                                        "power_difference_W": 9.0e-7, "trim_mean_shoulder_power_W": 8.2083799,
                                                        "trim_multipliers": [[0.9694013, 0.0029660], [0.2840549, 0.0]]}}
    assert compare(v, w, rtol=1e-6, atol=1e-8) == []
    for key, value in (("trim_x0_difference", 3e-3), ("trim_mean_shoulder_power_W", 8.27),
                       ("trim_multipliers", [[0.9694013, 0.0129679], [0.2840549, 0.0]])):
        far = {**v, "verification": {**v["verification"], key: value}}
        assert compare(v, far, rtol=1e-6, atol=1e-8)[0][0].startswith(f"/verification/{key}"), key


def test_symmetry_zeros_and_eigenvector_shares():
    assert compare({"coupling_max": 2.8e-12, "max_abs_lateral_x0": 3.2e-12}, {"coupling_max": 4.3e-11, "max_abs_lateral_x0": 3.7e-11}) == []
    assert compare({"coupling_max": 2.8e-12}, {"coupling_max": 2e-9})         # above the solve's tolerance
    assert compare({"coupling_max": 0.0123}, {"coupling_max": 0.0124})        # a real coupling: relative
    assert compare({"body_share": 0.1903572481}, {"body_share": 0.1903572472}) == []
    assert compare({"body_share": 0.19035}, {"body_share": 0.19036})


def test_aero_valid_optimize_stages_are_chained_through_committed_seeds():
    entries = {e["name"]: e for e in check_results.REGISTRY if e["name"].startswith("aero-valid-optimize")}
    assert len(entries) == 5
    written = {f for e in entries.values() for f in e["files"]}
    for e in entries.values():
        args = e["args"]
        assert "--max-iter" in args or "--hessian" not in args     # iteration bounds, never wall time
        if "--from-reached" in args:                               # starts from a row it does not write
            gait = args[args.index("--gaits") + 1]
            assert check_results._opt(gait) in e["seed"] and check_results._opt(gait) not in e["files"]
        assert all(s in written for s in e["seed"])                # every seed is checked by its own entry
    tail = entries["aero-valid-optimize-tail-fd"]
    assert tail["args"][tail["args"].index("--max-iter") + 1] == "8"
    assert {"aero/valid/optimized.json", "aero/valid/optimized.md"} <= set(tail["files"])
    committed = {p.relative_to(check_results.RESULTS).as_posix()
                 for p in (check_results.RESULTS / "aero" / "valid").rglob("opt*")}
    assert committed <= written                                    # every file --optimize wrote is checked


def test_every_entry_registered_unconverged_has_an_unconverged_solve_committed():
    """The looser rule is only registered where it applies: each such entry's committed files hold at
    least one solve that did not converge."""
    import json

    def has(v) -> bool:
        if unconverged(v):
            return True
        items = v.values() if isinstance(v, dict) else v if isinstance(v, list) else ()
        return any(has(x) for x in items)

    flagged = [e for e in check_results.REGISTRY if e["unconverged"]]
    assert flagged
    for e in flagged:
        files = [p for p in check_results._committed(e) if p.suffix == ".json"]
        assert any(has(json.loads(p.read_text())) for p in files), e["name"]
