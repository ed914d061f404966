"""The package's structure: the layers hold, no module reaches into another's private names, no
import cycle, public functions are documented, ruff finds nothing.

Issue 27's "Done when", item by item: one Levenberg-Marquardt and one IPOPT front in the engine
(test_engine_has_one_levenberg_marquardt_and_one_ipopt_front), no package function over 80 lines
(test_package_functions_fit_on_a_screen_except_the_known_offenders, LONG_FUNCTION_ALLOWED empty), no
module over 600 lines (test_modules_are_small), a non-empty public API that imports (test_public_faces),
the README under 200 lines (test_readme_is_a_front_page)."""
from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "birdocp"


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path):
    """(imported module, imported names, line) of every import statement (function-level ones too)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module, [a.name for a in node.names], node.lineno
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, [], node.lineno


MODULES = {_module_name(p): p for p in PKG.rglob("*.py")}


def test_import_contract_layers():
    """import-linter's contracts in pyproject.toml: cli > plots > studies > export > bird > engine; the
    engine imports only casadi, numpy and the standard library; io imports no other layer."""
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(exe).exists():
        pytest.fail("lint-imports (import-linter) is not installed: pip install '.[test]'")
    out = subprocess.run([exe, "--config", str(ROOT / "pyproject.toml")], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]


def test_no_private_names_across_modules():
    offenders = []
    for name, path in MODULES.items():
        for mod, names, line in _imports(path):
            if not mod.startswith("birdocp") or mod == name:
                continue
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            private += [part for part in mod.split(".") if part.startswith("_") and part != "__init__"]
            if private:
                offenders.append(f"{path.relative_to(ROOT)}:{line} imports {private} from {mod}")
    assert not offenders, "\n".join(offenders)


PRIVATE_WRITE_LAYERS = ("studies", "engine")
"""The layers where no code writes another object's private attribute (``obj._name = ...``)."""


def _written_attributes(node):
    """The attribute targets (``a.b``) that an assignment, augmented/annotated assignment or ``del``
    writes, through tuples, starred names and subscripts (``a._b[0] = ...`` writes ``a._b``)."""
    if isinstance(node, ast.Assign):
        stack = list(node.targets)
    elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
        stack = [node.target]
    elif isinstance(node, ast.Delete):
        stack = list(node.targets)
    else:
        return
    while stack:
        t = stack.pop()
        if isinstance(t, (ast.Tuple, ast.List)):
            stack.extend(t.elts)
        elif isinstance(t, (ast.Starred, ast.Subscript)):
            stack.append(t.value)
        elif isinstance(t, ast.Attribute):
            yield t


def private_writes(paths) -> list:
    """``"path:line target"`` of every write of a private attribute (one leading underscore, not a
    dunder) of an object other than ``self``/``cls``, and every ``setattr``/``delattr`` of a private
    name given as a literal, in ``paths``."""
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets = [(t.value, t.attr) for t in _written_attributes(node)]
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("setattr", "delattr") and len(node.args) >= 2
                    and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)):
                targets.append((node.args[0], node.args[1].value))
            for obj, attr in targets:
                if (attr.startswith("_") and not (attr.startswith("__") and attr.endswith("__"))
                        and not (isinstance(obj, ast.Name) and obj.id in ("self", "cls"))):
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno} {ast.unparse(obj)}.{attr}")
    return out


def test_private_writes_check_finds_outside_writes(tmp_path):
    """The checker itself: writes of another object's private attribute are found (plain, tuple,
    augmented, subscript, setattr); writes through self/cls, of public names and of dunders are not."""
    (tmp_path / "a.py").write_text(
        "class C:\n    def f(self, rc):\n        self._a = 1\n        cls._b = 2\n        rc.y = 3\n"
        "        rc.__doc__ = ''\n        rc._y = 4\n        rc._t, x = 5, 6\n        rc._n += 1\n"
        "        rc._v[0] = 7\n        setattr(rc, '_w', 8)\n")
    global ROOT
    root, ROOT = ROOT, tmp_path
    try:
        found = private_writes([tmp_path / "a.py"])
    finally:
        ROOT = root
    assert sorted(found) == sorted(["a.py:7 rc._y", "a.py:8 rc._t", "a.py:9 rc._n", "a.py:10 rc._v",
                                    "a.py:11 rc._w"])


