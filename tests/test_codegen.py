"""C export (birdocp export-c) and the compiled RHS (trim(compiled=True)) against Python/CasADi."""
from __future__ import annotations

import os
import shutil
from pathlib import Path
import subprocess
import warnings

import casadi as ca
import numpy as np
import pytest

from birdocp.engine.cache import clear_caches
from birdocp.export.compiled import CompiledFallbackWarning, compiled_ode, find_compiler
from birdocp.bird.config import Config

CC = find_compiler()
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc/gcc/clang or $CC) on this machine")
X0 = (18.0, 0.5, 0.1, 0.01)


@pytest.mark.slow
@needs_cc
def test_export_builds_and_matches_python(tmp_path):
    from birdocp.export.codegen import export_c
    from birdocp.engine.integrate import RK4Grid
    from birdocp.bird.model import get_model

    cfg = Config()
    info = export_c(cfg, tmp_path / "bird_c")
    assert {"bird.h", "bird.c", "bird_casadi.c", "bird_casadi.h", "bird_data.c", "main.c",
            "Makefile"} <= set(info.files)
    assert info.runtime_params == ["body.mass_kg", "body.pitch_inertia_kgm2", "body.gravity_mps2",
                                   "aero.air_density_kgm3"]
    make = shutil.which("make")
    d = tmp_path / "bird_c"
    if make:
        env = dict(os.environ, CC=" ".join(CC))
        subprocess.run([make, "-j2", "bird_period"], cwd=d, check=True, capture_output=True, env=env)
    else:  # same build as the Makefile, without make
        subprocess.run(CC + ["-O1", "-o", "bird_period", "main.c", "bird.c", "bird_casadi.c", "bird_data.c",
                             "-lm"], cwd=d, check=True, capture_output=True)

    m = get_model(cfg)
    grid = RK4Grid(m.ode, cfg.solve.steps_per_period, 1)
    D = grid.blocks_numeric(0.0, m.p0)
    pd = ca.DM(m.p0)
    for x0, extra in ((X0, []), ((17.0, 1.0, -0.2, 0.05), ["1.3", "0.12", "9.7", "1.1"])):
        p = np.array(m.p0, float)
        for name, v in zip(info.runtime_params, extra):
            p[list(m.ode.param_names).index(name)] = float(v)
        pd = ca.DM(p)
        out = subprocess.run([str(d / "bird_period"), *map(repr, x0), *extra], capture_output=True,
                             text=True, check=True).stdout.split("\n")
        rows = [np.array(line.split(), float) for line in out if line.strip()]
        assert len(rows) == 5
        xT_c, M_c = rows[0], np.vstack(rows[1:])
        xT, J = grid.period_jacobian(ca.DM(x0), D, pd)
        xT_py = np.asarray(grid.period_map(ca.DM(x0), D, pd)[0]).ravel()
        assert np.max(np.abs(xT_c - xT_py)) < 1e-10
        assert np.max(np.abs(xT_c - np.asarray(xT).ravel())) < 1e-10
        assert np.max(np.abs(M_c - np.asarray(J))) < 1e-10

    bad = subprocess.run([str(d / "bird_period"), "1", "x", "0", "0"], capture_output=True, text=True)
    assert bad.returncode == 2 and "not a number" in bad.stderr


@pytest.fixture(scope="module")
def shared_cache(tmp_path_factory):
    """One library folder for the compiled solves of this module: the variational RK4 step (h an input:
    one library for every grid; gcc ~50 s on a loaded 2-core machine) is compiled once."""
    return tmp_path_factory.mktemp("compiled") / "cache"


@pytest.mark.slow
@needs_cc
def test_compiled_trim_same_multipliers(shared_cache, monkeypatch):
    from birdocp.export import compiled
    from birdocp.studies.trim import trim

    monkeypatch.setenv("BIRDOCP_CACHE", str(shared_cache))
    clear_caches()
    a = trim()
    with warnings.catch_warnings():
        warnings.simplefilter("error", CompiledFallbackWarning)
        b = trim(compiled=True)
    assert a.success and b.success
    assert list(shared_cache.glob("birdocp_rhs-*.so"))
    # the sensitivities came from the compiled variational step, and give the same numbers bit for bit
    assert list(shared_cache.glob("birdocp_rk4_variational_step-*.so"))
    assert np.array_equal(a.multipliers, b.multipliers)
    assert np.array_equal(a.x0, b.x0)
    clear_caches()  # the second build is a cache hit
    b2 = trim(compiled=True)
    assert compiled.last_compile_s["birdocp_rhs"]["cached"]
    assert np.max(np.abs(b2.multipliers - b.multipliers)) < 1e-10


