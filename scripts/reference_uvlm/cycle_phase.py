"""The lift-peak rule shared by the UVLM runs (run_uvlm.py, PteraSoftware's environment) and birdocp's
side (compare.py): numpy only, so both environments import it."""
from __future__ import annotations

import numpy as np


def peak_phase_deg(values: np.ndarray) -> float:
    """Phase [deg] of the largest value of one periodic cycle sampled at n uniform steps (parabolic
    refinement through the largest sample and its two neighbours)."""
    n = len(values)
    i = int(np.argmax(values))
    a, b, c = values[(i - 1) % n], values[i], values[(i + 1) % n]
    den = a - 2 * b + c
    shift = 0.5 * (a - c) / den if den != 0 else 0.0
    return float(((i + shift) / n * 360.0) % 360.0)
