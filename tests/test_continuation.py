"""Pseudo-arclength continuation: exact special points on constructed forced systems, a short bird branch."""

import pytest
import json
import math

import casadi as ca
import numpy as np

from birdocp.engine.continuation import Branch, continuation
from birdocp.engine.problem import LimitCycleProblem, PeriodicODE

T = 1.0


def _ode(expr_fn, nx, name):
    x = ca.SX.sym("x", nx)
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", 1)
    f = ca.Function(name, [x, t, p], [expr_fn(x, t, p[0])])
    return PeriodicODE.from_rhs(f, T, tuple(f"x{i}" for i in range(nx)), ("lam",))


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
    prob = LimitCycleProblem(fold_ode(), [1.0], [1.0, 0.0])
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
    prob = LimitCycleProblem(ode, [lam_from], [0.0, 0.0])
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
