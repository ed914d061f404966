"""Sphinx configuration of the birdocp documentation.

Build (warnings are errors, so a broken reference fails):  python -m sphinx -W -b html docs OUT
Tool choice: Sphinx, because the scientific Python stack (numpy, scipy, CasADi's users, python-control)
documents itself with it: numpydoc reads the docstrings as they are written in birdocp, autosummary
generates one page per module recursively (a new module appears without editing the docs),
sphinx-gallery executes the tutorials at every build, and MyST lets pages be Markdown.

Adding to the docs: a study page is a new file docs/studies/NAME.md, listed in the Studies
toctree of index.md (in the paper's order); any other new page goes into a toctree of index.md too
(-W turns a page outside every toctree into an error, so a forgotten entry fails the build). A
tutorial is a new script docs/tutorials_src/plot_NN_name.py (executed at every build: keep it to
seconds). A new module appears by itself in the API reference (recursive autosummary) and on the
layout page (docs/_ext/layout_tree.py); a new command in the CLI reference (generated from the
parser); a new name of the package faces must be added to the topic tables of docs/api.rst
(tests/test_docstrings.py checks that they list exactly the faces' names). Every Python block of a
page runs in the tests (tests/test_docs_examples.py) unless marked as a sketch.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

from birdocp import __version__  # noqa: E402

project = "birdocp"
author = "birdocp developers"
copyright = "birdocp developers"
version = release = __version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "cli_reference",
    "layout_tree",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store", "tutorials/*.md5", "tutorials/*.py",
                    "tutorials/*.ipynb", "tutorials/*.zip", "tutorials/*.json", "tutorials_src/README.txt"]
templates_path = ["_templates"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
autosummary_imported_members = False
# Members are documented where they are defined: a module's __all__ may re-export names (the package
# faces birdocp and birdocp.engine re-export dozens), which would otherwise be documented twice.
autodoc_default_options = {"members": True, "show-inheritance": False, "ignore-module-all": True}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_validation_checks: set = set()
numpydoc_xref_param_type = False

sphinx_gallery_conf = {
    "examples_dirs": ["tutorials_src"],
    "gallery_dirs": ["tutorials"],
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
    "show_memory": False,
    "matplotlib_animations": False,
    "min_reported_time": 1,
}

html_theme = "pydata_sphinx_theme"
html_title = f"birdocp {version}"
html_static_path: list = []
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}

# The figures under results/ are shown by the pages; copy them next to the built pages.
html_extra_path: list = []
nitpicky = False
suppress_warnings: list = []
os.environ.setdefault("BIRDOCP_DOCS_BUILD", "1")


# The docstrings write absolute values and norms as |x| (the project's plain-text convention); in
# reStructuredText |x| is a substitution reference. Escape the bars outside inline literals.
import re  # noqa: E402

_LITERAL = re.compile(r"(``.*?``)")


def _escape_bars(app, what, name, obj, options, lines):
    for i, line in enumerate(lines):
        if "|" in line:
            parts = _LITERAL.split(line)
            lines[i] = "".join(p if p.startswith("``") else p.replace("|", r"\|") for p in parts)


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars)
