"""Do the committed results reproduce? Re-run each script that wrote a committed result folder, with
``--out`` into a scratch folder, and compare every JSON number with the committed one
(``scripts/result_compare.py``: exact integers and strings, floats within ``--rtol``; timing, host and
provenance keys ignored).

    python scripts/check_results.py --out /tmp/repro                       # every script under --budget-s
    python scripts/check_results.py --out /tmp/repro --only experiment1 examples-lorenz
    python scripts/check_results.py --out /tmp/repro --list                # the registry, nothing run

Prints one line per result (``identical``, ``differs: <first keys with both values>``, ``skipped: ...``,
``failed: ...``) and writes OUT/report.json and OUT/report.md; the regenerated folders stay in OUT/runs/.
The scripts run one at a time, in this process's foreground (each under ``timeout --budget-s``). A script
whose recorded duration (read from its committed JSON) is over the budget is skipped as too slow without
being run; so are the benchmarks (their numbers are timings) and the reference runs that need another
environment (AeroSandbox, PteraSoftware). The report also lists the scripts with no committed output and
the committed JSON files that no registered script writes.
"""
from __future__ import annotations

import argparse
import fnmatch
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from result_compare import compare, compare_text, relative_gap  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"


def entry(name, script, out, files, args=(), seed=(), recorded=(), skip=None, out_file=None, rtol=0.0,
          then=(), unconverged=False):
    """One registered script: ``out`` the results sub-folder it writes (``--out``), ``files`` the globs
    (relative to results/) compared, ``seed`` committed inputs copied beside the scratch output first,
    ``recorded`` ``(file, key, ...)`` paths whose sum is its recorded duration in seconds, ``skip`` a reason
    not to run it, ``out_file`` when ``--out`` takes a file (relative to results/) rather than a folder,
    ``rtol`` a floor on ``--rtol`` for this script's files (:data:`OPTIMUM_RTOL`), ``then`` argument lists
    of further runs of the same script into the same folder (a result written in several steps), ``unconverged``
    that its solves that did not converge are compared by their statements (the scripts whose failed
    solves were measured to move with the solver's path: result_compare.compare)."""
    return {"name": name, "script": script, "out": out, "files": list(files), "args": list(args),
            "seed": list(seed), "recorded": list(recorded), "skip": skip, "out_file": out_file, "rtol": rtol,
            "then": [list(t) for t in then], "unconverged": unconverged}


#: The relative tolerance of the optimisers' results: an optimum solved to a KKT residual of ~1e-8
#: (IPOPT's tol) is determined only to about that, times the problem's conditioning; its free values,
#: multipliers and validity extremes move together by 1e-9..1e-7 when round-off changes (measured:
#: lateral_optimum.py's optimum moved by 2.8e-9 relative, the same 25 iterations).
OPTIMUM_RTOL = 1e-6
#: The absolute tolerance of the same results: what is zero at a converged optimum (a constraint's
#: residual such as a level cycle's mean vertical speed, the multiplier of an inactive constraint, the
#: KKT residual itself) is zero only to the optimiser's KKT tolerance, ~1e-8 (measured: a mean vertical
#: speed of -6.99e-12 against -6.93e-12, a KKT residual of 6.02e-8 against 6.21e-8, inactive multipliers
#: of -1.17366e-10 against -1.17355e-10, with the same optimum).
OPTIMUM_ATOL = 1e-8


#: ``scripts/aero_valid_study.py --optimize`` (results/aero/valid/cases/opt_*): the SR1 stage of each problem
#: from the quasi-steady optimum (at_speed, free_speed, tail: independent runs), then the exact-Hessian stage
#: (:data:`AERO_FD`) of free_speed and tail from the point their SR1 stage reached, read from the out folder.
#: Each stage is its own entry, so the five run in parallel (``--only 'aero-valid-optimize*'`` in separate
#: calls): an exact-Hessian stage's folder is seeded with the *committed* SR1 row it starts from (checked
#: identical by that stage's own entry), as the committed row was made from it. The tail stage's folder is
#: seeded with the four other committed rows, so its run writes optimized.json and optimized.md from all five,
#: as the last of the committed runs did. Iteration bounds only: the tail exact-Hessian stage stops at 8
#: iterations, where the committed run stopped (it was cut by a wall-clock limit, removed since). The rows
#: of the stages stopped by their cap (the SR1 stages of free_speed and tail, the tail's exact-Hessian stage)
#: are iterates of the optimiser's path and are compared by their statements (result_compare.unconverged); the
#: converged optima (at_speed, free_speed's exact-Hessian stage) by their numbers, to :data:`OPTIMUM_RTOL`.
AERO_OPTIMIZE = ["--optimize", "--cases", "wagner"]
AERO_FD = ["--hessian", "fd", "--from-reached", "--valid-rounds", "2", "--own-state", "--stall-at-optimum", "30",
           "--label", "fd_reached"]


