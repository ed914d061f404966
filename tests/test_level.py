"""Level flight as one NLP (amplitude free, mean vertical speed constrained) against independent checks.

A coarse grid (3 shooting points, 48 RK4 steps) keeps the graphs small; every comparison below uses
the same grid on both sides, so the RK4 period map is the same function of (x0, A).
"""

from __future__ import annotations

import math

import pytest
from conftest import COARSE_METHOD

from birdocp.bird.config import Config, ConfigError, with_values
from birdocp.studies.level import AMPLITUDE_KEY, level, mean_sensitivity
from birdocp.studies.trim import trim



@pytest.fixture(scope="module")
def lev(coarse):
    return level(Config(), **coarse)


def _trim_at(a, warm=None):
    return trim(with_values(Config(), {AMPLITUDE_KEY: float(a)}), warm_start=warm, **COARSE_METHOD)


def test_level_flight_has_zero_mean_vertical_speed(lev):
    assert lev.success, lev.message
    assert abs(lev.mean_vertical_speed_mps) < 1e-8
    assert lev.max_residual < 1e-9
    a = lev.free_values[AMPLITUDE_KEY]
    assert a == lev.amplitude_deg
    assert 42.0 < a < 45.0
    assert abs(lev.flight_path_angle_deg) < 1e-7
    assert lev.multipliers is not None and len(lev.multipliers) == 4


def test_level_agrees_with_a_secant_search_over_trims(lev):
    """Independent check: the paper's way (one limit cycle per amplitude), secant steps on mean W."""
    a0, a1 = 43.2, 43.3
    r0 = _trim_at(a0)
    r1 = _trim_at(a1, r0)
    w0, w1 = r0.mean_vertical_speed_mps, r1.mean_vertical_speed_mps
    trims = 2
    while True:
        a2 = a1 - w1 * (a1 - a0) / (w1 - w0)
        if abs(w1) < 1e-11 or trims == 4:
            break
        r2 = _trim_at(a2, r1)
        assert r2.success
        trims += 1
        a0, w0, a1, w1, r1 = a1, w1, a2, r2.mean_vertical_speed_mps, r2
    assert abs(a2 - lev.amplitude_deg) < 1e-6, (a2, lev.amplitude_deg, trims)


def test_mean_vertical_speed_derivative_matches_finite_differences(lev):
    a = lev.amplitude_deg
    r = _trim_at(a, lev)
    s = mean_sensitivity(r, AMPLITUDE_KEY, "vertical_speed_mps")
    assert abs(s["mean"] - r.mean_vertical_speed_mps) < 1e-12
    h = 0.01
    rp, rm = _trim_at(a + h, r), _trim_at(a - h, r)
    fd = (rp.mean_vertical_speed_mps - rm.mean_vertical_speed_mps) / (2 * h)
    assert s["derivative"] == pytest.approx(fd, rel=1e-6)
    assert 0.02 < s["derivative"] < 0.1  # m/s per deg: climbing with more amplitude


def test_climb_rate_and_flight_path_angle_conditions_agree(lev, coarse):
    """A climb rate, then the same flight asked for by its flight path angle: the same amplitude."""
    climb = level(Config(), climb_rate_mps=0.05, warm_start=lev, **coarse)
    assert climb.success and abs(climb.mean_vertical_speed_mps - 0.05) < 1e-8
    assert climb.amplitude_deg > lev.amplitude_deg
    beta = climb.flight_path_angle_deg
    same = level(Config(), constrain="flight_path_angle_deg", target=beta, warm_start=lev, **coarse)
    assert same.success
    assert math.isclose(same.flight_path_angle_deg, beta, abs_tol=1e-8)
    assert same.amplitude_deg == pytest.approx(climb.amplitude_deg, abs=1e-6)


def test_bad_level_arguments_raise_config_errors():
    with pytest.raises(ConfigError, match="did you mean"):
        level(Config(), free="gait.shoulder_flap.amplitud")
    with pytest.raises(ConfigError, match="bounds"):
        level(Config(), free="body.mass_kg")
    with pytest.raises(ConfigError, match="constrain"):
        level(Config(), constrain="vertical_sped")
    with pytest.raises(ConfigError, match="target"):
        level(Config(), constrain="forward_speed_mps")
