"""Wagner's unsteady section and dynamic stall in six degrees of freedom (birdocp.bird.sixdof_unsteady,
birdocp.studies.lateral_aero). Exact properties: the 6-DOF added-mass vectors are the gradient of the
mid-chord normalwash built from the 6-DOF air velocity (a second construction) and their data rates the
time derivatives of the data; at a symmetric state the 6-DOF right-hand side is the planar one (body and
aerodynamic states); swapping the per-side offsets mirrors the equations ((v, p, r, phi, psi) change
sign, element j's aerodynamic states trade places with element 15 - j's); a symmetric gait's 6-DOF Wagner
cycle is the planar Wagner cycle with a block-diagonal monodromy in the mirror basis."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from birdocp.bird import unsteady
from birdocp.bird.config import Config, param_vector, with_values
from birdocp.bird.model import N_EL, get_model, unpack_data
from birdocp.bird.sides import side_vector, swap_sides
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL, air_velocity, body_loads, sixdof_model
from birdocp.bird import sixdof_unsteady as am6
from birdocp.studies.lateral_aero import mirror_basis, mirror_state, split_indices

WAGNER = {"aero.unsteady": "wagner"}
DYN = {"aero.section": "dynamic-stall"}
MIRROR = np.array([1, -1, 1, -1, 1, -1, -1, 1, -1.0])
TURN = {"gait.right_offset.shoulder_flap.amplitude_deg": 6.0, "gait.right_offset.shoulder_sweep.offset_deg": -4.0,
        "gait.left_offset.elbow_flex.offset_deg": 5.0}


def _six(**extra):
    return with_values(Config(), {"model.degrees_of_freedom": 6, **extra})


def _state(six, rng, symmetric):
    """A state off the cycle: body states, then the aerodynamic states (symmetric over the wings or not)."""
    x = np.array([17.5, 0.0, -1.0, 0.0, 0.2, 0.0, 0.0, -0.1, 0.0]) if symmetric else \
        np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7])
    air = []
    for name in six.state_names[9::N_EL]:
        e = rng.uniform(0.6, 1.0, N_EL) if name.startswith("f_sep") else rng.normal(0.0, 0.5, N_EL)
        air.append(np.r_[e[:8], e[:8][::-1]] if symmetric else e)
    return np.concatenate([x, *air])


@pytest.mark.slow
def test_added_mass_vectors_are_the_gradient_of_the_mid_chord_normalwash():
    """a_j = d w_mid,j / d(u, v, w, p, q, r), w_mid = V . n_hat + c omega / 4 from the 6-DOF air velocity
    and section pitch rate, on an asymmetric gait; the data rates of a_j (rows v, p, r) and tau_hat are
    their time derivatives (central differences, 1e-6 relative). At an asymmetric state: every row acts."""
    cfg = _six(**WAGNER)
    six = sixdof_model(cfg)
    p6 = six.params(param_vector(cfg))
    x, d = ca.SX.sym("x", six.ode.nx), ca.SX.sym("d", six.ode.nd)
    _, _, e = body_loads(x, d, ca.SX(p6[:len(param_vector(cfg))]), section=six.section)
    b = unpack_data(d)
    k0 = six.section.data_offset
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    V = air_velocity(x, b["r_m"], b["v_kin_mps"])
    w_mid = ca.sum1(V * ud["n_hat"]) + 0.25 * b["chord_m"].T * e["sec"]["omega"]
    terms = am6.added_mass_terms(e["sec"], ud, d[k0 + unsteady.data_size(N_EL):], {"r": b["r_m"], "chord": b["chord_m"],
                                 "ds": b["ds_m"]}, x[0:6], {"rho": 1.2, "chi_nc": 1.0})
    f = ca.Function("f", [x, d], [ca.jacobian(w_mid, x)[:, 0:6].T, terms["a"]])
    rng = np.random.default_rng(3)
    xv = _state(six, rng, symmetric=False)
    rates = ca.Function("r", [d], [am6.lateral_rows(b["r_m"], ud["n_hat"], ud["tau_hat"], b["chord_m"].T),
                                   ud["tau_hat"], d[k0 + unsteady.data_size(N_EL):]])
    h = 1e-5
    for t in (0.03, 0.16):
        grad, a = (np.asarray(v) for v in f(xv, six.data(t, p6)))
        np.testing.assert_allclose(a, grad, rtol=0, atol=1e-12 * np.abs(grad).max())
        assert np.abs(a[[1, 3, 5]]).max() > 1e-2  # the normal does couple v, p, r
        lat_p, th_p, _ = (np.asarray(v) for v in rates(six.data(t + h, p6)))
        lat_m, th_m, _ = (np.asarray(v) for v in rates(six.data(t - h, p6)))
        data6 = np.asarray(rates(six.data(t, p6))[2]).ravel()
        fd = np.concatenate([((lat_p - lat_m) / (2 * h)).ravel(order="F"), ((th_p - th_m) / (2 * h)).ravel(order="F")])
        np.testing.assert_allclose(data6, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


@pytest.mark.slow
@pytest.mark.parametrize("section", [WAGNER, DYN], ids=["wagner", "dynamic-stall"])
def test_symmetric_state_is_planar_and_swapped_offsets_mirror_the_equations(section):
    """At a symmetric state (aerodynamic states symmetric over the wings) the 6-DOF right-hand side is
    the planar model's (body and aerodynamic rows, 1e-12) with zero lateral rows; with Wagner's section
    (the 6 x 6 added mass) and the per-side offsets swapped, the mirrored state's derivative is the
    mirrored derivative (1e-12 relative). (Dynamic stall's mirror is that of the stall section's law with
    one more state per element; its per-side model is not built here, to keep the test short.)"""
    cfg = _six(**section)
    six, planar = sixdof_model(cfg), get_model(with_values(Config(), section))
    p = param_vector(cfg)
    rng = np.random.default_rng(5)
    x = _state(six, rng, symmetric=True)
    x4 = np.concatenate([x[list(LONGITUDINAL)], x[9:]])
    for t in (0.0, 0.11):
        f6 = np.array(six.rhs(x, six.data(t, six.params(p)), six.params(p))).ravel()
        f4 = np.array(planar.rhs(x4, planar.data(t, p), p)).ravel()
        np.testing.assert_allclose(np.concatenate([f6[list(LONGITUDINAL)], f6[9:]]), f4, rtol=0,
                                   atol=1e-12 * np.abs(f4).max())
        assert np.abs(f6[list(LATERAL)]).max() < 1e-11
    if section is not WAGNER:
        return
    turn = _six(**section, **TURN)
    sides = sixdof_model(turn)
    off = side_vector(turn)
    pa, pb = sides.params(p, offsets=off), sides.params(p, offsets=swap_sides(off))
    x = _state(sides, rng, symmetric=False)
    for t in (0.02, 0.13):
        f = np.array(sides.rhs(x, sides.data(t, pa), pa)).ravel()
        fm = np.array(sides.rhs(mirror_state(x, 9, MIRROR), sides.data(t, pb), pb)).ravel()
        np.testing.assert_allclose(fm, mirror_state(f, 9, MIRROR), rtol=0, atol=1e-12 * np.abs(f).max())
        assert np.abs(f[list(LATERAL)]).max() > 1e-2


@pytest.mark.slow
def test_wagner_cycle_of_a_symmetric_gait_is_the_planar_wagner_cycle():
    """6 DOF with Wagner's section against the planar Wagner trim (3 points, 48 RK4 steps): x0 with the
    lag states to 1e-9, the longitudinal multipliers (body and symmetric lag states) equal the planar
    monodromy's symmetric block to 1e-9, coupling of the blocks below 1e-10, heading multiplier 1, four
    lateral body modes."""
    from birdocp.studies.lateral import lateral_trim
    from birdocp.studies.trim import trim

    six = lateral_trim(_six(**WAGNER), points=3, steps_per_period=48)
    planar = trim(with_values(Config(), WAGNER), points=3, steps_per_period=48)
    assert six.success and planar.success
    x0 = np.asarray(six.cycle.x0)
    np.testing.assert_allclose(np.concatenate([x0[list(LONGITUDINAL)], x0[9:]]), planar.x0, rtol=0, atol=1e-9)
    assert np.abs(x0[list(LATERAL)]).max() < 1e-10
    B = mirror_basis(4, 32)
    lon, anti = split_indices(range(4), (), 4, 32)
    Mp = B @ np.asarray(planar.cycle.monodromy) @ B.T
    assert np.abs(Mp[np.ix_(lon, anti)]).max() < 1e-10  # the planar model's own mirror split
    np.testing.assert_allclose(np.sort_complex(six.longitudinal_multipliers),
                               np.sort_complex(np.linalg.eigvals(Mp[np.ix_(lon, lon)])), rtol=0, atol=1e-9)
    assert six.coupling_max < 1e-10 and abs(six.heading_multiplier - 1) < 1e-12
    labels = sorted(m["label"] for m in six.lateral_modes if m["label"] != "aerodynamic")
    assert labels == ["dutch_roll_like", "dutch_roll_like", "roll_subsidence", "spiral"]
    assert len(six.lateral_multipliers) == 4 + 16 and six.validity.valid


@pytest.mark.slow
def test_one_added_mass_law_serves_the_planar_and_the_sixdof_model(monkeypatch):
    """The planar and the 6-DOF Wagner sections put their added mass through the one element law
    (:func:`birdocp.bird.unsteady.added_mass_loads`, counted by a spy), and for a symmetric gait at a
    symmetric state (v = p = r = 0) the 6-DOF law on (u, v, w, p, q, r) gives the planar M_A and b_nc on
    (u, w, q) (the planar data against the 6-DOF assembly of the lateral rows, 1e-12 relative), with no
    longitudinal-lateral coupling in M_A (mirror symmetry, 1e-12)."""
    from birdocp.bird.loads import section_terms, unsteady_params

    cfg = _six(**WAGNER)
    six, planar = sixdof_model(cfg), get_model(with_values(Config(), WAGNER)).model
    calls = []
    law = unsteady.added_mass_loads
    monkeypatch.setattr(unsteady, "added_mass_loads", lambda nu, *a: calls.append(nu.shape[0]) or law(nu, *a))
    p = param_vector(cfg)
    p6 = six.params(p)
    x, d = ca.SX.sym("x", six.ode.nx), ca.SX.sym("d", six.ode.nd)
    _, _, e = body_loads(x, d, ca.SX(p6[:len(p)]), section=six.section)
    b = unpack_data(d)
    k0 = six.section.data_offset
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    terms = am6.added_mass_terms(e["sec"], ud, d[k0 + unsteady.data_size(N_EL):],
                                 {"r": b["r_m"], "chord": b["chord_m"], "ds": b["ds_m"]}, x[0:6], unsteady_params(p))
    x4, d4 = ca.SX.sym("x4", planar.ode.nx), ca.SX.sym("d4", planar.ode.nd)
    sec4 = section_terms(planar.structure, x4, d4, ca.SX(p))
    assert sorted(calls) == [3, 6]
    f6 = ca.Function("f6", [x, d], [terms["M_A"], terms["b_nc"]])
    f4 = ca.Function("f4", [x4, d4], [sec4["M_A"], sec4["b_nc"]])
    xv = _state(six, np.random.default_rng(7), symmetric=True)
    lon = [0, 2, 4]
    for t in (0.04, 0.19):
        MA6, b6 = (np.asarray(v) for v in f6(xv, six.data(t, p6)))
        MA4, b4 = (np.asarray(v) for v in f4(np.concatenate([xv[lon + [7]], xv[9:]]), planar.data(t, p)))
        np.testing.assert_allclose(MA6[np.ix_(lon, lon)], MA4, rtol=0, atol=1e-12 * np.abs(MA4).max())
        np.testing.assert_allclose(b6[lon], b4, rtol=0, atol=1e-12 * np.abs(b4).max())
        assert np.abs(MA6[np.ix_(lon, [1, 3, 5])]).max() < 1e-12 * np.abs(MA4).max()
        assert np.abs(MA6[np.ix_([1, 3, 5], [1, 3, 5])]).min() >= 0 and np.abs(MA6[1, 1]) > 1e-6
