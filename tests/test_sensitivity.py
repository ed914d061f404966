"""Exact multiplier sensitivities against finite differences of two trims (independent check)."""

import numpy as np
import pytest
from conftest import COARSE_METHOD

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.studies.sensitivity import multiplier_sensitivities
from birdocp.studies.trim import trim

# A coarse grid keeps the test fast; the derivatives are exact for whichever grid the trim uses.
STEPS = {"gait.shoulder_flap.amplitude_deg": 0.01, "wing.root_ahead_m": 1e-4,
         "gait.elbow_flex.amplitude_deg": 0.01}


@pytest.fixture(scope="module")
def base(coarse):
    r = trim(Config(), tol=1e-12, **coarse)
    assert r.success
    return r


def _fd(base, key, h, level=False):
    v = base.cycle.p[PARAM_NAMES.index(key)]
    out = []
    for s in (+1, -1):
        cfg = with_values(base.cfg, {key: v + s * h})
        if level:
            from birdocp.studies.level import level as solve_level
            r = solve_level(cfg, warm_start=base, tol=1e-12, **COARSE_METHOD)
        else:
            r = trim(cfg, warm_start=base, tol=1e-12, **COARSE_METHOD)
        assert r.success
        out.append(r)
    return out


@pytest.mark.slow
def test_multiplier_and_mean_speed_derivatives_match_finite_differences(base):
    keys = list(STEPS)
    s = multiplier_sensitivities(base, keys)
    assert np.allclose(s.multipliers, base.multipliers, atol=1e-12)
    for k, key in enumerate(keys):
        rp, rm = _fd(base, key, STEPS[key])
        h = STEPS[key]
        fd_mod = (np.abs(rp.multipliers) - np.abs(rm.multipliers)) / (2 * h)
        fd_lam = (rp.multipliers - rm.multipliers) / (2 * h)
        fd_W = (rp.mean_vertical_speed_mps - rm.mean_vertical_speed_mps) / (2 * h)
        fd_x0 = (rp.x0 - rm.x0) / (2 * h)
        scale = np.max(np.abs(fd_mod)) + 1e-12
        assert np.max(np.abs(s.d_moduli[k] - fd_mod)) < 1e-4 * scale + 1e-9, key
        assert np.max(np.abs(s.d_multipliers[k] - fd_lam)) < 1e-4 * np.max(np.abs(fd_lam)) + 1e-9, key
        assert abs(s.d_mean_vertical_speed[k] - fd_W) < 1e-4 * abs(fd_W) + 1e-9, key
        assert np.max(np.abs(s.d_x0[k] - fd_x0)) < 1e-4 * np.max(np.abs(fd_x0)) + 1e-9, key
    ranked = s.ranked()
    assert [r["parameter"] for r in ranked][0] == "wing.root_ahead_m"
    assert ranked[0]["unit"] == "cm"
    # every row says whether the model holds on the cycle differentiated; the cycle can be re-solved
    assert s.validity == base.validity.to_dict() and all(r["valid"] is base.validity.valid for r in ranked)
    assert np.array_equal(s.x0, base.x0) and s.amplitude_deg == base.amplitude_deg


def test_level_held_sensitivity_matches_two_level_solves(base, coarse):
    key = "gait.elbow_flex.amplitude_deg"
    lv = __import__("birdocp.studies.level", fromlist=["level"]).level(base.cfg, tol=1e-12, **coarse)
    assert lv.success
    fixed = trim(with_values(base.cfg, {"gait.shoulder_flap.amplitude_deg": lv.amplitude_deg}), tol=1e-12,
                 warm_start=lv, **coarse)
    s = multiplier_sensitivities(fixed, [key], hold_level=True)
    assert s.parameters == [key]
    rp, rm = _fd(lv, key, 0.01, level=True)
    fd_mod = (np.abs(rp.multipliers) - np.abs(rm.multipliers)) / 0.02
    fd_A = (rp.amplitude_deg - rm.amplitude_deg) / 0.02
    assert abs(s.d_amplitude[0] - fd_A) < 1e-4 * abs(fd_A) + 1e-8
    assert np.max(np.abs(s.d_moduli[0] - fd_mod)) < 1e-4 * np.max(np.abs(fd_mod)) + 1e-8
