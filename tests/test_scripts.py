"""The reproduction scripts in scripts/: every one that writes files takes ``--out`` (through
script_common.script_parser), so a re-run can go elsewhere than the committed results/."""
from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
WRITES = ("atomic_write", "write_result", "write_text", "savefig", "open(")


def _calls(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Call):
            f = node.func
            names.add(f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else "")
    return names


def test_every_writing_script_takes_out():
    missing = []
    for path in sorted((ROOT / "scripts").glob("*.py")):
        if path.name == "script_common.py":
            continue
        text = path.read_text(encoding="utf-8")
        if not any(w in text for w in WRITES):
            continue
        if "script_parser" not in _calls(path) and '"--out"' not in text:
            missing.append(path.name)
    assert not missing, f"scripts writing files without --out: {missing}"


def test_write_result_writes_the_json_and_the_table_and_prints_the_table(tmp_path, capsys, monkeypatch):
    import json

    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    from script_common import write_result

    write_result(tmp_path, {"wall_s": 1.5, "rows": [1, 2]}, "| a |\n|---|\n")
    assert json.loads((tmp_path / "result.json").read_text()) == {"wall_s": 1.5, "rows": [1, 2]}
    assert (tmp_path / "table.md").read_text() == "| a |\n|---|\n"
    assert capsys.readouterr().out == "| a |\n|---|\n\n"


@pytest.mark.slow
def test_experiment3_reuse_redraws_and_writes_its_result_again_byte_for_byte(tmp_path):
    """``scripts/experiment3.py --reuse`` with two workers on a copy of the committed Experiment 3: it
    ends (it used to hang closing a worker pool started from its drawing thread, whose workers died
    with that thread), redoes no trim, and writes result.json, table.md and the branches again byte for
    byte (the trim checks and wall times are those of the run that computed them), with the figures."""
    src = ROOT / "results" / "experiment3"
    out = tmp_path / "experiment3"
    shutil.copytree(src, out)
    figures = sorted(p.name for p in src.glob("*.png"))
    for name in figures:
        (out / name).unlink()
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "experiment3.py"), "--reuse", "--jobs", "2",
                        "--out", str(out)], capture_output=True, text=True, timeout=240)
    assert r.returncode == 0, r.stderr[-2000:]
    for path in sorted(src.glob("*.json")) + [src / "table.md"]:
        assert (out / path.name).read_bytes() == path.read_bytes(), path.name
    assert len(figures) == 4 and all((out / name).stat().st_size > 10_000 for name in figures)
