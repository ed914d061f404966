"""``aero.normalwash``: the section law of the lifting line. ``angle`` (the default, the paper's model:
the normalwash |Vp| alpha, lift linear in the section angle; the committed reference numbers of the
other tests) or ``tangency`` (|Vp| sin(alpha), the flow tangency of a flat plate: lift linear in the
sine of the angle, the law a vortex lattice solves). The vortex-lattice comparison of the option is in
tests/test_reference_aerosandbox.py."""
from __future__ import annotations

import json
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from birdocp import Config, trim, with_values
from birdocp.bird.aero import section_angle, section_normalwash
from birdocp.bird.config import ConfigError
from birdocp.bird.layout import Structure
from birdocp.studies.glide import attached_config, load_derivatives_at
from birdocp.studies.glide_refined import refined_load_derivatives, section_law_terms

GLIDE = Path(__file__).resolve().parents[1] / "results" / "lateral" / "glide" / "birdocp.json"
MODEL_C = {"aero.span_direction": "element", "aero.collocation": "three_quarter"}


def test_normalwash_values_and_the_linear_section_only():
    assert Config().aero.normalwash == "angle" and Structure.of(Config()).normalwash == "angle"
    assert Structure.of(with_values(Config(), {"aero.normalwash": "tangency"})).normalwash == "tangency"
    with pytest.raises(ConfigError, match="aero.normalwash"):
        with_values(Config(), {"aero.normalwash": "sine"})
    for other in ({"aero.unsteady": "wagner"}, {"aero.section": "stall"}):
        with pytest.raises(ConfigError, match="aero.normalwash"):
            with_values(Config(), {"aero.normalwash": "tangency", **other})


def test_the_tangency_normalwash_is_the_velocity_along_the_section_normal():
    """Flow tangency on a flat plate: q = |Vp| sin(alpha) is the velocity component along the section's
    normal (whatever the spanwise component), the angle law |Vp| alpha is larger by alpha / sin(alpha)."""
    rng = np.random.default_rng(3)
    V = rng.normal(size=(3, 5)) + np.array([[0.0], [0.5], [10.0]])
    c_hat = np.tile([[0.0], [0.0], [1.0]], 5)
    up = np.tile([[0.0], [1.0], [0.0]], 5)
    tau = np.tile([[1.0], [0.0], [0.0]], 5)
    alpha, speed = (np.asarray(ca.evalf(a)) for a in section_angle(ca.DM(V), ca.DM(c_hat), ca.DM(up), ca.DM(tau)))
    q = {law: np.asarray(ca.evalf(section_normalwash(ca.DM(speed), ca.DM(alpha), law))) for law in ("angle", "tangency")}
    np.testing.assert_allclose(q["tangency"].ravel(), V[1], rtol=1e-13)
    np.testing.assert_allclose((q["angle"] / q["tangency"]).ravel(), (alpha / np.sin(alpha)).ravel(), rtol=1e-13)


@pytest.fixture(scope="module")
def state():
    return json.loads(GLIDE.read_text())["state"]


def test_the_model_option_is_glide_refineds_tangency_line(state):
    """Two code paths: the 6-DOF model with the option (its data and right-hand side graphs; 16 and,
    with aero.span_subdivisions = 2, 32 elements) has the load derivatives of glide_refined's NumPy line
    with the tangency law at split 1 and 2, to round-off."""
    for split in (1, 2):
        option = load_derivatives_at(with_values(attached_config(), {
            **MODEL_C, "aero.normalwash": "tangency", "aero.span_subdivisions": split}), state["u_mps"], state["w_mps"])
        line = refined_load_derivatives(attached_config(), state["u_mps"], state["w_mps"], split, "step", "element",
                                        "three_quarter", "tangency")
        for k, v in option.items():
            assert abs(line[k] - v) <= 1e-10 * max(1.0, abs(v)), (split, k, line[k], v)


def test_the_roll_damping_gap_of_the_two_laws_is_the_lift_slope_cos_alpha(state):
    """Physics of the 2.2 % roll-damping difference between the laws at the compared glide (sections
    at 11.7-12.0 deg): the roll rate turns every section's relative wind (its speed changes by < 1 % of
    |Vp| dalpha), so the normalwash answers with |Vp| dalpha (angle law) against |Vp| cos(alpha) dalpha
    (a flat plate's lift slope at alpha): per element the two answers differ by 1/cos(alpha) to 1e-4,
    and so does every element's share of L_p. The turning of the force at a held circulation adds no
    roll moment (the roll damping is the circulation's answer)."""
    t = {law: section_law_terms(attached_config(), state["u_mps"], state["w_mps"], law) for law in ("angle", "tangency")}
    alpha = np.radians(t["angle"]["alpha_deg"])
    assert 11.5 < t["angle"]["alpha_deg"][8] < 12.5
    turning = np.abs(np.array(t["angle"]["dspeed_dp"]) / (np.array(t["angle"]["speed_mps"]) * np.array(t["angle"]["dalpha_dp"])))
    assert turning.max() < 0.01
    ratio = np.array(t["angle"]["dq_dp"]) / np.array(t["tangency"]["dq_dp"])
    np.testing.assert_allclose(ratio, 1 / np.cos(alpha), rtol=1e-4)
    np.testing.assert_allclose(np.sum(np.array(t["tangency"]["L_p"]) / np.cos(alpha)), t["angle"]["L_p_total"], rtol=1e-4)
    assert abs(sum(t["angle"]["L_p_force_turning"])) < 1e-12 * abs(t["angle"]["L_p_total"])
    assert 1.02 < t["angle"]["L_p_total"] / t["tangency"]["L_p_total"] < 1.025


def test_the_flapping_bird_trims_with_the_tangency_law(coarse):
    """The option acts in flapping flight (sections up to ~25 deg in the stroke): the coarse trim
    converges, the symmetric 6-DOF cycle is the planar one (longitudinal multipliers to 1e-9, coupling
    below 1e-12) and the cycle differs from the default's (measured u at t = 0 18.077 against 18.040 m/s)."""
    from birdocp.engine.method import OrbitMethod
    from birdocp.studies.lateral import lateral_trim

    cfg = with_values(Config(), {"aero.normalwash": "tangency"})
    base = trim(Config(), **coarse)
    planar = trim(cfg, **coarse)
    six = lateral_trim(cfg, method=OrbitMethod(**coarse))
    assert base.success and planar.success and six.success
    assert six.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(six.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-9)
    assert float(np.asarray(planar.x0)[0]) - float(np.asarray(base.x0)[0]) > 0.01