def test_no_private_writes_from_outside():
    """No module of birdocp/studies or birdocp/engine writes a private attribute of another object:
    state an object exposes for change has a method or an explicit object for it (a warm start:
    :class:`birdocp.studies.gait_types.WarmStart`). Nothing is allowed."""
    found = private_writes(sorted(p for layer in PRIVATE_WRITE_LAYERS for p in (PKG / layer).rglob("*.py")))
    assert not found, "\n".join(found)


def test_no_import_cycles():
    """No cycle among birdocp's modules, counting every import statement (function-level ones too)."""
    graph = {name: set() for name in MODULES}
    for name, path in MODULES.items():
        for mod, names, _ in _imports(path):
            if not mod.startswith("birdocp"):
                continue
            targets = [f"{mod}.{n}" for n in names if f"{mod}.{n}" in MODULES] or [mod]
            for t in targets:
                while t and t not in MODULES:
                    t = t.rpartition(".")[0]
                if t and t != name and t != "birdocp" and not name.startswith(t + ".") :
                    graph[name].add(t)
    state, stack, cycles = {}, [], []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                cycles.append(stack[stack.index(m):] + [m])
            elif m not in state:
                visit(m)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_ruff_clean():
    exe = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    if not Path(exe).exists():
        pytest.fail("ruff is not installed: pip install '.[test]'")
    out = subprocess.run([exe, "check", "birdocp", "tests", "scripts"], cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:]


def test_public_functions_have_docstrings():
    """Every function and class a module exports in ``__all__`` has a docstring (python-control's rule)."""
    import importlib

    missing = []
    for name in sorted(MODULES):
        if name.startswith("birdocp.cli") or name.endswith("__main__"):
            continue
        mod = importlib.import_module(name)
        for attr in getattr(mod, "__all__", []):
            obj = getattr(mod, attr, None)
            if callable(obj) and getattr(obj, "__module__", None) == name and not (obj.__doc__ or "").strip():
                missing.append(f"{name}.{attr}")
    assert not missing, "undocumented public API: " + ", ".join(missing)


def _calls_with_keyword(path: Path, keyword: str) -> list:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call) and any(k.arg == keyword for k in n.keywords)]


def test_engine_has_one_levenberg_marquardt_and_one_ipopt_front():
    """Every damped Gauss-Newton step of the engine is engine/lm.py's (a second copy is a
    ``lam * np.diag(...)`` normal-equation solve anywhere else), and every IPOPT run goes through
    engine/nlp.py's run_ipopt (a second front is a solver call with ``lbg=`` anywhere else)."""
    import re

    lm_pattern = re.compile(r"\blam\w*\s*\*\s*np\.diag\(")
    engine = PKG / "engine"
    lm_copies = [f"{p.relative_to(ROOT)}" for p in engine.rglob("*.py")
                 if p.name != "lm.py" and lm_pattern.search(p.read_text(encoding="utf-8"))]
    fronts = [f"{p.relative_to(ROOT)}:{line}" for p in engine.rglob("*.py") if p.name != "nlp.py"
              for line in _calls_with_keyword(p, "lbg")]
    assert lm_pattern.search((engine / "lm.py").read_text(encoding="utf-8")), "engine/lm.py lost its LM step"
    assert _calls_with_keyword(engine / "nlp.py", "lbg") or "lbg" in (engine / "nlp.py").read_text(encoding="utf-8")
    assert not lm_copies, f"a second Levenberg-Marquardt in the engine: {lm_copies}"
    assert not fronts, f"IPOPT run outside engine/nlp.py: {fronts}"
    runners = solver_runners(sorted(engine.rglob("*.py")))
    assert runners, "no LM or IPOPT runner found: the name patterns of solver_runners are stale"
    stray = [r for r in runners if not r.endswith(("-> lm.levenberg_marquardt", "-> nlp.run_ipopt"))]
    assert not stray, f"a solver runner of the engine that is not the one LM / IPOPT front: {stray}"


RUNNER_NAMES = {"lm": re.compile(r"(^|_)lm($|_)|levenberg|marquardt", re.IGNORECASE),
                "ipopt": re.compile(r"run_ipopt", re.IGNORECASE)}
