"""The public face is documented: every function exported by ``birdocp`` and ``birdocp.engine``
documents each of its parameters (numpydoc ``Parameters``; no missing, no misspelt name) and what it
returns, as python-control's docstring test does; the core functions' ``Examples`` run (doctest)."""
from __future__ import annotations

import doctest
import importlib
import inspect

import pytest

numpydoc_docscrape = pytest.importorskip("numpydoc.docscrape")

FACES = ("birdocp", "birdocp.engine")


def _face_functions():
    out = []
    for face in FACES:
        mod = importlib.import_module(face)
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isfunction(obj):
                out.append(pytest.param(obj, id=f"{face}.{name}"))
    return out


def _documented(obj) -> tuple[list[str], bool]:
    doc = numpydoc_docscrape.FunctionDoc(obj)
    names = []
    for param in doc["Parameters"]:
        names += [n.strip() for n in param.name.split(",") if n.strip()]
    return names, bool(doc["Returns"] or doc["Yields"])


def _signature_names(obj) -> list[str]:
    names = []
    for p in inspect.signature(obj).parameters.values():
        if p.kind is p.VAR_POSITIONAL:
            names.append("*" + p.name)
        elif p.kind is p.VAR_KEYWORD:
            names.append("**" + p.name)
        else:
            names.append(p.name)
    return names


@pytest.mark.parametrize("func", _face_functions())
def test_parameters_documented(func):
    documented, has_returns = _documented(func)
    signature = _signature_names(func)
    missing = [n for n in signature if n not in documented]
    unknown = [n for n in documented if n not in signature]
    assert not missing, f"{func.__module__}.{func.__qualname__}: parameters not documented: {missing}"
    assert not unknown, f"{func.__module__}.{func.__qualname__}: documented but not parameters: {unknown}"
    returns_none = inspect.signature(func).return_annotation in (None, "None")
    assert has_returns or returns_none, f"{func.__module__}.{func.__qualname__}: no Returns section"


def test_face_is_not_empty():
    """Each face exports functions, so the test above checks something."""
    assert len(_face_functions()) >= 20


# The core functions whose Examples run here (kept to seconds: small grids).
DOCTEST_MODULES = ("birdocp", "birdocp.engine", "birdocp.bird.config", "birdocp.studies.trim",
                   "birdocp.studies.level", "birdocp.engine.shooting")


@pytest.mark.parametrize("module", DOCTEST_MODULES)
def test_examples_run(module):
    mod = importlib.import_module(module)
    finder = doctest.DocTestFinder(exclude_empty=True)
    tests = [t for t in finder.find(mod, module) if t.examples]
    assert tests, f"{module}: no Examples to run"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{module}: {result.failed} of {result.attempted} examples failed (output above)"


def test_api_page_lists_the_faces():
    """docs/api.rst's topic tables list exactly the faces' names (no name missing, none stale)."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "api.rst").read_text(encoding="utf-8")
    listed = set(re.findall(r"^   ~(birdocp[\w.]+)$", text, flags=re.M))
    expected = set()
    for face in FACES:
        mod = importlib.import_module(face)
        for name, target in mod._TARGETS.items():
            module, _, attr = target.partition(":")
            expected.add(f"{module}.{attr or name}")
    assert listed == expected, f"missing: {sorted(expected - listed)}; stale: {sorted(listed - expected)}"
