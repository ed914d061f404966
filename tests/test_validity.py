"""Validity of a cycle (birdocp.bird.validity): element angles against independent computations, the
verdict on constructed cases, and the ``validity`` object in every cycle result."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from birdocp.bird.config import Config, ConfigError, with_values
from birdocp.bird.model import get_model, unpack_data
from birdocp.bird.validity import cycle_validity, element_angles_function, validity_columns

FIXTURES = Path(__file__).parent / "reference" / "force_fixtures.json"
TIMES = (0.0, 0.06, 0.13, 0.2)
STATE = np.array([18.04, -2.0, -0.11, -0.117])


def _numpy_effective_angles(d, x):
    """Effective angles (rad) of the 16 elements from the data blocks, in plain numpy."""
    b = {k: np.asarray(v) for k, v in unpack_data(d).items()}
    u, w, q = x[0], x[1], x[2]
    r, vk, ch, up, tau = b["r_m"], b["v_kin_mps"], b["c_hat"], b["up"], b["tau"]
    V = np.vstack([-vk[0], w + q * r[2] - vk[1], u - q * r[1] - vk[2]])

    def in_plane(A):
        return A - tau * np.sum(tau * A, axis=0)

    Vp = in_plane(V)
    alpha = np.arctan2(np.sum(Vp * up, axis=0), np.sum(Vp * ch, axis=0))
    qv = np.linalg.norm(Vp, axis=0) * alpha
    W = V + np.vstack([b["Wx"] @ qv, b["Wy"] @ qv, np.zeros(16)])
    Wp = in_plane(W)
    return np.arctan2(np.sum(Wp * up, axis=0), np.sum(Wp * ch, axis=0)), alpha


def test_element_angles_match_numpy_and_the_section_lift():
    cfg = Config()
    m = get_model(cfg)
    f = element_angles_function(cfg, len(TIMES))
    X = np.tile(STATE[:, None], (1, len(TIMES)))
    ae, ag, ds = (np.asarray(v) for v in f(X, np.array([TIMES]), m.p0))
    for k, t in enumerate(TIMES):
        d = m.data(t, m.p0)
        ae_np, ag_np = _numpy_effective_angles(d, STATE)
        assert np.allclose(ae[:, k], ae_np, atol=1e-12)
        assert np.allclose(ag[:, k], ag_np, atol=1e-12)
        # physics: the section lift coefficient 2 Gamma / (c |Vp|) equals the lift slope times the
        # effective angle (linear lifting line; small-angle differences only)
        gamma, alpha, vp, _ = (np.asarray(v).ravel() for v in m.aero_detail(STATE, t, m.p0))
        chord = np.asarray(m.geometry(t, m.p0)[6]).ravel()[1::2]
        cl_over_slope = 2 * gamma / (chord * vp) / cfg.aero.lift_slope_per_rad
        assert np.max(np.abs(np.degrees(ae[:, k] - cl_over_slope))) < 0.6
        assert np.allclose(ag[:, k], alpha, atol=1e-12)
        assert np.allclose(ds[:, k], np.asarray(unpack_data(d)["ds_m"]).ravel())
    # the induced velocity matters: the effective angle is not the geometric one
    assert np.max(np.abs(np.degrees(ae - ag))) > 1.0


def test_geometric_angles_match_the_reference_implementation():
    """The geometric angle of attack against the reference implementation's alpha per element."""
    pts = json.loads(FIXTURES.read_text())["points"]
    cfg = with_values(Config(), {"aero.kinematic_velocity": "backward-difference"})
    f = element_angles_function(cfg, len(pts))
    X = np.array([p["state"] for p in pts]).T
    T = np.array([[p["t"] for p in pts]])
    p = get_model(cfg).p0
    for k, pt in enumerate(pts):
        assert pt["A_deg"] == 42 and pt["wing_root_ahead_m"] == 0.05
    _, ag, _ = (np.asarray(v) for v in f(X, T, p))
    ref = np.array([p["alpha_deg"] for p in pts]).T
    assert np.max(np.abs(np.degrees(ag) - ref)) < 1e-3


def test_constructed_invalid_cycle_names_its_reasons():
    cfg = Config()
    n = 40
    t = np.linspace(0, 0.25, n, endpoint=False)
    # slow, nose-high, airflow from below: every limit but the stall one is crossed by construction
    X = np.column_stack([np.full(n, 2.0), np.full(n, 3.0), np.zeros(n), np.full(n, math.radians(60))])
    v = cycle_validity(cfg, t, X)
    assert v.valid is False
    text = " ".join(v.reasons)
    assert "forward speed u falls to 2.00 m/s" in text
    assert "pitch angle reaches 60.0 deg" in text
    assert f"airflow at {math.degrees(math.atan2(3, 2)):.1f} deg" in text
    assert "stall" in text and v.measures["stalled_fraction"] > 0.5  # airflow at 56 deg: stalled wing
    d = v.to_dict()
    assert d["valid"] is False and d["reasons"] == v.reasons
    assert validity_columns(d)["valid"] is False

    # the same states at 20 m/s, level, are a valid cycle; tighter thresholds make it invalid
    X[:, 0], X[:, 1], X[:, 3] = 20.0, -2.0, -0.117
    ok = cycle_validity(cfg, t, X)
    assert ok.valid and ok.reasons == []
    strict = with_values(cfg, {"validity.stall_angle_deg": 2.0, "validity.min_forward_speed_mps": 25.0})
    bad = cycle_validity(strict, t, X)
    assert not bad.valid and len(bad.reasons) == 2
    assert bad.reasons[0].startswith("stall") and "forward speed" in bad.reasons[1]


