"""The six-degree-of-freedom simulation (birdocp.studies.lateral_simulate) against the planar one: a
vertical gust on a symmetric cycle keeps the flight in the plane of symmetry, so the 6-DOF histories
are the planar simulation's (an independent integrator, stepper and validity code) to round-off,
stall check included; asymmetric flight is checked per wing."""
from __future__ import annotations

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL
from birdocp.studies.lateral import lateral_trim
from birdocp.studies.lateral_control import sides_parameters
from birdocp.studies.lateral_simulate import SideGust, simulate_lateral
from birdocp.studies.simulate import Gust, simulate

STEPS = 48


@pytest.fixture(scope="module")
def cycle6():
    cfg = with_values(Config(), {"model.degrees_of_freedom": 6})
    res = lateral_trim(cfg, points=3, steps_per_period=STEPS)
    assert res.success
    return cfg, res


def test_a_vertical_gust_in_six_dof_is_the_planar_simulation(cycle6):
    cfg6, res = cycle6
    x0 = np.asarray(res.cycle.x0)
    gust = Gust("vertical", 3.0, 1.0)
    six = simulate_lateral(cfg6, x0, sides_parameters(res.cycle.p), 3, steps_per_period=STEPS, gusts=[gust])
    cfg4 = Config()
    planar = simulate(cfg4, x0[list(LONGITUDINAL)], 3, steps_per_period=STEPS, gusts=[gust])
    assert six.success and planar.success
    scale = np.abs(planar.states).max(axis=0)
    assert np.abs((six.states[:, list(LONGITUDINAL)] - planar.states) / scale).max() < 1e-9
    assert np.abs(six.states[:, list(LATERAL)]).max() < 1e-12
    assert six.gusts[0]["start_m"] == pytest.approx(planar.gust_spans_m[0]["start_m"], rel=1e-9)
    assert planar.max_stalled_fraction > 0.02  # the gust does stall part of the wing
    assert six.max_stalled_fraction == pytest.approx(planar.max_stalled_fraction, abs=1e-9)
    assert six.to_dict()["stall_fraction_checked"] is True


def test_a_strong_gust_stops_the_six_dof_simulation_at_the_stall_of_one_wing(cycle6):
    """A side gust and an up gust: one wing stalls more than the other; the run stops in the beat where a
    wing's stalled share crosses validity.max_stalled_fraction, naming the wing."""
    cfg6, res = cycle6
    cfg = with_values(cfg6, {"validity.max_stalled_fraction": 0.04})
    sim = simulate_lateral(cfg, res.cycle.x0, sides_parameters(res.cycle.p), 3, steps_per_period=STEPS,
                           gusts=[Gust("vertical", 3.0, 1.0)], side_gust=SideGust(3.0, 1.0, 1.0))
    assert sim.status == "left_validity" and "wing's span-time area beyond the stall angle" in sim.message
    assert sim.max_stalled_fraction > 0.04
    assert len(sim.states) < 3 * STEPS + 1  # stopped before the end


def test_simulate_cli_with_a_vertical_gust_in_six_dof(tmp_path):
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", "simulate", "--beats", "2", "--gust", "vertical=2:1",
                           "--wind", "horizontal=-1", "--set", "model.degrees_of_freedom=6", "--set", "solve.points=3",
                           "--set", f"solve.steps_per_period={STEPS}", "--out", str(tmp_path / "s"), "--json"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["success"] and r["degrees_of_freedom"] == 6 and r["stall_fraction_checked"] is True
    assert r["gusts"][0]["direction"] == "vertical" and r["wind_mps"] == [-1.0, 0.0]
    assert 0 < r["max_stalled_fraction_per_beat"] < 1 and r["peak_deviation"] > 0.1
