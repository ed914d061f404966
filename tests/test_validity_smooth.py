"""Validity as smooth constraints (birdocp.bird.validity_smooth, birdocp.studies.gait_validity): each
smooth measure's exact gradient (implicit function theorem through the level cycle) against central
differences of re-solved cycles; the smooth values near the exact ones; an energy optimum that is not
valid without the constraints and is valid with them (CLI, JSON keys); level --valid."""

import json

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.bird.validity import periodic_validity
from birdocp.bird.validity_smooth import SMOOTH_LIMITS, cycle_smooth_measures, integrand_names, smooth_measures
from birdocp.cli import main as cli
from birdocp.studies.gait import ReducedLevelCycle, optimize_gait

STEPS = 24
KEYS = ["gait.shoulder_incidence.offset_deg", "gait.shoulder_sweep.offset_deg"]
FREE = {KEYS[0]: (0.0, 25.0), KEYS[1]: (-30.0, -5.0)}
AMP = "gait.shoulder_flap.amplitude_deg"


def small():
    return with_values(Config(), {"solve.steps_per_period": STEPS})


def _measures(cfg, ev, grads=False):
    names = integrand_names()
    return smooth_measures(cfg, [ev.means[n] for n in names], [ev.grads[n] for n in names] if grads else None)


def test_smooth_validity_gradients_match_central_differences():
    cfg = small()
    rc = ReducedLevelCycle(cfg, KEYS, valid=True)
    th = np.array([14.0, -19.0])
    ev = rc.evaluate(th)
    vals, der = _measures(cfg, ev, grads=True)
    d = np.array([1.0, -0.6])  # one direction mixing both keys (each key's own partial weighs in)
    h = 1e-3
    a, _ = _measures(cfg, rc.evaluate(th + h * d))
    b, _ = _measures(cfg, rc.evaluate(th - h * d))
    for k in SMOOTH_LIMITS:
        fd = (a[k] - b[k]) / (2 * h)
        assert fd == pytest.approx(float(der[k] @ d), rel=1e-4, abs=1e-7), k
        assert abs(der[k][0]) > 1e-4 and abs(der[k][1]) > 1e-4, k  # both partials non-trivial
    # the smooth values lie near the exact measures of the same cycle (the KS integral form below the
    # maximum by a few tenths of a degree; the logistic share within a few per cent of span-time)
    gait = with_values(cfg, dict(zip(KEYS, th)) | {AMP: ev.amplitude_deg})
    exact = periodic_validity(gait, ev.x0, rc.pfull(th, ev.amplitude_deg)).to_dict()
    assert abs(vals["stalled_fraction"] - exact["stalled_fraction"]) < 0.02
    assert 0 < exact["max_airflow_body_angle_deg"] - vals["max_airflow_body_angle_deg"] < 1.0
    assert 0 < exact["max_abs_pitch_deg"] - vals["max_abs_pitch_deg"] < 1.0
    assert 0 < vals["min_forward_speed_mps"] - exact["min_forward_speed_mps"] < 0.5
    # the same numbers from one RK4 period of the cycle (what level --valid reports)
    again = cycle_smooth_measures(gait, ev.x0, rc.pfull(th, ev.amplitude_deg), STEPS)
    for k in SMOOTH_LIMITS:
        assert again[k] == pytest.approx(vals[k], rel=1e-8, abs=1e-10)


def test_valid_optimum_where_the_unconstrained_one_is_not(tmp_path, capfd):
    """Least power at 18 m/s: without constraints the optimum's airflow reaches 20.2 deg to the body
    axis (limit 20); with --valid the optimum is valid, the airflow limit is the active one, and the
    power is no lower."""
    free = optimize_gait(small(), FREE, objective="power", speed_mps=18.0)
    assert free.success and free.validity is not None and not free.validity["valid"]
    assert free.validity["max_airflow_body_angle_deg"] > 20.0
    code = cli.main(["optimize-gait", "--speed", "18", "--free", KEYS[0], "--free", KEYS[1],
                     "--bounds", f"{KEYS[0]}=0:25", "--set", f"solve.steps_per_period={STEPS}", "--valid",
                     "--json", "--out", str(tmp_path / "run")])
    out, err = capfd.readouterr()
    assert code == 0, err
    r = json.loads(out)
    assert r["success"] and r["validity"]["valid"]
    vc = r["validity_constraints"]
    assert set(vc) == set(SMOOTH_LIMITS)
    for c in vc.values():
        assert {"smooth", "exact", "bound", "bound_used", "active", "kind"} <= set(c)
        assert c["exact_within_bound"]
    assert vc["max_airflow_body_angle_deg"]["active"] and vc["max_airflow_body_angle_deg"]["bound"] == 20.0
    assert not vc["min_forward_speed_mps"]["active"]
    assert r["objective_value"] >= free.objective_value - 1e-9
    assert r["validity_rounds"][-1]["exact_valid"]


