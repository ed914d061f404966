"""Reduced-space gait optimisation: exact gradients (implicit function theorem, variational equations)
against central differences, the optimum's KKT residual, the optimum re-trimmed independently, the
CLI's JSON, and the Pareto front's monotonicity."""

import json
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.cli import main as cli
from birdocp.engine.integrate import RK4Grid
from birdocp.studies.gait import ReducedLevelCycle, optimize_gait
from birdocp.studies.gait_fronts import stability_pareto

STEPS = 24
KEYS = ["gait.shoulder_incidence.offset_deg", "gait.shoulder_sweep.offset_deg"]
FREE = {KEYS[0]: (0.0, 25.0), KEYS[1]: (-30.0, -5.0)}


def small():
    return with_values(Config(), {"solve.steps_per_period": STEPS})


def test_reduced_gradients_match_central_differences():
    rc = ReducedLevelCycle(small(), KEYS, second_order=True)
    th = np.array([14.0, -19.0])
    ev = rc.evaluate(th)
    g = {k: v.copy() for k, v in ev.grads.items()}
    dMon, Mon = ev.d_monodromy.copy(), ev.monodromy.copy()
    # the monodromy from the variational equations is the period map's Jacobian
    grid = RK4Grid(rc.m.ode, STEPS, 1)
    p = rc.pfull(th, ev.amplitude_deg)
    _, J = grid.period_jacobian(ca.DM(ev.x0), grid.blocks_numeric(0.0, p), ca.DM(p))
    assert np.allclose(Mon, np.asarray(J), rtol=0, atol=1e-11)
    for i, h in enumerate((1e-3, 1e-4)):
        e = np.zeros(2)
        e[i] = h
        a, b = rc.evaluate(th + e), rc.evaluate(th - e)
        for k in ("forward_speed_mps", "flapping_power_W", "aerodynamic_power_W"):
            fd = (a.means[k] - b.means[k]) / (2 * h)
            assert fd == pytest.approx(g[k][i], rel=1e-5, abs=1e-7), k
        assert (a.amplitude_deg - b.amplitude_deg) / (2 * h) == pytest.approx(g["amplitude_deg"][i], rel=1e-5)
        fdM = (a.monodromy - b.monodromy).ravel(order="F") / (2 * h)
        assert np.allclose(fdM, dMon[:, i], rtol=1e-4, atol=1e-6)


def test_optimize_gait_cli_json_optimum_verified(tmp_path, capfd):
    """optimize-gait on a small problem: documented JSON keys; the optimum satisfies the KKT
    conditions, beats the configured gait at the same speed, and a trim from scratch at the optimal
    gait gives the same power, speed and multipliers."""
    out = tmp_path / "run"
    code = cli.main(["optimize-gait", "--speed", "18", "--free", KEYS[0], "--free", KEYS[1],
                     "--bounds", f"{KEYS[0]}=0:25", "--set", f"solve.steps_per_period={STEPS}", "--json",
                     "--out", str(out)])
    stdout, err = capfd.readouterr()
    assert code == 0, err
    r = json.loads(stdout)
    for k in ("success", "status", "objective_value", "start_objective_value", "free", "multipliers",
              "mean_forward_speed_mps", "kkt_residual"):
        assert k in r, k
    assert r["success"] and set(r["free"]) == set(KEYS)
    assert r["mean_forward_speed_mps"] == pytest.approx(18.0, abs=1e-7)
    assert r["objective_value"] < r["start_objective_value"]
    assert r["kkt_residual"] < 1e-6
    v = r["verification"]
    assert v["trim_success"]
    assert abs(v["power_difference_W"]) < 1e-7
    assert v["trim_mean_forward_speed_mps"] == pytest.approx(18.0, abs=1e-6)
    assert abs(v["trim_mean_vertical_speed_mps"]) < 1e-7
    assert v["max_multiplier_difference"] < 1e-7
    assert len(r["multipliers"]) == 4 and all(len(z) == 2 for z in r["multipliers"])
    assert json.loads((out / "result.json").read_text())["objective_value"] == r["objective_value"]


