"""The bird model against the reference implementation's numbers (tests/reference, found by
birdocp.io.reference) and against independent checks (finite differences, symmetry)."""

import json

import casadi as ca
import numpy as np
import pytest

from birdocp.bird import wing
from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.bird.model import GEOMETRY_OUTPUTS, get_model, unpack_data
from birdocp.io.reference import reference_dir

REF = reference_dir()
FIX = json.loads((REF / "force_fixtures.json").read_text())


def model(**over):
    return get_model(with_values(Config(), over))


def geometry(m, t):
    return dict(zip(GEOMETRY_OUTPUTS, [np.array(v) for v in m.geometry(t, m.p0)]))


BD = {"aero.kinematic_velocity": "backward-difference"}


@pytest.mark.parametrize("g", FIX["geometry"], ids=lambda g: f"t={g['t']}")
def test_geometry_matches_reference(g):
    m = model(**BD)
    o = geometry(m, g["t"])
    assert np.allclose(o["joint_angles_rad"].ravel(), list(g["joint_angles_rad"].values()), atol=1e-12, rtol=0)
    assert np.max(np.abs(o["leading_edge_raw"].T - g["leading_edge_raw"])) < 1e-9
    assert np.max(np.abs(o["trailing_edge_raw"].T - g["trailing_edge_raw"])) < 1e-9
    assert np.max(np.abs(o["line"].T - g["merged_line_points"])) < 1e-9
    assert np.max(np.abs(o["chord_m"].ravel() - g["chord"])) < 1e-9
    # Chord and up directions at the element centres (the tips are round-off noise, never used).
    assert np.max(np.abs(o["chord_dir"].T[1::2] - np.array(g["chord_dir"])[1::2])) < 1e-9
    assert np.max(np.abs(o["up_dir"].T[1::2] - np.array(g["up_dir"])[1::2])) < 1e-9


@pytest.mark.parametrize("g", FIX["geometry"], ids=lambda g: f"t={g['t']}")
def test_kinematic_velocity(g):
    ref = np.array(g["v_kin_at_centres"])
    for mode, tol in (("backward-difference", 1e-8), ("exact", 0.005 * np.max(np.abs(ref)))):
        m = model(**{"aero.kinematic_velocity": mode})
        vk = np.array(unpack_data(m.data(g["t"], m.p0))["v_kin_mps"]).T
        assert np.max(np.abs(vk - ref)) < tol, mode


def _loads(m, pt):
    r = m.evaluate(pt["state"], pt["t"])
    return np.array([r["Fx_N"], r["Fz_N"], r["My_Nm"]]), np.array(r["xdot"])


def _ref(body):
    return np.array([body["Fx_prime"], body["Fz_prime"], body["My_prime"]])


def test_loads_exact_circulation_match_reference_to_round_off():
    m = model(**BD)
    for pt in FIX["points"]:
        loads, _ = _loads(m, pt)
        assert np.max(np.abs(loads - _ref(pt["exact_solve_body_frame"]))) < 1e-8
        gamma = np.array(m.aero_detail(pt["state"], pt["t"], m.p0)[0]).ravel()
        assert np.max(np.abs(gamma - pt["gamma_exact_linear_solve"])) < 1e-8


def test_loads_relaxed_circulation_match_reference_iteration():
    m = model(**BD, **{"aero.circulation": "relaxed"})
    tol = np.array([0.005, 0.02, 0.001])  # Fx' drag-like, Fz' lift-like, My'
    for pt in FIX["points"]:
        loads, xdot = _loads(m, pt)
        assert np.all(np.abs(loads - _ref(pt["body_frame"])) < tol)
        # The state derivative follows from the loads with the spec's equations of motion.
        assert np.allclose(xdot[3], pt["xdot"][3])
        assert abs(xdot[0] - pt["xdot"][0]) < tol[0] / 1.2 + 1e-12


