"""The reproduction scripts in scripts/: every one that writes files takes ``--out`` (through
script_common.script_parser), so a re-run can go elsewhere than the committed results/."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WRITES = ("atomic_write", "write_text", "savefig", "open(")


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
