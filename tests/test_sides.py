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


MASSES = {"wing.mass_kg": 0.086, "tail.opening_angle_deg": 20.0}
RIGHT = {"gait.right_offset.shoulder_flap.amplitude_deg": 6.0, "gait.right_offset.shoulder_sweep.offset_deg": -4.0,
         "gait.left_offset.elbow_flex.offset_deg": 5.0}
LEFT = {"gait.left_offset.shoulder_flap.amplitude_deg": 6.0, "gait.left_offset.shoulder_sweep.offset_deg": -4.0,
        "gait.right_offset.elbow_flex.offset_deg": 5.0}


def test_wing_masses_with_an_asymmetric_gait_conserve_momentum_and_angular_momentum_in_vacuum():
    """Both wings with mass, each on its own joint law (roll, yaw and every product of inertia loaded
    by the wings), no air and no gravity, a tumbling start: the inertial momentum and the angular
    momentum of body plus wings stay constant to RK4 accuracy (~16x smaller per halving of the step)."""
    from birdocp.studies.lateral_checks import vacuum_drift

    r = vacuum_drift(_six(**MASSES, **RIGHT), (50, 100, 200), one_wing=False)
    assert np.abs(r["initial"][3:]).max() > 0.03
    assert r["drift"][-1] < 5e-9
    assert all(12.0 < q < 20.0 for q in r["ratios"]), r["drift"]
    # the same start with the symmetric gait ends elsewhere: the offsets did reach the wing masses
    s = vacuum_drift(_six(**MASSES), (200,), one_wing=False)
    assert np.abs(np.subtract(s["final_state"][-1], r["final_state"][-1])).max() > 1e-3


def test_zero_offsets_with_wing_masses_give_the_symmetric_right_hand_side():
    """Per-side data at zero offsets: the symmetric model's aerodynamic blocks and 3-D wing sums
    (to round-off: the same sums, taken over two evaluations of the wing)."""
    cfg = _six(**MASSES)
    sym, sides = sixdof_model(cfg), sixdof_model(cfg, sides=True)
    p = param_vector(cfg)
    x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7])
    for t in (0.02, 0.13):
        f0 = np.array(sym.rhs(x, sym.data(t, sym.params(p)), sym.params(p))).ravel()
        f1 = np.array(sides.rhs(x, sides.data(t, sides.params(p)), sides.params(p))).ravel()
        np.testing.assert_allclose(f1, f0, rtol=1e-13, atol=1e-12)


def test_swapping_the_wings_mirrors_the_equations_with_wing_masses():
    """With wing masses and tail: the right-hand side of the mirrored gait at the mirrored state is the
    mirrored right-hand side ((v, p, r, phi, psi) and their rates change sign), to round-off."""
    a, b = _six(**MASSES, **RIGHT), _six(**MASSES, **LEFT)
    assert side_vector(b) == swap_sides(side_vector(a))
    six = sixdof_model(a)
    pa, pb = (six.params(param_vector(c), offsets=side_vector(c)) for c in (a, b))
    x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7])
    for t in (0.03, 0.11, 0.19):
        fa = np.array(six.rhs(x, six.data(t, pa), pa)).ravel()
        fb = np.array(six.rhs(FLIP * x, six.data(t, pb), pb)).ravel()
        assert np.abs(fa[[1, 3, 5]]).max() > 0.1  # the gait loads the lateral axes
        np.testing.assert_allclose(fb, FLIP * fa, rtol=1e-12, atol=1e-11)


TURN = {"gait.right_offset.shoulder_flap.amplitude_deg": 1.0, "gait.right_offset.shoulder_sweep.offset_deg": -1.0}
TURN_MIRRORED = {"gait.left_offset.shoulder_flap.amplitude_deg": 1.0, "gait.left_offset.shoulder_sweep.offset_deg": -1.0}


def test_an_asymmetric_cycle_has_its_validity_over_both_wings_and_labelled_modes(coarse):
    """The turn of an asymmetric gait: validity measured per wing in 6-DOF (the mirrored gait swaps
    the two wings' stalled shares and keeps every other measure), and its coupled monodromy's modes
    labelled by eigenvector content (the lateral ones nearly purely lateral at this small asymmetry)."""
    a, b = (lateral_trim(_six(**kv), **coarse) for kv in (TURN, TURN_MIRRORED))
    assert a.success and b.success and not a.symmetric
    va, vb = a.validity.to_dict(), b.validity.to_dict()
    assert va["valid"] is True and va["max_abs_bank_deg"] > 1.0 and va["max_sideslip_deg"] > 0.01
    assert abs(va["stalled_fraction_left"] - va["stalled_fraction_right"]) > 1e-3  # the wings differ
    assert va["stalled_fraction"] == max(va["stalled_fraction_left"], va["stalled_fraction_right"])
    assert abs(va["stalled_fraction_left"] - vb["stalled_fraction_right"]) < 1e-12
    for k in ("alpha_eff_max_deg", "min_forward_speed_mps", "max_airflow_body_angle_deg", "max_sideslip_deg"):
        assert abs(va[k] - vb[k]) < 1e-9, k
    labels = sorted(m["label"] for m in a.lateral_modes)
    assert labels == ["dutch_roll_like", "dutch_roll_like", "roll_subsidence", "spiral"]
    assert all(m["lateral_share"] > 0.9 for m in a.lateral_modes)
    assert len(a.longitudinal_multipliers) == 4 and len(a.multipliers) == 9
    d = a.to_dict()  # one exponent per listed multiplier (the heading's 1 included), in the same order
    mu = np.array([complex(*z) for z in d["floquet_exponents"]])
    assert len(mu) == 9 and np.abs(np.exp(mu[:8] * a.cycle.period) - a.multipliers[:8]).max() < 1e-12
    np.testing.assert_allclose(np.sort_complex(np.concatenate([a.lateral_multipliers, a.longitudinal_multipliers,
                                                               [1.0]])), np.sort_complex(a.multipliers), atol=1e-12)


