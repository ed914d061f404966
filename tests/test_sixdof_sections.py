"""The stall-aware section in six degrees of freedom (birdocp.bird.sixdof.SectionLaw): the planar model's
section law (birdocp.bird.unsteady.section_loads, one implementation) over both wings in the asymmetric
flow. Exact properties: at a symmetric state the 6-DOF right-hand side is the planar stall model's, a
symmetric gait's 6-DOF stall cycle is the planar stall cycle with a block-diagonal monodromy, and swapping
the per-side offsets mirrors the equations."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from birdocp.bird.config import Config, param_vector, with_values
from birdocp.bird.model import get_model
from birdocp.bird.sides import side_vector, swap_sides
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL, embed_planar_state, sixdof_model

STALL = {"aero.section": "stall"}
MIRROR = np.array([1, -1, 1, -1, 1, -1, -1, 1, -1.0])  # (v, p, r, phi, psi) change sign
TURN = {"gait.right_offset.shoulder_flap.amplitude_deg": 6.0, "gait.right_offset.shoulder_sweep.offset_deg": -4.0,
        "gait.left_offset.elbow_flex.offset_deg": 5.0}


def _six(**extra):
    return with_values(Config(), {"model.degrees_of_freedom": 6, **STALL, **extra})


@pytest.mark.slow
def test_stall_section_at_a_symmetric_state_is_the_planar_stall_model(default_model):
    """Same section law, same data: the longitudinal rows equal the planar stall model's right-hand side
    and the lateral ones vanish to round-off; the swapped per-side offsets mirror the equations (elements
    j and 15 - j exchange) at an asymmetric state with a stalled wing."""
    cfg = _six()
    six, planar = sixdof_model(cfg), get_model(with_values(Config(), STALL))
    assert six.section is not None and six.section.section == "stall" and six.ode.nx == 9
    p = param_vector(cfg)
    for t in (0.0, 0.07, 0.17):
        d = planar.data(t, p)
        x4 = [18.1, -1.3, 0.4, -0.1]
        f6 = np.array(six.rhs(embed_planar_state(x4), d, six.params(p))).ravel()
        f4 = np.array(planar.rhs(x4, d, p)).ravel()
        np.testing.assert_allclose(f6[list(LONGITUDINAL)], f4, rtol=0, atol=1e-12)
        assert np.abs(f6[list(LATERAL)]).max() < 1e-12
        f_lin = np.array(default_model.rhs(x4, default_model.data(t, p), p)).ravel()
        assert np.abs(f4 - f_lin).max() > 1e-3  # the stall section does act here
    turn = _six(**TURN)
    sides = sixdof_model(turn)
    assert sides.sides and sides.section is not None
    off = side_vector(turn)
    pa, pb = sides.params(p, offsets=off), sides.params(p, offsets=swap_sides(off))
    x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7])
    for t in (0.02, 0.13):
        f = np.array(sides.rhs(x, sides.data(t, pa), pa)).ravel()
        fm = np.array(sides.rhs(MIRROR * x, sides.data(t, pb), pb)).ravel()
        np.testing.assert_allclose(fm, MIRROR * f, rtol=0, atol=1e-12 * np.abs(f).max())
        assert np.abs(f[list(LATERAL)]).max() > 1e-2  # the asymmetric gait does load the lateral states


@pytest.mark.slow
def test_stall_cycle_of_a_symmetric_gait_is_the_planar_stall_cycle_through_the_cli(tmp_path):
    """``birdocp trim`` with 6 DOF and the stall section against the planar stall trim: the same x0 and
    multipliers to 1e-9, a block-diagonal monodromy (coupling below 1e-12), the heading's 1."""
    from birdocp.studies.trim import trim

    proc = subprocess.run([sys.executable, "-m", "birdocp", "trim", "--set", "model.degrees_of_freedom=6", "--set",
                           "aero.section=stall", "--set", "solve.points=3", "--set", "solve.steps_per_period=48",
                           "--out", str(tmp_path / "t"), "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    planar = trim(with_values(Config(), STALL), points=3, steps_per_period=48)
    assert r["success"] and planar.success
    x0 = np.asarray(r["x0"])
    np.testing.assert_allclose(x0[list(LONGITUDINAL)], planar.x0, rtol=0, atol=1e-9)
    assert np.abs(x0[list(LATERAL)]).max() < 1e-9 and r["coupling_max"] < 1e-12
    lon = np.sort_complex([complex(*z) for z in r["longitudinal_multipliers"]])
    np.testing.assert_allclose(lon, np.sort_complex(planar.multipliers), rtol=0, atol=1e-9)
    assert abs(r["heading_multiplier"] - 1) < 1e-12 and len(r["lateral_multipliers"]) == 4
    assert r["validity"]["max_newton_residual"] < 1e-10  # the stall circulation solved on the cycle
