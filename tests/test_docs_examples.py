"""Every Python example in the README and the documentation pages runs as printed (issue 26: "every
README example runs as printed (a test runs them)").

The blocks of one page run in order in one namespace, as a reader would paste them. A block is left
out only when the line just before it marks it: ``<!-- sketch: ... -->`` (Markdown) or
``.. sketch: ...`` (reStructuredText) for a fragment that is not a program, ``<!-- not-run: ... -->``
for a block whose page says why it is not run here (minutes of optimisation). The tutorials are
run by the documentation build (sphinx-gallery), not here.
"""
from __future__ import annotations

import re
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md")) + sorted((ROOT / "docs").rglob("*.rst"))
PAGES = [p for p in PAGES if not {"_build", "_autosummary", "tutorials"} & set(p.relative_to(ROOT).parts)]
MARK = re.compile(r"^(<!--|\.\.)\s*(sketch|not-run)\b")


def python_blocks(path: Path) -> list[tuple[int, str, str | None]]:
    """(line, code, marker) of each Python block of a Markdown or reStructuredText page."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        line = lines[i]
        prev = next((lines[k] for k in range(i - 1, -1, -1) if lines[k].strip()), "")
        mark = MARK.match(prev.strip())
        marker = mark.group(2) if mark else None
        if line.strip() in ("```python", "```{code-block} python"):
            j = i + 1
            while not lines[j].startswith("```"):
                j += 1
            blocks.append((i + 1, "\n".join(lines[i + 1:j]), marker))
            i = j + 1
            continue
        if line.strip() == ".. code-block:: python":
            j = i + 1
            body = []
            while j < len(lines) and (not lines[j].strip() or lines[j].startswith("   ")):
                body.append(lines[j][3:])
                j += 1
            blocks.append((i + 1, "\n".join(body).strip("\n"), marker))
            i = j
            continue
        i += 1
    return blocks


CASES = [pytest.param(p, id=str(p.relative_to(ROOT))) for p in PAGES if any(not m for _, _, m in python_blocks(p))]


def test_pages_have_examples():
    """The collection finds the examples (so the test below checks something)."""
    assert len(CASES) >= 5


@pytest.mark.slow
@pytest.mark.parametrize("page", CASES)
def test_examples_run_as_printed(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)          # a block that writes files writes them here
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict = {"__name__": "__docs_example__"}
    for line, code, marker in python_blocks(page):
        if marker:
            continue
        try:
            exec(compile(code, f"{page.relative_to(ROOT)}:{line}", "exec"), namespace)
        except Exception as exc:
            pytest.fail(f"{page.relative_to(ROOT)}, block at line {line}: {type(exc).__name__}: {exc}")
