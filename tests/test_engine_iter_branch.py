"""One continuation front that yields points (iter_branch): orbits and equilibria alike, the collectors
equal to the iteration, an early exit keeps its points, error estimates of continuation points."""

import numpy as np
import pytest

from birdocp.engine import ODE, iter_branch
from birdocp.engine.continuation import continuation
from birdocp.engine.equilibria import continue_equilibria
from birdocp.engine.problem import OrbitProblem
from test_continuation import fold_ode, ns_ode

SL = ODE.from_function(lambda x, t, p: [p[0] * x[0] - p[1] * x[1] - (x[0] ** 2 + x[1] ** 2) * x[0],
                                        p[1] * x[0] + p[0] * x[1] - (x[0] ** 2 + x[1] ** 2) * x[1]], 2, ("mu", "omega"))


def test_orbit_steps_are_the_points_continuation_collects():
    """On x' = (1 + y/2)(lam - x^2) the cycles fold at lam = 0 exactly: the iterator's steps carry the
    same points as continuation()'s branch, the fold arrives with the step after it, and the branch
    the iterator returns is the collector's."""
    prob = OrbitProblem(fold_ode(), [1.0], [1.0, 0.0])
    it = iter_branch(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40)
    steps = list(it)
    br = continuation(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40)
    assert [s.point.to_dict() for s in steps if s.point is not None] == [p.to_dict() for p in br.points]
    assert [s.index for s in steps] == list(range(len(br.points)))
    folds = [s for s in steps if "fold" in s.kinds]
    assert len(folds) == 1 and abs(folds[0].special_points[0].parameter) < 1e-6
    assert folds[0].index == br.special_points[0].between[1]
    mine = it.branch().to_dict()
    theirs = br.to_dict()
    mine.pop("wall_s"), theirs.pop("wall_s")
    assert mine == theirs and br.end_reason == "reached_from"
    with pytest.raises(RuntimeError, match="runs once"):
        iter(it)


def test_an_iterator_left_early_keeps_its_points_and_says_so():
    prob = OrbitProblem(fold_ode(), [1.0], [1.0, 0.0])
    it = iter_branch(prob, "lam", 1.0, -1.0, points=3, steps_per_period=40)
    for step in it:
        if step.index == 2:
            break
    br = it.branch()
    assert len(br.points) == 3 and br.end_reason == "incomplete"
    # x = sqrt(lam) exactly on the branch (RK4 keeps it)
    assert np.allclose([p.x0[0] for p in br.points], np.sqrt(br.parameters), atol=1e-9)


def test_equilibria_through_the_same_front_hopf_at_zero():
    """Stuart-Landau: the origin's eigenvalues are mu +- i omega, so a Hopf point at mu = 0 with
    frequency omega = 2 arrives with the step after it, where the points turn unstable; the
    collector continue_equilibria gives the same branch."""
    steps = list(iter_branch(SL, "mu", -0.5, 0.5, start=[0.01, 0.0], p=[-0.5, 2.0], ds=0.1))
    hopf = [s for s in steps if "hopf" in s.kinds]
    assert len(hopf) == 1
    hp = hopf[0].special_points[0]
    assert abs(hp.p[0]) < 1e-10 and abs(hp.omega - 2.0) < 1e-10
    k = hopf[0].index
    assert all(s.stable for s in steps[:k]) and not any(s.stable for s in steps[k:])
    assert np.allclose(steps[1].spectrum, [steps[1].parameter + 2j, steps[1].parameter - 2j], atol=1e-9)
    eb = continue_equilibria(SL, [-0.5, 2.0], "mu", [0.01, 0.0], 0.5, ds=0.1)
    assert np.array_equal(eb.params, [s.parameter for s in steps]) and eb.status == "ok"
    assert np.array_equal(eb.x, [s.state for s in steps])


def test_iter_branch_refuses_what_it_cannot_follow():
    with pytest.raises(TypeError, match="OrbitProblem of an ODE with data or an ODE"):
        iter_branch("not a problem", "mu", 0.0, 1.0)
    with pytest.raises(ValueError, match="start="):
        iter_branch(SL, "mu", 0.0, 1.0)
    with pytest.raises(TypeError, match="unknown setting"):
        iter_branch(SL, "mu", 0.0, 1.0, start=[0.0, 0.0], p=[0.0, 1.0], step=0.1)


def test_error_estimates_of_continuation_points_track_the_true_error():
    """x' = lam x - 2y + sin(2 pi t), y' = 2x + lam y: the multipliers are exp((lam +- 2i) T) exactly;
    on a coarse RK4 grid (20 steps) every point's estimate is within 5 % of the true error of its
    multipliers, and the key is in the JSON only when asked for."""
    prob = OrbitProblem(ns_ode(), [-0.5], [0.0, 0.0])
    it = iter_branch(prob, "lam", -0.5, 0.5, points=3, steps_per_period=20, error_estimate=True)
    ratios = []
    for step in it:
        if step.point is None:
            continue
        true = np.min(np.abs(step.spectrum - np.exp(step.parameter + 2j)))
        est = step.error_estimate
        assert est["fine_status"] == "converged" and est["steps_per_period_fine"] == 40
        ratios.append(est["multipliers"] / true)
    assert len(ratios) >= 4 and min(ratios) > 0.95 and max(ratios) < 1.05, ratios
    assert "error_estimate" in it.branch().to_dict()["points"][0]
    plain = continuation(prob, "lam", -0.5, -0.3, points=3, steps_per_period=20)
    assert "error_estimate" not in plain.to_dict()["points"][0]