def _opt(gait: str, label: str = "") -> str:
    """The case file (relative to results/) of an ``--optimize`` row of ``gait`` with ``wagner``."""
    return f"aero/valid/cases/opt_{gait}_wagner{'_' + label if label else ''}.json"


EXAMPLES = ("forced_van_der_pol", "goodwin", "lorenz", "redox", "rossler", "stuart_landau")
TIMINGS = "benchmark: its numbers are timings, not results"
EXTERNAL = "runs in another environment (a reference code), not on birdocp"
REGISTRY = [
    entry("experiment1", "scripts/experiment1.py", "experiment1", ["experiment1/result.json"],
          recorded=[("experiment1/result.json", "wall_s_script")]),
    entry("experiment2", "scripts/experiment2.py", "experiment2",
          ["experiment2/result.json", "experiment2/sweep/sweep.json", "experiment2/sweep/points/*.json"]),
    entry("experiment3", "scripts/experiment3.py", "experiment3", ["experiment3/*.json"],
          recorded=[(f"experiment3/branch_{b}.json", "job_wall_s") for b in
                    ("fixed_down", "fixed_up", "level_down", "level_up")]),
    entry("appendix", "scripts/appendix_jacobians.py", "appendix", ["appendix/jacobians.json"],
          recorded=[("appendix/jacobians.json", "wall_s_script")]),
    *[entry(f"examples-{e}", f"scripts/examples/{e}.py", f"engine/{e}", [f"engine/{e}/result.json"],
            recorded=[(f"engine/{e}/result.json", "wall_s")]) for e in EXAMPLES],
    entry("examples-theodorsen", "scripts/examples/theodorsen.py", "aero/theodorsen",
          ["aero/theodorsen/result.json"], recorded=[("aero/theodorsen/result.json", "wall_s")]),
    entry("rk4-order", "scripts/rk4_order.py", "engine/rk4_order", ["engine/rk4_order/rk4_order.json"]),
    entry("continuation-error-estimate", "scripts/continuation_error_estimate.py", "engine",
          ["engine/continuation_error_estimate.json"], out_file="engine/continuation_error_estimate.json"),
    entry("model-validation", "scripts/validate_model.py", ".", ["model_validation.json"],
          out_file="model_validation.json"),
    entry("glide-comparison", "scripts/glide_comparison.py", "lateral/glide",
          ["lateral/glide/birdocp.json", "lateral/glide/geometry.json", "lateral/glide/comparison.json"],
          seed=["lateral/glide/aerosandbox.json", "lateral/glide/aerosandbox_linear.json",
                "lateral/glide/aerosandbox_chordwise16.json", "lateral/glide/aerosandbox_chordwise1.json"]),
    entry("glide-induced-check", "scripts/glide_induced_check.py", "lateral/glide",
          ["lateral/glide/induced_check.json"], seed=["lateral/glide/aerosandbox_linear.json"]),
    entry("glide-section-law", "scripts/glide_section_law.py", "lateral/glide",
          ["lateral/glide/section_law.json"]),
    entry("lateral-asymmetric", "scripts/lateral_asymmetric.py", "lateral/asymmetric",
          ["lateral/asymmetric/result.json"], recorded=[("lateral/asymmetric/result.json", "wall_s")]),
    entry("lateral-figures", "scripts/lateral_figures.py", "lateral/modes", ["lateral/modes/modes.json"],
          args=["--gif", ""]),
    entry("lateral-unsteady", "scripts/lateral_unsteady.py", "lateral/unsteady", ["lateral/unsteady/result.json"],
          recorded=[("lateral/unsteady/result.json", "wall_s")]),
    entry("lateral-simulate-aero", "scripts/lateral_simulate_aero.py", "lateral/simulate_aero",
          ["lateral/simulate_aero/result.json"], recorded=[("lateral/simulate_aero/result.json", "wall_s")]),
    entry("lateral-sweep", "scripts/lateral_sweep.py", "lateral/sweep", ["lateral/sweep/result.json"],
          recorded=[("lateral/sweep/result.json", "wall_s")]),
    entry("lateral-optimum", "scripts/lateral_optimum.py", "lateral/optimum", ["lateral/optimum/result.json"],
          recorded=[("lateral/optimum/result.json", "script_wall_s")], rtol=OPTIMUM_RTOL),
    entry("lateral-turn-power", "scripts/lateral_turn_power.py", "lateral/turn_power",
          ["lateral/turn_power/result.json"], recorded=[("lateral/turn_power/result.json", "wall_s")],
          rtol=OPTIMUM_RTOL),
    entry("lateral-control", "scripts/lateral_control_study.py", "lateral/control",
          ["lateral/control/result.json"], recorded=[("lateral/control/result.json", "wall_s")]),
    entry("lateral-study", "scripts/lateral_study.py", "lateral", ["lateral/result.json"],
          recorded=[("lateral/result.json", "wall_s")]),
    entry("lateral-masses", "scripts/lateral_masses.py", "lateral/masses", ["lateral/masses/result.json"],
          recorded=[("lateral/masses/result.json", "wall_s")]),
    entry("lateral-stall", "scripts/lateral_stall.py", "lateral/stall", ["lateral/stall/result.json"],
          recorded=[("lateral/stall/result.json", "wall_s")]),
    entry("control", "scripts/control_study.py", "control", ["control/result.json"],
          recorded=[("control/result.json", "wall_s")]),
    entry("inertia", "scripts/inertia_study.py", "inertia", ["inertia/result.json"],
          recorded=[("inertia/result.json", "wall_s", "total")]),
    entry("aero-cases-fast", "scripts/aero_study.py", "aero", ["aero/cases/today.json", "aero/cases/wagner.json",
                                                                 "aero/cases/lag_only.json"],
          args=["--cases", "today", "wagner", "lag_only"],
          recorded=[(f"aero/cases/{c}.json", k) for c in ("today", "wagner", "lag_only")
                    for k in ("trim_wall_s", "level_wall_s")]),
    entry("aero-cases-slow", "scripts/aero_study.py", "aero",
          ["aero/cases/lag_added_mass.json", "aero/cases/lag_three_quarter_chord.json",
           "aero/cases/wagner_stall.json", "aero/cases/wagner_dynamic_stall.json", "aero/table.json"],
          recorded=[(f"aero/cases/{c}.json", k) for c in ("today", "wagner", "lag_only", "lag_added_mass",
                                                          "lag_three_quarter_chord", "wagner_stall",
                                                          "wagner_dynamic_stall")
                    for k in ("trim_wall_s", "level_wall_s")]),
    entry("aero-options-matrix", "scripts/aero_options_matrix.py", "aero/options_matrix",
          ["aero/options_matrix/matrix.json", "aero/options_matrix/cases/*.json",
           "aero/options_matrix/optimum_stall_scan.json", "aero/options_matrix/level_solvers.json"],
          then=[["--optimum-scan"], ["--level-solvers"]],
          recorded=[("aero/options_matrix/cases/*.json", k, "wall_s") for k in ("trim", "level", "continuation")]),
    entry("stability", "scripts/stability_study.py", ".", ["stability_optimum/result.json"],
          recorded=[("stability_optimum/result.json", "script_wall_s")], rtol=OPTIMUM_RTOL),
    entry("energetics-optimize-stability", "scripts/energetics_study.py", "energetics",
          ["energetics/result.json"], args=["--only", "optimize-stability"],
          seed=["energetics/result.json", "stability_optimum/result.json"], rtol=OPTIMUM_RTOL),
    entry("energetics", "scripts/energetics_study.py", "energetics",
          ["energetics/result.json", "energetics/power_curve.json", "energetics/optimal_gait.json",
           "energetics/most_stable_gait.json"], seed=["stability_optimum/result.json"],
          recorded=[("energetics/result.json", "wall_s")], rtol=OPTIMUM_RTOL),
    entry("tail", "scripts/tail_study.py", "tail", ["tail/branch_*.json"],
          recorded=[("tail/branch_*.json", "wall_s")]),
    entry("tail-optimum", "scripts/tail_study.py", "tail", ["tail/optimum_valid.json", "tail/summary.json"],
          args=["--optimize"], recorded=[("tail/optimum_valid.json", "script_wall_s")], rtol=OPTIMUM_RTOL),
    entry("stability-valid", "scripts/stability_valid_study.py", "stability_optimum/valid",
          ["stability_optimum/valid/result.json"],
          recorded=[("stability_optimum/valid/result.json", g, "script_wall_s") for g in ("free_speed", "at_speed")], rtol=OPTIMUM_RTOL,
          unconverged=True),
    entry("energetics-valid", "scripts/energetics_valid_study.py", "energetics/valid",
          ["energetics/valid/result.json"], seed=["stability_optimum/valid/result.json"],
          recorded=[("energetics/valid/result.json", "wall_s")], rtol=OPTIMUM_RTOL, unconverged=True),
    entry("aero-valid", "scripts/aero_valid_study.py", "aero/valid",
          ["aero/valid/table.json", "aero/valid/cases/at_speed_*.json", "aero/valid/cases/free_speed_*.json"],
          recorded=[(f"aero/valid/cases/{g}_{c}.json", "trim_wall_s") for g in ("at_speed", "free_speed")
                    for c in ("today", "wagner", "wagner_stall")]),
    *[entry(f"aero-valid-optimize-{g.replace('_', '-')}", "scripts/aero_valid_study.py", "aero/valid", [_opt(g)],
            args=[*AERO_OPTIMIZE, "--gaits", g], recorded=[(_opt(g), "wall_s")], rtol=OPTIMUM_RTOL,
            unconverged=g != "at_speed") for g in ("at_speed", "free_speed", "tail")],
    entry("aero-valid-optimize-free-speed-fd", "scripts/aero_valid_study.py", "aero/valid",
          [_opt("free_speed", "fd_reached")], seed=[_opt("free_speed")], rtol=OPTIMUM_RTOL,
          args=[*AERO_OPTIMIZE, "--gaits", "free_speed", *AERO_FD, "--max-iter", "40"],
          recorded=[(_opt("free_speed", "fd_reached"), "wall_s")], unconverged=True),
    entry("aero-valid-optimize-tail-fd", "scripts/aero_valid_study.py", "aero/valid",
          [_opt("tail", "fd_reached"), "aero/valid/optimized.json", "aero/valid/optimized.md"],
          seed=[_opt("at_speed"), _opt("free_speed"), _opt("tail"), _opt("free_speed", "fd_reached")],
          args=[*AERO_OPTIMIZE, "--gaits", "tail", *AERO_FD, "--max-iter", "8"], rtol=OPTIMUM_RTOL,
          recorded=[(_opt("tail", "fd_reached"), "wall_s")], unconverged=True),
    entry("aero-stall-optimum", "scripts/aero_stall_optimum.py", "aero/stall_optimum",
          ["aero/stall_optimum/result.json", "aero/stall_optimum/scan.json", "aero/stall_optimum/cases/opt_*.json"],
          args=["--max-iter", "6", "--label", "explore6"],
          then=[["--from-label", "explore6", "--max-iter", "10", "--label", "fd16"]],
          recorded=[("aero/stall_optimum/cases/opt_*.json", "wall_s")], rtol=OPTIMUM_RTOL, unconverged=True),
    entry("aero-iterate-claims", "scripts/iterate_claims.py", "aero/iterate_claims",
          ["aero/iterate_claims/result.json", "aero/iterate_claims/table.md", "aero/iterate_claims/cases/*.json"],
          recorded=[("aero/iterate_claims/cases/*.json", "wall_s")]),
    entry("reference-trim", "-m birdocp trim", "animation/reference_trim",
          ["animation/reference_trim/result.json"], recorded=[("animation/reference_trim/result.json", "wall_s")]),
    entry("hostile-cases", "scripts/hostile_cases.py", "reliability", ["reliability/hostile_cases.json"],
          skip="no --out: writes results/reliability itself; its numbers are exit codes of CLI fault cases"),
    *[entry(n, f"scripts/{n}.py", ".", [f], skip=TIMINGS) for n, f in (
        ("benchmark", "benchmark.json"), ("benchmark_compiled", "benchmark_compiled.json"),
        ("benchmark_model", "benchmark_model.json"), ("benchmark_sixdof", "benchmark_sixdof.json"),
        ("benchmark_aero", "aero/benchmark*.json"), ("benchmark_validity", "stability_optimum/benchmark_validity.json"),
        ("benchmark_engine", "engine/[br]e*.json"))],
    entry("uvlm-inputs", "scripts/reference_uvlm/make_inputs.py", "aero/uvlm", ["aero/uvlm/inputs.json"]),
    entry("uvlm-compare", "scripts/reference_uvlm/compare.py", "aero/uvlm", ["aero/uvlm/result.json"],
          args=["--unsteady", "none"], then=[["--unsteady", "wagner"]],
          seed=["aero/uvlm/inputs.json", "aero/uvlm/uvlm.json"]),
    entry("reference-uvlm", "scripts/reference_uvlm/run_uvlm.py", "aero/uvlm", ["aero/uvlm/uvlm.json",
                                                                                  "aero/uvlm/steady/*.json"],
          skip=EXTERNAL),
    entry("wing-kinematics", "scripts/plot_wing_kinematics.py", ".", [],
          skip="a figure only (results/wing_kinematics.png), no JSON to compare"),
    entry("reference-aerosandbox", "scripts/reference_aerosandbox/run_aerosandbox.py", "lateral/glide",
          ["lateral/glide/aerosandbox*.json"], skip=EXTERNAL),
]


