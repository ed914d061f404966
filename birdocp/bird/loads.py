"""The aerodynamic and body loads of the bird at one (state, data, parameters), as expressions.

:func:`load_terms` is the one code path for the dynamics (``BirdModel.rhs``) and the power outputs
(:mod:`birdocp.bird.energetics`); with an unsteady or stall section it calls
:func:`birdocp.bird.unsteady.section_loads` (:func:`section_terms`) and puts the added mass on the
left of the equations of motion (:func:`_with_added_mass`).
"""

from __future__ import annotations

import casadi as ca

from birdocp.bird import aero
from birdocp.bird import tail
from birdocp.bird import unsteady
from birdocp.bird.layout import N_EL, N_MASS, Structure, n_data, param as _p, unpack_data

def unsteady_params(p) -> dict:
    """The numbers of :func:`birdocp.bird.unsteady.section_loads` (``prm``) from the parameter vector p.

    Parameters
    ----------
    p : casadi.SX
        Parameter vector.

    Returns
    -------
    dict
    """
    a0 = 1.0 - _p(p, "aero.wagner_weight") * (unsteady.A1 + unsteady.A2)
    return {"rho": _p(p, "aero.air_density_kgm3"), "cla": _p(p, "aero.lift_slope_per_rad"),
            "eps": _p(p, "aero.wagner_weight"), "a0": a0, "kappa": _p(p, "aero.wagner_time_scale"),
            "chi_w": _p(p, "aero.pitch_rate_weight"), "chi_nc": _p(p, "aero.added_mass_weight"),
            "alpha1": _p(p, "aero.separation_angle_deg") * (ca.pi / 180), "cd90": _p(p, "aero.flat_plate_cd90"),
            "Tf": _p(p, "aero.separation_lag_semichords"), "T2": _p(p, "aero.separation_delay_semichords")}


def _opts(structure: Structure) -> dict:
    return {"unsteady": structure.unsteady, "section": structure.section, "newton_steps": structure.newton_steps}


def unsteady_data_offset(structure: Structure) -> int:
    """Where the unsteady data blocks start in the data vector (after the wing-mass sums).

    Parameters
    ----------
    structure : Structure
        Structure of the model.

    Returns
    -------
    int
    """
    return n_data(structure.n_elements) + (N_MASS if structure.wing_mass else 0)


def section_terms(structure: Structure, x, d, p) -> dict:
    """:func:`birdocp.bird.unsteady.section_loads` of an unsteady/stall structure at the air-relative
    state x (4 + aerodynamic states) and data d.

    Parameters
    ----------
    structure : Structure
        Structure of the model.
    x : casadi.SX
        Air-relative state.
    d : casadi.SX
        Data vector.
    p : casadi.SX
        Parameter vector.

    Returns
    -------
    dict
    """
    b = unpack_data(d)
    k0 = unsteady_data_offset(structure)
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    base = {"r": b["r_m"], "v_kin": b["v_kin_mps"], "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"],
            "ds": b["ds_m"], "chord": b["chord_m"]}
    wake = {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}
    return unsteady.section_loads(_opts(structure), x[0:3], x[4:], base, ud, wake, unsteady_params(p))


