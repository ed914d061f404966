"""The gait optimisers with an asymmetric gait in six degrees of freedom: the level turn's reduced NLP
(:mod:`birdocp.studies.turn_cycle`) against central differences, an independent 6-DOF trim and, with the
per-side offsets at 0, the symmetric optimiser's NLP; the refusals of what is not written."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from birdocp.bird.config import Config, ConfigError, get_value, with_values

SIX = {"model.degrees_of_freedom": 6}
KEYS = ["gait.shoulder_sweep.offset_deg", "gait.shoulder_incidence.offset_deg"]
RIGHT = "gait.right_offset.shoulder_sweep.offset_deg"
N = 12


def _problem(cfg, keys, turn=None, valid=None):
    from birdocp.studies.gait_problem import ReducedProblem
    from birdocp.studies.lateral_optimize import reduced_level_cycle

    rc = reduced_level_cycle(cfg, keys, steps_per_period=N, second_order=True, valid=valid is not None)
    prob = ReducedProblem(rc, "stability", None, None, (20.0, 70.0), valid, turn)
    return rc, prob, np.array([float(get_value(cfg, k)) for k in keys])


@pytest.fixture(scope="module")
def turn_problem():
    cfg = with_values(Config(), SIX | {RIGHT: -2.0})
    return _problem(cfg, KEYS[:1] + [RIGHT], turn=-3.0)


def test_turn_nlp_jacobian_against_central_differences(turn_problem):
    """Every row of the turn's reduced NLP (amplitude, heading change per beat, the Jury rows of both
    invariant blocks of the 8 x 8 monodromy) has the exact derivative: central differences agree."""
    rc, prob, theta = turn_problem
    assert type(rc).__name__ == "TurnLevelCycle"
    assert prob.names[:2] == ["amplitude_deg", "heading_change_deg"] and prob.ng == 1 + 2 + 10
    ev = rc.evaluate(theta)
    z = np.append(theta, 1.1 * float(np.max(np.abs(ev.multipliers))))
    G, J = prob.both(z)
    assert G[2] == pytest.approx(ev.means["turn_rate_degps"] * rc.T) and abs(G[2]) > 0.3
    h = 1e-5
    for c in range(len(theta)):
        e = np.zeros(len(z))
        e[c] = h
        fd = (prob.both(z + e, grads=False)[0] - prob.both(z - e, grads=False)[0]) / (2 * h)
        np.testing.assert_allclose(J[1:, c], fd[1:], rtol=1e-5, atol=1e-7 * np.max(np.abs(J[1:])))
    assert np.max(np.abs(J[3:, 1])) > 1e-3  # the per-side offset moves the Jury rows of the turn


def test_turn_cycle_is_an_independent_trims(turn_problem):
    """The turn's 8 multipliers and heading change per beat are those of a 6-DOF trim from scratch (multiple
    shooting, configured initial guess) at the same gait and amplitude."""
    from birdocp.engine.floquet import matched_distances
    from birdocp.studies.lateral import lateral_trim

    rc, prob, theta = turn_problem
    ev = rc.evaluate(theta)
    tr = lateral_trim(with_values(rc.cfg, {"gait.shoulder_flap.amplitude_deg": ev.amplitude_deg}),
                      steps_per_period=N, points=3)
    assert tr.success and not tr.symmetric
    assert np.max(matched_distances(tr.cycle.multipliers, ev.multipliers)) < 1e-8
    assert tr.heading_change_deg == pytest.approx(ev.means["turn_rate_degps"] * rc.T, abs=1e-9)
    split = rc.multiplier_split(ev)
    assert split["heading_change_deg"] == pytest.approx(tr.heading_change_deg, abs=1e-9)
    lat = [complex(*p) for p in split["lateral_multipliers"]]
    assert np.max(matched_distances(lat, tr.lateral_multipliers)) < 1e-8
    blocks = rc.stability_blocks(ev)  # the two invariant blocks hold the eight multipliers
    lam = np.concatenate([np.linalg.eigvals(B) for B, _ in blocks])
    assert np.max(matched_distances(lam, ev.multipliers)) < 1e-9


def _symmetric_jury_rows(rc0, ev, r):
    """The Jury rows (values, theta and r derivatives) that the turn's grouping gives on the symmetric
    cycle's own monodromy: its longitudinal and lateral blocks (and their derivatives) put into the
    8 x 8 heading-free monodromy, block-diagonal, then :func:`turn_blocks` and the Jury conditions."""
    from birdocp.bird.sixdof import LATERAL, LONGITUDINAL
    from birdocp.studies.jury import jury_function, jury_values
    from birdocp.studies.turn_cycle import turn_blocks

    (Mlon, dlon), (Mlat, dlat) = rc0.stability_blocks(ev)
    M, dM = np.zeros((8, 8)), np.zeros((64, dlon.shape[1]))
    for idx, B, dB in ((LONGITUDINAL, Mlon, dlon), (LATERAL, Mlat, dlat)):
        M[np.ix_(idx, idx)] = B
        for c in range(dB.shape[1]):
            d = np.zeros((8, 8))
            d[np.ix_(idx, idx)] = dB[:, c].reshape(4, 4, order="F")
            dM[:, c] += d.ravel(order="F")
    rows = [jury_values(jury_function(), B, r, dB) for B, dB in turn_blocks(M, dM, rc0.T, ev.means["forward_speed_mps"])]
    return (np.concatenate([v for v, _, _ in rows]), np.vstack([d for _, d, _ in rows]),
            np.concatenate([dr for _, _, dr in rows]))


@pytest.mark.slow
def test_symmetric_limit_is_the_symmetric_nlp():
    """With the per-side offsets at 0 the turn's NLP (a per-side offset free) is the symmetric
    optimiser's: the same values and derivatives of every shared row (amplitude, smooth validity), and
    Jury rows equal to those of the symmetric cycle's longitudinal and lateral blocks (and derivatives),
    grouped as a turn groups its 8 x 8 monodromy. Mirror symmetry: a right offset is half the symmetric
    offset plus half an antisymmetric one, along which every mirror-invariant row is stationary, so its
    derivatives are half the symmetric key's; the heading change moves along it."""
    from birdocp.bird.validity_smooth import limit_bounds

    cfg = with_values(Config(), SIX)
    valid = limit_bounds(cfg)
    rc0, p0, th0 = _problem(cfg, KEYS, valid=valid)
    rc1, p1, th1 = _problem(cfg, KEYS + [RIGHT], turn=0.0, valid=valid)
    assert type(rc0).__name__ == "LateralLevelCycle" and type(rc1).__name__ == "TurnLevelCycle"
    ev = rc0.evaluate(th0)
    r = 1.1 * float(np.max(np.abs(ev.multipliers)))
    G0, J0 = p0.both(np.append(th0, r))
    G1, J1 = p1.both(np.append(th1, r) * p1.sigma)
    J1 = J1 * p1.sigma  # per unit of each key
    names1 = ["f"] + p1.names
    jury1 = [i for i, n in enumerate(names1) if n.startswith("jury")]
    other1 = [i for i, n in enumerate(names1) if n != "heading_change_deg" and i not in jury1]
    other0 = [i for i, n in enumerate(["f"] + p0.names) if not n.startswith("jury")]
    np.testing.assert_allclose(G1[other1], G0[other0], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(J1[other1][:, [0, 1, 3]], J0[other0], rtol=1e-6, atol=1e-8 * np.max(np.abs(J0)))
    jv, jt, jr = _symmetric_jury_rows(rc0, ev, r)
    np.testing.assert_allclose(G1[jury1], jv, rtol=1e-7, atol=1e-9)
    scale = np.max(np.abs(jt))
    np.testing.assert_allclose(J1[jury1][:, [0, 1]], jt, rtol=1e-6, atol=1e-8 * scale)
    np.testing.assert_allclose(J1[jury1][:, 3], jr, rtol=1e-6, atol=1e-8 * np.max(np.abs(jr)))
    rows1 = [i for i, n in enumerate(names1) if n != "heading_change_deg"]
    np.testing.assert_allclose(J1[rows1][:, 2], 0.5 * J1[rows1][:, 0], rtol=1e-6, atol=1e-8 * np.max(np.abs(J0)))
    assert abs(J1[2, 2]) > 0.1  # degrees of heading change per beat per degree of offset


@pytest.mark.parametrize("argv, field", [
    (["optimize-stability", "--turn-rate", "5"], "--turn-rate"),
    (["optimize-stability", "--free", RIGHT, "--bounds", f"{RIGHT}=-5:5"], RIGHT),
    (["optimize-gait", "--speed", "17", "--set", "model.degrees_of_freedom=6", "--set",
      "gait.left_offset.shoulder_sweep.offset_deg=-1", "--set", "aero.unsteady=wagner"], "aero.unsteady"),
    (["optimize-stability", "--set", "model.degrees_of_freedom=6", "--turn-rate", "nan"], "--turn-rate"),
])
def test_turn_refusals_one_line_exit_2(tmp_path, argv, field):
    """What a turn cannot take is refused before any computation: one line naming the field, exit 2,
    nothing written."""
    proc = subprocess.run([sys.executable, "-m", "birdocp", *argv, "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and not (tmp_path / "run").exists(), proc.stderr
    assert field in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_turn_power_objective_refused():
    """A power objective takes a turn (tests/test_sixdof_power.py), also with wing masses, except where the
    per-wing power is not written: Wagner's added mass."""
    from birdocp.studies.turn_cycle import check_turn

    cfg = with_values(Config(), SIX | {RIGHT: 1.0})
    check_turn(cfg, "power", None, True)
    check_turn(with_values(cfg, {"wing.mass_kg": 0.086}), "power", None, True)
    wagner = with_values(cfg, {"aero.unsteady": "wagner"})
    with pytest.raises(ConfigError, match="power"):
        check_turn(wagner, "power", None, True)
    check_turn(wagner, "stability", 5.0, True)  # the stability objective takes it


@pytest.mark.slow
def test_optimize_stability_turn_json_keys(tmp_path, capfd, monkeypatch):
    """A tiny turn through the CLI: one JSON object with the turn rate, the split and the 6-DOF trim's check."""
    from birdocp.cli import main as cli

    monkeypatch.chdir(tmp_path)
    code = cli.main(["optimize-stability", "--set", "model.degrees_of_freedom=6", "--set", f"solve.steps_per_period={N}",
                     "--free", KEYS[0], "--free", RIGHT, "--bounds", f"{RIGHT}=-5:5", "--turn-rate", "-2",
                     "--max-iter", "2", "--out", "run", "--json", "--quiet"])
    assert code in (0, 1)
    d = json.loads(capfd.readouterr().out)
    for k in ("turn_rate_degps", "heading_change_deg", "symmetric", "longitudinal_radius", "lateral_radius",
              "lateral_modes", "multipliers", "radius", "validity", "verification"):
        assert k in d, k
    assert d["symmetric"] is False and len(d["multipliers"]) == 8
    assert d["verification"]["trim_success"] and d["verification"]["max_multiplier_difference"] < 1e-8


def test_turn_stages_continue_from_the_straight_optimum():
    """The continuation in the turn rate: the straight optimum without the per-side keys first, then the
    turn rate in equal steps to its target on the first grid, then the finer grids at the target."""
    from birdocp.studies.turn_cycle import turn_stages

    free = {KEYS[0]: (-30.0, -5.0), RIGHT: (-5.0, 5.0)}
    assert turn_stages([32], free, 5.0, 0) == [(32, 5.0, free)]
    assert turn_stages([32, 48], free, None, 3) == [(32, None, free), (48, None, free)]
    st = turn_stages([24, 48], free, 5.0, 2)
    assert [(n, t) for n, t, _ in st] == [(24, None), (24, 2.5), (24, 5.0), (48, 5.0)]
    assert list(st[0][2]) == [KEYS[0]] and all(list(f) == list(free) for _, _, f in st[1:])


def test_turn_progress_one_line_per_point(turn_problem):
    """IPOPT asks for the derivatives several times at each iterate (objective gradient, constraint
    Jacobian, Hessian): the progress line is written once per new point."""
    rc, prob, theta = turn_problem
    lines = []
    prob.progress = lines.append
    try:
        z = np.append(theta, 1.2) * prob.sigma
        for _ in range(3):
            prob.jacobian(z)
        assert len(lines) == 1 and "heading change" in lines[0]
        prob.jacobian(z * (1 + 1e-7))
        assert len(lines) == 2
    finally:
        prob.progress = None
