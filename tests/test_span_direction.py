"""``aero.span_direction``: the sections' span direction from the relaxed leading line (the paper's,
the default: today's model, bit for bit) or along each element node to node (docs/model.md §5)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from birdocp import Config, trim, with_values
from birdocp.bird.config import ConfigError, param_vector
from birdocp.bird.model import get_model, unpack_data

ROOT = Path(__file__).resolve().parents[1]
ELEMENT = {"aero.span_direction": "element"}


def test_default_is_the_leading_line_and_reproduces_the_committed_multiplier():
    """Default ``leading_line``; the default trim (2 points, 144 steps) gives the committed experiment-1
    multiplier to round-off."""
    assert Config().aero.span_direction == "leading_line"
    ref = json.loads((ROOT / "results/experiment1/result.json").read_text())["studies"]["m_invariance"]
    r = trim(Config(), points=2, steps_per_period=ref["steps_per_period"])
    assert r.success
    assert abs(float(np.max(np.abs(r.multipliers))) - ref["by_points"]["2"]["multipliers"][0][0]) < 1e-9


def test_element_frames_follow_the_nodes_and_are_orthonormal():
    """With ``element``: tau is the unit vector node to node, (tau, c_hat, up) orthonormal and
    right-handed (tau = up x c_hat); the leading-line frames differ by degrees (the swept hand)."""
    out = []
    for cfg in (Config(), with_values(Config(), ELEMENT)):
        b = {k: np.asarray(v) for k, v in unpack_data(get_model(cfg).data(0.05, param_vector(cfg))).items()}
        out.append(b)
    b = out[1]
    d = np.diff(b["nodes_m"], axis=1)
    np.testing.assert_allclose(b["tau"], d / np.linalg.norm(d, axis=0), rtol=0, atol=1e-13)
    for x, y in (("tau", "c_hat"), ("tau", "up"), ("c_hat", "up")):
        assert np.abs(np.sum(b[x] * b[y], axis=0)).max() < 1e-13
    np.testing.assert_allclose(np.cross(b["up"].T, b["c_hat"].T).T, b["tau"], rtol=0, atol=1e-13)
    turn_deg = np.degrees(np.arccos(np.clip(np.sum(out[0]["tau"] * b["tau"], axis=0), -1, 1)))
    assert turn_deg.max() > 1.0
    np.testing.assert_array_equal(out[0]["r_m"], b["r_m"])  # the same line, only the frames turn


def test_symmetric_six_dof_cycle_is_the_planar_cycle_with_element_frames(coarse):
    from birdocp.studies.lateral import lateral_trim
    from birdocp.engine.method import OrbitMethod

    cfg = with_values(Config(), ELEMENT)
    planar = trim(cfg, **coarse)
    res = lateral_trim(cfg, method=OrbitMethod(**coarse))
    assert planar.success and res.success
    assert res.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-9)
    base = trim(Config(), **coarse)
    assert np.abs(np.sort_complex(planar.multipliers) - np.sort_complex(base.multipliers)).max() > 1e-4


def test_span_direction_must_be_a_known_value():
    with pytest.raises(ConfigError, match="aero.span_direction"):
        with_values(Config(), {"aero.span_direction": "chord"})
