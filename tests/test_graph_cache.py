"""The on-disk graph cache (birdocp.engine.graphcache) and its use by the bird model.

Expected values: a Function read back from the cache must give bit-identical numbers to the one
that was built (CasADi's serialisation stores the instructions); a broken or foreign entry is never
used."""
from __future__ import annotations

import json
import multiprocessing as mp
import os
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

from birdocp.engine import graphcache


def _small_functions():
    x = ca.SX.sym("x", 3)
    p = ca.SX.sym("p", 2)
    f = ca.Function("f", [x, p], [ca.sin(x) * p[0] + ca.exp(-x * p[1])])
    g = ca.Function("g", [x], [ca.dot(x, x)])
    return {"f": f, "g": g}


KEY = {"model": "test", "structure": {"n": 3}, "version": "1"}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BIRDOCP_CACHE", str(tmp_path))
    monkeypatch.delenv("BIRDOCP_GRAPH_CACHE", raising=False)
    return tmp_path


def _entry_folder(cache_root, kind="test"):
    (folder,) = [d for d in (cache_root / "graphs").iterdir() if d.name.startswith(kind + "-")]
    return folder


def test_round_trip_is_bit_identical(cache):
    fns = _small_functions()
    assert graphcache.load("test", KEY) is None
    assert graphcache.store("test", KEY, fns, {"extra": [1, 2]}) is not None
    entry = graphcache.load("test", KEY)
    assert entry is not None and entry.meta == {"extra": [1, 2]}
    f = entry.function("f")
    xv, pv = np.array([0.3, -1.2, 2.5]), np.array([1.7, 0.4])
    assert np.array_equal(np.asarray(f(xv, pv)), np.asarray(fns["f"](xv, pv)))
    assert f.n_instructions() == fns["f"].n_instructions()


@pytest.mark.parametrize("damage", ["truncate", "garble", "delete"])
def test_corrupt_file_is_detected_and_the_entry_removed(cache, damage):
    graphcache.store("test", KEY, _small_functions())
    path = _entry_folder(cache) / "f.casadi"
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "garble":
        k = len(data) // 3
        path.write_bytes(data[:k] + (b"z" if data[k:k + 1] != b"z" else b"y") + data[k + 1:])
    else:
        path.unlink()
    entry = graphcache.load("test", KEY)
    assert entry is not None  # the manifest itself is fine
    with pytest.raises(graphcache.CacheMiss):
        entry.function("f")
    assert graphcache.load("test", KEY) is None  # removed: the caller rebuilds and stores again
    assert graphcache.store("test", KEY, _small_functions()) is not None
    assert graphcache.load("test", KEY).function("f").n_instructions() > 0


def test_garbled_manifest_is_not_trusted(cache):
    graphcache.store("test", KEY, _small_functions())
    (_entry_folder(cache) / "manifest.json").write_text("{not json")
    assert graphcache.load("test", KEY) is None
    assert not (cache / "graphs").exists() or not list((cache / "graphs").glob("test-*"))


def test_foreign_key_is_not_used(cache):
    graphcache.store("test", KEY, _small_functions())
    other = dict(KEY, structure={"n": 4})
    assert graphcache.load("test", other) is None  # a different key: another folder
    # the same folder name but a manifest written for another key (a collision, a copied folder)
    folder = _entry_folder(cache)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["key"]["version"] = "2"
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert graphcache.load("test", KEY) is None
    # and another CasADi version is another key
    assert graphcache.key_digest(KEY) != graphcache.key_digest(dict(KEY, version="2"))


def test_disabled_by_environment(cache, monkeypatch):
    monkeypatch.setenv("BIRDOCP_GRAPH_CACHE", "0")
    assert graphcache.store("test", KEY, _small_functions()) is None
    assert graphcache.load("test", KEY) is None
    assert not (cache / "graphs").exists()


def _store_in_child(root):
    os.environ["BIRDOCP_CACHE"] = root
    return graphcache.store("test", KEY, _small_functions()) is not None