def test_validity_thresholds_are_checked():
    with pytest.raises(ConfigError, match="validity.stall_angle_deg"):
        with_values(Config(), {"validity.stall_angle_deg": 0.0})
    with pytest.raises(ConfigError, match="validity.max_stalled_fraction"):
        with_values(Config(), {"validity.max_stalled_fraction": 1.5})


def _cli_json(*args):
    out = subprocess.run([sys.executable, "-m", "birdocp", *args, "--json"], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


@pytest.mark.slow
def test_trim_and_sweep_json_carry_validity(tmp_path):
    tr = _cli_json("trim", "--out", str(tmp_path / "trim"))
    v = tr["validity"]
    assert v["valid"] is True and v["reasons"] == []
    # the paper's reference cycle: the wingtips briefly pass 15 deg, a small share of span-time
    assert 15.0 < v["alpha_eff_max_deg"] < 20.0 and 0.0 < v["stalled_fraction"] < 0.05
    stored = json.loads((tmp_path / "trim" / "result.json").read_text())
    assert stored["validity"]["valid"] is True
    sw = _cli_json("sweep", "amplitude", "--from", "42", "--to", "44", "--by", "2", "--quiet",
                   "--out", str(tmp_path / "sweep"))
    assert len(sw["points"]) == 2
    for pt in sw["points"]:
        assert pt["validity"]["valid"] is True and pt["validity"]["reasons"] == []
        assert pt["valid"] is True
    csv_head = (tmp_path / "sweep" / "sweep.csv").read_text().splitlines()[0].split(",")
    assert {"valid", "invalid_reasons", "stalled_fraction"} <= set(csv_head)


@pytest.mark.slow
def test_level_json_carries_validity(tmp_path):
    lv = _cli_json("level", "--out", str(tmp_path / "level"), "--set", "solve.points=2",
                   "--set", "solve.steps_per_period=60")
    assert lv["success"] and set(lv["validity"]) >= {"valid", "reasons"}
    assert lv["validity"]["valid"] is True


def test_periodic_validity_from_x0_matches_the_trajectory():
    """A stored cycle (x0 only) re-integrated over one period gets the validity of the solved trajectory."""
    from birdocp.bird.validity import periodic_validity
    from birdocp.studies.trim import trim

    r = trim(Config())
    a = r.validity.measures
    b = periodic_validity(Config(), r.x0, r.p, t0_s=float(r.trajectory_t[0])).measures
    for k in ("alpha_eff_max_deg", "alpha_eff_min_deg", "stalled_fraction", "min_forward_speed_mps",
              "max_airflow_body_angle_deg", "pitch_min_deg"):
        assert abs(a[k] - b[k]) < 1e-8, k


@pytest.mark.slow
def test_validity_follows_the_element_count_of_a_subdivided_line():
    """``aero.span_subdivisions = 2`` (32 elements): the effective angles are the 32 of the numpy
    construction, and the six-degree-of-freedom validity of a symmetric state splits the elements into
    the two wings by the element count (left 0..15, right 16..31), so the two wings' stalled shares are
    equal and equal the planar stalled share (it took elements 0..7 and 8..15: two parts of the left wing)."""
    from birdocp.bird.config import param_vector
    from birdocp.bird.sixdof import LONGITUDINAL, sixdof_model
    from birdocp.bird.validity import effective_angles, grid_validity

    vals = {"aero.span_subdivisions": 2, "validity.stall_angle_deg": 9.0}
    cfg = with_values(Config(), vals)
    model, p = get_model(cfg).model, param_vector(cfg)
    d = model.data(0.06, p)
    ae, ag, ds = (np.asarray(v).ravel() for v in effective_angles(model.ode.nd, model.structure.normalwash)(STATE, d, p))
    assert ae.shape == ag.shape == ds.shape == (32,)
    b = {k: np.asarray(v) for k, v in unpack_data(d).items()}
    r, vk, ch, up, tau = b["r_m"], b["v_kin_mps"], b["c_hat"], b["up"], b["tau"]
    V = np.vstack([-vk[0], STATE[1] + STATE[2] * r[2] - vk[1], STATE[0] - STATE[2] * r[1] - vk[2]])
    Vp = V - tau * np.sum(tau * V, axis=0)
    alpha = np.arctan2(np.sum(Vp * up, axis=0), np.sum(Vp * ch, axis=0))
    qv = np.linalg.norm(Vp, axis=0) * alpha
    W = V + np.vstack([b["Wx"] @ qv, b["Wy"] @ qv, np.zeros(32)])
    Wp = W - tau * np.sum(tau * W, axis=0)
    np.testing.assert_allclose(ag, alpha, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ae, np.arctan2(np.sum(Wp * up, axis=0), np.sum(Wp * ch, axis=0)), rtol=0, atol=1e-12)

    cfg6 = with_values(Config(), {**vals, "model.degrees_of_freedom": 6})
    six = sixdof_model(cfg6)
    n = 8
    X6 = np.tile([17.5, 0.0, -1.0, 0.0, 0.2, 0.0, 0.0, -0.1, 0.0], (n, 1))
    v6 = grid_validity(cfg6, X6, six.params(p), steps_per_period=n, ode=six.ode).measures
    v4 = grid_validity(cfg, X6[:, list(LONGITUDINAL)], p, steps_per_period=n).measures
    assert 0.05 < v4["stalled_fraction"] < 0.95
    assert abs(v6["stalled_fraction_left"] - v6["stalled_fraction_right"]) < 1e-12
    assert abs(v6["stalled_fraction_left"] - v4["stalled_fraction"]) < 1e-12
    assert abs(v6["stalled_fraction"] - v4["stalled_fraction"]) < 1e-12
