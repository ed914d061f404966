"""The gliding limit against an independent vortex-lattice model: birdocp's lateral roots of the frozen
wing's steady glide, computed here, against AeroSandbox's committed numbers
(results/lateral/glide/aerosandbox.json, made offline by scripts/reference_aerosandbox from the
geometry birdocp exported: results/lateral/glide/geometry.json)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from birdocp.studies.glide import glide_geometry, load_derivatives_at, steady_glide

FOLDER = Path(__file__).resolve().parents[1] / "results" / "lateral" / "glide"


@pytest.fixture(scope="module")
def glide():
    g = steady_glide()
    assert g["success"] and g["residual"] < 1e-10
    return g


@pytest.fixture(scope="module")
def reference():
    return json.loads((FOLDER / "aerosandbox.json").read_text())


def test_the_reference_is_of_the_geometry_birdocp_builds(glide):
    """The committed geometry (AeroSandbox's input) is the frozen lifting line and glide of today's code."""
    committed = json.loads((FOLDER / "geometry.json").read_text())
    now = glide_geometry(glide=glide)
    for key in ("nodes_m", "centres_m", "chords_m", "chord_directions", "lengths_m"):
        np.testing.assert_allclose(np.asarray(now[key]), np.asarray(committed[key]), rtol=0, atol=1e-9)
    for key in ("u_mps", "w_mps", "theta_rad"):
        assert abs(now["glide_state"][key] - committed["glide_state"][key]) < 1e-9


def test_dutch_roll_frequency_within_five_percent_of_the_vortex_lattice(glide, reference):
    ours = glide["dutch_roll"]["frequency_radps"]
    ref = reference["body_axis_wake"]["dutch_roll"]["frequency_radps"]
    assert abs(ours - ref) <= 0.05 * ref, (ours, ref)


@pytest.mark.xfail(strict=True, reason="known: at the glide the sections fly at ~36 deg, where the lifting line's "
                   "lift linear in the angle has a slope 1/cos(36 deg) above the vortex lattice's (linear in its "
                   "sine): roll damping 28 % higher, roll subsidence 35 % faster (docs/studies/lateral.md)")
def test_roll_subsidence_within_five_percent_of_the_vortex_lattice(glide, reference):
    ours = glide["roll_subsidence_per_s"]
    ref = reference["body_axis_wake"]["roll_subsidence_per_s"]
    assert abs(ours - ref) <= 0.05 * abs(ref), (ours, ref)


def test_roll_damping_agrees_at_a_small_section_angle(reference):
    """The explanation of the roll-subsidence gap: at a small section angle of attack (where the two
    section laws agree) birdocp's roll damping L_p is within 10 % of the vortex lattice's, while at the
    glide (section angle ~36 deg) it is 20-35 % above."""
    st = reference["body_axis_wake"]["check_states"][0]
    ours = load_derivatives_at(None, st["u_mps"], st["w_mps"])["L_p"]
    ref = st["derivatives"]["L_p"]
    assert ours < 0 and ref < 0
    assert abs(ours - ref) <= 0.10 * abs(ref), (ours, ref)
    at_glide = reference["body_axis_wake"]["derivatives"]["L_p"]
    ours_glide = load_derivatives_at(None, reference["glide_state"]["u_mps"], reference["glide_state"]["w_mps"])["L_p"]
    assert 1.2 < ours_glide / at_glide < 1.35


def test_the_two_rigid_body_linearisations_agree_and_roll_damping_explains_the_gap(glide, reference):
    """birdocp's exact lateral matrix with all nine load derivatives replaced by the VLM's is the VLM
    script's own lateral matrix (written apart, with the same glide, mass and inertia); with the VLM's
    roll damping L_p alone, birdocp's roll-subsidence root comes within 5 % of the VLM's."""
    from birdocp.studies.glide import lateral_glide_modes, lateral_matrix_with

    ref = reference["body_axis_wake"]
    A = lateral_matrix_with(glide, ref["derivatives"])
    np.testing.assert_allclose(A, np.asarray(ref["lateral_matrix"]), rtol=1e-9, atol=1e-9)
    only_lp = lateral_glide_modes(lateral_matrix_with(glide, {"L_p": ref["derivatives"]["L_p"]}))
    assert abs(only_lp["roll_subsidence_per_s"] - ref["roll_subsidence_per_s"]) <= 0.05 * abs(ref["roll_subsidence_per_s"])
