"""The six-degree-of-freedom simulation with aerodynamic states (birdocp.studies.lateral_simulate with
``aero.unsteady = "wagner"`` and ``aero.section = "dynamic-stall"``), and the mirror symmetry of their
cycles.

Checks against a second method or an exact property: with a vertical or horizontal gust on a symmetric
state the 6-DOF Wagner simulation is the planar Wagner simulation (an independent stepper whose added
mass sees the wind's rate) to round-off; unperturbed, it stays on the trimmed cycle (the trim's
residual); a small roll-rate perturbation grows over the first beat as the cycle's monodromy (the
engine's exact sensitivities) predicts, to second order; a side gust from the left on an asymmetric gait
and from the right on the mirrored gait give mirrored histories ((v, p, r, phi, psi) and the east drift
change sign, element j's aerodynamic states trade places with element 15 - j's); swapping the left and
right gaits mirrors the solved cycle along the whole beat, aerodynamic states included.
"""
from __future__ import annotations

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.bird.sixdof import HEADING, LATERAL, LONGITUDINAL, embed_planar_state, sixdof_model
from birdocp.cli.main import main
from birdocp.studies.lateral import heading_trajectory, lateral_trim
from birdocp.studies.lateral_aero import mirror_state
from birdocp.studies.lateral_control import sides_parameter_vector, sides_parameters
from birdocp.studies.lateral_simulate import SideGust, simulate_lateral
from birdocp.studies.simulate import Gust, simulate

STEPS = 48
WAGNER = {"aero.unsteady": "wagner"}
DYN = {"aero.section": "dynamic-stall"}
RIGHT = {"gait.right_offset.shoulder_flap.amplitude_deg": 1.0, "gait.right_offset.shoulder_sweep.offset_deg": -1.0}
LEFT = {"gait.left_offset.shoulder_flap.amplitude_deg": 1.0, "gait.left_offset.shoulder_sweep.offset_deg": -1.0}
FLIP = np.array([1, -1, 1, -1, 1, -1, -1, 1, -1.0])  # (v, p, r, phi, psi) change sign


def _six(**extra):
    return with_values(Config(), {"model.degrees_of_freedom": 6, **extra})


def _pair(section):
    """The asymmetric gait and its mirror image, trimmed (3 points, 48 RK4 steps)."""
    out = []
    for side in (RIGHT, LEFT):
        cfg = _six(**section, **side)
        res = lateral_trim(cfg, points=3, steps_per_period=STEPS)
        assert res.success and not res.symmetric
        out.append((cfg, res))
    return out


@pytest.fixture(scope="module")
def wagner_pair():
    return _pair(WAGNER)


def _full(sim) -> np.ndarray:
    return np.hstack([sim.states, sim.aero_states])


@pytest.mark.slow
def test_a_gust_on_a_symmetric_state_is_the_planar_wagner_simulation():
    """The planar stepper (its own wind-rate term, birdocp.bird.layout.air_wind_rate) and the 6-DOF one
    agree to round-off with vertical and horizontal gusts; without the wind's rate in the 6-DOF added mass
    they differ by ~10 % of the state's range (the term is exercised)."""
    c4 = with_values(Config(), {**WAGNER, "validity.max_stalled_fraction": 0.5})
    c6 = with_values(c4, {"model.degrees_of_freedom": 6})
    x4 = c4.solve.initial_guess
    for gust in (Gust("vertical", 3.0, 0.5, None, 0.2), Gust("horizontal", -3.0, 0.5, None, 0.2)):
        planar = simulate(c4, x4, 1, steps_per_period=STEPS, gusts=[gust])
        six = simulate_lateral(c6, embed_planar_state(x4), sides_parameter_vector(c6), 1, steps_per_period=STEPS,
                               gusts=[gust])
        assert planar.success and six.success and len(six.states) == STEPS + 1
        scale = np.abs(planar.states).max(axis=0)
        assert np.abs((six.states[:, list(LONGITUDINAL)] - planar.states) / scale).max() < 1e-12
        assert np.abs(six.states[:, list(LATERAL)]).max() < 1e-12
        assert np.ptp(six.aero_states[:, 0]) > 0.1  # the lag states move with the gust


@pytest.mark.slow
def test_wagner_simulation_stays_on_the_cycle_and_a_roll_perturbation_grows_as_the_monodromy(wagner_pair):
    (cfg, res), _ = wagner_pair
    c, p = res.cycle, sides_parameters(res.cycle.p)
    sim = simulate_lateral(cfg, c.x0, p, 3, steps_per_period=STEPS)
    assert sim.success and sim.aero_states.shape == (3 * STEPS + 1, 32)
    assert sim.deviation_per_beat[1:].max() < 1e-9  # the trim's residual, carried 3 beats
    x_end = np.delete(_full(sim)[-1], HEADING)  # lag states back on the cycle too
    assert np.abs(x_end - np.asarray(c.x0)).max() < 1e-9
    M = np.asarray(c.monodromy)  # 8 body states (heading excluded) then the 32 lag states
    dx = np.zeros(9)
    dx[3] = 1e-3  # roll rate [rad/s]
    one = simulate_lateral(cfg, c.x0, p, 1, steps_per_period=STEPS, perturbation=dx)
    d0, d1 = (np.delete(_full(one)[k], HEADING) - np.asarray(c.x0) for k in (0, -1))
    predicted = M @ d0
    assert np.linalg.norm(d1 - predicted) < 1e-4 * np.linalg.norm(predicted)
    assert np.abs(predicted[8:]).max() > 1e-2 * np.abs(predicted[:8]).max()  # the lag states respond


