"""Sphinx directive ``birdocp-layout``: the repository's layout, generated from the tree at build time.

For each folder given as an argument (default: ``birdocp scripts docs/_ext docs/tutorials_src``) it
lists the sub-packages (with the first line of their ``__init__.py`` docstring) and the modules (with
the first line of theirs), read with :mod:`ast` (no import), so the page can never name a file that
no longer exists, and a new module appears without editing the docs. A module without a docstring is
listed as such. Files whose name starts with ``_`` and ``build_info.py`` (written at install time)
are left out.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_FOLDERS = ("birdocp", "scripts", "docs/_ext", "docs/tutorials_src")
SKIP = {"build_info.py"}


def first_line(path: Path) -> str:
    """The first line of a Python file's module docstring, or ``""`` when it has none.

    Parameters
    ----------
    path : Path
        A ``.py`` file.

    Returns
    -------
    str
        The docstring's first line, stripped.
    """
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
    return doc.strip().splitlines()[0].strip() if doc else ""


def entries(folder: Path) -> list[tuple[Path, str, list]]:
    """The modules of ``folder`` and its sub-packages, recursively (a package's ``__init__.py``
    docstring is the line of its folder).

    Parameters
    ----------
    folder : Path
        A folder of the repository.

    Returns
    -------
    list of (Path, str, list)
        ``(path, first docstring line, children)``; children only for sub-folders.
    """
    out = []
    files = sorted(p for p in folder.glob("*.py") if p.name not in SKIP and not p.name.startswith("_"))
    for p in files:
        out.append((p, first_line(p), []))
    for sub in sorted(d for d in folder.iterdir() if d.is_dir() and not d.name.startswith((".", "_"))):
        kids = entries(sub)
        if kids:
            init = sub / "__init__.py"
            out.append((sub, first_line(init) if init.exists() else "", kids))
    return out


_CODE = re.compile(r"(?::[a-z]+:)?`{1,2}~?([^`]+?)`{1,2}")


def _inline(text: str) -> list:
    """Text with its ``code`` and :role:`target` parts as literals (docstrings are reStructuredText)."""
    out, pos = [], 0
    for m in _CODE.finditer(text):
        if m.start() > pos:
            out.append(nodes.Text(text[pos:m.start()]))
        out.append(nodes.literal(text=m.group(1)))
        pos = m.end()
    if pos < len(text):
        out.append(nodes.Text(text[pos:]))
    return out


def _list(items) -> nodes.bullet_list:
    bl = nodes.bullet_list()
    for path, line, kids in items:
        name = path.relative_to(ROOT).as_posix() + ("/" if path.is_dir() else "")
        para = nodes.paragraph()
        para += nodes.literal(text=name)
        para += nodes.Text(": ")
        para += _inline(line) if line else [nodes.Text("(no docstring)")]
        li = nodes.list_item()
        li += para
        if kids:
            li += _list(kids)
        bl += li
    return bl


class BirdocpLayout(SphinxDirective):
    optional_arguments = 20
    has_content = False

    def run(self):
        folders = self.arguments or list(DEFAULT_FOLDERS)
        items = []
        for name in folders:
            folder = ROOT / name
            init = folder / "__init__.py"
            items.append((folder, first_line(init) if init.exists() else "", entries(folder)))
        return [_list(items)]


def setup(app):
    app.add_directive("birdocp-layout", BirdocpLayout)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
