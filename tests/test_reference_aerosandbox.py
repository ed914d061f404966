"""The gliding limit against an independent vortex-lattice model: birdocp's lateral roots of the frozen
wing's steady glide (the attached pose ``birdocp.studies.glide.ATTACHED_POSE``), computed here, against
AeroSandbox's committed numbers (results/lateral/glide/aerosandbox.json: the VLM of the model's stepped
planform, every element a constant-chord strip, made offline by scripts/reference_aerosandbox from the
geometry birdocp exported: results/lateral/glide/geometry.json). (a) is the paper's model, (b) the model
with aero.span_direction = "element" (and its lifting line cut into sub-elements, glide_refined)."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from birdocp.bird.config import param_vector, with_values
from birdocp.bird.sixdof import LateralInertia, sixdof_model
from birdocp.engine.method import OrbitMethod
from birdocp.engine.shooting import floquet
from birdocp.studies.glide import (attached_config, glide_geometry, lateral_glide_modes, lateral_matrix_with,
                                   load_derivatives_at, steady_glide)
from birdocp.studies.glide_refined import refined_load_derivatives

FOLDER = Path(__file__).resolve().parents[1] / "results" / "lateral" / "glide"


@pytest.fixture(scope="module")
def cfg():
    return attached_config()


@pytest.fixture(scope="module")
def glide(cfg):
    g = steady_glide(cfg)
    assert g["success"] and g["residual"] < 1e-10
    return g


@pytest.fixture(scope="module")
def reference():
    return json.loads((FOLDER / "aerosandbox.json").read_text())


def test_the_reference_is_of_the_geometry_birdocp_builds(cfg, glide, reference):
    """The committed geometry (AeroSandbox's input) is the frozen lifting line and glide of today's code,
    and the committed VLM numbers were made from that very file."""
    text = (FOLDER / "geometry.json").read_text()
    committed = json.loads(text)
    assert reference["geometry_sha256"] == hashlib.sha256(text.encode()).hexdigest()
    now = glide_geometry(cfg, glide=glide)
    for key in ("nodes_m", "centres_m", "chords_m", "chord_directions", "lengths_m"):
        np.testing.assert_allclose(np.asarray(now[key]), np.asarray(committed[key]), rtol=0, atol=1e-9)
    for key in ("u_mps", "w_mps", "theta_rad"):
        assert abs(now["glide_state"][key] - committed["glide_state"][key]) < 1e-9
    assert now["joint_offsets_deg"] == committed["joint_offsets_deg"] == reference["joint_offsets_deg"]


def test_the_compared_glide_is_attached_and_valid(glide):
    """The pose is chosen so that the glide is a flight the lifting line (and the VLM) represent:
    valid by the project's validity check, the airflow along the body axis (so the body-axis wake is
    also the wind-aligned one), every section well below the stall angle."""
    v = glide["validity"]
    assert v["valid"], v["reasons"]
    assert abs(glide["alpha_body_deg"]) < 1.0
    assert 5.0 < v["alpha_eff_min_deg"] and v["alpha_eff_max_deg"] < 15.0


def test_frozen_attached_wing_multipliers_are_the_glide_eigenvalues(cfg, glide):
    """The gliding limit in the compared pose: ln(Lambda)/T of the frozen wing's cycle (the engine's
    exact monodromy, 600 RK4 steps) are steady_glide's eigenvalues (plus the heading's 0) to 1e-6."""
    six = sixdof_model(cfg)
    p6 = six.params(param_vector(cfg), LateralInertia.of(cfg))
    x0 = np.append(list(glide["state"].values()), 0.0)
    fl = floquet(six.ode, x0, p6, OrbitMethod(points=3, steps_per_period=600))
    ln = np.sort_complex(np.log(fl.multipliers.astype(complex)) / six.ode.forcing_period)
    lam = np.sort_complex(np.append([complex(*z) for z in glide["eigenvalues"]], 0.0))
    np.testing.assert_allclose(ln.real, lam.real, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(np.abs(ln.imag), np.abs(lam.imag), rtol=1e-6, atol=1e-6)


@pytest.mark.xfail(strict=True, reason="measured: (a) the paper's model -45.30 1/s, the VLM of the same stepped "
                   "planform (body-axis wake) -41.34 1/s, 9.6 % apart: the roll damping L_p is 9.5 % larger; the "
                   "refined model (b) is also not within 5 % (test below)")
def test_roll_subsidence_within_five_percent_of_the_vortex_lattice(glide, reference):
    ours = glide["roll_subsidence_per_s"]
    ref = reference["body_axis_wake"]["roll_subsidence_per_s"]
    assert abs(ours - ref) <= 0.05 * abs(ref), (ours, ref)


@pytest.mark.xfail(strict=True, reason="measured: (a) the paper's model 1.819 rad/s, the VLM 1.664 rad/s, 9.3 % "
                   "apart, from the sideslip derivatives L_v and N_v (23-25 %): the model's section span direction "
                   "(n x c_hat from the relaxed leading line, docs/model.md) is swept up to 11 deg more than the "
                   "elements the vortices follow; with aero.span_direction = element (b) it is within 5 % (below)")
def test_dutch_roll_frequency_within_five_percent_of_the_vortex_lattice(glide, reference):
    ours = glide["dutch_roll"]["frequency_radps"]
    ref = reference["body_axis_wake"]["dutch_roll"]["frequency_radps"]
    assert abs(ours - ref) <= 0.05 * ref, (ours, ref)


@pytest.fixture(scope="module")
def element_model(cfg, glide):
    """(b) the refined model's derivatives at the glide: ``aero.span_direction = "element"`` (the model
    option, 16 elements) and the same with every element cut in two (glide_refined; 128 elements in
    results/lateral/glide/comparison.md)."""
    s = glide["state"]
    one = load_derivatives_at(with_values(cfg, {"aero.span_direction": "element"}), s["u_mps"], s["w_mps"])
    two = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], 2, "step", "element")
    two.pop("elements")
    return one, two


def test_refined_model_dutch_roll_frequency_within_five_percent_of_the_vortex_lattice(cfg, glide, reference,
                                                                                      element_model):
    """(b): with the span direction along the elements the Dutch-roll frequency is the VLM's within 5 %
    (1.653 rad/s against 1.664: 0.7 %; cut 8 times 1.9 %), at 16 and 32 elements."""
    ref = reference["body_axis_wake"]["dutch_roll"]["frequency_radps"]
    for d in element_model:
        dr = lateral_glide_modes(lateral_matrix_with(glide, d, cfg))["dutch_roll"]["frequency_radps"]
        assert abs(dr / ref - 1) < 0.05, (dr, ref)


@pytest.mark.xfail(strict=True, reason="measured: (b) -45.48 1/s at 16 elements, -45.01 at 32, -44.50 at 128 "
                   "against the VLM's -41.34 (7.7 % at 128 elements, the change per halving shrinking by ~0.6: "
                   "about -44.2, 7 %, in the limit): the remaining roll-damping gap is the lifting line against "
                   "the lattice (docs/studies/lateral.md), not the discretisation, the planform or the span direction")
def test_refined_model_roll_subsidence_within_five_percent_of_the_vortex_lattice(cfg, glide, reference, element_model):
    ref = reference["body_axis_wake"]["roll_subsidence_per_s"]
    roll = lateral_glide_modes(lateral_matrix_with(glide, element_model[1], cfg))["roll_subsidence_per_s"]
    assert abs(roll / ref - 1) <= 0.05, (roll, ref)


@pytest.fixture(scope="module")
def weissinger(cfg, glide):
    """(c) the model with ``aero.span_direction = "element"`` and ``aero.collocation = "three_quarter"``
    (Weissinger's extended lifting line) at 16 and 32 elements (``aero.span_subdivisions`` 1 and 2), with
    the paper's section law (``aero.normalwash = "angle"``: lift linear in the angle) and with the
    vortex lattice's (``"tangency"``: the flow tangency of a flat plate, lift linear in the sine of the
    angle); and glide_refined's line of (c) at split 1 with the paper's law (a second code path)."""
    s = glide["state"]
    out = {}
    for law in ("angle", "tangency"):
        for split in (1, 2):
            out[law, split] = load_derivatives_at(with_values(cfg, {
                "aero.span_direction": "element", "aero.collocation": "three_quarter", "aero.normalwash": law,
                "aero.span_subdivisions": split}), s["u_mps"], s["w_mps"])
    out["option"] = out["angle", 1]
    d = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], 1, "step", "element", "three_quarter", "angle")
    d.pop("elements")
    out["refined"] = d
    return out


def _roots(glide, der, cfg):
    m = lateral_glide_modes(lateral_matrix_with(glide, der, cfg))
    return m["roll_subsidence_per_s"], m["dutch_roll"]["frequency_radps"]


def test_weissingers_lifting_line_is_the_one_panel_lattice(cfg, glide, weissinger):
    """Two code paths and an independent model for the same thing: the model option (c) is
    glide_refined's three-quarter-chord line at split 1 to round-off, and with the lattice's
    flow-tangency law (``aero.normalwash = "tangency"``) it is AeroSandbox's VLM with one panel an element (the same 16 horseshoes;
    aerosandbox_chordwise1.json) within 1.5 % in L_p, L_v and N_v (measured 0.4 %, 0.9 %, 0.9 %: the
    forces' induced velocity is the model's two-dimensional one at the bound vortex); the quarter-chord
    model is 7 % from it in L_p."""
    for k, v in weissinger["option"].items():
        assert abs(weissinger["refined"][k] - v) <= 1e-10 * max(1.0, abs(v)), (k, weissinger["refined"][k], v)
    one_panel = json.loads((FOLDER / "aerosandbox_chordwise1.json").read_text())
    assert one_panel["resolution"]["chordwise"] == 1 and one_panel["resolution"]["spanwise_per_section"] == 1
    vlm1 = one_panel["body_axis_wake"]["derivatives"]
    for k in ("L_p", "L_v", "N_v"):
        assert abs(weissinger["tangency", 1][k] / vlm1[k] - 1) < 0.015, (k, weissinger["tangency", 1][k], vlm1[k])
    assert abs(glide["derivatives"]["L_p"] / vlm1["L_p"] - 1) > 0.05


def test_the_vortex_lattice_reference_is_converged_in_its_panels(reference):
    """The VLM reference (16 spanwise panels an element, 8 chordwise) against 8 x 16: the roll root
    and the Dutch-roll frequency move by 0.1 % and 0.6 %; against one panel an element (Weissinger's
    lattice) the roll root is 2.7 % less damped: the chordwise loading the lifting line cannot carry."""
    runs = {f: json.loads((FOLDER / f).read_text())["body_axis_wake"]
            for f in ("aerosandbox_chordwise16.json", "aerosandbox_chordwise1.json")}
    ref = reference["body_axis_wake"]
    fine = runs["aerosandbox_chordwise16.json"]
    assert abs(fine["roll_subsidence_per_s"] / ref["roll_subsidence_per_s"] - 1) < 0.005
    assert abs(fine["dutch_roll"]["frequency_radps"] / ref["dutch_roll"]["frequency_radps"] - 1) < 0.01
    one = runs["aerosandbox_chordwise1.json"]["roll_subsidence_per_s"] / ref["roll_subsidence_per_s"] - 1
    assert 0.02 < one < 0.035


def test_flat_plate_section_law_roll_subsidence_and_dutch_roll_within_five_percent_of_the_vortex_lattice(
        cfg, glide, reference, weissinger):
    """The model (c) with ``aero.normalwash = "tangency"`` (the flow tangency of a flat plate, the
    section law a VLM solves): the roll-subsidence root within 5 % of the VLM's (measured -42.67 1/s at
    16 elements, -42.48 at 32, against -41.34: 3.2 %, 2.8 %), and the Dutch-roll frequency too (1.3 %,
    0.7 %)."""
    ref = reference["body_axis_wake"]
    for split in (1, 2):
        roll, dutch = _roots(glide, weissinger["tangency", split], cfg)
        assert abs(roll / ref["roll_subsidence_per_s"] - 1) <= 0.05, (split, roll)
        assert abs(dutch / ref["dutch_roll"]["frequency_radps"] - 1) <= 0.05, (split, dutch)


def test_weissinger_dutch_roll_within_five_percent_of_the_vortex_lattice(cfg, glide, reference, weissinger):
    """(c) with the model's section law: the Dutch-roll frequency 1.671 rad/s (0.4 %; 32 elements 0.2 %)."""
    for d in (weissinger["option"], weissinger["angle", 2]):
        dutch = _roots(glide, d, cfg)[1]
        assert abs(dutch / reference["body_axis_wake"]["dutch_roll"]["frequency_radps"] - 1) <= 0.05, dutch