def test_optimize_gait_bad_input_exit_2(tmp_path, capfd):
    for argv in (["--speed", "0"], ["--speed", "18", "--free", "gait.elbow_flex.offset_deg", "--bounds",
                                    "gait.elbow_flex.offset_deg=0:50"],
                 ["--speed", "18", "--bounds", "gait.shoulder_sweep.offset_deg=5:1"],
                 ["--speed", "18", "--max-multiplier", "-1"]):
        code = cli.main(["optimize-gait", *argv, "--out", str(tmp_path / "x")])
        err = capfd.readouterr().err
        assert code == 2, argv
        assert len(err.strip().splitlines()) == 1
        assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_pareto_front_is_monotone():
    """Tighter stability bounds never lower the minimum power, and the bound holds at the optimum."""
    cfg = small()
    free = {KEYS[0]: (0.0, 25.0), KEYS[1]: (-30.0, -5.0)}
    a = optimize_gait(cfg, free, speed_mps=18, verify=False)
    b = optimize_gait(cfg, free, objective="stability", speed_mps=18, verify=False)
    assert a.success and b.success
    assert b.objective_value <= a.largest_modulus
    bounds = [a.largest_modulus - frac * (a.largest_modulus - b.objective_value) for frac in (0.4, 0.8)]
    rows = stability_pareto(cfg, 18, bounds, free=free, start=a.free, verify=False)  # warm-started tracing
    powers = [a.objective_value]
    for R, c in zip(bounds, [q for q in rows if q["success"]]):
        assert c["bound"] == R and c["largest_modulus"] <= R + 1e-6
        assert c["kkt_residual"] < 1e-5
        powers.append(c["objective_value"])
    assert len(powers) == 3
    assert powers[0] <= powers[1] + 1e-9 <= powers[2] + 2e-9


def test_newton_failure_is_an_error_not_a_nan_cycle():
    """A level-cycle solve that cannot converge raises (IPOPT then sees an evaluation error and cuts its
    step): once, a NaN residual counted as converged (NaN > tol is False) and NaN gradients reached
    IPOPT (Invalid_Number_Detected). Same for an amplitude outside the allowed range."""
    rc = ReducedLevelCycle(small(), KEYS[:1])
    ev = rc.evaluate(np.array([14.0]))
    assert np.isfinite(ev.amplitude_deg) and ev.residual <= 1e-10
    with pytest.raises(RuntimeError, match="level cycle not found"):
        rc.evaluate(np.array([np.nan]))
    rc.amplitude_range_deg = (0.0, ev.amplitude_deg - 5.0)
    with pytest.raises(RuntimeError, match="amplitude"):
        rc.evaluate(np.array([14.5]))
    rc.amplitude_range_deg = (0.0, 90.0)  # the last accepted cycle still restarts Newton
    rc.accept(np.array([14.0]))
    assert abs(rc.evaluate(np.array([14.5])).amplitude_deg - ev.amplitude_deg) < 5.0


def test_committed_pareto_front_is_monotone():
    """A check of the COMMITTED results (results/energetics/result.json, written by
    scripts/energetics_study.py), not a computation: along the traced front the minimum power never
    rises as the bound R loosens, every point keeps its bound, and the front reaches from the energy
    optimum to the most stable gait."""
    path = Path(__file__).resolve().parents[1] / "results" / "energetics" / "result.json"
    front = json.loads(path.read_text())["pareto"]
    ok = sorted((q for q in front if q["success"]), key=lambda q: q["largest_modulus"])
    assert len(ok) >= 8
    P = [q["objective_value"] for q in ok]
    assert all(x >= y - 1e-9 for x, y in zip(P, P[1:]))
    for q in ok:
        if isinstance(q["bound"], float):
            assert q["largest_modulus"] <= q["bound"] + 1e-6
    assert ok[-1]["bound"] is None                             # the loose end: the energy optimum
    stable = next(q for q in front if q["bound"] == "most stable")
    assert ok[0]["largest_modulus"] < stable["largest_modulus"] + 1e-3  # the tight end: the most stable gait
    for q in front:  # a failed step was retried until its bound was reached
        assert q["success"] or any(o["success"] and o["bound"] == q["bound"] for o in front)


