"""``wing.smooth_geometry``: the switch-free wing geometry (docs/model.md §4.8) makes the bird's RK4
grid converge at order 4; off (the default), the model is today's, bit for bit."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from birdocp import Config, trim, with_values
from birdocp.bird.config import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def _leading(cfg, steps: int) -> float:
    r = trim(cfg, steps_per_period=steps)
    assert r.success, r.message
    return float(np.max(np.abs(r.multipliers)))


def test_smooth_geometry_observed_order_is_four():
    """Richardson on 12, 24, 48 steps: log2((m12 - m24) / (m24 - m48)) (about 4.3 measured; the
    reference geometry's data jump twice a wingbeat and give no order at all)."""
    cfg = with_values(Config(), {"wing.smooth_geometry": True})
    m = [_leading(cfg, n) for n in (12, 24, 48)]
    order = math.log2(abs(m[0] - m[1]) / abs(m[1] - m[2]))
    assert 3.5 < order < 5.0, (m, order)


def test_default_geometry_is_todays():
    """Off by default, and the default trim reproduces the committed experiment-1 multiplier (2 points,
    144 steps) to round-off: the reference geometry is untouched."""
    assert Config().wing.smooth_geometry is False
    ref = json.loads((ROOT / "results/experiment1/result.json").read_text())
    row = ref["studies"]["m_invariance"]["by_points"]["2"]
    r = trim(Config(), points=2, steps_per_period=ref["studies"]["m_invariance"]["steps_per_period"])
    assert r.success
    assert abs(float(np.max(np.abs(r.multipliers))) - row["multipliers"][0][0]) < 1e-9
    smooth = trim(with_values(Config(), {"wing.smooth_geometry": True}), points=2, steps_per_period=144)
    assert abs(float(np.max(np.abs(smooth.multipliers))) - row["multipliers"][0][0]) > 1e-4


def test_smooth_geometry_must_be_a_bool():
    with pytest.raises(ConfigError, match="wing.smooth_geometry"):
        with_values(Config(), {"wing.smooth_geometry": "yes"})