@pytest.mark.slow
def test_side_gusts_from_left_and_right_on_mirrored_gaits_give_mirrored_histories(wagner_pair):
    (ca_, ra), (cb, rb) = wagner_pair
    a = simulate_lateral(ca_, ra.cycle.x0, sides_parameters(ra.cycle.p), 2, steps_per_period=STEPS,
                         side_gust=SideGust(2.0, 0.5, 0.5), gusts=[Gust("vertical", 1.0, 1.0)])
    b = simulate_lateral(cb, rb.cycle.x0, sides_parameters(rb.cycle.p), 2, steps_per_period=STEPS,
                         side_gust=SideGust(-2.0, 0.5, 0.5), gusts=[Gust("vertical", 1.0, 1.0)])
    assert a.success and b.success
    Xa, Xb = _full(a), _full(b)
    assert np.abs(Xa[:, [1, 3, 5, 6]]).max() > 0.1  # the gust does roll and slip the bird
    mirrored = np.array([mirror_state(x, 9, FLIP) for x in Xa])
    scale = np.abs(Xa).max(axis=0) + 1e-3
    assert np.abs((Xb - mirrored) / scale).max() < 1e-10
    np.testing.assert_allclose(b.position_m * [1, -1, 1], a.position_m, rtol=0, atol=1e-9)


def _mirrored_cycles(pair):
    (ca_, ra), (cb, rb) = pair
    _, Xa = heading_trajectory(sixdof_model(ca_), ra.cycle)
    _, Xb = heading_trajectory(sixdof_model(cb), rb.cycle)
    assert Xa.shape[1] > 9 and np.abs(Xa[:, list(LATERAL)]).max() > 1e-2  # a banked turn with aerodynamic states
    scale = np.abs(Xa).max(axis=0) + 1e-3
    return np.abs((Xb - np.array([mirror_state(x, 9, FLIP) for x in Xa])) / scale).max()


@pytest.mark.slow
def test_swapping_the_gaits_mirrors_the_wagner_cycle(wagner_pair):
    assert _mirrored_cycles(wagner_pair) < 1e-9
    (_, ra), (_, rb) = wagner_pair
    np.testing.assert_allclose(np.sort(np.abs(ra.multipliers)), np.sort(np.abs(rb.multipliers)), rtol=0, atol=1e-8)


@pytest.mark.slow
def test_swapping_the_gaits_mirrors_the_dynamic_stall_cycle():
    assert _mirrored_cycles(_pair(DYN)) < 1e-9


def test_simulate_cli_six_dof_with_wagner_runs_and_writes_the_lag_states(wagner_pair, tmp_path, monkeypatch, capsys):
    import json

    monkeypatch.chdir(tmp_path)
    sets = [a for k, v in {**WAGNER, **RIGHT, "solve.points": 3, "solve.steps_per_period": STEPS}.items()
            for a in ("--set", f"{k}={v}")]
    code = main(["simulate", "--beats", "2", "--side-gust", "pulse=1:0.5", "--perturb", "p=0.1",
                 "--set", "model.degrees_of_freedom=6", *sets, "--json", "--out", "s"])
    assert code == 0
    r = json.loads(capsys.readouterr().out)
    assert r["success"] and r["degrees_of_freedom"] == 6 and len(r["aero_state_names"]) == 32
    assert np.load(tmp_path / "s" / "arrays.npz")["aero_states"].shape == (2 * STEPS + 1, 32)


@pytest.mark.slow
def test_the_6dof_quasi_steady_manifold_and_its_slope(wagner_pair):
    """complete_state6 completes a body state with the lag states the full state would have on the
    manifold; manifold_slopes6 is its derivative over the 8 body states (central differences, 1e-6
    relative) at an asymmetric state, where the lateral columns act."""
    from birdocp.studies.lateral_simulate_aero import complete_state6, manifold_slopes6

    (cfg, res), _ = wagner_pair
    six, p = sixdof_model(cfg, sides=True), sides_parameters(res.cycle.p)
    x9 = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.0])
    full = complete_state6(six, x9, p, 0.03)
    assert full.shape == (41,) and np.array_equal(complete_state6(six, full, p), full)
    np.testing.assert_array_equal(complete_state6(six, np.delete(x9, HEADING), p, 0.03), full)
    S = manifold_slopes6(six, [np.delete(full, HEADING)], [0.03], p)[0]
    h, fd = 1e-6, np.zeros_like(S)
    for j in range(8):
        e = np.zeros(9)
        e[j if j < HEADING else j + 1] = h
        fd[:, j] = (complete_state6(six, x9 + e, p, 0.03)[9:] - complete_state6(six, x9 - e, p, 0.03)[9:]) / (2 * h)
    assert np.abs(S - fd).max() < 1e-6 * np.abs(S).max()
    assert np.abs(S[:, list(LATERAL)]).max() > 1e-2 * np.abs(S).max()


def test_a_diverging_run_keeps_its_states_up_to_the_last_one_in_range(wagner_pair):
    (cfg, res), _ = wagner_pair
    dx = np.zeros(9)
    dx[5] = 900.0  # yaw rate [rad/s], within the model's range at the start
    sim = simulate_lateral(cfg, res.cycle.x0, sides_parameters(res.cycle.p), 2, steps_per_period=STEPS,
                           perturbation=dx)
    assert sim.status == "diverged" and sim.diverged_beat == 1
    assert 1 <= len(sim.states) < STEPS + 1 and np.all(np.isfinite(sim.states)) and np.all(np.isfinite(sim.aero_states))
    assert sim.to_dict()["max_abs_bank_deg"] is not None
