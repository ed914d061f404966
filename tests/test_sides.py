"""Asymmetric gaits (birdocp.bird.sides): per-side joint offsets in six degrees of freedom.

Exact properties: zero offsets give the symmetric data bit for bit; swapping the left and right
offsets mirrors the solved cycle ((v, p, r, phi, psi) change sign along it, the rest stays) to
round-off; offsets are refused in four degrees of freedom."""
from __future__ import annotations

import numpy as np
import pytest

from birdocp.bird.config import Config, ConfigError, param_vector, with_values
from birdocp.bird.sides import side_vector, swap_sides
from birdocp.bird.sixdof import sixdof_model
from birdocp.studies.lateral import heading_trajectory, lateral_trim

FLIP = np.array([1, -1, 1, -1, 1, -1, -1, 1, -1.0])  # (v, p, r, phi, psi) change sign


def _six(**extra):
    return with_values(Config(), {"model.degrees_of_freedom": 6, **extra})


def test_zero_offsets_give_the_symmetric_data_bit_for_bit():
    cfg = _six()
    sym, sides = sixdof_model(cfg), sixdof_model(cfg, sides=True)
    assert not sym.sides and sides.sides
    p = param_vector(cfg)
    for t in (0.0, 0.071, 0.2):
        assert np.array_equal(np.asarray(sym.data(t, sym.params(p))), np.asarray(sides.data(t, sides.params(p))))


def test_an_offset_changes_one_wing_only():
    cfg = _six()
    six = sixdof_model(cfg, sides=True)
    p = param_vector(cfg)
    off = np.zeros(len(side_vector(cfg)))
    off[1 * 3 + 1] = 5.0  # right wing: shoulder_flap.amplitude_deg + 5
    d0 = np.asarray(six.data(0.05, six.params(p))).ravel()
    d1 = np.asarray(six.data(0.05, six.params(p, offsets=off))).ravel()
    r0, r1 = d0[:48].reshape(16, 3), d1[:48].reshape(16, 3)  # element centres (column-major 3 x 16)
    assert np.abs(r1[8:] - r0[8:]).max() > 1e-3  # the right wing (elements 8..15) moved
    np.testing.assert_array_equal(r1[:8], r0[:8])  # the left wing did not


def test_offsets_need_six_degrees_of_freedom():
    with pytest.raises(ConfigError, match="gait.left_offset.shoulder_sweep.offset_deg"):
        with_values(Config(), {"gait.left_offset.shoulder_sweep.offset_deg": 2.0})
    with pytest.raises(ConfigError, match="gait.right_offset.shoulder_flap.amplitude_deg"):
        _six(**{"gait.right_offset.shoulder_flap.amplitude_deg": 170.0})  # 42 + 170 > 180


@pytest.mark.slow
def test_swapping_the_wings_mirrors_the_solved_cycle():
    right = _six(**{"gait.right_offset.shoulder_flap.amplitude_deg": 1.0,
                    "gait.right_offset.shoulder_sweep.offset_deg": -1.0,
                    "gait.left_offset.shoulder_incidence.offset_deg": 0.5})
    left = _six(**{"gait.left_offset.shoulder_flap.amplitude_deg": 1.0,
                   "gait.left_offset.shoulder_sweep.offset_deg": -1.0,
                   "gait.right_offset.shoulder_incidence.offset_deg": 0.5})
    assert side_vector(left) == swap_sides(side_vector(right))
    a, b = lateral_trim(right), lateral_trim(left)
    assert a.success and b.success and not a.symmetric
    assert abs(a.cycle.x0[6]) > 1e-2 and abs(a.heading_change_deg) > 0.1  # a banked turn, not a symmetric cycle
    six_a, six_b = sixdof_model(right), sixdof_model(left)
    _, Xa = heading_trajectory(six_a, a.cycle)
    _, Xb = heading_trajectory(six_b, b.cycle)
    scale = np.abs(Xa).max(axis=0) + 1e-3
    assert np.abs((Xb - Xa * FLIP) / scale).max() < 1e-9
    np.testing.assert_allclose(np.sort(np.abs(a.multipliers)), np.sort(np.abs(b.multipliers)), rtol=0, atol=1e-8)
    assert abs(a.heading_change_deg + b.heading_change_deg) < 1e-9