@pytest.mark.xfail(strict=True, reason="measured: (c) with the paper's section law (aero.normalwash = 'angle', lift "
                   "linear in the angle) -43.62 1/s at 16 elements, -43.43 at 32, -43.66 at 128 against the VLM's "
                   "-41.34: 5.5 %, 5.1 %, 5.6 %; the law's lift slope C_la against the flat plate's C_la cos(alpha) "
                   "answers a roll rate 1/cos(alpha) = 2.1-2.3 % more at the compared sections (11.7-12.0 deg; "
                   "section_law.json); with aero.normalwash = 'tangency' 3.2 % (passing); the VLM's chordwise "
                   "loading 2.7 (one panel an element: -42.46)")
def test_weissinger_roll_subsidence_within_five_percent_of_the_vortex_lattice(cfg, glide, reference, weissinger):
    for d in (weissinger["option"], weissinger["angle", 2]):
        roll = _roots(glide, d, cfg)[0]
        assert abs(roll / reference["body_axis_wake"]["roll_subsidence_per_s"] - 1) <= 0.05, roll


def test_the_roots_agree_within_ten_percent_and_the_spiral_within_five(glide, reference):
    """What does hold in the attached glide: both named roots within 10 %, the spiral within 5 %."""
    ref = reference["body_axis_wake"]
    assert abs(glide["roll_subsidence_per_s"] / ref["roll_subsidence_per_s"] - 1) < 0.10
    assert abs(glide["dutch_roll"]["frequency_radps"] / ref["dutch_roll"]["frequency_radps"] - 1) < 0.10
    assert abs(glide["spiral_per_s"] / ref["spiral_per_s"] - 1) < 0.05