def test_threaded_fd_hessian_of_the_reduced_problem():
    """The stability NLP's finite-difference second derivatives (StencilHessian: each perturbed level
    cycle by Newton from the iterate's cycle, side-effect-free) are the same to the bit with 1 and 2
    threads, leave the warm-start state as the iterate's Jacobian left it, and agree with forward
    differences through the ordinary (stateful) evaluation path and with central differences."""
    from birdocp.engine.oracle import StencilHessian
    from birdocp.studies.gait import ReducedProblem

    rc = ReducedLevelCycle(small(), KEYS, second_order=True)
    prob = ReducedProblem(rc, "stability", None, None, (20.0, 70.0))
    ev0 = rc.evaluate(np.array([14.0, -19.0]))
    prob.set_scale(ev0)
    z = np.append(ev0.theta * prob.sigma[:2], 1.5)
    J0 = prob.jacobian(z)
    ws = rc.warm_start
    state = (ws.y, ws.theta, ws.dy, rc.last_jacobian)
    h = 1e-6
    c1 = StencilHessian(h, threads=1).columns(prob, z)
    c2 = StencilHessian(h, threads=2).columns(prob, z)
    assert np.array_equal(c1, c2)
    ws = rc.warm_start
    for a, b in zip(state, (ws.y, ws.theta, ws.dy, rc.last_jacobian)):
        assert np.array_equal(a, b)
    assert np.all(c1[2][:2] == 0) and np.any(c1[2] != 0)  # r enters the Jury rows only (objective r: linear)
    scale = np.max(np.abs(c1))
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        fwd = (prob.jacobian(z + e) - J0) / h                  # stateful path: evaluate() with warm starts
        assert np.allclose(fwd, c1[k], rtol=0, atol=1e-4 * scale), k
        e[k] = 1e-4
        central = (prob.jacobian(z + e) - prob.jacobian(z - e)) / 2e-4
        assert np.allclose(central, c1[k], rtol=0, atol=1e-5 * scale), k


def test_combined_second_order_pass_equals_all_directions():
    """The monodromy's derivatives along the total directions (x0 and A moving with theta, one
    second-order pass over nt combined directions) equal the pass over all 4 + nt + 1 directions
    combined afterwards by the implicit-function theorem."""
    from birdocp.engine.variational import PeriodSensitivities

    rc = ReducedLevelCycle(small(), KEYS, second_order=True)
    ev = rc.evaluate(np.array([14.0, -19.0]))
    full = PeriodSensitivities(rc.m.ode, STEPS, (rc.outputs,), rc.nt + 1, True)
    p = rc.pfull(ev.theta, ev.amplitude_deg)
    D, seeds, cols = rc.sensitivity_inputs(p)
    s = full(ev.x0, D, p, dp=seeds, columns=cols)
    ct, cy = [4, 5], [0, 1, 2, 3, 6]
    dMon = s["dMon"][:, ct] + s["dMon"][:, cy] @ ev.dy
    assert np.allclose(ev.d_monodromy, dMon, rtol=0, atol=1e-12 * np.max(np.abs(dMon)))
    assert np.allclose(ev.monodromy, s["Mon"], rtol=0, atol=1e-13)