@pytest.mark.slow
@needs_cc
def test_compiled_level_bit_identical(shared_cache, monkeypatch, coarse, default_model):
    """Level flight (the amplitude free: post and its amplitude derivative evaluated on the stage grid
    at every iterate) with the compiled RHS and data gives the interpreted numbers bit for bit, and a
    second process finds the libraries by the graph key alone."""
    from birdocp.engine.integrate import clear_stage_data
    from birdocp.export import compiled
    from birdocp.studies.level import level

    monkeypatch.setenv("BIRDOCP_CACHE", str(shared_cache))
    clear_caches()
    clear_stage_data()
    a = level(**coarse)
    clear_stage_data()  # the compiled solve evaluates the data itself
    with warnings.catch_warnings():
        warnings.simplefilter("error", CompiledFallbackWarning)
        b = level(compiled=True, **coarse)
    assert a.success and b.success
    names = {f.name.split("-")[0] for f in shared_cache.glob("birdocp_*.so")}
    assert {"birdocp_rhs", f"birdocp_{default_model.ode.post.name()}", "birdocp_post_dpf",
            "birdocp_rk4_variational_step"} <= names
    assert np.array_equal(a.multipliers, b.multipliers)
    assert a.amplitude_deg == b.amplitude_deg
    assert np.array_equal(a.x0, b.x0)
    clear_caches()  # the compiled ODEs and Functions kept by their sources too
    clear_stage_data()
    c = level(compiled=True, **coarse)
    assert compiled.last_compile_s["birdocp_post_dpf"] == {"generate": 0.0, "compile": 0.0, "cached": True,
                                                           "path": compiled.last_compile_s["birdocp_post_dpf"]["path"]}
    assert np.array_equal(c.multipliers, b.multipliers)


@needs_cc
def test_compiled_library_is_checked_before_use(tmp_path):
    """A cached library that does not match the SHA-256 written when it was built (truncated,
    replaced, or without its seal) is removed and rebuilt, never loaded."""
    from birdocp.export import compiled

    x = ca.SX.sym("x", 2)
    f = ca.Function("tiny_fn", [x], [ca.sin(x) * x[0]])
    lib = Path(compiled.compile_functions("birdocp_tiny", [f], directory=tmp_path, graph_key="k1"))
    assert not compiled.last_compile_s["birdocp_tiny"]["cached"]
    assert compiled.compile_functions("birdocp_tiny", [f], directory=tmp_path, graph_key="k1") == str(lib)
    assert compiled.last_compile_s["birdocp_tiny"]["cached"]
    good = lib.read_bytes()
    for damage in (lambda: lib.write_bytes(good[: len(good) // 2]),          # truncated
                   lambda: lib.write_bytes(good[:-1] + bytes([good[-1] ^ 1])),  # one bit changed
                   lambda: lib.with_name(lib.name + ".sha256").unlink()):    # no seal
        damage()
        assert compiled.compile_functions("birdocp_tiny", [f], directory=tmp_path, graph_key="k1") == str(lib)
        assert not compiled.last_compile_s["birdocp_tiny"]["cached"]  # rebuilt
        out = ca.external("tiny_fn", str(lib))(ca.DM([0.5, 2.0]))
        assert np.allclose(np.asarray(out).ravel(), np.sin([0.5, 2.0]) * 0.5, rtol=0, atol=1e-15)


def test_compile_failure_falls_back_with_warning(tmp_path, monkeypatch):
    from birdocp.engine.ode import ODE

    monkeypatch.setenv("BIRDOCP_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", shutil.which("false") or "false")
    if not shutil.which("false"):
        pytest.skip("no 'false' program to act as a failing compiler")
    x = ca.SX.sym("x", 1)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    ode = ODE.from_rhs(ca.Function("f", [x, t, p], [-p * x + ca.sin(t)]), 2 * np.pi)
    with pytest.warns(CompiledFallbackWarning, match="interpreted"):
        assert compiled_ode(ode) is None


def test_cli_export_c(tmp_path, capsys):
    from birdocp.cli.main import main

    assert main(["export-c", "--out", str(tmp_path / "c"), "--amplitude", "40", "--json"]) == 0
    info = __import__("json").loads(capsys.readouterr().out)
    assert info["baked_params"]["gait.shoulder_flap.amplitude_deg"] == 40.0
    assert "#define BIRD_STEPS 148" in (tmp_path / "c" / "bird.h").read_text()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "x.txt").write_text("keep")
    assert main(["export-c", "--out", str(tmp_path / "other")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err


@pytest.mark.slow
@needs_cc
def test_variational_step_over_the_size_limit_stays_interpreted(shared_cache, monkeypatch, coarse):
    """A variational step larger than MAX_INSTRUCTIONS is built from the right-hand side with its
    tangents (RK4Grid.staged_variational_step); that piece larger too: one CompiledFallbackWarning,
    the step (h an input) evaluated by CasADi, and the trim's numbers those of the interpreted path."""
    from birdocp.export import compiled
    from birdocp.studies.trim import trim

    monkeypatch.setenv("BIRDOCP_CACHE", str(shared_cache))
    monkeypatch.setattr(compiled, "MAX_INSTRUCTIONS", 1000)
    clear_caches()  # the compiled ODEs and Functions kept by their sources too
    a = trim(**coarse)
    with pytest.warns(CompiledFallbackWarning, match="rhs_tangent.*MAX_INSTRUCTIONS"):
        b = trim(compiled=True, **coarse)
    clear_caches()  # the compiled ODEs and Functions kept by their sources too
    assert a.success and b.success
    assert np.max(np.abs(a.multipliers - b.multipliers)) < 1e-12
    assert np.max(np.abs(a.x0 - b.x0)) < 1e-12