def _cli(*args):
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", *args, "--json"], capture_output=True, text=True,
                          timeout=300)
    return proc.returncode, (json.loads(proc.stdout) if proc.stdout.strip() else None), proc.stderr


def test_continue_in_a_per_side_offset(tmp_path):
    """``continue`` in one wing's sweep offset from the symmetric gait: the symmetric cycle turns into a
    banked turn (phi grows from round-off), every point has its 6-DOF validity (one stalled share per
    wing) and its multipliers split by eigenvector content; the first point's are the symmetric trim's."""
    key = "gait.right_offset.shoulder_sweep.offset_deg"
    code, r, err = _cli("continue", key, "--from", "0", "--to", "-1", "--points", "3", "--steps", "48",
                        "--max-points", "4", "--set", "model.degrees_of_freedom=6", "--out", str(tmp_path / "c"))
    assert code in (0, 1), err
    pts = r["branch"]["points"]
    assert len(pts) >= 3 and r["degrees_of_freedom"] == 6 and r["parameter"] == key
    assert abs(pts[0]["x0"][6]) < 1e-12 < 1e-3 < abs(pts[-1]["x0"][6])  # bank: none, then a turn
    assert all("stalled_fraction_left" in p["validity"] for p in pts)
    assert len(r["lateral_multipliers"][-1]) == 4 and len(r["longitudinal_multipliers"][-1]) == 4
    sym = lateral_trim(_six(), points=3, steps_per_period=48)
    np.testing.assert_allclose(sorted(abs(complex(*m)) for m in r["lateral_multipliers"][0]),
                               sorted(np.abs(sym.lateral_multipliers)), rtol=0, atol=1e-8)


def test_continue_in_a_per_side_offset_needs_six_degrees_of_freedom(tmp_path):
    code, _, err = _cli("continue", "gait.left_offset.shoulder_flap.amplitude_deg", "--from", "0", "--to", "1",
                        "--out", str(tmp_path / "c"))
    assert code == 2 and "degrees_of_freedom" in err and not (tmp_path / "c").exists()


def test_swapping_the_wings_mirrors_the_solved_cycle_with_wing_masses(coarse):
    """Wing masses on, an asymmetric gait and its mirror image, solved on a coarse grid: the cycles'
    (v, p, r, phi, psi) are opposite and the rest equal along the whole beat, to round-off."""
    heavy = {"wing.mass_kg": 0.086}
    a, b = (lateral_trim(_six(**heavy, **kv), **coarse) for kv in (TURN, TURN_MIRRORED))
    assert a.success and b.success and abs(a.cycle.x0[6]) > 1e-2
    six = sixdof_model(_six(**heavy, **TURN))
    _, Xa = heading_trajectory(six, a.cycle)
    _, Xb = heading_trajectory(six, b.cycle)
    scale = np.abs(Xa).max(axis=0) + 1e-3
    assert np.abs((Xb - Xa * FLIP) / scale).max() < 1e-9
    assert abs(a.heading_change_deg + b.heading_change_deg) < 1e-9
    assert b.validity.to_dict()["stalled_fraction_left"] == pytest.approx(
        a.validity.to_dict()["stalled_fraction_right"], abs=1e-12)


@pytest.mark.slow
def test_sensitivities_of_an_asymmetric_cycle_against_central_differences(coarse):
    """Exact derivatives of the 8 multipliers of a turn (the heading-free ODE, cycle change included)
    with respect to one wing's sweep offset, against central differences of re-solved cycles."""
    from birdocp.studies.lateral_sensitivity import lateral_sensitivities

    cfg = _six(**TURN)
    res = lateral_trim(cfg, **coarse)
    key, h = "gait.right_offset.shoulder_sweep.offset_deg", 1e-3
    (row,) = lateral_sensitivities(res, cfg, [key])
    assert sorted(row["labels"]).count("longitudinal") == 4 and "spiral" in row["labels"]
    plus, minus = (lateral_trim(with_values(cfg, {key: -1.0 + s * h}), warm_start=res, **coarse) for s in (1, -1))
    cd = (np.abs(plus.cycle.multipliers) - np.abs(minus.cycle.multipliers)) / (2 * h)
    np.testing.assert_allclose(row["d_moduli"], cd, rtol=0, atol=1e-6)
    assert np.abs(cd).max() > 1e-2
