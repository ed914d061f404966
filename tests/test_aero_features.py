"""Engine features on models with aerodynamic states (docs/model_unsteady.md, "Features"): the
wingbeat map and feedback design with Wagner's lag states, the stall sections' start, the held-body
loads of the UVLM comparison.

Independent checks: the wingbeat map's monodromy (forward AD through the interval maps) against the
trim's Floquet multipliers (the engine's variational shooting); the held loads against the quasi-steady
model in steady flow, where Wagner's lag states settle on the quasi-steady normalwash.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values

ROOT = Path(__file__).resolve().parents[1]
STEPS = 64  # RK4 at 4 Hz: h lambda2 = 1.9 at the tip (stable below 2.78; 40 steps diverge)


@pytest.fixture(scope="module")
def lag_trim():
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), {"aero.unsteady": "wagner", "solve.steps_per_period": STEPS})
    r = trim(cfg)
    assert r.success
    return r


@pytest.mark.slow
def test_control_with_lag_states(lag_trim):
    """The wingbeat map of a wagner cycle is over all 36 states; its monodromy has the trim's
    multipliers; the LQR's body-state gains stabilise the full linearised map."""
    from birdocp.studies.control import closed_loop_monodromy, design_controller, sorted_eigs

    ctl = design_controller(lag_trim, ["sweep"], updates_per_beat=1)
    wm = ctl.map
    assert wm.A.shape == (1, 36, 36) and wm.manifold.shape == (1, 32, 4)
    floquet = np.asarray(lag_trim.multipliers)
    ours = wm.multipliers[:len(floquet)]
    assert np.allclose(np.abs(ours[:3]), np.abs(floquet[:3]), rtol=1e-7)
    assert abs(ours[0]) > 1.3  # the ibis's expanding mode survives the lag
    assert ctl.K.shape == (1, 1, 4) and ctl.x_starts.shape == (1, 4)  # what simulate feeds back
    rho = ctl.spectral_radius
    assert rho < 1.0
    # the closed loop evaluated by hand on the full map with the body gains padded by zeros
    Kpad = np.concatenate([ctl.K, np.zeros((1, 1, 32))], axis=2)
    by_hand = sorted_eigs(closed_loop_monodromy(wm.A, wm.B, Kpad))[0]
    assert math.isclose(np.max(np.abs(by_hand)), rho, rel_tol=1e-12)
    d = ctl.to_dict()
    assert d["aero_states"] == 32 and d["full_state_spectral_radius"] < 1.0
    assert np.asarray(d["gains"]).shape == (1, 1, 4) and len(d["cycle_x0"]) == 4


@pytest.mark.slow
def test_held_steady_lift_equals_quasi_steady():
    """Not flapping, body held: Wagner's lag states settle on the quasi-steady normalwash and the
    lift equals the quasi-steady model's (the UVLM comparison's held loads carry no added-mass
    reaction to a free body's acceleration; with it the lift was 0.7 % low)."""
    sys.path.insert(0, str(ROOT / "scripts" / "reference_uvlm"))
    try:
        from compare import birdocp_steady
    finally:
        sys.path.pop(0)
    inputs = json.loads((ROOT / "results" / "aero" / "uvlm" / "inputs.json").read_text())
    qs = birdocp_steady(inputs, "none", 1)
    lag = birdocp_steady(inputs, "wagner", 4)
    assert qs["lift_N"] > 10
    assert abs(lag["lift_N"] - qs["lift_N"]) < 1e-4 * qs["lift_N"]
    assert abs(lag["thrust_N"] - qs["thrust_N"]) < 1e-4 * abs(qs["lift_N"])


@pytest.mark.slow
def test_quasi_steady_limit_multipliers():
    """Recipe 12(c): with epsilon = 0 (chi = 0) the lag states decay on their own (z' = -lambda z)
    and only feed the body: the body multipliers are today's, and the slow aerodynamic multipliers
    are exp(-integral of lambda1_j dt) over the cycle, lambda1_j = 2 b1 |Vp_j| / (kappa c_j)."""
    import casadi as ca

    from birdocp.bird import unsteady
    from birdocp.bird.model import get_model, unpack_data
    from birdocp.studies.trim import trim

    base = with_values(Config(), {"solve.steps_per_period": STEPS})
    today = trim(base)
    cfg = with_values(base, {"aero.unsteady": "wagner", "aero.wagner_weight": 0.0,
                             "aero.pitch_rate_weight": 0.0, "aero.added_mass_weight": 0.0})
    lag = trim(cfg, x_guess=today.cycle.x0)
    assert today.success and lag.success
    body = np.asarray(today.multipliers)
    mult = np.asarray(lag.multipliers)
    for lam in body[:3]:  # the three body multipliers outside the lag states' cluster
        assert np.min(np.abs(mult - lam)) < 1e-10 * max(1.0, abs(lam))
    # the lag states' slow multipliers from the cycle's trajectory (Simpson over the RK4 stage points)
    m = get_model(cfg)
    p = ca.DM(m.p0)
    t = np.asarray(lag.cycle.trajectory_t, float)
    X = np.asarray(lag.cycle.trajectory_x, float)
    lam1 = []
    for tk, xk in zip(t, X):
        d = m.data(float(tk), p)
        vp = np.asarray(m.detail_d(ca.DM(xk), d, p)[2]).ravel()
        chord = np.asarray(unpack_data(d)["chord_m"]).ravel()
        lam1.append(2 * unsteady.B1 * vp / chord)
    assert t[-1] - t[0] > 0.99 * m.period_s
    L1 = np.array(lam1)
    integral = np.sum(0.5 * (L1[1:] + L1[:-1]) * np.diff(t)[:, None], axis=0)  # trapezoid
    # the slow ones (> 1e-2 per beat; for faster ones the trapezoid and RK4's own damping differ from
    # exp(-integral) by more: 1.6e-3 at 0.005 with 64 steps)
    expected = np.sort(np.exp(-integral)[np.exp(-integral) > 1e-2])[::-1]
    aero = np.sort(np.abs([z for z in mult if np.min(np.abs(body - z)) > 1e-8]))[::-1]
    assert len(expected) >= 6
    assert np.allclose(aero[:len(expected)], expected, rtol=1e-3)
    assert aero[len(expected)] < 1e-2  # nothing else that slow