def test_concurrent_writers_leave_one_complete_entry(cache):
    ctx = mp.get_context("spawn")
    with ctx.Pool(4) as pool:
        ok = pool.map(_store_in_child, [str(cache)] * 8)
    assert all(ok)
    entries = [d.name for d in (cache / "graphs").iterdir()]
    assert len(entries) == 1 and not entries[0].startswith(".")  # no temporary folder left behind
    entry = graphcache.load("test", KEY)
    assert entry.function("f").n_instructions() == _small_functions()["f"].n_instructions()


# ---------------------------------------------------------------------------------------------
# the bird model through the cache

@pytest.fixture(scope="module")
def bird_cache(tmp_path_factory):
    root = tmp_path_factory.mktemp("graphs")
    old = {k: os.environ.get(k) for k in ("BIRDOCP_CACHE", "BIRDOCP_GRAPH_CACHE")}
    os.environ["BIRDOCP_CACHE"] = str(root)
    os.environ.pop("BIRDOCP_GRAPH_CACHE", None)
    from birdocp.bird.config import Config
    from birdocp.bird.model import BirdModel, Structure

    s = Structure.of(Config())
    built = BirdModel(s)
    yield root, s, built
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


@pytest.mark.slow
def test_bird_model_from_cache_gives_bit_identical_trim(bird_cache):
    from birdocp.bird.config import Config, param_vector
    from birdocp.bird.model import BirdModel
    from birdocp.engine.problem import OrbitProblem
    from birdocp.engine import OrbitMethod, solve

    root, s, built = bird_cache
    assert built.graph_source == "built+stored"
    loaded = BirdModel(s)
    assert loaded.graph_source == "cache"
    cfg = Config()
    p0 = param_vector(cfg)
    method = OrbitMethod(points=5, steps_per_period=148)
    res = [solve(OrbitProblem(ode=m.ode, p=p0, x_guess=cfg.solve.initial_guess), method)
           for m in (built, loaded)]
    assert res[0].success and res[1].success
    for name in ("x0", "shooting_points", "multipliers", "monodromy"):
        assert np.array_equal(getattr(res[0], name), getattr(res[1], name)), name
    # the Functions read on first use (data, geometry) too
    t = 0.0123
    assert np.array_equal(np.asarray(built.data(t, p0)), np.asarray(loaded.data(t, p0)))
    g0, g1 = built.geometry(t, p0), loaded.geometry(t, p0)
    assert all(np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(g0, g1))


@pytest.mark.slow
def test_pre_is_read_only_when_evaluated(bird_cache):
    """A model from the cache leaves its largest graph (pre) unread through a trim whose stage data
    are on disk (engine.datastore), with the same numbers; evaluating pre reads it."""
    from birdocp.bird.config import Config, param_vector
    from birdocp.bird.model import BirdModel
    from birdocp.engine.integrate import clear_stage_data
    from birdocp.engine.lazy import LazyFunction
    from birdocp.engine.problem import OrbitProblem
    from birdocp.engine import OrbitMethod, solve

    root, s, built = bird_cache
    cfg = Config()
    p0 = param_vector(cfg)
    method = OrbitMethod(points=5, steps_per_period=148)
    a = solve(OrbitProblem(ode=built.ode, p=p0, x_guess=cfg.solve.initial_guess), method)  # stores pre's values
    clear_stage_data()
    m = BirdModel(s)
    assert m.graph_source == "cache"
    assert isinstance(m.ode.pre, LazyFunction) and not m.ode.pre.loaded and not m.ode.data.loaded
    b = solve(OrbitProblem(ode=m.ode, p=p0, x_guess=cfg.solve.initial_guess), method)
    assert not m.ode.pre.loaded  # read from disk, not evaluated
    assert np.array_equal(a.multipliers, b.multipliers) and np.array_equal(a.x0, b.x0)
    t = 0.0123
    assert np.array_equal(np.asarray(m.ode.data(t, p0)), np.asarray(built.ode.data(t, p0)))
    assert m.ode.pre.loaded and m.ode.data.loaded


