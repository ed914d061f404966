"""Run folders given to a command (``plot``, ``animate``, ``simulate --controller``), read through the
one checked reader :func:`birdocp.io.inputs.read_run`, with the stored configuration parsed and the
arrays checked against it. Every problem is a ConfigError on the flag naming the folder (exit 2)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Sequence

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.cli.common import PROG, config_message, one_line

N_STATES = 4
"""States of the longitudinal model (u, w, q, theta): the second axis of a stored trajectory."""


def read_run_folder(path: str | Path, key: str = "RUN_DIR", *, commands: Sequence[str] | None = None,
                    kind: str = "a run folder", arrays: str | None = "optional", hint: str | None = None):
    """``(run, cfg)``: the checked :class:`~birdocp.io.inputs.RunFolder` and its configuration (a
    :class:`~birdocp.bird.config.Config`); its warnings are printed on stderr, one line each.

    Parameters
    ----------
    path : str or Path
        The run folder.
    key : str
        The flag that named it (key of every error).
    commands : sequence of str, optional
        The commands whose folders are accepted (None: any).
    kind : str
        What the caller wants, for the messages.
    arrays : {"required", "optional", None}
        Read arrays.npz: it must exist; when it exists; not at all.
    hint : str, optional
        The fix named when the command is not one of ``commands``.

    Returns
    -------
    run : RunFolder
    cfg : Config
    """
    from birdocp.io.inputs import read_run

    run = read_run(path, key, commands=commands, arrays=arrays, kind=kind, hint=hint)
    try:
        cfg = C.from_dict(run.config_data)
    except ConfigError as exc:
        raise run.error("config.toml", f"{exc.key}: {config_message(exc)}" if exc.key else config_message(exc)) from None
    for line in run.warnings:
        print(f"{PROG}: warning: {one_line(line)}", file=sys.stderr)
    if run.arrays is not None:
        _check_cycle_arrays(run, cfg)
    return run, cfg


def _check_cycle_arrays(run, cfg) -> None:
    """The cycle arrays of a trim-like run folder fit its configuration: the parameter vector ``p`` has
    one entry per :data:`birdocp.bird.config.PARAM_NAMES`, the trajectory N x 4 states at N times,
    the shooting points and the monodromy 4 columns (arrays that are absent are not checked)."""
    arrays = run.arrays or {}
    n = len(arrays["trajectory_t_s"]) if getattr(arrays.get("trajectory_t_s"), "ndim", 0) == 1 else None
    six = cfg.model.degrees_of_freedom == 6  # 9 states, 3 lateral inertia parameters appended
    nx, n_p = (9, len(C.PARAM_NAMES) + 3) if six else (N_STATES, len(C.PARAM_NAMES))
    run.check_arrays({"p": (n_p,), "trajectory_t_s": (None,), "trajectory_x": (n, nx),
                      "shooting_points": (None, nx), "monodromy": (nx, nx),
                      "multipliers": (nx,), "eigenvectors": (nx, nx)}, required=False)