def test_second_order_pass_on_given_state_columns_equals_the_full_pass_times_them():
    """``state_columns=k`` carries the monodromy on k given columns S0 only (forward directions instead
    of the step Jacobian): its Mon and dMon equal the full pass's M S0 and dM S0, direction by direction;
    without S0 it refuses (one line naming S0)."""
    from birdocp.engine.variational import PeriodSensitivities

    rc = ReducedLevelCycle(small(), KEYS, second_order=True)
    ev = rc.evaluate(np.array([14.0, -19.0]))
    p = rc.pfull(ev.theta, ev.amplitude_deg)
    D, seeds, cols = rc.sensitivity_inputs(p)
    part = PeriodSensitivities(rc.m.ode, STEPS, (rc.outputs,), rc.nt, True, combined=True, n_data=rc.nt + 1,
                               state_columns=3)
    S0 = np.random.default_rng(3).normal(size=(4, 3))
    W = np.vstack([np.eye(rc.nt), ev.dy[4]])
    s = part(ev.x0, D, p, dp=seeds, columns=cols, W=W, dx0=ev.dy[:4], S0=S0)
    assert np.allclose(s["Mon"], ev.monodromy @ S0, rtol=0, atol=1e-12)
    for c in range(rc.nt):
        want = ev.d_monodromy[:, c].reshape(4, 4, order="F") @ S0
        got = s["dMon"][:, c].reshape(4, 3, order="F")
        assert np.allclose(got, want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
    with pytest.raises(ValueError, match="S0"):
        part(ev.x0, D, p, dp=seeds, columns=cols, W=W, dx0=ev.dy[:4])


def test_trial_point_values_equal_the_gradient_evaluation_values():
    """A line-search trial point (values only) gets the monodromy alone (4 state directions): its
    constraint values, Jury rows included, equal those of the full evaluation with second-order
    gradients at the same point (another code path), with the bound R and with r free; a second
    reduced cycle of the same problem reuses the first one's CasADi Functions."""
    from birdocp.studies.gait import ReducedProblem

    rc = ReducedLevelCycle(small(), KEYS, second_order=True)
    assert ReducedLevelCycle(small(), KEYS, second_order=True).sens2 is rc.sens2
    for objective, R in (("power", 1.2), ("stability", None)):
        prob = ReducedProblem(rc, objective, None, R, (20.0, 70.0))
        theta = np.array([14.0 if R else 13.5, -19.0])
        z = theta if R else np.append(theta, 1.3)
        g_trial = prob.g(z)
        ev = rc.cached(theta)
        assert ev is not None and ev.grads is None and ev.d_monodromy is None  # no gradients were computed
        G, J = prob.both(z)
        assert J is not None and rc.cached(theta).d_monodromy is not None
        assert np.allclose(g_trial, G, rtol=1e-9, atol=1e-12), (objective, g_trial - G)
        assert np.all(np.abs(g_trial[2:7]) > 1e-8)  # the Jury rows are there, not zero padding


def _fake_cycle(**attrs):
    """A ReducedLevelCycle shell (no model, no graphs) with the attributes a test gives."""
    from birdocp.studies.gait_cycle import ReducedLevelCycle

    rc = ReducedLevelCycle.__new__(ReducedLevelCycle)
    rc.__dict__.update(attrs)
    return rc


def test_solve_speed_names_the_speed_extremum_it_cannot_pass():
    """U(theta) = 18 - 0.01 (theta - 4)^2 (the wagner power curve's shape at 48 steps: a maximum of the
    level speed in the incidence offset): 17.9 m/s is reached; 18.5 m/s gets a RuntimeError naming the
    maximum (18 m/s near theta 4), not an exhausted iteration count."""
    from types import SimpleNamespace

    def evaluate(theta):
        t = float(theta[0])
        return SimpleNamespace(means={"forward_speed_mps": 18.0 - 0.01 * (t - 4.0) ** 2},
                               grads={"forward_speed_mps": np.array([-0.02 * (t - 4.0)])})

    rc = _fake_cycle(keys=["gait.shoulder_incidence.offset_deg"], evaluate=evaluate)
    ev = rc.solve_speed(17.9, np.array([12.7]), 0, (-10.0, 35.0))
    assert abs(ev.means["forward_speed_mps"] - 17.9) < 1e-9
    with pytest.raises(RuntimeError, match="local maximum near") as e:
        rc.solve_speed(18.5, np.array([12.7]), 0, (-10.0, 35.0))
    import re

    u, t = map(float, re.search(r"near ([\d.]+) m/s \(\S+ about ([\d.]+)", str(e.value)).groups())
    assert abs(u - 18.0) < 0.01 and abs(t - 4.0) < 1.0


def test_level_newton_rescues_a_slow_chord():
    """A chord Jacobian contracting by 0.29 a step (12 steps: 0.29^12 = 3.5e-7 > tol) used to fail;
    the fresh-Jacobian steps after it solve the linear residual exactly (second method: numpy)."""
    from birdocp.studies.gait_cycle import NEWTON_RESCUE_STEPS

    A = np.diag([2.0, 1.0, 3.0, 1.5, 1.0])
    b = np.array([1.0, -2.0, 0.5, 0.3, 20.0])
    residual = lambda y, theta: (A @ y - b, np.zeros(2))  # noqa: E731
    full = lambda y, theta: (None, A @ y - b, A)  # noqa: E731
    stale = A / 0.71  # chord step y - stale^-1 R: the error shrinks by 1 - 0.71 = 0.29 a step
    rc = _fake_cycle(nx=4, amplitude_range_deg=(-1e3, 1e3), _Ry=stale, residual=residual, _full=full,
                     out_names=("a", "b"))
    ev = rc._newton(np.zeros(5), np.zeros(1), 1e-10, 12)
    assert np.allclose(ev.y, np.linalg.solve(A, b), atol=1e-10)
    assert 12 < ev.newton_iterations <= 12 + NEWTON_RESCUE_STEPS