def test_equations_of_motion_reproduce_reference_xdot():
    """With the reference's own loads substituted, xdot follows spec 1.2 (m = 1.2, I = 0.1, g = 9.81)."""
    m = model(**BD, **{"aero.circulation": "relaxed"})
    for pt in FIX["points"]:
        u, w, q, th = pt["state"]
        b = pt["body_frame"]
        expect = [-q * w - 9.81 * np.sin(th) + b["Fx_prime"] / 1.2,
                  q * u + 9.81 * np.cos(th) + b["Fz_prime"] / 1.2, b["My_prime"] / 0.1, q]
        assert np.allclose(expect, pt["xdot"], atol=1e-12)
        _, xdot = _loads(m, pt)
        assert np.allclose(xdot, pt["xdot"], atol=0.02)


def test_default_model_within_0p2_percent_of_lift():
    m = model()
    for pt in FIX["points"]:
        loads, _ = _loads(m, pt)
        ref = _ref(pt["exact_solve_body_frame"])
        assert np.max(np.abs(loads - ref)) < 0.002 * abs(ref[1])


def test_symmetry_lateral_force_and_mirrored_circulation():
    m = model()
    for pt in FIX["points"][:6]:
        gamma, alpha, vp, F = (np.array(v).ravel() for v in m.aero_detail(pt["state"], pt["t"], m.p0))
        assert abs(F[0]) < 1e-10
        assert np.allclose(gamma, gamma[::-1], atol=1e-12)
        assert np.allclose(alpha, alpha[::-1], atol=1e-12)


def _central(fun, x0, h):
    cols = []
    for k in range(len(x0)):
        e = np.zeros(len(x0))
        e[k] = h[k]
        cols.append((fun(x0 + e) - fun(x0 - e)) / (2 * h[k]))
    return np.array(cols).T


def test_state_jacobian_against_central_differences():
    m = model()
    x = ca.MX.sym("x", 4)
    for pt in FIX["points"][::5]:
        x0 = np.array(pt["state"], float)
        fun = lambda xx: np.array(m.f(xx, pt["t"], m.p0)).ravel()
        Jc = _central(fun, x0, [1e-5] * 4)
        J = np.array(ca.Function("J", [x], [ca.jacobian(m.f(x, pt["t"], m.p0), x)])(x0))
        assert np.allclose(J, Jc, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("name", ["gait.shoulder_flap.amplitude_deg", "wing.root_ahead_m",
                                  "gait.shoulder_incidence.offset_deg"])
def test_parameter_jacobian_against_central_differences(name):
    m = model()
    k = PARAM_NAMES.index(name)
    p = ca.MX.sym("p", len(PARAM_NAMES))
    for pt in FIX["points"][1:18:4]:
        J = ca.Function("J", [p], [ca.jacobian(m.f(pt["state"], pt["t"], p), p)])
        exact = np.array(J(m.p0))[:, k]
        h = 1e-5 * max(1.0, abs(m.p0[k]))
        e = np.zeros(len(m.p0))
        e[k] = h
        fd = (np.array(m.f(pt["state"], pt["t"], m.p0 + e)) - np.array(m.f(pt["state"], pt["t"], m.p0 - e))).ravel() / (2 * h)
        assert np.allclose(exact, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(exact))), (name, pt["t"])


@pytest.mark.parametrize("amplitude_deg", [38.0, 42.0, 48.0])
def test_emulated_discrete_steps_stay_within_their_margins(amplitude_deg):
    """The masked emulations of the reference's loops are exact only within their margins: over a
    wingbeat, corner smoothing never needs a third pass nor a third halving, the aliased walk never
    needs more advances than emulated, the improvement loop does exactly one iteration and the body
    section has one point."""
    m = get_model(with_values(Config(), {"gait.shoulder_flap.amplitude_deg": amplitude_deg}))
    times = np.linspace(0, m.period_s, 100, endpoint=False)
    Gmap = m.geometry.map(len(times))
    diag = np.array(Gmap(ca.DM(times).T, ca.repmat(ca.DM(m.p0), 1, len(times)))[GEOMETRY_OUTPUTS.index("diagnostics")])
    d = dict(zip(wing.DIAGNOSTICS, diag))
    assert np.all(d["halvings_pass2"] == 0)
    assert np.all(d["halving_margin_used"] == 0)
    assert np.all(d["walk_unfinished"] == 0)
    assert np.all(d["improve_change"] <= 0.1)
    assert np.all(d["n_mid"] == 3)
    assert 0 < np.count_nonzero(d["halvings_pass1"]) < len(times)  # the corner step does fire