FRONTS = {"lm": ("lm.py", "levenberg_marquardt"), "ipopt": ("nlp.py", "run_ipopt")}


def solver_runners(paths) -> list:
    """``"path:name -> module.front"`` for every engine function named as a Levenberg-Marquardt or IPOPT
    runner (RUNNER_NAMES) outside the front's own module, where ``front`` is what it reaches through
    the calls of its module (``-> none`` when it does not reach its front: a second solver loop)."""
    out = []
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        funcs = {n.name: n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}

        def reaches(name, front, seen):
            calls = {c.func.id if isinstance(c.func, ast.Name) else getattr(c.func, "attr", "")
                     for c in ast.walk(funcs[name]) if isinstance(c, ast.Call)}
            return front in calls or any(reaches(c, front, seen | {c}) for c in calls - seen if c in funcs)

        for name in funcs:
            for kind, pattern in RUNNER_NAMES.items():
                module, front = FRONTS[kind]
                if pattern.search(name) and path.name != module:
                    hit = f"{module[:-3]}.{front}" if reaches(name, front, {name}) else "none"
                    out.append(f"{path.relative_to(ROOT)}:{name} -> {hit}")
    return out


def test_solver_runner_check_finds_a_second_lm(tmp_path):
    """The checker itself: a runner that reaches the front is fine, a hand-written LM loop is not."""
    (tmp_path / "a.py").write_text("def _run_lm(s, z):\n    return _inner(s, z)\n\n\n"
                                   "def _inner(s, z):\n    return levenberg_marquardt(s, z)\n\n\n"
                                   "def my_lm(J, g, lam):\n    return -(J.T @ J + lam) @ g\n")
    global ROOT
    root, ROOT = ROOT, tmp_path
    try:
        found = solver_runners([tmp_path / "a.py"])
    finally:
        ROOT = root
    assert found == ["a.py:_run_lm -> lm.levenberg_marquardt", "a.py:my_lm -> none"]


def _engine_classes():
    """(class name, annotated field names, module path) of every class defined in engine/."""
    for p in (PKG / "engine").rglob("*.py"):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                names = {n.target.id for n in node.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
                yield node.name, names, p.relative_to(ROOT)


def test_engine_has_one_ode_orbit_problem_method_front_and_result():
    """One periodic-orbit engine: one problem class (``*Problem``), one method class (``*Method`` or
    ``*Shooting``, or any class with both ``steps_per_period`` and ``solver`` fields), one result class
    (any class with both ``shooting_points`` and ``multipliers`` fields; a branch's point, which has a
    ``parameter``, is the continuation's record) defined in engine/, one ODE class (``*ODE``, or any
    class with an ``rhs`` field), and one ``solve*`` front on the engine's face."""
    import birdocp.engine as engine

    classes = list(_engine_classes())
    problems = [f"{path}:{name}" for name, _, path in classes if name.endswith("Problem")]
    methods = [f"{path}:{name}" for name, fields, path in classes
               if name.endswith(("Method", "Shooting")) or {"steps_per_period", "solver"} <= fields]
    results = [f"{path}:{name}" for name, fields, path in classes
               if {"shooting_points", "multipliers"} <= fields and "parameter" not in fields]
    assert problems == ["birdocp/engine/problem.py:OrbitProblem"], problems
    assert methods == ["birdocp/engine/method.py:OrbitMethod"], methods
    assert results == ["birdocp/engine/orbit_result.py:OrbitResult"], results
    odes = [f"{path}:{name}" for name, fields, path in classes if name.endswith("ODE") or "rhs" in fields]
    assert odes == ["birdocp/engine/ode.py:ODE"], odes
    assert [n for n in engine.__all__ if n.startswith("solve")] == ["solve"]
    assert engine.API["orbits"]["solve"] == "birdocp.engine.orbit_front"


MAX_README_LINES = 200


def test_readme_is_a_front_page():
    """README.md stays a front page (issue 27: under MAX_README_LINES lines; the manual is docs/)."""
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n < MAX_README_LINES, f"README.md has {n} lines (under {MAX_README_LINES}: move details to docs/)"


def test_modules_are_small():
    """No module of the package over 600 lines (split by concern instead)."""
    long = [f"{p.relative_to(ROOT)}: {n}" for p in PKG.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES]
    assert not long, long


MAX_FUNCTION_LINES = 80
MAX_MODULE_LINES = 600
LONG_FUNCTION_ALLOWED = (
    # Modules outside the engine still known to hold functions over MAX_FUNCTION_LINES (being split;
    # shrink this list as they are). Nothing of birdocp/engine may be listed here.
)


def long_functions(paths, max_lines: int = MAX_FUNCTION_LINES) -> list:
    """``"path:line name (n lines)"`` of every function or method in ``paths`` longer than
    ``max_lines`` (from its ``def`` to its last line, decorators and docstring included)."""
    out = []
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > max_lines:
                    out.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    return out


def test_long_functions_check_finds_a_long_function(tmp_path):
    """The checker itself: a function of MAX_FUNCTION_LINES + 1 lines is found, one of
    MAX_FUNCTION_LINES is not."""
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES - 1))
    (tmp_path / "a.py").write_text(f"def ok():\n{body}\n\n\ndef too_long():\n{body}\n    return 0\n")
    global ROOT
    root, ROOT = ROOT, tmp_path
    try:
        found = long_functions([tmp_path / "a.py"])
    finally:
        ROOT = root
    assert found == [f"a.py:{MAX_FUNCTION_LINES + 3} too_long ({MAX_FUNCTION_LINES + 1} lines)"]


