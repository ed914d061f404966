"""Where the reference numbers live: ``$BIRDOCP_REFERENCE``, else ``../shared/reference`` beside
the repository (the team's shared folder), else the copy in ``tests/reference`` (looked up beside
the package's source and beside the working directory)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

_REPO = Path(__file__).resolve().parents[2]


def reference_dir() -> Path:
    """The folder of the reference numbers: ``$BIRDOCP_REFERENCE``, else the checkout's ``tests/reference``.

    Returns
    -------
    Path
        The first candidate folder holding ``reference_cycle.json``; none is a ``FileNotFoundError``.
    """
    env = os.environ.get("BIRDOCP_REFERENCE")
    here = Path.cwd()
    candidates = ([Path(env)] if env else []) + [
        _REPO.parent / "shared" / "reference", _REPO / "tests" / "reference",   # a source checkout
        here.parent / "shared" / "reference", here / "tests" / "reference",     # an installed package run from the repo
    ]
    for c in candidates:
        if (c / "reference_cycle.json").is_file():
            return c
    raise FileNotFoundError("reference numbers not found: set BIRDOCP_REFERENCE to the folder holding "
                            "reference_cycle.json and force_fixtures.json")


def load(name: str) -> dict:
    """``load("force_fixtures")`` or ``load("reference_cycle")``.

    Parameters
    ----------
    name : str
        File name of the reference set without ``.json``.

    Returns
    -------
    dict
        The parsed JSON file.
    """
    return json.loads((reference_dir() / f"{name}.json").read_text())


def multipliers(entry: dict) -> np.ndarray:
    """The complex multipliers of a reference entry (its ``multipliers_re`` and ``multipliers_im``).

    Parameters
    ----------
    entry : dict
        Reference entry with lists ``multipliers_re`` and ``multipliers_im``.

    Returns
    -------
    ndarray of complex
        The Floquet multipliers [-].
    """
    return np.asarray(entry["multipliers_re"], float) + 1j * np.asarray(entry["multipliers_im"], float)