def test_the_refined_lifting_line_is_the_model_at_split_one_and_approaches_the_lattice(cfg, glide, reference):
    """birdocp's lifting line cut into sub-elements: at split 1 (step planform) it is the model (the
    derivatives of load_derivatives_at to round-off); cutting each element in two moves the roll damping
    towards the VLM's, which it stays above."""
    s = glide["state"]
    one = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], 1)
    assert one.pop("elements") == 16
    for k, v in glide["derivatives"].items():
        assert abs(one[k] - v) <= 1e-10 * max(1.0, abs(v)), (k, one[k], v)
    two = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], 2)
    vlm = reference["body_axis_wake"]["derivatives"]["L_p"]
    assert two["elements"] == 32
    assert one["L_p"] < two["L_p"] < vlm < 0


def test_roll_damping_gap_is_smaller_at_a_small_section_angle(cfg, reference):
    """At a small section angle of attack (4 deg; the two section laws, linear in the angle and in its
    sine, agree) birdocp's roll damping L_p is within 7 % of the vortex lattice's; at the glide
    (sections at 8-14 deg) the gap is larger."""
    st = reference["body_axis_wake"]["check_states"][0]
    ours = load_derivatives_at(cfg, st["u_mps"], st["w_mps"])["L_p"]
    ref = st["derivatives"]["L_p"]
    assert ours < ref < 0
    assert abs(ours / ref - 1) < 0.07
    g = reference["glide_state"]
    at_glide = load_derivatives_at(cfg, g["u_mps"], g["w_mps"])["L_p"] / reference["body_axis_wake"]["derivatives"]["L_p"]
    assert at_glide - 1 > abs(ours / ref - 1)