def test_lazy_function_signature_without_loading():
    import casadi as ca

    from birdocp.engine.lazy import LazyFunction, signature

    x = ca.SX.sym("x", 3)
    f = ca.Function("f", [x, ca.SX.sym("p", 2, 1)], [2 * x, ca.sumsqr(x)])
    calls = []
    lazy = LazyFunction(lambda: calls.append(1) or f, signature(f))
    assert isinstance(lazy, ca.Function)
    assert (lazy.n_in(), lazy.n_out(), lazy.size_in(1), lazy.size1_out(0), lazy.numel_out(1), lazy.name()) == \
        (2, 2, (2, 1), 3, 1, "f")
    assert not lazy.loaded and calls == []
    out = lazy(ca.DM([1, 2, 3]), ca.DM([0, 0]))
    assert np.array_equal(np.asarray(out[0]).ravel(), [2, 4, 6]) and calls == [1]
    m = ca.MX.sym("m", 3)
    g = ca.Function("g", [m], [lazy(m, ca.DM([0, 0]))[1]])  # passed into CasADi graphs like any Function
    assert float(g(ca.DM([1, 1, 1]))) == 3.0 and calls == [1]


@pytest.mark.slow
def test_bird_model_rebuilds_a_corrupt_entry(bird_cache):
    from birdocp.bird.model import BirdModel

    root, s, built = bird_cache
    folder = _entry_folder(root, "bird-model")
    pre = folder / "pre.casadi"
    pre.write_bytes(pre.read_bytes()[:1000])
    m = BirdModel(s)
    # pre is read on first use (LazyFunction): the broken file is found then, not trusted, and the
    # model rebuilt and stored again
    assert m.graph_source == "cache"
    assert m.pre.n_instructions() == built.pre.n_instructions()
    fresh = BirdModel(s)
    assert fresh.graph_source == "cache"
    assert fresh.pre.n_instructions() == built.pre.n_instructions()


def test_bird_model_key_follows_structure_and_sources(bird_cache):
    from dataclasses import replace

    from birdocp.bird.model import graph_key

    _, s, _ = bird_cache
    k = graph_key(s)
    assert graph_key(replace(s, relaxed_evaluations=s.relaxed_evaluations + 1)) != k
    assert graph_key(replace(s, tail=not s.tail)) != k
    assert len(k["sources_sha256"]) == 64 and k["structure"]["frequency_hz"] == s.frequency_hz


# ---------------------------------------------------------------------------------------------
# nothing imported that a command does not use

_PROBE = """
import contextlib, io, json, sys
sys.argv = ["birdocp"] + json.loads(sys.argv[1])
from birdocp.cli.main import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main()
    except SystemExit:
        pass
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in ("matplotlib", "scipy", "casadi", "numpy"))))
"""


def _modules_of(args, env=None):
    out = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(args)], capture_output=True, text=True,
                         env=env, check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_help_imports_neither_casadi_nor_matplotlib():
    mods = _modules_of(["--help"])
    assert not {"casadi", "numpy", "matplotlib"} & {m.split(".")[0] for m in mods}


@pytest.mark.slow
def test_trim_json_does_not_import_matplotlib(tmp_path):
    mods = {m.split(".")[0] for m in _modules_of(["trim", "--json", "--out", str(tmp_path / "run")])}
    assert "casadi" in mods  # it did solve
    assert "matplotlib" not in mods and "scipy" not in mods


@pytest.mark.slow
def test_optional_wing_mass_functions_through_the_cache(bird_cache):
    from dataclasses import replace

    from birdocp.bird.config import Config, param_vector
    from birdocp.bird.model import BirdModel

    _, s, built = bird_cache
    assert BirdModel(s).mass_points is None  # a structure without wing masses has none, cached or not
    sm = replace(s, wing_mass=True)
    first, second = BirdModel(sm), BirdModel(sm)
    assert (first.graph_source, second.graph_source) == ("built+stored", "cache")
    p0, t = param_vector(Config()), 0.031
    a, b = first.mass_points(t, p0), second.mass_points(t, p0)
    assert all(np.array_equal(np.asarray(u), np.asarray(v)) for u, v in zip(a, b))
    x, d = np.array([18.0, 0.5, 0.1, 0.01]), first.data(t, p0)
    assert np.array_equal(np.asarray(first.wing_power_d(x, d, p0)), np.asarray(second.wing_power_d(x, d, p0)))
