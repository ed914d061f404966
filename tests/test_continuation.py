"""Pseudo-arclength continuation: exact special points on constructed forced systems, a short bird branch."""

import pytest
import json
import math

import casadi as ca
import numpy as np

from birdocp.engine.continuation import Branch, continuation
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE

T = 1.0


def _ode(expr_fn, nx, name):
    x = ca.SX.sym("x", nx)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    f = ca.Function(name, [x, t, p], [expr_fn(x, t, p[0])])
    return ODE.from_rhs(f, T, tuple(f"x{i}" for i in range(nx)), ("lam",))


def fold_ode():
    """x' = (1 + y/2)(lam - x^2), y' = -y + sin(2 pi t): the cycles (+-sqrt(lam), y*(t)) fold at lam = 0
    exactly, also for the RK4 discretisation (RK4 keeps x = +-sqrt(lam) fixed); multiplier of the x
    part exp(-+2 sqrt(lam) int(1 + y/2)) crosses +1 there."""
    return _ode(lambda x, t, lam: ca.vertcat((1 + 0.5 * x[1]) * (lam - x[0] ** 2),
                                              -x[1] + ca.sin(2 * np.pi * t / T)), 2, "fold")


def pd_ode():
    """x' = (pi/T) J x + R(pi t/T) diag(lam, -1) R^T x + forcing: multipliers -exp(lam T), -exp(-T)
    (half a turn per period), so a real multiplier crosses -1 at lam = 0 (up to the RK4 error)."""
    def f(x, t, lam):
        th = np.pi * t / T
        R = ca.vertcat(ca.horzcat(ca.cos(th), -ca.sin(th)), ca.horzcat(ca.sin(th), ca.cos(th)))
        Jm = ca.DM([[0, -1], [1, 0]])
        A = np.pi / T * Jm + R @ ca.diag(ca.vertcat(lam, -1)) @ R.T
        return A @ x + ca.vertcat(ca.sin(2 * np.pi * t / T), 0)
    return _ode(f, 2, "pd")


def ns_ode():
    """x' = lam x - 2 y + sin(2 pi t), y' = 2 x + lam y: multipliers exp((lam +- 2i) T), a complex
    pair crossing the unit circle at lam = 0 (up to the RK4 error)."""
    return _ode(lambda x, t, lam: ca.vertcat(lam * x[0] - 2 * x[1] + ca.sin(2 * np.pi * t / T),
                                              2 * x[0] + lam * x[1]), 2, "ns")


def test_fold_located_to_1e_minus_6_and_branch_turns_back():
    prob = OrbitProblem(fold_ode(), [1.0], [1.0, 0.0])
    br = continuation(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40)
    folds = [s for s in br.special_points if s.kind == "fold"]
    assert len(folds) == 1 and folds[0].located
    assert abs(folds[0].parameter) < 1e-6
    mult = np.array([complex(*m) for m in folds[0].multipliers])
    assert np.min(np.abs(mult - 1)) < 1e-4
    assert not [s for s in br.special_points if s.kind != "fold"]
    # after the fold the branch is the other family x = -sqrt(lam) and comes back to lam = 1
    assert br.end_reason == "reached_from"
    last = br.points[-1]
    assert abs(last.parameter - 1.0) < 1e-12 and abs(last.x0[0] + 1.0) < 1e-8
    # every point is on the exact family x = +-sqrt(lam)
    for pt in br.points:
        assert abs(abs(pt.x0[0]) - math.sqrt(pt.parameter)) < 1e-8
    assert br.points[0].stable and not br.points[-1].stable
    # JSON round trip
    d = json.loads(json.dumps(br.to_dict()))
    assert Branch.from_dict(d).to_dict() == d


def _one_special_point(ode, lam_from: float, lam_to: float, steps: int, kind: str):
    """The branch of ``ode`` from lam_from to lam_to (reached) and its only special point, of ``kind``."""
    prob = OrbitProblem(ode, [lam_from], [0.0, 0.0])
    br = continuation(prob, "lam", lam_from, lam_to, points=3, steps_per_period=steps)
    assert br.end_reason == "reached_to"
    kinds = [s.kind for s in br.special_points]
    assert kinds == [kind], kinds
    return br, br.special_points[0]


def test_period_doubling_detected():
    br, sp = _one_special_point(pd_ode(), -0.5, 0.5, 120, "period_doubling")
    assert abs(sp.parameter) < 1e-4
    mult = np.array([complex(*m) for m in sp.multipliers])
    assert np.min(np.abs(mult + 1)) < 1e-8


