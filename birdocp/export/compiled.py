"""Compiled speed inside birdocp: the state RHS and the data's ``post`` generated as C, compiled once
and cached.

The small state right-hand side ``rhs(x, d, p)`` (~3.4k SX instructions) is compiled, with the
derivative functions CasADi's AD asks an external for (``fwd1_rhs``, one forward direction, and
``adj1_rhs``, one reverse direction; CasADi maps them for more directions and builds Jacobians from
them). The time loop (RK4 steps, ``mapaccum``, segment Jacobians, IPOPT) stays in CasADi: calling
the external with SX arguments makes a *call node* in the SX RK4 step, so
:class:`birdocp.engine.integrate.RK4Grid` and the shooting code need no change. The Functions the engine
evaluates only for numbers (``post`` on the stage grid, 35k instructions per time; ``post`` with its
derivatives along the free parameters, 104k for two; gcc 7-9 s each, once) are compiled on first use
through the ODE's ``numeric`` hook (:class:`NumericCompiler`), and so is the RK4 step of the
variational equations the shooting evaluates for its exact sensitivities, built from the interpreted
SX right-hand side (the state and its nx directions in one piece of C; up to :data:`MAX_INSTRUCTIONS`). The arm-frame geometry ``pre`` (183k
nodes) is never compiled (``docs/performance.md``): its values are kept on disk instead
(:mod:`birdocp.engine.datastore`).

Cache: ``$BIRDOCP_CACHE`` or ``$XDG_CACHE_HOME/birdocp`` (default ``~/.cache/birdocp``), one shared
library per key; the key is a SHA-256 of the generated C source, the structural configuration, the
birdocp and CasADi versions and the compiler command, so any change of the model code, of CasADi or
of the flags gives a new library (generating the source to hash costs ~0.05 s). Libraries are built
under a temporary name and renamed into place (safe with parallel processes).

Failure to compile or load never raises from :func:`compiled_ode`: it warns
(:class:`CompiledFallbackWarning`, on stderr) and returns ``None``; callers use the interpreted ODE.
"""
from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import casadi as ca

from birdocp.engine import graphcache
from birdocp.io.files import atomic_target
from birdocp.engine.cache import owned_cache
from birdocp.engine.ode import ODE

__all__ = ["CompiledFallbackWarning", "cache_dir", "find_compiler", "compile_functions", "compiled_ode",
           "NumericCompiler", "MAX_INSTRUCTIONS",
           "OPT_FLAGS", "last_compile_s"]

OPT_FLAGS = ("-O1",)
"""-O1: measured best trade-off here (docs/performance.md: -O0 is slower than the interpreter; -O2/-O3 only
lengthen the build of generated straight-line code)."""

MAX_INSTRUCTIONS = 1_000_000
"""Largest Function (CasADi instructions) the ``numeric`` hook compiles: gcc -O1 took 217 s and 3 GB for
the 647k-instruction variational RK4 step of ``aero.unsteady = "wagner"`` (once, then cached) and grows
faster than linearly. A larger variational step (the 1.4M of ``stall``, 2.0M of ``dynamic-stall``) is
built from four calls of the compiled right-hand side with its nx tangents instead (448k for
``dynamic-stall``); a larger Function stays interpreted, with one :class:`CompiledFallbackWarning`."""

last_compile_s: dict = {}
"""Wall times of the last build per library name: ``{"generate": s, "compile": s, "cached": bool}``."""


class CompiledFallbackWarning(UserWarning):
    """Compilation or loading failed; the interpreted CasADi path is used instead."""


def cache_dir() -> Path:
    """The folder of compiled libraries: ``$BIRDOCP_CACHE``, else ``$XDG_CACHE_HOME/birdocp`` or
    ``~/.cache/birdocp`` (shared with the graph cache: :func:`birdocp.engine.graphcache.cache_dir`).

    Returns
    -------
    Path
    """
    return graphcache.cache_dir()


def find_compiler() -> list[str] | None:
    """The C compiler command: ``$CC`` (split like a shell word list), else ``cc``, ``gcc``, ``clang``.

    Returns
    -------
    list of str or None
        The command and its arguments; None when no compiler is found.
    """
    env = os.environ.get("CC")
    if env:
        cmd = shlex.split(env)
        if cmd and shutil.which(cmd[0]):
            return cmd
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return None


def _version() -> str:
    from birdocp import __version__

    return __version__


def _library(directory: Path, name: str, parts, cmd) -> Path:
    h = hashlib.sha256()
    for part in (*parts, _version(), ca.__version__, " ".join(cmd), sys.platform):
        h.update(part.encode())
        h.update(b"\0")
    return directory / f"{name}-{h.hexdigest()[:20]}.so"


