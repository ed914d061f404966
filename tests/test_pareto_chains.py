"""The Pareto front's parallel chains (birdocp.studies.pareto.chains) and the one rule of which
variable bounds are active at an optimum (birdocp.engine.oracle.active_bounds)."""

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.engine.oracle import ACTIVE_BOUND_RTOL, active_bounds
from birdocp.studies.gait import GaitOptimum, optimize_gait

AMP = "gait.shoulder_flap.amplitude_deg"
FREE = {"gait.shoulder_incidence.offset_deg": (0.0, 25.0), "gait.shoulder_sweep.offset_deg": (-30.0, -5.0)}


def test_active_bounds_relative_to_the_range():
    """IPOPT leaves an active bound's value 5e-6..3e-5 inside (bound_push, barrier): active; a value
    further in than rtol times the range is not, whatever the range's size."""
    bounds = {"a": (0.0, 25.0), "b": (-30.0, -5.0), "c": (0.0, 1e-3), "d": (10.0, 30.0)}
    values = {"a": 3e-5, "b": -5.0 - 5e-6, "c": 5e-7, "d": 20.0}
    assert active_bounds(values, bounds) == ["a", "b"]  # c: 5e-7 is half its tiny range
    assert active_bounds({"a": 25.0 * ACTIVE_BOUND_RTOL * 2}, bounds) == []
    assert active_bounds({"a": 0.0, "unbounded": 1.0}, bounds) == ["a"]


def test_gait_optimum_reports_a_bound_ipopt_left_inside():
    """GaitOptimum.to_dict's active_bounds use the helper: 2e-5 deg off a bound is active (the old
    absolute 1e-6 missed it)."""
    nan4 = np.full(4, np.nan)
    opt = GaitOptimum(True, "ok", "", "power", 1, 5.0, 5.0, {"gait.shoulder_incidence.offset_deg": 25.0 - 2e-5},
                      {"gait.shoulder_incidence.offset_deg": (0.0, 25.0)}, {}, 40.0, nan4, nan4.astype(complex),
                      nan4.astype(complex), 18.0, 18.0, None, {}, 0.0, 0.0)
    assert opt.to_dict()["active_bounds"] == ["gait.shoulder_incidence.offset_deg"]


@pytest.mark.slow
def test_chains_match_sequential_tracing():
    """Three bounds of the stability-power front on a coarse grid, traced as today (sequential, each
    from the previous optimum, IPOPT's defaults) and as two chains (one from each known end, warm
    IPOPT starts): the same optima; which point starts from which is fixed by the plan."""
    from birdocp.engine.executors import SerialExecutor
    from birdocp.studies.gait_fronts import stability_pareto

    cfg = with_values(Config(), {"solve.steps_per_period": 16})
    opt = optimize_gait(cfg, FREE, objective="power", speed_mps=18.0)
    top = opt.largest_modulus
    bounds = [0.998 * top, 0.996 * top, 0.994 * top]
    kw = dict(free=FREE, start=dict(opt.free) | {AMP: opt.amplitude_deg}, x_guess=opt.x0)
    seq = stability_pareto(cfg, 18.0, bounds, **kw)
    low = seq[-1]
    anchor = {"bound": 0.993 * top, "free": low["free"], "amplitude_deg": low["amplitude_deg"], "x0": low["x0"]}
    par = stability_pareto(cfg, 18.0, bounds, executor=SerialExecutor(), start_bound=top, anchors=[anchor],
                           wave=2, **kw)
    assert [r["bound"] for r in par] == bounds and all(r["success"] for r in seq + par)
    # chain 1: the two lower bounds from the anchor upward; chain 2: the top bound from the start
    assert [r["started_from"] for r in par] == [None, bounds[2], anchor["bound"]]
    for a, b in zip(seq, par):
        assert b["objective_value"] == pytest.approx(a["objective_value"], abs=1e-7)
        assert b["largest_modulus"] <= b["bound"] + 1e-6
