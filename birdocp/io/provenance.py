"""Provenance of a run: what code, which libraries, which machine, which configuration, when.

Everything here is cheap (no model build) and never raises for a missing piece of information: a
field that cannot be determined is ``None``.
"""

from __future__ import annotations

import hashlib
import os
import platform
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from birdocp.io.files import dataclass_to_dict

__all__ = ["provenance", "config_hash", "canonical_toml", "birdocp_version", "git_revision", "build_revision",
           "source_revision"]

PACKAGE_DIR = Path(__file__).resolve().parents[1]

IPOPT_LINEAR_SOLVER = "mumps"
"""The linear solver IPOPT is run with (the one shipped in the casadi wheels)."""


def birdocp_version() -> str | None:
    """The version of the running package (``birdocp.__version__``: recorded by setuptools-scm when it
    was built or installed, else the installed metadata).

    Returns
    -------
    str or None
        The version; None when it cannot be found.
    """
    try:
        from birdocp import __version__

        return str(__version__)
    except Exception:
        return None


def git_revision(path: str | Path = PACKAGE_DIR) -> dict[str, Any] | None:
    """``{"commit": sha, "dirty": bool}`` of the git checkout holding ``path``; None otherwise.

    ``dirty`` counts modified tracked files only (untracked files such as run folders do not make a
    checkout dirty).

    Parameters
    ----------
    path : str or Path
        File or folder inside the checkout (default: the package's folder).

    Returns
    -------
    dict or None
        ``{"commit": str, "dirty": bool}``; None when ``path`` is not in a git checkout or git is missing.
    """
    def git(*args: str) -> str | None:
        try:
            out = subprocess.run(["git", "-C", str(path), *args], capture_output=True, text=True,
                                 timeout=10, check=False)
        except (OSError, subprocess.SubprocessError):
            return None
        return out.stdout.strip() if out.returncode == 0 else None

    commit = git("rev-parse", "HEAD")
    if not commit:
        return None
    status = git("status", "--porcelain", "--untracked-files=no")
    return {"commit": commit, "dirty": None if status is None else bool(status)}


def build_revision() -> dict[str, Any] | None:
    """``{"commit", "dirty", "source": "build"}`` recorded by setuptools-scm when the package was built
    (``birdocp/build_info.py``), or None (a source tree that was never built, or no git at build time).

    Returns
    -------
    dict or None
        ``{"commit": str, "dirty": bool, "source": "build"}`` or None.
    """
    try:
        from birdocp import build_info
    except ImportError:
        return None
    node = str(getattr(build_info, "git_commit", "") or "")
    commit = node[1:] if node.startswith("g") and len(node) > 1 else node
    if not commit or not all(c in "0123456789abcdef" for c in commit.lower()):
        return None
    return {"commit": commit, "dirty": bool(getattr(build_info, "git_dirty", False)), "source": "build"}


def source_revision() -> dict[str, Any] | None:
    """The revision of the code that runs: live git when the package is imported from its own source
    checkout (an editable install; reflects later commits and edits), else the revision recorded at
    build time (:func:`build_revision`), else None.

    Returns
    -------
    dict or None
        ``{"commit", "dirty", "source"}`` with ``source`` "checkout" or "build"; None when unknown.
    """
    root = PACKAGE_DIR.parent
    if (root / "pyproject.toml").is_file() and (root / ".git").exists():
        live = git_revision(PACKAGE_DIR)
        if live is not None:
            return dict(live, source="checkout")
    return build_revision()


def _sorted(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _sorted(obj[k]) for k in sorted(obj)}
    return obj


def canonical_toml(cfg) -> str:
    """The resolved configuration as TOML with sorted keys: the same config gives the same text.

    Parameters
    ----------
    cfg : Config or dict
        Configuration (a dataclass or the dict of a parsed config.toml).

    Returns
    -------
    str
        TOML text with sorted keys.
    """
    import tomli_w

    return tomli_w.dumps(_sorted(dataclass_to_dict(cfg)))


def config_hash(cfg) -> str:
    """sha256 (hex) of :func:`canonical_toml`.

    Parameters
    ----------
    cfg : Config or dict
        Configuration (a dataclass or the dict of a parsed config.toml).

    Returns
    -------
    str
        Hexadecimal SHA-256 of the canonical TOML text.
    """
    return hashlib.sha256(canonical_toml(cfg).encode("utf-8")).hexdigest()


def _module_version(name: str) -> str | None:
    try:
        module = __import__(name)
    except Exception:
        return None
    return str(getattr(module, "__version__", None) or "") or None


def _cpu_count() -> dict[str, int | None]:
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = None
    return {"logical": os.cpu_count(), "usable": usable}


def provenance(cfg, command_line: list[str] | None, wall_s: Any = None) -> dict[str, Any]:
    """A JSON-able record of how a result was produced (stored under ``provenance`` in result.json).

    Parameters
    ----------
    cfg : Config
        Resolved configuration of the run (stored whole, with its hash).
    command_line : list of str or None
        The command line of the run (None from the Python API).
    wall_s : float, optional
        Wall time of the run [s].

    Returns
    -------
    dict
        Version, git revision, Python and library versions, machine, configuration and its
        ``config_sha256``, command line, working folder, ``wall_s`` and a UTC time stamp.
    """

    return {
        "birdocp_version": birdocp_version(),
        "git": source_revision(),
        "python": platform.python_version(),
        "python_executable": sys.executable,
        "casadi": _module_version("casadi"),
        "numpy": _module_version("numpy"),
        "ipopt_linear_solver": IPOPT_LINEAR_SOLVER,
        "platform": platform.platform(),
        "machine": platform.machine(),
        "hostname": platform.node() or None,
        "cpu_count": _cpu_count(),
        "config": dataclass_to_dict(cfg),
        "config_sha256": config_hash(cfg),
        "command_line": list(command_line) if command_line is not None else None,
        "cwd": os.getcwd(),
        "wall_s": wall_s,
        "timestamp_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