def test_neimark_sacker_detected():
    br, sp = _one_special_point(ns_ode(), -0.3, 0.3, 60, "neimark_sacker")
    assert abs(sp.parameter) < 1e-6
    mods = np.array(sp.moduli)
    assert np.max(np.abs(mods - 1)) < 1e-8
    assert br.points[0].stable and not br.points[-1].stable


@pytest.mark.slow
def test_bird_branch_agrees_with_independent_trims(tmp_path):
    """A short fixed-amplitude branch in the root position (coarse grid) = trims at three root positions;
    the CLI writes it and 'plot' redraws it."""
    from birdocp.cli.main import main
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.branch import bird_branch
    from birdocp.studies.trim import trim

    coarse = dict(points=3, steps_per_period=48)
    br = bird_branch(Config(), "root_ahead_m", 0.05, 0.048, **coarse)
    assert br.end_reason == "reached_to" and len(br.points) >= 3
    assert not br.special_points
    for pt in (br.points[0], br.points[len(br.points) // 2], br.points[-1]):
        tr = trim(with_values(Config(), {"wing.root_ahead_m": pt.parameter}), **coarse)
        assert tr.success
        assert np.max(np.abs(np.array(pt.x0) - tr.x0)) < 1e-7
        L = np.sort_complex(np.array([complex(*m) for m in pt.multipliers]))
        assert np.max(np.abs(L - np.sort_complex(tr.multipliers))) < 1e-7
        # every branch point carries the model's validity, the same as the trim's (its trajectory)
        assert pt.validity["valid"] is tr.validity.valid
        assert abs(pt.validity["alpha_eff_max_deg"] - tr.validity.measures["alpha_eff_max_deg"]) < 1e-6
    # the expanding multiplier falls as the root moves back (fact: +0.354 per cm forward at 42 deg)
    assert br.points[-1].moduli[0] < br.points[0].moduli[0] - 0.05
    out = tmp_path / "run"
    assert main(["continue", "stability_margin", "--from", "-25", "--to", "-24.5", "--points", "3", "--steps", "48",
                 "--out", str(out), "--quiet", "--json"]) == 0
    d = json.loads((out / "branch.json").read_text())
    assert d["end_reason"] == "reached_to" and abs(d["points"][-1]["parameter"] - 0.049) < 1e-12
    assert all(set(p["validity"]) >= {"valid", "reasons"} for p in d["points"])
    (out / "moduli.png").unlink()
    assert main(["plot", str(out)]) == 0 and (out / "moduli.png").is_file()


@pytest.mark.slow
def test_branch_leaves_a_start_where_the_parameter_derivative_vanishes():
    """The tail's loads grow like the square of its opening angle, so dG/d(angle) ~ 0 at angle 0: a
    corrector that trusted the start's Jacobian wandered to negative angles and reported a fold at
    0.3 deg (the branch then 'turned back' to 0). The branch must leave 0 forward, without special
    points."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.branch import bird_branch

    br = bird_branch(with_values(Config(), {"tail.enabled": True}), "tail.opening_angle_deg", 0.0, 60.0,
                     level=True, bounds=(20.0, 90.0), max_points=3, points=3, steps_per_period=48)
    lam = br.parameters
    assert br.end_reason == "max_points", br.end_message
    assert not br.special_points
    assert lam[0] == 0.0 and np.all(np.diff(lam) > 0.1)


def _x_margin(level):
    """A user test function of a point: x0[0] - level (exact zero at lam = level^2 on x = sqrt(lam))."""
    from birdocp.engine.continuation import BranchEvents

    return lambda stop: BranchEvents(lambda pt: {"x_above": pt.x0[0] - level}, kind="threshold", stop=stop)


def test_user_event_located_exactly_and_branch_goes_on_or_stops():
    """On x = +sqrt(lam) (exact for RK4 too) the test x0 - 0.5 crosses zero at lam = 0.25 exactly: the
    event is located there (falling, direction -1); the branch goes on through it (and the fold at 0),
    and with ``stop`` it ends at the located point."""
    prob = OrbitProblem(fold_ode(), [1.0], [1.0, 0.0])
    make = _x_margin(0.5)
    br = continuation(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40, events=make(False))
    ev = [s for s in br.special_points if s.kind == "threshold"]
    # down the upper family (x falls through 0.5) and back up the lower one (x < 0 stays below)
    assert len(ev) == 1 and ev[0].located and ev[0].event == "x_above" and ev[0].direction == -1
    assert abs(ev[0].parameter - 0.25) < 1e-9 and abs(ev[0].x0[0] - 0.5) < 1e-9
    assert br.end_reason == "reached_from" and any(s.kind == "fold" for s in br.special_points)
    assert all(pt.event_values["x_above"] == pytest.approx(pt.x0[0] - 0.5, abs=0) for pt in br.points)
    i, j = ev[0].between
    assert br.points[i].event_values["x_above"] >= 0 > br.points[j].event_values["x_above"]
    d = json.loads(json.dumps(br.to_dict()))
    assert Branch.from_dict(d).to_dict() == d and d["special_points"][0]["event"] == "x_above"

    st = continuation(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40, events=make(True))
    assert st.end_reason == "stopped_at_event"
    assert abs(st.points[-1].parameter - 0.25) < 1e-9
    assert [s.kind for s in st.special_points] == ["threshold"]
    assert all(pt.parameter >= 0.25 - 1e-9 for pt in st.points)
    # a start already below zero stops at once
    st0 = continuation(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40, events=_x_margin(1.5)(True))
    assert st0.end_reason == "stopped_at_event" and len(st0.points) == 1


@pytest.mark.slow
def test_bird_branch_locates_the_validity_boundary_and_can_stop_there(tmp_path):
    """A short bird branch (root 4.8 -> 5 cm, coarse grid) with the airflow-to-body-angle limit set
    halfway between its ends' angles: one ``validity_boundary`` naming that limit, where a re-solve
    of the cycle at the located root (trim) measures the angle at the limit; with stop_at_invalid
    the branch ends there, its last point at the boundary; the CLI's --stop-at-invalid the same."""
    from birdocp.bird.config import Config, with_values
    from birdocp.cli.main import main
    from birdocp.studies.branch import bird_branch
    from birdocp.studies.trim import trim

    coarse = dict(points=3, steps_per_period=48)
    ends = [trim(with_values(Config(), {"wing.root_ahead_m": r}), **coarse) for r in (0.048, 0.05)]
    angles = [e.validity.measures["max_airflow_body_angle_deg"] for e in ends]
    assert angles[1] > angles[0] + 0.1 and all(e.validity.valid for e in ends)
    limit = 0.5 * sum(angles)
    cfg = with_values(Config(), {"validity.max_airflow_body_angle_deg": limit})
    br = bird_branch(cfg, "root_ahead_m", 0.048, 0.05, **coarse)
    assert br.end_reason == "reached_to"
    (sp,) = br.special_points
    assert (sp.kind, sp.event, sp.direction, sp.located) == ("validity_boundary", "max_airflow_body_angle_deg", -1,
                                                             True)
    assert 0.048 < sp.parameter < 0.05
    at = trim(with_values(cfg, {"wing.root_ahead_m": sp.parameter}), **coarse)
    assert abs(at.validity.measures["max_airflow_body_angle_deg"] - limit) < 1e-6
    valid = [p.validity["valid"] for p in br.points]
    assert valid[0] and not valid[-1] and valid == sorted(valid, reverse=True)
    assert all(p.event_values["max_airflow_body_angle_deg"] == pytest.approx(
        limit - p.validity["max_airflow_body_angle_deg"], abs=1e-12) for p in br.points)

    st = bird_branch(cfg, "root_ahead_m", 0.048, 0.05, stop_at_invalid=True, **coarse)
    assert st.end_reason == "stopped_at_event" and abs(st.points[-1].parameter - sp.parameter) < 1e-9
    assert all(p.validity["valid"] for p in st.points[:-1])
    out = tmp_path / "run"
    code = main(["continue", "root_ahead_m", "--from", "0.048", "--to", "0.05", "--points", "3", "--steps", "48",
                 "--set", f"validity.max_airflow_body_angle_deg={limit!r}", "--stop-at-invalid", "--out", str(out),
                 "--quiet", "--json"])
    d = json.loads((out / "branch.json").read_text())
    assert code == 0 and d["end_reason"] == "stopped_at_event"
    assert [(s["kind"], s["event"]) for s in d["special_points"]] == [("validity_boundary",
                                                                      "max_airflow_body_angle_deg")]
