"""Stability optimisation: Jury conditions, and an optimum checked independently (numpy eigenvalues,
a trim from scratch, and level solves at neighbouring gaits)."""

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import Config, ConfigError, with_values
from birdocp.studies.level import level
from birdocp.studies.optimize import jury_conditions, optimize_stability


def test_jury_conditions_match_eigenvalues():
    rng = np.random.default_rng(1)
    for _ in range(500):
        A = rng.normal(size=(4, 4)) * rng.uniform(0.1, 0.7)
        inside = np.max(np.abs(np.linalg.eigvals(A))) < 1
        j = np.asarray(ca.DM(jury_conditions(ca.DM(A)))).ravel()
        assert inside == bool(np.all(j > 0))


def test_free_key_that_reshapes_the_wing_is_refused():
    with pytest.raises(ConfigError, match="arm frame"):
        optimize_stability(Config(), {"gait.elbow_flex.offset_deg": (20.0, 40.0)}, steps_per_period=24)


KEY = "gait.shoulder_sweep.offset_deg"
BOUNDS = (-30.0, -5.0)


@pytest.fixture(scope="module")
def optimum():
    return optimize_stability(Config(), {KEY: BOUNDS}, steps_per_period=24)


@pytest.mark.slow
def test_optimum_is_verified_independently(optimum):
    r = optimum
    assert r.success, r.message
    lam = np.max(np.abs(r.multipliers))
    assert lam < np.max(np.abs(r.start_multipliers))            # better than the paper's gait
    assert 0 <= r.radius - lam < 1e-4                          # r bounds the spectral radius, tightly
    v = r.verification
    assert v["trim_success"]                                    # multiple shooting, 5 points
    assert v["trim_x0_difference"] < 1e-6
    assert v["max_multiplier_difference"] < 1e-6
    assert abs(v["trim_mean_vertical_speed_mps"]) < 1e-8       # level flight
    assert v["scratch_trim_success"]


def test_reduced_optimum_radius_and_kkt(optimum):
    """The reduced-space optimum (the default method): r equals the spectral radius of the verifying
    trim's monodromy (numpy eigenvalues of an independent multiple-shooting solve) up to the Jury
    margin's effect, one Jury condition is active, and the gradient of the Lagrangian vanishes."""
    r = optimum
    assert r.method == "reduced" and r.success, r.message
    v = r.verification
    trim_radius = max(abs(complex(*z)) for z in v["trim_multipliers"])
    assert 0 <= r.radius - trim_radius < 1e-3
    assert min(v["jury_at_optimum"]) < 1e-5                    # the stability constraint is active
    assert r.kkt_residual is not None and r.kkt_residual < 1e-6
    assert r.to_dict()["kkt_residual"] == r.kkt_residual


def test_optimum_is_a_local_minimum(optimum):
    """Level flight at gaits next to the optimum (the amplitude re-solved) has a larger spectral
    radius, unless the optimum sits on a bound."""
    best = optimum.free[KEY]
    base = np.max(np.abs(optimum.multipliers))
    for step in (-0.5, 0.5):
        value = best + step
        if not BOUNDS[0] <= value <= BOUNDS[1]:
            continue
        lv = level(with_values(Config(), {KEY: value}), points=2, steps_per_period=24)
        assert lv.success
        assert np.max(np.abs(lv.multipliers)) > base - 1e-9


@pytest.mark.slow
def test_reduced_and_full_space_reach_the_same_optimum(optimum):
    """Two formulations, one answer: the full-space single-shooting NLP (``method="full"``, state,
    parameters, amplitude and r as unknowns) finds the reduced-space optimum's gait and radius."""
    full = optimize_stability(Config(), {KEY: BOUNDS}, steps_per_period=24, verify=False, method="full")
    assert full.success and full.method == "full", full.message
    assert abs(full.radius - optimum.radius) < 1e-6
    assert abs(full.free[KEY] - optimum.free[KEY]) < 1e-4
    assert abs(full.amplitude_deg - optimum.amplitude_deg) < 1e-4


def test_unknown_method_is_refused():
    with pytest.raises(ConfigError, match="--method"):
        optimize_stability(Config(), {KEY: BOUNDS}, method="newton")


@pytest.mark.slow
def test_reduced_result_is_the_same_with_1_and_2_threads():
    """Coarse stage (finite-difference Hessian, its points in a thread pool) then the fine stage (the
    coarse second derivatives held fixed): the answer, a KKT point, does not depend on the number of
    threads, to the bit."""
    runs = [optimize_stability(Config(), {KEY: BOUNDS}, steps_per_period=24, coarse_steps=16, verify=False,
                               threads=n) for n in (1, 2)]
    a, b = runs
    assert a.success and b.success, (a.message, b.message)
    assert "coarse stage (16 steps)" in a.message
    assert a.free == b.free and a.radius == b.radius and a.iterations == b.iterations
    assert np.array_equal(a.x0, b.x0) and np.array_equal(a.multipliers, b.multipliers)
    assert a.kkt_residual == b.kkt_residual < 1e-6
    assert a.evaluations == b.evaluations


def test_threads_must_be_positive():
    with pytest.raises(ConfigError, match="--threads"):
        optimize_stability(Config(), {KEY: BOUNDS}, threads=0)
