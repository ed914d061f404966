"""The RK4 stage-time grid: the times at which a fixed-step RK4 over one period needs the forcing data
(:mod:`birdocp.engine.integrate` samples the data there)."""
from __future__ import annotations

import numpy as np

__all__ = ["stage_time_grid", "stage_block_index"]

def stage_time_grid(t0: float, period_s: float, n_steps: int) -> np.ndarray:
    """The 2N+1 times ``t0 + k h/2`` at which RK4 needs the data (1 x (2N+1)).

    Parameters
    ----------
    t0 : float
        Start time [s].
    period_s : float
        Period [s].
    n_steps : int
        RK4 steps N.

    Returns
    -------
    ndarray, shape (1, 2N + 1)
    """
    h = period_s / n_steps
    return (t0 + 0.5 * h * np.arange(2 * n_steps + 1)).reshape(1, -1)


def stage_block_index(n_steps: int) -> list[int]:
    """Column indices into the data grid giving the hstacked per-step blocks (2k, 2k+1, 2k+2).

    Parameters
    ----------
    n_steps : int
        RK4 steps N.

    Returns
    -------
    list of int
    """
    return [c for k in range(n_steps) for c in (2 * k, 2 * k + 1, 2 * k + 2)]