def _recorded_s(e) -> float | None:
    """The script's duration recorded in its committed JSON (sum over ``recorded``), or None."""
    total, found = 0.0, False
    for file, *keys in e["recorded"]:
        for path in sorted(RESULTS.glob(file)):
            v = json.loads(path.read_text())
            for k in keys:
                v = v.get(k) if isinstance(v, dict) else None
            if isinstance(v, dict):
                v = v.get("total", sum(x for x in v.values() if isinstance(x, (int, float))))
            if isinstance(v, (int, float)):
                total, found = total + v, True
    return total if found else None


def _committed(e) -> list[Path]:
    return sorted({p for g in e["files"] for p in RESULTS.glob(g) if p.is_file()})


def _command(e, run_root: Path, args=None) -> list[str]:
    out = run_root / (e["out_file"] or e["out"])
    head = e["script"].split() if e["script"].startswith("-m ") else [str(ROOT / e["script"])]
    return [sys.executable, *head, *(e["args"] if args is None else args), "--out", str(out)]


def _prepare(e, run_root: Path) -> None:
    if run_root.exists():
        shutil.rmtree(run_root)
    run_root.mkdir(parents=True)
    for rel in e["seed"]:
        (run_root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(RESULTS / rel, run_root / rel)
    if not e["out_file"] and not e["script"].startswith("-m "):
        (run_root / e["out"]).mkdir(parents=True, exist_ok=True)


def _normalise(text: str, run_root: Path) -> str:
    """The regenerated JSON text with the scratch folder's path written as the committed one's."""
    return text.replace(str(run_root) + "/", "results/").replace(str(run_root), "results").replace(
        str(ROOT) + "/", "")


def compare_files(e, run_root: Path, rtol: float) -> list[dict]:
    """One row per committed file of entry ``e``: identical, differs (first differences) or missing. JSON
    files are compared by :func:`result_compare.compare`, others (a Markdown table) by
    :func:`result_compare.compare_text`."""
    rows = []
    for old in _committed(e):
        rel = old.relative_to(RESULTS).as_posix()
        new = run_root / rel
        if not new.exists():
            rows.append({"file": rel, "status": "missing", "differences": []})
            continue
        text = _normalise(new.read_text(), run_root)
        diffs = compare(json.loads(old.read_text()), json.loads(text), rtol=max(rtol, e["rtol"]),
                        atol=OPTIMUM_ATOL if e["rtol"] >= OPTIMUM_RTOL else 1e-14, unconverged_statements=e["unconverged"]) \
            if old.suffix == ".json" else compare_text(old.read_text(), text, unconverged_statements=e["unconverged"])
        rows.append({"file": rel, "status": "differs" if diffs else "identical",
                     "differences": [{"key": k, "committed": a, "regenerated": b, "relative": relative_gap(a, b)}
                                     for k, a, b in diffs]})
    return rows


def check(e, runs: Path, budget_s: float, rtol: float, compare_only: bool = False) -> dict:
    """Run entry ``e`` (unless skipped) into ``runs/<name>`` and compare; the report row. With
    ``compare_only``, compare the run left in ``runs/<name>`` by an earlier call (``not run`` if none)."""
    row = {"name": e["name"], "script": e["script"], "args": e["args"], "recorded_s": _recorded_s(e),
           "committed": [p.relative_to(RESULTS).as_posix() for p in _committed(e)]}
    if e["skip"]:
        return {**row, "status": "skipped", "reason": e["skip"]}
    run_root = runs / e["name"]
    if row["recorded_s"] is not None and row["recorded_s"] > budget_s and not (run_root / "run.json").exists():
        return {**row, "status": "skipped", "reason": f"too slow: recorded {row['recorded_s']:.0f} s > "
                                                        f"--budget-s {budget_s:.0f}"}
    if compare_only:
        if not (run_root / "run.json").exists():
            return {**row, "status": "skipped", "reason": "not run (compare-only, no earlier run in --out)"}
        row.update(json.loads((run_root / "run.json").read_text()))
    else:
        row.update(_run(e, run_root, budget_s))
    if row["returncode"] in (124, 130, -2, 137):
        return {**row, "status": "skipped", "reason": f"too slow: killed after {row['wall_s']:.0f} s "
                                                        f"(--budget-s {row['budget_s']:.0f})"}
    files = compare_files(e, run_root, rtol)
    status = "identical" if all(f["status"] == "identical" for f in files) else "differs"
    if row["returncode"] != 0:
        status = "failed" if status != "identical" else status
    return {**row, "status": status, "files": files}


def _run(e, run_root: Path, budget_s: float) -> dict:
    """Run the script of ``e`` into ``run_root`` under ``timeout``; what happened (also in run.json)."""
    _prepare(e, run_root)
    t0, text = time.perf_counter(), ""
    for args in [e["args"], *e["then"]]:
        cmd = _command(e, run_root, args)
        left = max(1.0, budget_s - (time.perf_counter() - t0))
        try:
            p = subprocess.run(["timeout", "-s", "INT", "-k", "30", f"{left:.0f}", *cmd], cwd=run_root,
                               capture_output=True, text=True)
        except KeyboardInterrupt:
            raise SystemExit(130) from None
        text += f"$ {' '.join(cmd)}\n{p.stdout}\n--- stderr ---\n{p.stderr}\n"
        if p.returncode != 0:
            break
    from birdocp.io.files import atomic_write_json, atomic_write_text

    atomic_write_text(run_root / "stdout.txt", text)
    run = {"wall_s": round(time.perf_counter() - t0, 1), "command": " ".join(cmd), "returncode": p.returncode,
           "budget_s": budget_s, "stderr_tail": p.stderr.strip().splitlines()[-3:],
           "load_average_after": " ".join(f"{x:.2f}" for x in os.getloadavg())}
    atomic_write_json(run_root / "run.json", run)
    return run


def _value(v) -> str:
    s = json.dumps(v)
    return s if len(s) <= 60 else s[:57] + "..."


def line(row: dict) -> str:
    """The one-line verdict of a report row."""
    head = f"{row['name']:<32} "
    if row["status"] == "skipped":
        return head + f"skipped: {row['reason']}"
    took = f" ({row['wall_s']:.0f} s)"
    if row["status"] == "identical":
        return head + f"identical ({len(row['files'])} files){took}"
    bad = [f for f in row["files"] if f["status"] != "identical"]
    first = bad[0] if bad else {"file": "-", "status": "", "differences": []}
    what = "; ".join(f"{d['key']}: {_value(d['committed'])} -> {_value(d['regenerated'])}"
                     for d in first["differences"][:3]) or first["status"]
    rc = f" [exit {row['returncode']}]" if row["returncode"] else ""
    return head + f"{row['status']}{rc}: {len(bad)}/{len(row['files'])} files; {first['file']}: {what}{took}"


def uncovered() -> dict:
    """Scripts that no registry entry runs, and committed JSON files that no entry compares."""
    registered = {e["script"] for e in REGISTRY}
    helpers = {"script_common.py", "result_compare.py", "check_results.py", "example_common.py",
               "reference_toolbox.py", "cycle_phase.py", "report.py"}  # modules the scripts import
    scripts = sorted(p.relative_to(ROOT).as_posix() for p in (ROOT / "scripts").rglob("*.py")
                     if p.name not in helpers and p.relative_to(ROOT).as_posix() not in registered)
    covered = {p for e in REGISTRY for p in _committed(e)}
    files = sorted(p.relative_to(RESULTS).as_posix() for p in RESULTS.rglob("*.json") if p not in covered
                   and "reproducibility" not in p.parts)
    return {"scripts_without_registered_output": scripts, "committed_json_without_script": files}


def markdown(report: dict) -> str:
    """report.md: the settings, one line per result, and what is not covered."""
    lines = ["# Do the committed results reproduce?", "",
             f"`python scripts/check_results.py --out DIR` on {report['revision']} (birdocp imported from "
             f"`{report.get('birdocp')}`), `--rtol {report['rtol']:g}`, "
             f"`--budget-s {report['budget_s']:.0f}`, load average {report['load_average']} at the start.",
             "Timing, host and provenance keys ignored (`scripts/result_compare.py`); what was found and "
             "re-committed: docs/reproducibility.md.", "", "```"]
    lines += [line(r) for r in report["rows"]] + ["```", ""]
    for r in report["rows"]:
        for f in r.get("files", []):
            if f["status"] != "identical":
                lines.append(f"- `{f['file']}` {f['status']}: " + "; ".join(
                    f"`{d['key']}` {_value(d['committed'])} -> {_value(d['regenerated'])}"
                    for d in f["differences"][:6]))
    un = report["uncovered"]
    lines += ["", "Scripts with no registered output: " + (", ".join(f"`{s}`" for s in
                                                             un["scripts_without_registered_output"]) or "none"),
              "", "Committed JSON that no registered script writes: " + (
                  ", ".join(f"`{s}`" for s in un["committed_json_without_script"]) or "none"), ""]
    return "\n".join(lines)


def write_report(report: dict, out: Path) -> None:
    """OUT/report.json and OUT/report.md (rewritten after every result, so an interrupted check keeps
    what it has)."""
    from birdocp.io.files import atomic_write_json, atomic_write_text

    report["uncovered"] = uncovered()
    atomic_write_json(out / "report.json", report)
    atomic_write_text(out / "report.md", markdown(report))


def _imported_birdocp() -> str:
    """The birdocp package the scripts import (this interpreter, outside the repository), with a warning
    when it is not this repository's."""
    p = subprocess.run([sys.executable, "-c", "import birdocp; print(birdocp.__file__)"], cwd="/",
                       capture_output=True, text=True)
    where = str(Path(p.stdout.strip()).parent) if p.returncode == 0 else "not importable"
    if where != str(ROOT / "birdocp"):
        print(f"warning: the scripts import birdocp from {where}, not {ROOT / 'birdocp'} "
              f"(run this script with the repository's environment)", file=sys.stderr)
    return where


def _revision() -> str:
    p = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True)
    return p.stdout.strip() or "unknown"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="scratch and report folder (runs/, report.json, report.md)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="these registry names (shell patterns) only")
    ap.add_argument("--rtol", type=float, default=1e-9, help="relative tolerance on floats (default %(default)g)")
    ap.add_argument("--budget-s", type=float, default=600.0,
                    help="longest run allowed per script in s, recorded or measured (default %(default)g)")
    ap.add_argument("--list", action="store_true", help="print the registry and exit")
    ap.add_argument("--compare-only", action="store_true",
                    help="run nothing: compare the runs left in OUT/runs by earlier calls (report of several calls)")
    args = ap.parse_args(argv)
    if args.rtol < 0 or args.budget_s <= 0:
        print("--rtol must be >= 0 and --budget-s > 0", file=sys.stderr)
        return 2
    names = [e["name"] for e in REGISTRY]
    bad = [n for n in args.only or [] if not fnmatch.filter(names, n)]
    if bad:
        print(f"--only: no registry entry {bad}; see --list", file=sys.stderr)
        return 2
    chosen = [e for e in REGISTRY if not args.only or any(fnmatch.fnmatch(e["name"], n) for n in args.only)]
    if args.list:
        for e in chosen:
            print(f"{e['name']:<32} {e['script']} {' '.join(e['args'])} -> results/{e['out_file'] or e['out']}"
                  + (f"  [skip: {e['skip']}]" if e["skip"] else ""))
        return 0
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    report = {"revision": _revision(), "birdocp": _imported_birdocp(), "rtol": args.rtol, "budget_s": args.budget_s,
              "load_average": " ".join(f"{x:.2f}" for x in os.getloadavg()), "rows": []}
    for e in chosen:
        report["rows"].append(check(e, out / "runs", args.budget_s, args.rtol, args.compare_only))
        print(line(report["rows"][-1]), flush=True)
        write_report(report, out)
    write_report(report, out)
    return 0 if all(r["status"] in ("identical", "skipped") for r in report["rows"]) else 1


if __name__ == "__main__":
    sys.exit(main())