def test_level_valid_reports_and_fails_on_an_invalid_cycle(tmp_path, capfd):
    """level --valid: validity_constraints in the JSON; a tightened limit (--set validity...) that
    the cycle crosses makes it exit 1 with the result written."""
    base = ["level", "--set", f"solve.steps_per_period={STEPS}", "--valid", "--json"]
    assert cli.main(base + ["--out", str(tmp_path / "a")]) == 0
    r = json.loads(capfd.readouterr().out)
    assert r["validity"]["valid"] and set(r["validity_constraints"]) == set(SMOOTH_LIMITS)
    code = cli.main(base + ["--set", "validity.max_abs_pitch_deg=3", "--out", str(tmp_path / "b")])
    captured = capfd.readouterr()
    assert code == 1 and "NOT VALID" in captured.err
    r = json.loads(captured.out)
    assert not r["validity"]["valid"] and not r["validity_constraints"]["max_abs_pitch_deg"]["exact_within_bound"]
    assert (tmp_path / "b" / "result.json").is_file()


@pytest.mark.slow
def test_optimize_stability_valid_resolved_by_level(tmp_path, capfd):
    """The done-when of issue 26 on a cheap grid: optimize-stability --valid --json returns a cycle
    whose exact validity is valid; birdocp level at its gait (free values and amplitude set, the
    optimum's state as the initial guess) reproduces its multipliers and its validity."""
    steps = ["--set", f"solve.steps_per_period={STEPS}"]
    code = cli.main(["optimize-stability", "--valid", "--json", "--free", KEYS[1], *steps,
                     "--out", str(tmp_path / "opt")])
    out, err = capfd.readouterr()
    assert code == 0, err
    r = json.loads(out)
    assert r["validity"]["valid"] and r["valid_constrained"] and set(r["validity_constraints"]) == set(SMOOTH_LIMITS)
    sets = [f"{k}={v!r}" for k, v in r["free"].items()] + [f"{AMP}={r['amplitude_deg']!r}",
                                                            f"solve.initial_guess={list(r['x0'])!r}"]
    code = cli.main(["level", "--valid", "--json", *steps, *sum((["--set", s] for s in sets), []),
                     "--out", str(tmp_path / "lv")])
    out, err = capfd.readouterr()
    assert code == 0, err
    lv = json.loads(out)
    assert abs(lv["amplitude_deg"] - r["amplitude_deg"]) < 1e-6
    a = np.sort_complex([complex(*z) for z in r["multipliers"]])
    b = np.sort_complex([complex(*z) for z in lv["multipliers"]])
    assert np.max(np.abs(a - b)) < 1e-6
    assert lv["validity"]["valid"] == r["validity"]["valid"]
    for k in ("stalled_fraction", "max_airflow_body_angle_deg", "min_forward_speed_mps", "max_abs_pitch_deg"):
        assert lv["validity"][k] == pytest.approx(r["validity"][k], rel=1e-5, abs=1e-6)


@pytest.mark.slow
def test_parallel_pareto_matches_sequential():
    """One bound of the stability-power front, traced as today (sequential) and through an executor
    wave from the same neighbour: the same optimum; rows carry validity."""
    from birdocp.engine.executors import SerialExecutor
    from birdocp.studies.gait_fronts import stability_pareto

    cfg = with_values(Config(), {"solve.steps_per_period": 16})
    opt = optimize_gait(cfg, FREE, objective="power", speed_mps=18.0)
    R = 0.995 * opt.largest_modulus
    kw = dict(free=FREE, start=dict(opt.free) | {AMP: opt.amplitude_deg}, x_guess=opt.x0)
    seq = stability_pareto(cfg, 18.0, [R], **kw)
    par = stability_pareto(cfg, 18.0, [R], executor=SerialExecutor(), start_bound=opt.largest_modulus, **kw)
    assert seq[-1]["success"] and par[0]["success"] and par[0]["started_from"] is None
    assert par[0]["objective_value"] == pytest.approx(seq[-1]["objective_value"], abs=1e-7)
    assert par[0]["largest_modulus"] <= R + 1e-6 and "validity" in par[0] and "valid" in par[0]


@pytest.mark.slow
def test_valid_power_curve_rows():
    """The power curve over valid gaits: each row is a valid least-power optimum at its speed, with
    the cycle to re-solve it, and the optima come from valid rows only."""
    from birdocp.engine.executors import SerialExecutor
    from birdocp.studies.gait_fronts import valid_power_curve

    cfg = with_values(Config(), {"solve.steps_per_period": 16})
    out = valid_power_curve(SerialExecutor(), cfg, [18.0], free=FREE)
    (row,) = out["rows"]
    assert row["success"] and row["valid"] and row["validity"]["valid"]
    assert row["mean_forward_speed_mps"] == pytest.approx(18.0, abs=1e-6)
    assert {"x0", "free", "amplitude_deg", "validity_constraints"} <= set(row)
    assert out["minimum_power"]["speed_mps"] is None  # fewer than three valid rows: no vertex claimed