def test_the_two_rigid_body_linearisations_agree_and_roll_damping_explains_the_roll_gap(cfg, glide, reference):
    """birdocp's exact lateral matrix with all nine load derivatives replaced by the VLM's is the VLM
    script's own lateral matrix (written apart, with the same glide, mass and inertia); with the VLM's
    roll damping L_p alone, birdocp's roll-subsidence root comes within 0.5 % of the VLM's."""
    ref = reference["body_axis_wake"]
    A = lateral_matrix_with(glide, ref["derivatives"], cfg)
    np.testing.assert_allclose(A, np.asarray(ref["lateral_matrix"]), rtol=1e-9, atol=1e-9)
    only_lp = lateral_glide_modes(lateral_matrix_with(glide, {"L_p": ref["derivatives"]["L_p"]}, cfg))
    assert abs(only_lp["roll_subsidence_per_s"] / ref["roll_subsidence_per_s"] - 1) <= 0.005


def test_with_the_span_direction_along_the_elements_the_sideslip_derivatives_are_the_lattices(cfg, glide, reference):
    """The Dutch-roll gap found: the model's 16-element lifting line with every section frame turned to
    its element's node-to-node direction (the line its vortices and the VLM's follow) has the VLM's
    sideslip derivatives L_v and N_v within 5 % (2.7 %, 3.3 %; the paper's model: 23-25 % off). The
    model option ``aero.span_direction = "element"`` is glide_refined's element frames at split 1, to
    round-off (two code paths: the model's data graph and NumPy on the frozen line)."""
    s = glide["state"]
    d = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], 1, "step", "element")
    d.pop("elements")
    option = load_derivatives_at(with_values(cfg, {"aero.span_direction": "element"}), s["u_mps"], s["w_mps"])
    for k, v in option.items():
        assert abs(d[k] - v) <= 1e-10 * max(1.0, abs(v)), (k, d[k], v)
    vlm = reference["body_axis_wake"]["derivatives"]
    for k in ("L_v", "N_v"):
        assert abs(d[k] / vlm[k] - 1) < 0.05, (k, d[k], vlm[k])
        assert abs(glide["derivatives"][k] / vlm[k] - 1) > 0.2