def _digest_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _seal(built: Path, lib: Path) -> None:
    # the library's SHA-256 beside it (written first: a library without a matching seal is rebuilt)
    with atomic_target(lib.with_name(lib.name + ".sha256")) as tmp:
        Path(tmp).write_text(_digest_file(built) + "\n")


def _trusted(lib: Path) -> bool:
    """True when ``lib`` exists and matches the SHA-256 written when it was built; a library that does
    not (truncated, garbled, replaced, or left without its seal) is removed, to be rebuilt."""
    if not lib.exists():
        return False
    seal = lib.with_name(lib.name + ".sha256")
    try:
        ok = seal.read_text().strip() == _digest_file(lib)
    except OSError:
        ok = False
    if not ok:
        for f in (lib, seal):
            try:
                f.unlink()
            except OSError:
                pass
    return ok


def compile_functions(name: str, functions, key_extra: str = "", directory: Path | None = None,
                      graph_key: str = "") -> str:
    """Generate one C file holding ``functions`` (CasADi Functions, by their names), compile it as a
    shared library in the cache and return the library path (reused when the key matches).

    The key is a hash of the generated C source (generating it costs 0.05-0.2 s per Function of the
    bird), ``key_extra``, the birdocp and CasADi versions and the compiler command; with
    ``graph_key`` (a string that identifies the Functions' graphs exactly, e.g. a hash of the code
    that built them and of every structural setting) it replaces the source, and a library already
    in the cache is found without generating any code.

    Each library carries its SHA-256 in ``<lib>.sha256``, written when it was built; a library that
    does not match it (truncated, garbled, replaced) is removed and rebuilt, never loaded.

    Raises ``RuntimeError`` if no compiler is found or the compiler fails.

    Parameters
    ----------
    name : str
        Name of the C file and library.
    functions : sequence of casadi.Function
        Functions to generate, by their names.
    key_extra : str
        Extra text of the cache key.
    directory : Path, optional
        Cache folder (default: :func:`cache_dir`).
    graph_key : str
        Exact identity of the Functions' graphs; when given, it replaces the generated source in the key.

    Returns
    -------
    str
        Path of the shared library.
    """
    t = time.perf_counter()
    directory = Path(directory) if directory is not None else cache_dir()
    directory.mkdir(parents=True, exist_ok=True)
    cc = find_compiler()
    if cc is None:
        raise RuntimeError("no C compiler found (set CC, or install cc/gcc/clang)")
    cmd = cc + list(OPT_FLAGS) + ["-shared", "-fPIC"]
    if graph_key:
        lib = _library(directory, name, ("graph", graph_key, key_extra), cmd)
        if _trusted(lib):
            last_compile_s[name] = {"generate": 0.0, "compile": 0.0, "cached": True, "path": str(lib)}
            return str(lib)
    with tempfile.TemporaryDirectory(dir=directory, prefix=".gen-") as tmp:
        gen = ca.CodeGenerator(f"{name}.c")
        for f in functions:
            gen.add(f)
        gen.generate(tmp + os.sep)
        src = Path(tmp, f"{name}.c").read_text()
        gen_s = time.perf_counter() - t
        if not graph_key:
            lib = _library(directory, name, (src, key_extra), cmd)
        if _trusted(lib):
            last_compile_s[name] = {"generate": gen_s, "compile": 0.0, "cached": True, "path": str(lib)}
            return str(lib)
        c_file = Path(tmp, f"{name}.c")
        tc = time.perf_counter()
        with atomic_target(lib, suffix=".so") as out:  # the one atomic write: renamed into place when sealed
            proc = subprocess.run(cmd + [str(c_file), "-o", out], capture_output=True, text=True)
            if proc.returncode != 0:
                err = (proc.stderr or proc.stdout).strip().splitlines()
                raise RuntimeError(f"{' '.join(cmd)} failed (exit {proc.returncode}): "
                                   f"{err[0] if err else 'no output'}")
            _seal(Path(out), lib)
        last_compile_s[name] = {"generate": gen_s, "compile": time.perf_counter() - tc, "cached": False,
                                "path": str(lib)}
    return str(lib)


def compiled_rhs(rhs: ca.Function, key_extra: str = "", directory: Path | None = None,
                 graph_key: str = "") -> ca.Function:
    """``rhs`` as a ``casadi.external`` with compiled forward and reverse derivatives (may raise;
    ``graph_key`` as in :func:`compile_functions`).

    Parameters
    ----------
    rhs : casadi.Function
        Function to compile.
    key_extra : str
        Extra text of the cache key.
    directory : Path, optional
        Cache folder (default: :func:`cache_dir`).
    graph_key : str
        Exact identity of the graph (see :func:`compile_functions`).

    Returns
    -------
    casadi.Function
        The compiled Function, same name and signature as ``rhs``.
    """
    lib = compile_functions(f"birdocp_{rhs.name()}", [rhs, rhs.forward(1), rhs.reverse(1)], key_extra,
                            directory, graph_key=graph_key)
    return ca.external(rhs.name(), lib)


