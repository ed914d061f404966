"""Mode labels carried along a family by eigenvector continuity (birdocp.studies.lateral_modes.track_modes)."""
from __future__ import annotations

import numpy as np
import pytest

from birdocp.studies.lateral_modes import track_modes


def _mode(lam, vec, label):
    return {"multiplier": complex(lam), "eigenvector": dict(zip("abcd", (complex(v) for v in vec))), "label": label}


def _family():
    """Two real modes whose moduli cross while their eigenvectors turn slowly, each point labelled by the
    per-point rule (the real mode nearest 1 is the 'spiral'), so the names swap at the crossing; and a
    complex pair that stays a pair."""
    pts = []
    for k, s in enumerate(np.linspace(0.0, 1.0, 6)):
        a, b = 1.05 - 0.6 * s, 0.6 + 0.5 * s  # cross near s = 0.4
        la, lb = ("spiral", "roll_subsidence") if abs(a - 1) < abs(b - 1) else ("roll_subsidence", "spiral")
        modes = [_mode(a, [1.0, 0.2 * s, 0.1, 0.0], la), _mode(b, [0.1, 1.0, 0.3 * s, 0.0], lb),
                 _mode(0.7 + 0.3j, [0, 0, 1, 1j], "dutch_roll_like"), _mode(0.7 - 0.3j, [0, 0, 1, -1j], "dutch_roll_like")]
        pts.append(modes[::-1] if k % 2 else modes)  # the order within a point means nothing
    return pts


def test_labels_follow_the_eigenvectors_not_the_per_point_rule():
    pts = _family()
    out = track_modes(pts, 0)
    for modes in out:
        by = {m["label"]: m for m in modes if m["label"] != "dutch_roll_like"}
        assert abs(by["spiral"]["eigenvector"]["a"]) == 1.0  # the mode that started as the spiral
        assert by["spiral"]["tracking_overlap"] > 0.9
        assert sum(m["label"] == "dutch_roll_like" for m in modes) == 2
    # the per-point labels did swap: the tracking changed something
    assert any(m["label"] != m["point_label"] for modes in out for m in modes)


def test_two_real_modes_that_become_a_pair_get_both_labels():
    a = [_mode(0.3, [1, 0.1, 0, 0], "roll_subsidence"), _mode(0.2, [0.1, 1, 0, 0], "dutch_roll_like")]
    b = [_mode(0.25 + 0.02j, [1, 0.5 + 0.2j, 0, 0], "x"), _mode(0.25 - 0.02j, [1, 0.5 - 0.2j, 0, 0], "x")]
    out = track_modes([a, b], 0)
    assert {m["label"] for m in out[1]} == {"dutch_roll_like+roll_subsidence"}


def test_points_need_equally_many_modes():
    with pytest.raises(ValueError, match="same number"):
        track_modes([[_mode(0.5, [1, 0, 0, 0], "spiral")], []], 0)