def load_terms(structure: Structure, x, d, p, x_inertial=None, wind_rate=None) -> dict:
    """Every aerodynamic load term at state x (SX), data d and parameters p, as expressions.

    The one code path for the dynamics (:class:`BirdModel` ``rhs``) and the power outputs
    (:mod:`birdocp.bird.energetics`). Keys: per element (code frame, 3 x 16) ``r``, ``v_kin``, ``V``,
    ``Vp``, ``vind``, ``dF`` (lifting-line force) and ``dD`` (profile drag, zeros without drag); the
    parasite force ``F_par`` (3 x 1, code frame); the tail's ``tail`` = (L_t, D_t, M_t) or None; the
    wing's code-frame force ``F_code`` and the body loads ``Fx_N``, ``Fz_N``, ``My_Nm`` (everything
    included); ``Gamma``, ``alpha`` (16 x 1), ``Vp_norm`` (16 x 1).

    With an unsteady or stall section (``structure.aero_extra``) x carries the aerodynamic states after
    (u, w, q, theta) and ``x_inertial`` (default x) is the inertial body state of the kinematic terms;
    ``dF`` is then the attached force at the quarter chord, and the extra keys are ``sec`` (the dict of
    :func:`birdocp.bird.unsteady.section_loads`), ``dF_mid`` (separated + added-mass force at mid-chord,
    3 x 16), ``couple`` (1 x 16 added-mass couples about tau_hat, N m), ``nudot`` (u', w', q' with the
    added mass on the left) and ``xdot_aero``; the body loads include the added-mass reaction, to the
    air-relative acceleration nu' - (wind_rate, 0) with a wind rate (``wagner`` only).

    Parameters
    ----------
    structure : Structure
        Structure of the model.
    x : casadi.SX
        State (air-relative with a wind).
    d : casadi.SX
        Data vector.
    p : casadi.SX
        Parameter vector.
    x_inertial : casadi.SX, optional
        Inertial body state (default ``x``).
    wind_rate : casadi.SX, optional
        d/dt of the wind's body-frame components (:func:`birdocp.bird.layout.air_wind_rate`) [m/s^2];
        None: no wind rate (today's graph).

    Returns
    -------
    dict
        Name to expression.
    """
    b = unpack_data(d, structure.n_elements)
    rho = _p(p, "aero.air_density_kgm3")
    r = b["r_m"]
    sec = None
    if structure.aero_extra:
        sec = section_terms(structure, x, d, p)
        e = {k: sec[k] for k in ("V", "Vp", "vind", "Vp_norm", "alpha", "Gamma")}
        e["dF"] = sec["dF_att"]
        F, M = sec["F"], sec["M"]
    else:
        e = aero.element_forces(x, b["r_m"], b["v_kin_mps"], b["c_hat"], b["up"], b["tau"], b["ds_m"],
                                b["G"], b["Wx"], b["Wy"], rho, structure.normalwash)
        F = ca.sum2(e["dF"])
        M = aero.moment_about_G(r, e["dF"])
    out = {"r": r, "v_kin": b["v_kin_mps"], "V": e["V"], "Vp": e["Vp"], "vind": e["vind"], "dF": e["dF"],
           "dD": ca.SX.zeros(3, r.shape[1]), "F_par": ca.SX.zeros(3, 1), "tail": None,
           "Gamma": e["Gamma"], "alpha": e["alpha"].T, "Vp_norm": e["Vp_norm"].T}
    if structure.drag:
        # profile drag at the element centres, parasite drag at G along the free stream (0, w, u)
        dD = aero.profile_drag(e["Vp"], e["Vp_norm"], b["chord_m"], b["ds_m"], rho,
                               _p(p, "drag.profile_drag_coefficient"))
        U_inf = ca.vertcat(0, x[1], x[0])
        F_par = 0.5 * rho * _p(p, "drag.body_frontal_area_m2") * _p(p, "drag.body_drag_coefficient") \
            * ca.norm_2(U_inf) * U_inf
        F = F + ca.sum2(dD) + F_par
        M = M + aero.moment_about_G(r, dD)
        out.update(dD=dD, F_par=F_par)
    Fx, Fz, My = -F[2], -F[1], M
    if structure.tail:
        Lt, Dt, Mt = tail.tail_loads(x, b["nodes_m"], e["Gamma"], rho,
                                     *[_p(p, f"tail.{k}") for k in (
                                         "opening_angle_deg", "root_behind_m", "length_m",
                                         "kinematic_viscosity_m2ps", "reynolds_speed_mps", "incidence_deg")])
        Fx, Fz, My = Fx - Dt, Fz - Lt, My + Mt
        out["tail"] = (Lt, Dt, Mt)
    if sec is not None:
        Fx, Fz, My = _with_added_mass(out, sec, Fx, Fz, My, x if x_inertial is None else x_inertial, p,
                                      wind_rate)
        F = F + ca.sum2(out["dF_mid"] - sec["dF_mid"])  # the added-mass force (code frame)
    out.update(F_code=F, Fx_N=Fx, Fz_N=Fz, My_Nm=My)
    return out


def _with_added_mass(out, sec, Fx, Fz, My, xi, p, wind_rate=None):
    """Body accelerations with the added mass on the left, (M_b + M_A) nu' = b + b_nc, and the body loads
    with the added-mass reaction; fills ``nudot``, ``xdot_aero``, ``dF_mid``, ``couple``, ``sec`` of ``out``.
    With ``wind_rate`` (body frame) the added mass sees the air-relative acceleration nu' - W', W' =
    (wind_rate, 0): b_nc gains M_A W' (the wind is uniform, so q' and the couples are unchanged)."""
    m = _p(p, "body.mass_kg")
    I = _p(p, "body.pitch_inertia_kgm2")
    grav = _p(p, "body.gravity_mps2")
    u, w, q, theta = xi[0], xi[1], xi[2], xi[3]
    out["sec"] = sec
    out["xdot_aero"] = sec["zdot"]
    if not sec["wagner"]:  # no added mass: today's equations of motion
        out["nudot"] = ca.vertcat(-q * w - grav * ca.sin(theta) + Fx / m, q * u + grav * ca.cos(theta) + Fz / m,
                                  My / I)
        out["dF_mid"] = sec["dF_mid"]
        out["couple"] = ca.SX.zeros(1, N_EL)
        out["loads_held"] = ca.vertcat(Fx, Fz, My)
        return Fx, Fz, My
    bvec = ca.vertcat(m * (-q * w - grav * ca.sin(theta)) + Fx + sec["b_nc"][0],
                      m * (q * u + grav * ca.cos(theta)) + Fz + sec["b_nc"][1], My + sec["b_nc"][2])
    MA, b_nc, rel = sec["M_A"], sec["b_nc"], ca.SX.zeros(3, 1)
    if wind_rate is not None:
        rel = ca.vertcat(wind_rate[0], wind_rate[1], 0)  # the air's acceleration in the body frame
        b_nc = b_nc + MA @ rel
        bvec = bvec + MA @ rel
    nudot = unsteady.solve_sym3(ca.diag(ca.vertcat(m, m, I)) + MA, bvec)
    react = b_nc - MA @ nudot
    out["nudot"] = nudot
    out["loads_held"] = ca.vertcat(Fx, Fz, My) + b_nc  # body accelerations held at zero
    # added-mass force per element along n_hat and the couples, with the solved air-relative accelerations
    nc = sec["nc_coef"] + sec["m_a_chi"] * ((nudot - rel).T @ sec["a"])
    out["dF_mid"] = sec["dF_mid"] + ca.repmat(nc, 3, 1) * sec["n_hat"]
    out["couple"] = sec["couple0"] - sec["m_theta_chi"] * sec["tau1"] * nudot[2]
    return Fx + react[0], Fz + react[1], My + react[2]