class NumericCompiler:
    """The ``numeric`` hook of a compiled :class:`ODE`: a Function the engine evaluates for
    numbers only (``post`` on the stage grid, ``post`` with its derivatives along free parameters) is
    generated as C, compiled once into the cache and loaded as a ``casadi.external`` (bit-identical
    numbers, 4-5x faster on the bird's ``post``: measured 17 -> 3.6 ms on 297 stage times). A Function
    that cannot be compiled is used as it is (with one :class:`CompiledFallbackWarning`). ``key``: what
    identifies ``f``'s graph exactly (the engine passes the ODE's ``graph_key`` and what it built;
    :func:`compile_functions`' ``graph_key``), so a cached library is found without generating C.
    ``source``: the interpreted ODE the compiled one was made from; the engine builds the Functions
    whose graphs hold the RHS (the RK4 step of the variational equations:
    :meth:`birdocp.engine.integrate.RK4Grid.variational_function`) from its SX right-hand side, so they
    compile as one piece of C."""

    @property
    def max_instructions(self) -> int:
        """:data:`MAX_INSTRUCTIONS`: the largest Function compiled (the engine builds a larger
        variational step from compiled pieces, :meth:`birdocp.engine.integrate.RK4Grid.variational_function`)."""
        return MAX_INSTRUCTIONS

    def __init__(self, key_extra: str = "", directory: Path | None = None, source: ODE | None = None):
        self.key_extra = key_extra
        self.directory = directory
        self.source = source

    def __call__(self, f: ca.Function, key: str = "") -> ca.Function:
        cache = owned_cache(self, "compiled")  # id(f) keys: hashing a lazily loaded Function would load it
        hit = cache.get(id(f))
        if hit is not None and hit[0] is f:
            return hit[1]
        try:
            if f.n_instructions() > MAX_INSTRUCTIONS:
                raise RuntimeError(f"{f.n_instructions()} instructions, more than MAX_INSTRUCTIONS = "
                                   f"{MAX_INSTRUCTIONS} (compiling would take too long)")
            lib = compile_functions(f"birdocp_{f.name()}", [f], self.key_extra, self.directory, graph_key=key)
            out = ca.external(f.name(), lib)
        except Exception as e:  # never fail the solve because of the compiler
            warnings.warn(f"birdocp: compiled {f.name()} unavailable, using the interpreted CasADi path ({e})",
                          CompiledFallbackWarning, stacklevel=2)
            out = f
        cache.put(id(f), (f, out))  # holding f keeps its id unique
        return out


def compiled_ode(ode: ODE, key_extra: str = "", directory: Path | None = None) -> ODE | None:
    """An :class:`ODE` equal to ``ode`` but whose ``rhs`` is compiled C (an external) and whose
    numeric-only data Functions are compiled on first use (:class:`NumericCompiler`), or None with a
    :class:`CompiledFallbackWarning` when compiling or loading the RHS fails.

    The result is kept by ``ode`` (:func:`birdocp.engine.cache.owned_cache`), so the graphs the
    engine keeps on the compiled ODE are reused across solves.

    Parameters
    ----------
    ode : ODE
        The ODE to compile.
    key_extra : str
        Extra text for the cache key (e.g. the configuration's structure).
    directory : Path, optional
        The cache folder (default :func:`cache_dir`).

    Returns
    -------
    ODE or None
        The compiled ODE, or None when compiling or loading the right-hand side failed (a
        :class:`CompiledFallbackWarning` says why).
    """
    cache = owned_cache(ode, "compiled", 1)
    hit = cache.get("compiled_ode")
    if hit is not None:
        return hit
    try:
        ext = compiled_rhs(ode.rhs, key_extra, directory, f"{ode.graph_key}:rhs" if ode.graph_key else "")
        # pre/post kept symbolic (the engine differentiates post); their numbers come from compiled C
        out = ODE(rhs=ext, data=ode.data, forcing_period=ode.forcing_period, state_names=ode.state_names,
                          param_names=ode.param_names, pre=ode.pre, post=ode.post, pre_params=ode.pre_params,
                          graph_key=ode.graph_key, numeric=NumericCompiler(key_extra, directory, source=ode))
    except Exception as e:  # never fail the solve because of the compiler
        warnings.warn(f"birdocp: compiled RHS unavailable, using the interpreted CasADi path ({e})",
                      CompiledFallbackWarning, stacklevel=2)
        return None
    cache.put("compiled_ode", out)
    return out
