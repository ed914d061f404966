"""The power of the bird in six degrees of freedom, per wing: what each shoulder delivers in 3-D, with an
asymmetric gait (a turn) or a symmetric one (the equations: docs/studies/lateral.md, *Power in six degrees
of freedom*; the planar powers: :mod:`birdocp.bird.energetics`).

Every power is computed from the same element forces and velocities as the 6-DOF dynamics
(:func:`birdocp.bird.sixdof.body_loads`), in the code frame (e1 right, e2 up, e3 back; dot products are
frame-invariant). Element j (of both wings, left tip to right tip: the first half the left wing, the
second half the right) carries the force F_j (lifting line, plus the profile drag when on) at r_j moving
at v_kin,j relative to the body; a stall-aware section adds F_mid,j at the mid-chord point r_mid,j moving
at r_mid,j':

* ``flapping power of a wing`` P_flap,s = -sum_{j in s} (F_j . v_kin,j + F_mid,j . r_mid,j'): the power
  the shoulder of wing s supplies against the air through the wing's motion relative to the body;
* ``aerodynamic_power_W`` P_aero = sum_j (F_j . V_j + F_mid,j . V_mid,j) + F_par . U_inf + P_tail: the
  power delivered to the air (V the air velocity without the induced part, :func:`birdocp.bird.sixdof.air_velocity`);
* ``body_power_W`` P_body = X u + Y v + Z w + L p + M q + N r: the power of all aerodynamic loads on the
  body's rigid motion;
* instantaneous identity P_flap,right + P_flap,left = P_aero + P_body (round-off, every evaluation), and
  dE_b/dt = P_body + m g_b . v with E_b = m |v|^2 / 2 + omega^T J omega / 2 (massless wings), so over a
  level cycle, periodic up to its heading, mean P_sh = mean P_aero.

The shoulder power of wing s is ``right_shoulder_power_W`` / ``left_shoulder_power_W`` = P_flap,s + the
wing's inertial power sum_{i in s} m_i (a_i - g_b) . r_i' (wings with mass, :func:`inertial_power`, from
per-wing sums that :func:`power_ode` appends to the data); their sum is the bird's shoulder power (the
planar model's for a symmetric gait at a symmetric state, to round-off). Wagner's added mass (its
reaction is not split per element) is refused by :func:`check_power_model`.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError
from birdocp.bird.model import unpack_data
from birdocp.bird.sides import SIDE_PARAM_NAMES, side_parameters
from birdocp.bird.sixdof import LATERAL_PARAM_NAMES, air_velocity, body_loads, tail_body_loads
from birdocp.bird.sixdof_inertia import mass_sums_3d
from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.ode import ODE

__all__ = ["SIXDOF_POWER_NAMES", "power_terms", "sixdof_power_function", "check_power_model",
           "smooth_positive_power", "CYCLE_POWER_OUTPUTS", "cycle_power_outputs", "power_ode", "inertial_power",
           "N_WING_POWER_SUMS", "sampled_wing_powers"]

SIXDOF_POWER_NAMES = ("aerodynamic_power_W", "body_power_W", "right_shoulder_power_W", "left_shoulder_power_W")
"""Rows of :func:`sixdof_power_function` [W]."""


def _side_sums(values):
    """(left, right) sums of a 1 x n row of element values (left wing: the first half)."""
    n = values.shape[1]
    return ca.sum2(values[:, :n // 2]), ca.sum2(values[:, n // 2:])


def power_terms(x, d, p6, structure, section=None) -> dict:
    """The powers of :data:`SIXDOF_POWER_NAMES` (and ``flapping_power_W``, their shoulder sum) as SX at the
    9-state ``x`` (then the section's aerodynamic states), data ``d`` and 6-DOF parameters ``p6``.

    Parameters
    ----------
    x : casadi.SX
        9-state (body axes) and the aerodynamic states of ``section``.
    d : casadi.SX
        Data vector of the 6-DOF model.
    p6 : casadi.SX
        6-DOF parameter vector.
    structure : Structure
        The planar model's structure (tail, drag, normal wash).
    section : SectionLaw, optional
        The stall-aware section (:class:`birdocp.bird.sixdof.SectionLaw`; not Wagner's).

    Returns
    -------
    dict
        Name to scalar SX [W].
    """
    p = p6[:len(PARAM_NAMES)]
    Fb, Mb, e = body_loads(x, d, p, with_tail=bool(structure.tail), with_drag=bool(structure.drag),
                           section=section, normalwash=getattr(structure, "normalwash", "angle"))
    b = unpack_data(d)
    F = e["dF"] + e["dD"] if "dD" in e else e["dF"]
    flap = -ca.sum1(F * b["v_kin_mps"])             # 1 x n: -F_j . v_kin,j
    aero = ca.sum1(F * e["V"])                      # 1 x n: F_j . V_j
    if section is not None:  # the separated force at mid-chord, moving at r_mid'
        rmd = e["sec"]["r_mid_dot"]
        flap = flap - ca.sum1(e["dF_mid"] * rmd)
        aero = aero + ca.sum1(e["dF_mid"] * air_velocity(x, e["r_mid"], rmd))
    left, right = _side_sums(flap)
    u, v, w, pr, q, rr = (x[i] for i in range(6))
    P_aero = ca.sum2(aero)
    if "F_par" in e:
        P_aero = P_aero + ca.dot(e["F_par"], ca.vertcat(-v, w, u))
    if structure.tail:  # body-fixed: the power it takes from the body is the power it gives the air
        Lt, Dt, Mt = tail_body_loads(x, b, e["Gamma"], p)
        P_aero = P_aero - (-Dt * u - Lt * w + Mt * q)
    P_body = ca.dot(Fb, ca.vertcat(u, v, w)) + ca.dot(Mb, ca.vertcat(pr, q, rr))
    return {"aerodynamic_power_W": P_aero, "body_power_W": P_body, "right_shoulder_power_W": right,
            "left_shoulder_power_W": left, "flapping_power_W": right + left}


N_WING_POWER_SUMS = 13
"""Per-wing sums after the 6-DOF data in :func:`power_ode` (right wing, then left): S' (3) [kg m/s],
h (3) [kg m^2/s], I_w' (upper triangle, 6) [kg m^2/s] and P_rel = sum m r' . r'' [W]."""


def _wing_sums(planar) -> ca.Function:
    """``(t, p_right, p_left) -> the per-wing sums`` (:data:`N_WING_POWER_SUMS` per wing, right first)
    from the planar model's ``mass_points`` (right wing's points first, at ``p_right``; the left's at
    ``p_left``)."""
    t = ca.SX.sym("t")
    pr, pl = ca.SX.sym("p_right", len(PARAM_NAMES)), ca.SX.sym("p_left", len(PARAM_NAMES))
    out = []
    for pp, right in ((pr, True), (pl, False)):
        r, v, a, m = planar.mass_points(t, pp)
        h = r.shape[1] // 2
        sl = slice(0, h) if right else slice(h, r.shape[1])
        r, v, a, m = r[:, sl], v[:, sl], a[:, sl], m[sl]
        sm = mass_sums_3d(m, r, v, a)
        out += [sm["dS_kgmps"], sm["h_kgm2ps"], sm["dI_w_kgm2ps"], ca.sum2(ca.sum1(v * a) * m.T)]
    return ca.Function("wing_power_sums", [t, pr, pl], [ca.vertcat(*out)], ["t", "p_right", "p_left"], ["sums"])


def power_ode(six) -> ODE:
    """The heading-free ODE of a per-side :class:`~birdocp.bird.sixdof.SixDofModel` (``ode_no_heading``) whose
    data also holds, with wing masses, each wing's sums :data:`N_WING_POWER_SUMS` (what its inertial
    shoulder power needs; the right-hand side does not read them); without wing masses ``ode_no_heading``
    itself. Built once per model.

    Parameters
    ----------
    six : SixDofModel
        A model with per-side joint laws (``sides=True``).

    Returns
    -------
    ODE
    """
    ode = six.ode_no_heading
    if not six.structure.wing_mass:
        return ode

    def build():
        n, first = len(PARAM_NAMES), len(PARAM_NAMES) + len(LATERAL_PARAM_NAMES)
        sums = _wing_sums(six.planar)
        loc, t, pm = ca.MX.sym("local", ode.pre.size1_out(0)), ca.MX.sym("t"), ca.MX.sym("p", ode.np)
        pr, pl = side_parameters(pm[:n], pm[first:first + len(SIDE_PARAM_NAMES)])
        post = ca.Function("post_power", [loc, t, pm], [ca.vertcat(ode.post(loc, t, pm), sums(t, pr, pl))],
                           ["local", "t", "p"], ["d"])
        data = ca.Function("data_power", [t, pm], [post(ode.pre(t, pm), t, pm)], ["t", "p"], ["d"])
        x, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", ode.nd + 2 * N_WING_POWER_SUMS), ca.SX.sym("p", ode.np)
        rhs = ca.Function("rhs_power", [x, d, p], [ode.rhs(x, d[:ode.nd], p)], ["x", "d", "p"], ["xdot"])
        return ODE(rhs=rhs, data=data, forcing_period=ode.forcing_period, state_names=ode.state_names,
                   param_names=ode.param_names, pre=ode.pre, post=post, pre_params=ode.pre_params)

    return owned_cache(six).build("power_ode", build)


def inertial_power(x, nudot, sums, gravity_b):
    """The inertial shoulder power of one wing [W], sum_i m_i (a_i - g_b) . r_i' over its mass points, from
    its sums (:data:`N_WING_POWER_SUMS`): S' . (v' + omega x v - g_b) + omega' . h - omega^T I_w' omega / 2
    + P_rel (a_i = v' + omega x v + omega' x r_i + omega x (omega x r_i) + 2 omega x r_i' + r_i'', the
    Coriolis term does no work on r_i').

    Parameters
    ----------
    x : casadi.SX
        9-state (u, v, w, p, q, r first).
    nudot : casadi.SX
        (u', v', w', p', q', r').
    sums : casadi.SX
        The wing's 13 sums.
    gravity_b : casadi.SX
        Gravity in body axes [m/s^2].

    Returns
    -------
    casadi.SX
    """
    v, om = ca.vertcat(x[0], x[1], x[2]), ca.vertcat(x[3], x[4], x[5])
    dS, h, t = sums[0:3], sums[3:6], sums[6:12]
    dI = ca.blockcat([[t[0], t[1], t[2]], [t[1], t[3], t[4]], [t[2], t[4], t[5]]])
    return (ca.dot(dS, nudot[:3] + ca.cross(om, v) - gravity_b) + ca.dot(nudot[3:6], h)
            - 0.5 * ca.dot(om, dI @ om) + sums[12])


def sixdof_power_function(six, n_states: int = 9) -> ca.Function:
    """``(x, d, p) -> column of`` :data:`SIXDOF_POWER_NAMES` [W] of a
    :class:`~birdocp.bird.sixdof.SixDofModel` (built once per model and state size): ``n_states`` 9
    (the model's ODE) or 8 (its ``ode_no_heading``: the heading left out, which nothing depends on). With
    wing masses ``d`` is :func:`power_ode`'s data (the per-wing sums after the model's) and each wing's
    shoulder power adds its inertial power (:func:`inertial_power`).

    Parameters
    ----------
    six : SixDofModel
        The model.
    n_states : int
        Body states of ``x`` (9 or 8), then the section's aerodynamic states.

    Returns
    -------
    casadi.Function
    """
    def build():
        n_sec = six.section.n_states if six.section else 0
        x = ca.SX.sym("x", n_states + n_sec)
        nd = six.rhs.size1_in(1)
        mass = bool(six.structure.wing_mass)
        d = ca.SX.sym("d", nd + (2 * N_WING_POWER_SUMS if mass else 0))
        p = ca.SX.sym("p", six.ode.np)
        x9 = x if n_states == 9 else ca.vertcat(x[:8], 0, x[8:])
        t = power_terms(x9, d[:nd], p, six.structure, six.section)
        if mass:  # each wing's inertial power, at the body's accelerations of the 6-DOF equations
            nudot = six.rhs(x9, d[:nd], p)[:6]
            g, phi, th = p[PARAM_NAMES.index("body.gravity_mps2")], x9[6], x9[7]
            gb = g * ca.vertcat(-ca.sin(th), ca.sin(phi) * ca.cos(th), ca.cos(phi) * ca.cos(th))
            k = N_WING_POWER_SUMS
            for side, sums in (("right", d[nd:nd + k]), ("left", d[nd + k:nd + 2 * k])):
                t[f"{side}_shoulder_power_W"] = t[f"{side}_shoulder_power_W"] + inertial_power(x9, nudot, sums, gb)
        return ca.Function("sixdof_power", [x, d, p], [ca.vertcat(*[t[k] for k in SIXDOF_POWER_NAMES])],
                           ["x", "d", "p"], ["power"])

    return owned_cache(six).build(("sixdof_power", int(n_states)), build)


def smooth_positive_power(right_W, left_W, eps_W: float):
    """The smoothed positive-work power of the two shoulders, sum over the wings of
    1/2 (P_s + sqrt(P_s^2 + (eps/2)^2)): a wing's negative work does not pay for the other's positive work;
    each smoothing error is at most eps/4, so the sum's is at most eps/2, and for equal wings it is the
    planar 1/2 (P + sqrt(P^2 + eps^2)) of their sum P exactly.

    Parameters
    ----------
    right_W, left_W : casadi.SX or float
        Shoulder power of each wing [W].
    eps_W : float
        Smoothing of the bird's positive part [W].

    Returns
    -------
    casadi.SX or float
    """
    e = 0.5 * eps_W
    return sum(0.5 * (P + ca.sqrt(P ** 2 + e ** 2)) for P in (right_W, left_W))


CYCLE_POWER_OUTPUTS = ("flapping_power_W", "aerodynamic_power_W", "positive_power_smooth_W",
                       "right_shoulder_power_W", "left_shoulder_power_W")
"""Rows of :func:`cycle_power_outputs` [W]: the shoulder power of both wings (the name of the planar gait
optimiser's objective row), the power to the air, the smoothed positive-work power
(:func:`smooth_positive_power`), and each wing's shoulder power."""


def cycle_power_outputs(six, x, d, p, eps_W: float, n_states: int = 8):
    """The column :data:`CYCLE_POWER_OUTPUTS` [W] at the state ``x`` (``n_states`` body states, then the
    aerodynamic ones), data ``d`` and parameters ``p``: the power outputs of a gait optimiser's cycle.

    Parameters
    ----------
    six : SixDofModel
        The model.
    x, d, p : casadi.SX
        State, data and 6-DOF parameters.
    eps_W : float
        Smoothing of the positive-work power [W].
    n_states : int
        Body states of ``x`` (8: the heading left out, or 9).

    Returns
    -------
    casadi.SX
        (5, 1).
    """
    pw = sixdof_power_function(six, n_states)(x, d, p)
    right, left = pw[2], pw[3]
    return ca.vertcat(right + left, pw[0], smooth_positive_power(right, left, eps_W), right, left)


def check_power_model(cfg: Config, field: str = "--objective") -> None:
    """ConfigError (naming what to change) before any computation when the six-degree-of-freedom power
    of ``cfg``'s model is not written: Wagner's unsteady section (``aero.unsteady = "wagner"``, whose
    added-mass reaction is not split per wing).

    Parameters
    ----------
    cfg : Config
        Configuration.
    field : str
        The option that asked for the power (named in the message).
    """
    if cfg.aero.unsteady == "wagner":
        raise ConfigError("aero.unsteady", f"{field}: the per-wing power of Wagner's added mass in a turn is not "
                                           "written; set aero.unsteady = \"none\" or use optimize-stability")


def sampled_wing_powers(six, x0, p6, steps_per_period: int) -> dict:
    """Each wing's shoulder power sampled at the N RK4 step times of the heading-free cycle through ``x0``
    (state at t = 0) and what the samples give exactly: the positive-work power per wing, mean of
    max(P_sh,s, 0) (no elastic storage; a wing's negative work does not pay for the other's positive work),
    their sum, and the sampled mean shoulder power (the quadrature's mean to the sampling's accuracy).

    Parameters
    ----------
    six : SixDofModel
        A model with per-side joint laws.
    x0 : array_like
        Heading-free state at t = 0 (8 body states, then the aerodynamic ones).
    p6 : array_like
        6-DOF parameter vector.
    steps_per_period : int
        RK4 steps per period (the cycle's grid).

    Returns
    -------
    dict
        ``mean_positive_power_W``, ``mean_right_positive_power_W``, ``mean_left_positive_power_W``,
        ``mean_sampled_shoulder_power_W`` [W] and the samples ``t_s``, ``right_shoulder_power_W``,
        ``left_shoulder_power_W`` (lists).
    """
    ode = power_ode(six)
    N = int(steps_per_period)
    grid = RK4Grid(ode, N, 1)
    p = np.asarray(p6, float).ravel()
    D = grid.blocks_numeric(0.0, p)
    _, X, _ = grid.period_map(ca.DM(np.asarray(x0, float)), D, ca.DM(p))
    S = np.asarray(sixdof_power_function(six, 8).map(N)(X, D[:, list(range(2, 3 * N, 3))], ca.DM(p)))
    right, left = S[2], S[3]
    pos = [float(np.mean(np.maximum(P, 0.0))) for P in (right, left)]
    return {"mean_positive_power_W": pos[0] + pos[1], "mean_right_positive_power_W": pos[0],
            "mean_left_positive_power_W": pos[1], "mean_sampled_shoulder_power_W": float(np.mean(right + left)),
            "t_s": (grid.h * np.arange(1, N + 1)).tolist(), "right_shoulder_power_W": right.tolist(),
            "left_shoulder_power_W": left.tolist()}