def test_bird_branch_and_trim_carry_the_same_error_estimate_through_the_cli(tmp_path, capsys):
    """``continue --error-estimate`` gives every point an error estimate (a Newton re-solve of the
    branch's system on 2N steps) and ``trim --error-estimate`` the trim's (a full LM re-solve): two
    paths to the same number at the start of the branch; the branch's result.json sums them up."""
    import json

    from birdocp.cli.main import main

    coarse = ["--points", "3", "--steps", "48", "--quiet"]
    assert main(["trim", *coarse, "--error-estimate", "--out", str(tmp_path / "t")]) == 0
    trim_est = json.loads((tmp_path / "t" / "result.json").read_text())["error_estimate"]
    assert main(["continue", "root_ahead_m", "--from", "0.05", "--to", "0.0498", *coarse, "--error-estimate",
                 "--out", str(tmp_path / "c"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    pts = out["branch"]["points"]
    assert len(pts) >= 2 and all(p["error_estimate"]["fine_status"] == "converged" for p in pts)
    first = pts[0]["error_estimate"]
    for key in ("multipliers", "x0"):
        assert abs(first[key] - trim_est[key]) <= 1e-4 * trim_est[key], (key, first[key], trim_est[key])
    assert 1e-6 < trim_est["multipliers"] < 1e-3   # RK4 on 48 steps: visible, not large
    summary = json.loads((tmp_path / "c" / "result.json").read_text())["error_estimate"]
    assert summary["points"] == len(pts) and summary["multipliers"] == max(p["error_estimate"]["multipliers"]
                                                                            for p in pts)


def test_forced_and_any_ode_problems_give_the_one_result_type_with_the_same_names():
    """x'' + x'/2 + x = cos t posed both ways (an ODE with data: data-split multiple shooting with mean
    conditions; an ODE: time scaled by the period) through the one front: both results are
    OrbitResults of their formulation, and the shared names agree (x = 2 sin t exactly; period 2 pi;
    multipliers exp(eig(A) 2 pi)); each JSON leaves out what its formulation does not compute."""
    import casadi as ca

    from birdocp.engine import OrbitMethod, OrbitProblem, OrbitResult, ODE, solve
    from birdocp.engine.orbit_result import JSON_OMITS

    x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
    f = ca.Function("f", [x, t, p], [ca.vertcat(x[1], -p[0] * x[1] - x[0] + ca.cos(t))])
    forced = solve(OrbitProblem(ODE.from_rhs(f, 2 * np.pi), p=[0.5], x_guess=[0, 0]),
                   OrbitMethod(points=3, steps_per_period=120))
    ode = ODE.from_function(lambda x, t, p: [x[1], -p[0] * x[1] - x[0] + ca.cos(t)], 2, ("c",),
                            forcing_period=2 * np.pi)
    anyode = solve(OrbitProblem(ode, [0.5], [0.0, 1.5]), OrbitMethod(points=3, steps_per_period=120))
    assert (forced.formulation, anyode.formulation) == ("data_split", "time_scaled")
    assert forced.success and anyode.success
    lam_exact = np.exp(np.linalg.eigvals(np.array([[0.0, 1.0], [-1.0, -0.5]])) * 2 * np.pi)
    for r in (forced, anyode):
        assert type(r) is OrbitResult
        assert r.autonomous is False and abs(r.period - 2 * np.pi) < 1e-12
        assert np.allclose(r.x0, [0.0, 2.0], atol=1e-4)
        assert np.allclose(np.sort_complex(r.multipliers), np.sort_complex(lam_exact), atol=1e-6)
        assert not set(JSON_OMITS[r.formulation]) & set(r.to_dict())
    assert anyode.means == {} and forced.free_values == anyode.free_values == {}
    assert forced.method["solver"] == "ipopt" and anyode.method["solver"] == "lm"  # each formulation's default


def test_error_estimates_of_autonomous_orbit_points_track_the_true_error():
    """Stuart-Landau orbits (r = sqrt(mu), T = 2 pi / omega, non-trivial multiplier exp(-2 mu T)) on 20
    RK4 steps, continued through iter_branch from an OrbitResult: the period's estimate
    (``free_values["period"]``) and the multiplier's track their true errors within 10 %."""
    from birdocp.engine import OrbitMethod, OrbitProblem, solve

    o = solve(OrbitProblem(SL, [0.25, 2.0], [0.5, 0.0], period_guess=3.0), OrbitMethod(points=3, steps_per_period=20))
    n = 0
    for step in iter_branch(SL, "mu", 0.25, 1.0, start=o, step=0.25, error_estimate=True):
        if step.point is None:
            continue
        est = step.error_estimate
        t_ratio = est["free_values"]["period"] / abs(step.point.period - np.pi)
        l_ratio = est["multipliers"] / abs(step.spectrum[0] - np.exp(-2 * np.pi * step.parameter))
        assert 0.9 < t_ratio < 1.1 and 0.9 < l_ratio < 1.1, (step.parameter, t_ratio, l_ratio)
        n += 1
    assert n >= 3