def test_engine_functions_fit_on_a_screen():
    """No function of birdocp/engine over MAX_FUNCTION_LINES lines."""
    long = long_functions(sorted((PKG / "engine").rglob("*.py")))
    assert not long, "\n".join(long)


def test_package_functions_fit_on_a_screen_except_the_known_offenders():
    """No function of the package over MAX_FUNCTION_LINES lines outside the modules of
    LONG_FUNCTION_ALLOWED (none of them in the engine), and every module listed there still exists
    and still has one (then it leaves the list)."""
    assert not [m for m in LONG_FUNCTION_ALLOWED if m.startswith("birdocp/engine/")]
    files = sorted(PKG.rglob("*.py"))
    long = long_functions(f for f in files if str(f.relative_to(ROOT)) not in LONG_FUNCTION_ALLOWED)
    assert not long, "\n".join(long)
    stale = [m for m in LONG_FUNCTION_ALLOWED if not (ROOT / m).exists() or not long_functions([ROOT / m])]
    assert not stale, f"no longer long (remove from LONG_FUNCTION_ALLOWED): {stale}"


def test_public_faces():
    """The package faces (birdocp, birdocp.engine) are non-empty, every name imports, the lazy tables
    keep the layers (the engine's face names only engine modules; birdocp's none of the command line),
    no face name is shadowed by a submodule of the same name, and ``import birdocp`` imports no layer
    (the command line's start-up does not grow)."""
    import importlib
    import importlib.util

    import birdocp
    import birdocp.engine

    for face, allowed in ((birdocp, ("birdocp.bird", "birdocp.studies", "birdocp.export", "birdocp.engine",
                                     "birdocp.io", "birdocp.plots")),
                          (birdocp.engine, ("birdocp.engine",))):
        names = [n for n in face.__all__ if n != "__version__"]
        assert len(names) >= 10, f"{face.__name__}: the public API is (nearly) empty"
        for name in names:
            target = face._TARGETS[name].partition(":")[0]
            assert target.startswith(allowed), f"{face.__name__}.{name} -> {target}: outside the face's layers"
            assert importlib.util.find_spec(f"{face.__name__}.{name}") is None, \
                f"{face.__name__}.{name} is also a submodule: the import system would shadow the name"
            obj = getattr(face, name)
            module = face._TARGETS[name].partition(":")[0]
            assert getattr(obj, "__module__", module) == module, \
                f"{face.__name__}.{name}: name its defining module {obj.__module__}, not {module} (the docs link there)"
    code = ("import sys, birdocp, birdocp.engine; "
            "print(sorted(m for m in sys.modules if m.startswith('birdocp.') and m != 'birdocp.build_info'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['birdocp.engine']", out.stdout


# -- caches -----------------------------------------------------------------------------------------
# What is built from an object is kept by that object (birdocp.engine.cache.owned_cache). The only
# module-level caches are these value caches (keyed by values, not by an object's id), each registered
# in birdocp.engine.cache; a new one is a design decision: add it here with its reason.
MODULE_CACHES = {
    "birdocp/bird/model.py": {"_model_for"},  # the bird model of a Structure (a value): the one entry point
    "birdocp/bird/stall_section.py": {"_frozen_factorization", "_detached_newton"},  # sub-Functions called
    # inside the model's graphs, one per size (built before any model exists)
    "birdocp/bird/validity.py": {"sixdof_angles"},  # to become the six-DOF ODE's (kept while the
    # six-DOF section work changes its signature)
    "birdocp/bird/flight.py": {"bird.flight_outputs"},  # output Functions by (sizes, angle): one per value
    "birdocp/engine/integrate.py": {"engine.data_values"},  # a gait's data on a grid, shared by the grids
}
NOT_CACHES = {  # module-level dicts that are not caches
    "birdocp/engine/cache.py": {"_REGISTRY"},  # the registry of caches itself
    "birdocp/export/compiled.py": {"last_compile_s"},  # the last compile times (a report)
    "birdocp/io/runs.py": {"_HELD"},  # the run-folder locks this process holds
}


def _decorator_name(d) -> str:
    d = d.func if isinstance(d, ast.Call) else d
    return d.attr if isinstance(d, ast.Attribute) else getattr(d, "id", "")


def module_caches(path: Path) -> set:
    """The module-level caches of a module: functions decorated with ``functools.lru_cache`` or
    ``functools.cache``, the names given to ``bounded_cache(...)`` and module-level ``{}``,
    ``dict()`` or ``OrderedDict()`` assignments (by target name)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if any(_decorator_name(d) in ("lru_cache", "cache") for d in node.decorator_list):
                out.add(node.name)
        elif isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", "")) == "bounded_cache":
            arg = node.args[0] if node.args else None
            out.add(arg.value if isinstance(arg, ast.Constant) else ast.unparse(arg) if arg else "?")
    for node in tree.body:
        value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign)) else None
        empty = isinstance(value, ast.Dict) and not value.keys or (
            isinstance(value, ast.Call) and getattr(value.func, "id", "") in ("dict", "OrderedDict") and not value.args)
        if empty:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out |= {t.id for t in targets if isinstance(t, ast.Name)}
    return out


def test_module_cache_check_finds_new_caches(tmp_path):
    """The checker itself: an lru_cache, a functools.cache, a bounded_cache and a module dict are found."""
    (tmp_path / "a.py").write_text(
        "import functools\nfrom functools import lru_cache\n_SEEN = {}\n_T: dict = dict()\nX = {'a': 1}\n"
        "@functools.lru_cache(maxsize=4)\ndef f(n):\n    return n\n\n@lru_cache\ndef g(n):\n    return n\n\n"
        "@functools.cache\ndef h(n):\n    return n\n\nC = bounded_cache('x.y', 3)\n")
    assert module_caches(tmp_path / "a.py") == {"_SEEN", "_T", "f", "g", "h", "x.y"}


def test_module_level_caches_only_in_the_allowed_places():
    """No module-level cache outside MODULE_CACHES (things built from an object are kept by it:
    ``owned_cache``), every allowed one still exists, and every lru_cache is registered (cleared by
    ``clear_caches``)."""
    found = {}
    for path in sorted(PKG.rglob("*.py")):
        rel = str(path.relative_to(ROOT))
        names = module_caches(path) - NOT_CACHES.get(rel, set())
        if names:
            found[rel] = names
    extra = {k: v - MODULE_CACHES.get(k, set()) for k, v in found.items() if v - MODULE_CACHES.get(k, set())}
    assert not extra, f"new module-level caches (keep them on the object they are built from: owned_cache): {extra}"
    assert found == MODULE_CACHES, f"allowed caches that no longer exist: {MODULE_CACHES} vs {found}"
    for rel, names in MODULE_CACHES.items():
        text = (ROOT / rel).read_text(encoding="utf-8")
        for name in names:
            if f"def {name}(" in text:
                assert re.search(rf'register_cache\("[^"]+", {name}\)', text), f"{rel}: {name} is not registered"
