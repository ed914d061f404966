"""What the optimisers' capped iterates are cited for, solved again from their committed gaits.

An optimiser row stopped by its iteration cap (status ``Maximum_Iterations_Exceeded``) is a point of the
optimiser's path: a re-run of the same command ends at another point (a last-bit change of the code, or
the thread timing of the finite-difference Hessian, moves the path; docs/reproducibility.md), so
``scripts/check_results.py`` compares such a row only by what it is (problem, start, cap, status). What the
docs cite such a row for -- a level cycle found at its gait (stable or not, valid or not) -- is a property
of that *gait*, and this script checks it reproducibly: for every capped row committed under
``results/aero/valid/cases`` and ``results/aero/stall_optimum/cases`` that carries a ``fine_grid_trim``,
it solves level flight again from the committed gait, amplitude and state (148 RK4 steps per period, the
flapping amplitude solved: ``aero_valid_study.fine_grid_trim``) and, where the row has one, the
``wagner`` + ``stall`` level flight from the committed stall cycle (``aero_valid_study.stall_level_at_optimum``).
Converged solves from fixed inputs: the checker compares them by their numbers.

    python scripts/iterate_claims.py --out results/aero/iterate_claims

Writes DIR/cases/<folder>_<row>.json as each row finishes (a rerun skips the rows whose source file is
unchanged: its SHA-256 is recorded), then DIR/result.json and
DIR/table.md (each re-solved cycle beside the value the row itself recorded).
"""
from __future__ import annotations

import hashlib
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from aero_valid_study import _f, fine_grid_trim, stall_level_at_optimum  # noqa: E402
from result_compare import unconverged  # noqa: E402
from script_common import parse_with_out, script_parser, write_result  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
ROWS = ("aero/valid/cases/opt_*.json", "aero/stall_optimum/cases/opt_*.json")
"""The committed optimiser rows (globs relative to results/) whose capped iterates are re-verified."""


def capped_rows() -> list[Path]:
    """The committed rows of :data:`ROWS` stopped by their iteration cap (``result_compare.unconverged``, the
    rule that compares them by their statements only) that carry a ``fine_grid_trim``."""
    paths = sorted(p for g in ROWS for p in (ROOT / "results").glob(g))
    return [p for p in paths if unconverged(r := json.loads(p.read_text())) and "fine_grid_trim" in r]


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _claim(recorded: dict | None, solved: dict) -> dict:
    """A re-solved cycle beside the row's own record of it (``lambda1_difference``: |Lambda1| re-solved
    minus recorded, None when either failed)."""
    rec = recorded or {}
    diff = None if rec.get("lambda1") is None or solved.get("lambda1") is None else solved["lambda1"] - rec["lambda1"]
    return {"solved": {k: v for k, v in solved.items() if k != "wall_s"}, "recorded_lambda1": rec.get("lambda1"),
            "recorded_success": rec.get("success"), "lambda1_difference": diff}


def verify_row(path: Path) -> dict:
    """The claims of one committed capped row, solved again from its committed gait and states."""
    row = json.loads(path.read_text())
    t0 = time.perf_counter()
    out = {"source": path.relative_to(ROOT).as_posix(), "source_sha256": _sha256(path), "gait": row["gait"],
           "case": row["case"], "label": row.get("label") or "", "overrides": row["overrides"],
           "source_status": row["optimum"]["status"],
           "level": _claim(row.get("fine_grid_trim"), fine_grid_trim(row))}
    if (row.get("stall_level_at_optimum") or {}).get("success"):
        out["stall_level"] = _claim(row["stall_level_at_optimum"], stall_level_at_optimum(row))
    out["wall_s"] = time.perf_counter() - t0
    return out


def table(rows: list[dict]) -> str:
    """Markdown: one line per re-solved cycle (level flight at the row's gait; + stall where recorded)."""
    lines = ["| row | cycle | converged | \\|Λ1\\| re-solved (recorded) | stable | amplitude (deg) | U (m/s) | valid |",
             "|" + "---|" * 8]
    for r in rows:
        for name, c in (("level", r["level"]), ("wagner + stall level", r.get("stall_level"))):
            if c is None:
                continue
            s = c["solved"]
            lam = s.get("lambda1")
            lines.append(f"| {Path(r['source']).name} | {name} | {s['success']} | {_f(lam)} ({_f(c['recorded_lambda1'])}) | "
                         f"{'—' if lam is None else ('yes' if lam < 1 else 'no')} | {_f(s.get('amplitude_deg'), '{:.2f}')} | "
                         f"{_f(s.get('mean_forward_speed_mps'), '{:.2f}')} | {s.get('valid')} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/iterate_claims")
    args, out = parse_with_out(ap, argv)
    from birdocp.io.files import atomic_write_json

    (out / "cases").mkdir(exist_ok=True)
    rows = []
    for path in capped_rows():
        case = out / "cases" / f"{path.parent.parent.name}_{path.name}"
        if not case.exists() or json.loads(case.read_text()).get("source_sha256") != _sha256(path):
            print(f"{path.relative_to(ROOT)} ...", flush=True)
            atomic_write_json(case, verify_row(path))
        rows.append(json.loads(case.read_text()))
    write_result(out, {"rows": rows, "rows_from": list(ROWS)}, table(rows))
    claims = [c for r in rows for c in (r["level"], r.get("stall_level")) if c is not None]
    return 0 if all(c["solved"]["success"] for c in claims) else 1


if __name__ == "__main__":
    sys.exit(main())
