"""The SX graphs of the bird model for one :class:`~birdocp.bird.layout.Structure` (:func:`build`).

Split (``docs/model.md``): the wing in the arm's frame (``pre``, numbers of the gait and morphology),
its assembly into the per-time data (``post``: shoulder rotation, merge, kinematic velocity,
lifting-line matrices, the unsteady data), the user geometry, and the state part (``rhs``, loads,
details, powers, the section outputs of an unsteady or stall section).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird import aero
from birdocp.bird import inertia
from birdocp.bird import kinematics
from birdocp.bird import span
from birdocp.bird import subdivide
from birdocp.bird import unsteady
from birdocp.bird import wing
from birdocp.bird.config import JOINT_NAMES, PARAM_NAMES, WING_MASS_SHARES
from birdocp.bird.layout import (DATA_BLOCKS, N_EL, Structure, air_state, air_wind_rate, param as _p,
                                 unpack_data, unpack_mass)
from birdocp.bird.loads import load_terms, unsteady_data_offset, unsteady_params as _unsteady_params

def _joint_angles(t, p, frequency_hz):
    joints = {j: tuple(_p(p, f"gait.{j}.{k}") for k in ("offset_deg", "amplitude_deg", "phase_deg"))
              for j in JOINT_NAMES}
    return kinematics.joint_angles(t, frequency_hz, joints)


def _local_expr(t, p, frequency_hz, smooth=False):
    """The wing in the arm's frame (shoulder rotation R1 = I): every non-smooth step of the
    reference (resampling, corner smoothing, nearest points) happens here, and it depends on the
    elbow and wrist joints and the morphology only (docs/model.md §2-4; lengths and angles are invariant under
    the shoulder rotation, so the wing in the wing frame is R1 times this shape). ``smooth``: the
    switch-free geometry of ``wing.smooth_geometry`` instead (:func:`birdocp.bird.wing.smooth_geometry`)."""
    q = _joint_angles(t, p, frequency_hz)
    l1, l2, l4 = (_p(p, f"wing.{k}") for k in ("arm_length_m", "forearm_length_m", "hand_length_m"))
    feathers = [_p(p, f"wing.feather_lengths_m.{i}") for i in range(7)]
    sk = kinematics.skeleton(q, l1, l2, l4, feathers, with_shoulder=False)
    LE, TE = kinematics.raw_edges(sk, l1, l2, l4, _p(p, "wing.section_half_thickness_m"))
    radius = _p(p, "wing.smoothing_radius_m")
    if smooth:
        LEs, TEs, P, E, T, diag = wing.smooth_geometry(LE, TE, radius)
        Lr, change = P, ca.SX(0)
    else:
        LEs, dle = wing.smooth_line(LE, radius)
        TEs, dte = wing.smooth_line(TE, radius)
        P, E, T, Lr, change = wing.lifting_line(LEs, TEs)
        diag = {k: dle[k] + dte[k] for k in dle}
    chord, c_hat, up = wing.sections(P, E, T, Lr)
    diag["improve_change"] = change
    return {
        "joint_angles_rad": ca.vertcat(*[q[j] for j in JOINT_NAMES]),
        "leading_edge_raw": ca.horzcat(*LE), "trailing_edge_raw": ca.horzcat(*TE),
        "leading_edge": ca.horzcat(*LEs), "trailing_edge": ca.horzcat(*TEs),
        "P": ca.horzcat(*P), "c_hat": ca.horzcat(*c_hat), "up": ca.horzcat(*up),
        "chord": ca.horzcat(*chord), "dx": wing.mean_spacing(P), "diag": diag,
    }


def _shoulder(t, p, frequency_hz):
    return kinematics.shoulder_rotation(_joint_angles(t, p, frequency_hz))


def _columns(M):
    return [M[:, j] for j in range(M.shape[1])]


def _merged(R1, P, c_hat, up, chord, x_ep):
    """Both wings on one line (33 points, docs/model.md §4.5-4.6) from the arm-frame line and R1."""
    return wing.merge(_columns(R1 @ P), [chord[j] for j in range(chord.shape[1])],
                      _columns(R1 @ c_hat), _columns(R1 @ up), x_ep)


WING_POWER_NAMES = ("inertial_power_W", "shoulder_inertial_power_W", "wing_acceleration_power_W",
                    "wing_gravity_power_W", "wing_relative_kinetic_energy_J")
"""Outputs of ``BirdModel.wing_power_d`` (see :func:`birdocp.bird.inertia.wing_powers`)."""


def _local_mass_points(t, p, frequency_hz):
    q = _joint_angles(t, p, frequency_hz)
    l1, l2, l4 = (_p(p, f"wing.{k}") for k in ("arm_length_m", "forearm_length_m", "hand_length_m"))
    feathers = [_p(p, f"wing.feather_lengths_m.{i}") for i in range(7)]
    return inertia.local_mass_points(q, l1, l2, l4, feathers)[0]


def _point_masses(p):
    """The 20 point masses of one wing [kg] (two Gauss points per segment, half its mass each)."""
    seg_m = inertia.segment_masses(_p(p, "wing.mass_kg"), [_p(p, f"wing.{k}") for k in WING_MASS_SHARES])
    return [0.5 * seg_m[i // 2] for i in range(2 * len(seg_m))]


def _wing_points_body(R1, R1d, R1dd, rho, rho_d, rho_dd, p):
    """Right-wing mass points relative to G_b in the body frame (x', y', z'): positions, velocities
    and accelerations relative to the body, from the arm-frame points and the shoulder rotation.
    Code frame (e1, e2, e3) -> body: x' = -e3, y' = e1, z' = -e2; shoulder at (x_ep, 0, -root_ahead)."""
    root = ca.vertcat(_p(p, "wing.shoulder_half_separation_m"), 0, -_p(p, "wing.root_ahead_m"))
    rc = ca.repmat(root, 1, rho.shape[1]) + R1 @ rho
    vc = R1d @ rho + R1 @ rho_d
    ac = R1dd @ rho + 2 * (R1d @ rho_d) + R1 @ rho_dd

    def body(c):
        return [ca.vertcat(-c[2, j], c[0, j], -c[1, j]) for j in range(c.shape[1])]

    return body(rc), body(vc), body(ac)


GEOMETRY_OUTPUTS = ("joint_angles_rad", "leading_edge_raw", "trailing_edge_raw", "leading_edge",
                    "trailing_edge", "line", "chord_m", "chord_dir", "up_dir", "diagnostics")


def _pre(s: Structure, t, p) -> dict:
    """The arm-frame part ``pre``: the wing shape (P, c_hat, up, chord) with its kinematic-velocity
    companion, the wing-mass points and, for an unsteady or stall section, the first and second time
    derivatives of the aerodynamic shape (AD in t). Returns ``ell`` (the column), ``loc``, the sizes
    ``n_aero`` (shape and companion) and ``n_before_deriv`` (before the time derivatives)."""
    loc = _local_expr(t, p, s.frequency_hz, s.smooth_geometry)
    P = loc["P"]
    if s.kinematic_velocity == "exact":
        aux = ca.jtimes(ca.vec(P), t, ca.SX(1))       # dP/dt in the arm frame
    elif s.kinematic_velocity == "backward-difference":
        aux = ca.vec(ca.Function("P_local", [t, p], [P])(t - s.backward_step_s, p))  # P(t - delta)
    else:
        raise ValueError(f"aero.kinematic_velocity must be 'exact' or 'backward-difference', got {s.kinematic_velocity!r}")
    ell_aero = ca.vertcat(ca.vec(P), ca.vec(loc["c_hat"]), ca.vec(loc["up"]), ca.vec(loc["chord"]), aux)
    ell = ell_aero
    if s.wing_mass:
        # wing mass points in the arm's frame with their time derivatives (AD in t): smooth
        # functions of the elbow and wrist joints, so they belong to the numeric 'pre' part
        rho = ca.horzcat(*_local_mass_points(t, p, s.frequency_hz))
        rho_d = ca.jtimes(rho, t, ca.SX(1))
        rho_dd = ca.jtimes(rho_d, t, ca.SX(1))
        ell = ca.vertcat(ell, ca.vec(rho), ca.vec(rho_d), ca.vec(rho_dd))
    n_before_deriv = ell.numel()
    if s.aero_extra:
        # first and second time derivatives of the arm-frame aerodynamic shape (AD in t): the
        # unsteady data (pitch rates, added-mass rates) are time derivatives of the assembled geometry
        ell_d = ca.jtimes(ell_aero, t, ca.SX(1))
        ell = ca.vertcat(ell, ell_d, ca.jtimes(ell_d, t, ca.SX(1)))
    return {"ell": ell, "loc": loc, "n_aero": ell_aero.numel(), "n_before_deriv": n_before_deriv}


def _geometry(loc, R1, x_ep, t, p) -> ca.Function:
    """Geometry for users and plots (:data:`GEOMETRY_OUTPUTS`): the arm-frame shape rotated by R1, merged."""
    Q, ch, cd, nu = _merged(R1, loc["P"], loc["c_hat"], loc["up"], loc["chord"], x_ep)
    diag = dict(loc["diag"], n_mid=ca.ceil(2 * x_ep / loc["dx"]))
    geo = {
        "joint_angles_rad": loc["joint_angles_rad"],
        "leading_edge_raw": R1 @ loc["leading_edge_raw"], "trailing_edge_raw": R1 @ loc["trailing_edge_raw"],
        "leading_edge": R1 @ loc["leading_edge"], "trailing_edge": R1 @ loc["trailing_edge"],
        "line": ca.horzcat(*Q), "chord_m": ca.horzcat(*ch), "chord_dir": ca.horzcat(*cd),
        "up_dir": ca.horzcat(*nu), "diagnostics": ca.vertcat(*[diag[k] for k in wing.DIAGNOSTICS]),
    }
    return ca.Function("geometry", [t, p], [geo[k] for k in GEOMETRY_OUTPUTS], ["t", "p"], list(GEOMETRY_OUTPUTS))


def _arm_blocks(L):
    """(P, c_hat, up, chord, aux) of one wing from the first values of a ``pre`` output ``L``."""
    k, out = 0, []
    for rows, n in ((3, 48), (3, 48), (3, 48), (1, 16), (3, 48)):
        out.append(ca.reshape(L[k:k + n], rows, N_EL))
        k += n
    return out


def _kinematic_velocity(s: Structure, R1, arm, centres, t, p, x_ep, left=None):
    """The kinematic velocity of the element centres (body frame), exact (AD in t) or backward
    difference; ``left`` = (R1 of the left wing, its arm blocks, its p) of an asymmetric gait."""
    P_s, aux_s = arm[0], arm[4]
    if s.kinematic_velocity == "exact":
        Pdot = ca.jtimes(R1, t, ca.SX(1)) @ P_s + R1 @ aux_s
        lv = None if left is None else (_columns(ca.jtimes(left[0], t, ca.SX(1)) @ left[1][0] + left[0] @ left[1][4]),
                                        [0] * N_EL, _columns(left[1][0]), _columns(left[1][0]))
        Qd = wing.merge(_columns(Pdot), [0] * N_EL, _columns(P_s), _columns(P_s), 0.0, left=lv)[0]
        return ca.horzcat(*subdivide.refine_points(Qd, s.span_subdivisions))[:, 1::2]
    R1_prev = _shoulder(t - s.backward_step_s, p, s.frequency_hz)
    lv = None if left is None else (_columns(_shoulder(t - s.backward_step_s, left[2], s.frequency_hz) @ left[1][4]),
                                    [0] * N_EL, _columns(left[1][0]), _columns(left[1][0]))
    Qp = wing.merge(_columns(R1_prev @ aux_s), [0] * N_EL, _columns(P_s), _columns(P_s), x_ep, left=lv)[0]
    return (centres - ca.horzcat(*subdivide.refine_points(Qp, s.span_subdivisions))[:, 1::2]) / s.backward_step_s


def aero_blocks(s: Structure, L, t, p, left=None) -> dict:
    """The aerodynamic data blocks (:data:`DATA_BLOCKS`, SX) from the arm-frame wing ``L`` (a ``pre``
    output) at time ``t`` and parameters ``p``: shoulder rotation, merge, kinematic velocity,
    lifting-line matrices. ``left`` = (L, p) of a left wing with its own joint laws (an asymmetric
    gait, :mod:`birdocp.bird.sides`); None: the mirror image of the right wing (the planar model).

    Parameters
    ----------
    s : Structure
        Structure of the model.
    L : casadi.SX
        Arm-frame wing (a ``pre`` output).
    t : casadi.SX
        Time [s].
    p : casadi.SX
        Parameter vector.
    left : tuple, optional
        ``(L, p)`` of a left wing with its own joint laws.

    Returns
    -------
    dict of str to casadi.SX
    """
    x_ep = _p(p, "wing.shoulder_half_separation_m")
    R1 = _shoulder(t, p, s.frequency_hz)
    arm = _arm_blocks(L)
    P_s, c_s, u_s, ch_s, _ = arm
    lw = None
    if left is None:
        Q, ch, cd, nu = _merged(R1, P_s, c_s, u_s, ch_s, x_ep)
    else:
        R1l = _shoulder(t, left[1], s.frequency_hz)
        arm_l = _arm_blocks(left[0])
        Q, ch, cd, nu = wing.merge(_columns(R1 @ P_s), [ch_s[j] for j in range(N_EL)], _columns(R1 @ c_s),
                                   _columns(R1 @ u_s), x_ep,
                                   left=(_columns(R1l @ arm_l[0]), [arm_l[3][j] for j in range(N_EL)],
                                         _columns(R1l @ arm_l[1]), _columns(R1l @ arm_l[2])))
        lw = (R1l, arm_l, left[1])
    k, n = s.span_subdivisions, s.n_elements
    Q, ch, cd, nu = subdivide.refine_points(Q, k), *(subdivide.repeat_sections(v, k) for v in (ch, cd, nu))
    line = ca.horzcat(*Q)
    centres, nodes = line[:, 1::2], line[:, 0::2]
    v_kin = _kinematic_velocity(s, R1, arm, centres, t, p, x_ep, lw)
    c_hat = ca.horzcat(*cd)[:, 1::2]
    up = ca.horzcat(*nu)[:, 1::2]
    chord = ca.horzcat(*ch)[1::2]
    tau = ca.horzcat(*[ca.cross(up[:, j], c_hat[:, j]) for j in range(n)])
    wake = {} if s.collocation == "quarter" else {"collocation": s.collocation, "c_hat": _columns(c_hat)}
    if s.span_direction == "element":
        tau, c_hat, up = span.element_frames(nodes, c_hat)
    ds = ca.vertcat(*[ca.norm_2(nodes[:, j + 1] - nodes[:, j]) for j in range(n)])
    r_w = ca.vertcat(0, 0, -_p(p, "wing.root_ahead_m"))
    r = centres + ca.repmat(r_w, 1, n)
    if s.aero_extra:  # per unit circulation: the state right-hand side solves the lifting line
        Wx, Wy, G = aero.induced_matrices(_columns(centres), _columns(nodes))
    else:
        G, Wx, Wy = aero.circulation_matrices(
            _columns(centres), _columns(nodes), [chord[j] for j in range(n)],
            _p(p, "aero.lift_slope_per_rad"), s.circulation, s.relaxed_evaluations, **wake)
    return {"r_m": r, "v_kin_mps": v_kin, "c_hat": c_hat, "up": up, "tau": tau, "ds_m": ds,
            "G": G, "Wx": Wx, "Wy": Wy, "nodes_m": nodes + ca.repmat(r_w, 1, n + 1),
            "chord_m": chord.T}


def _wing_mass(pre: dict, L, R1, t, p) -> tuple:
    """The wing-mass sums :data:`birdocp.bird.inertia.MASS_BLOCK` of ``post`` (from L) and the
    Function ``mass_points`` (from the arm-frame expressions)."""
    npt, k = inertia.N_POINTS_PER_WING, pre["n_aero"]
    R1d = ca.jtimes(R1, t, ca.SX(1))
    R1dd = ca.jtimes(R1d, t, ca.SX(1))
    rho_s = [ca.reshape(L[k + 3 * npt * j:k + 3 * npt * (j + 1)], 3, npt) for j in range(3)]
    sums = inertia.mass_sums(_point_masses(p), *_wing_points_body(R1, R1d, R1dd, *rho_s, p))
    mpts = pre["ell"][k:]
    mr = [ca.reshape(mpts[3 * npt * j:3 * npt * (j + 1)], 3, npt) for j in range(3)]
    rb, vb, ab = _wing_points_body(R1, R1d, R1dd, *mr, p)
    mirror = ca.diag(ca.DM([1, -1, 1]))
    both = [ca.horzcat(ca.horzcat(*z), mirror @ ca.horzcat(*z)) for z in (rb, vb, ab)]
    mm = ca.vertcat(*_point_masses(p))
    # both wings' mass points relative to G_b in the body frame (x', y', z'), 3 x 40 each
    # (right wing then left), their velocities and accelerations relative to the body, masses
    fn = ca.Function("wing_mass_points", [t, p], both + [ca.vertcat(mm, mm)], ["t", "p"],
                     ["r_m", "v_mps", "a_mps2", "m_kg"])
    return [sums[kk] for kk in inertia.MASS_BLOCK], fn


def _unsteady_data(pre: dict, L, blocks: dict, t) -> ca.SX:
    """The unsteady data blocks (:func:`birdocp.bird.unsteady.element_data`) of ``post``: time
    derivatives by AD in t through the assembly, with the arm-frame derivatives from L."""
    return unsteady_blocks([L], pre["n_aero"], pre["n_before_deriv"], blocks, t)


def time_derivative(locals_, n_aero: int, n_before_deriv: int, t):
    """``ddt(e)``: the time derivative of an expression ``e`` of the assembled data made from the
    arm-frame wings ``locals_`` (one ``pre`` output, or the right and the left wing's): AD in t through
    the assembly, each wing's arm-frame derivatives read from its ``pre`` output.

    Parameters
    ----------
    locals_ : list of casadi.SX
        ``pre`` outputs the data was assembled from.
    n_aero : int
        Values of the aerodynamic shape in a ``pre`` output.
    n_before_deriv : int
        Values before its time derivatives.
    t : casadi.SX
        Time [s].

    Returns
    -------
    callable
        ``ddt(e) -> casadi.SX``.
    """
    na, nb = n_aero, n_before_deriv
    tangents = [ca.vertcat(L[nb:nb + na], ca.SX.zeros(nb - na), L[nb + na:nb + 2 * na], ca.SX.zeros(na))
                for L in locals_]

    def ddt(e):
        out = ca.jtimes(e, locals_[0], tangents[0])
        for L, tangent in zip(locals_[1:], tangents[1:]):
            out = out + ca.jtimes(e, L, tangent)
        return out + ca.jtimes(e, t, ca.SX(1))

    return ddt


def unsteady_blocks(locals_, n_aero: int, n_before_deriv: int, blocks: dict, t) -> ca.SX:
    """The unsteady data blocks (:func:`birdocp.bird.unsteady.element_data`, packed) of the assembled
    ``blocks`` (:func:`aero_blocks`) made from the arm-frame wings ``locals_`` (one ``pre`` output, or the
    right and the left wing's of an asymmetric gait): time derivatives by AD in t through the assembly,
    each wing's arm-frame derivatives read from its ``pre`` output.

    Parameters
    ----------
    locals_ : list of casadi.SX
        ``pre`` outputs the blocks were assembled from.
    n_aero : int
        Values of the aerodynamic shape in a ``pre`` output.
    n_before_deriv : int
        Values before its time derivatives.
    blocks : dict
        The assembled data blocks (:func:`aero_blocks`).
    t : casadi.SX
        Time [s].

    Returns
    -------
    casadi.SX
    """
    ddt = time_derivative(locals_, n_aero, n_before_deriv, t)
    ud = unsteady.element_data(blocks["r_m"], blocks["v_kin_mps"], blocks["c_hat"], blocks["up"], blocks["tau"],
                               blocks["chord_m"], blocks["ds_m"], ddt)
    return unsteady.pack(ud, N_EL)


def build(s: Structure) -> tuple[dict, tuple]:
    """The SX Functions of structure ``s`` (:data:`GRAPH_FUNCTIONS`, and
    :data:`OPTIONAL_FUNCTIONS` or None) and ``pre_params``.

    Parameters
    ----------
    s : Structure
        Structure of the model.

    Returns
    -------
    functions : dict
        Name to casadi.Function.
    pre_params : tuple
    """
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", len(PARAM_NAMES))
    x_ep = _p(p, "wing.shoulder_half_separation_m")
    pre = _pre(s, t, p)
    ell = pre["ell"]
    fns = {"pre": ca.Function("wing_local", [t, p], [ell], ["t", "p"], ["local"])}
    pre_params = tuple(int(k) for k in np.nonzero(
        np.asarray(ca.DM(ca.jacobian_sparsity(ell, p), 1)).sum(axis=0))[0])
    R1 = _shoulder(t, p, s.frequency_hz)
    fns["geometry"] = _geometry(pre["loc"], R1, x_ep, t, p)
    L = ca.SX.sym("local", ell.numel())
    blocks = aero_blocks(s, L, t, p)
    d = ca.vertcat(*[ca.vec(blocks[name]) for name, _ in DATA_BLOCKS])
    fns["mass_points"] = None
    if s.wing_mass:
        sums, fns["mass_points"] = _wing_mass(pre, L, R1, t, p)
        d = ca.vertcat(d, *sums)
    if s.aero_extra:
        d = ca.vertcat(d, _unsteady_data(pre, L, blocks, t))
    fns["post"] = ca.Function("wing_assemble", [L, t, p], [d], ["local", "t", "p"], ["d"])
    fns["data"] = ca.Function("data", [t, p], [fns["post"](ell, t, p)], ["t", "p"], ["d"])
    fns.update(_state_functions(s, p))
    return fns, pre_params


def _state_functions(s: Structure, p) -> dict:
    """The state part: ``rhs``, ``loads_d``, ``detail_d``, their wind versions, ``wing_power_d`` and
    the section Functions. The aerodynamics sees the air-relative state (``air_state``: the wind in the
    inertial frame, rotated into the body frame, subtracted from u, w); with ``wagner`` the added mass
    also sees the wind's rate (``air_wind_rate``: its rate along the trajectory, the ``wind_rate_mps2``
    input, and the frame's rotation); rhs/loads_d/detail_d are the same graphs with the wind and its
    rate substituted by zero (the exact graphs of before)."""
    fns = {}
    x = ca.SX.sym("x", 4 + s.n_aero_states)
    wind = ca.SX.sym("wind_mps", 2)
    wind_rate = ca.SX.sym("wind_rate_mps2", 2)
    xa = ca.vertcat(air_state(x, wind), x[4:])
    dsym = ca.SX.sym("d", unsteady_data_offset(s) + (unsteady.data_size(N_EL) if s.aero_extra else 0))
    lt = load_terms(s, xa, dsym, p, x_inertial=x,
                    wind_rate=air_wind_rate(x, wind, wind_rate) if s.unsteady == "wagner" else None)
    Fx, Fz, My, Gamma, alpha, vp, F = (lt[k] for k in ("Fx_N", "Fz_N", "My_Nm", "Gamma", "alpha", "Vp_norm",
                                                      "F_code"))
    m = _p(p, "body.mass_kg")
    I = _p(p, "body.pitch_inertia_kgm2")
    grav = _p(p, "body.gravity_mps2")
    u, w, q, theta = x[0], x[1], x[2], x[3]
    xdot = ca.vertcat(-q * w - grav * ca.sin(theta) + Fx / m, q * u + grav * ca.cos(theta) + Fz / m, My / I, q)
    if s.aero_extra:
        xdot = ca.vertcat(lt["nudot"], q, lt["xdot_aero"])
    powers = None
    if s.wing_mass:
        # body.mass_kg is the whole bird M, body.pitch_inertia_kgm2 the body alone about G_b
        # (docs/studies/inertia.md, equations: the massless limit: the massless right-hand side with m = M, I = I_b, plus a
        # correction that is exactly zero when the wings have no mass)
        sums = unpack_mass(dsym)
        nudot = inertia.accelerations(x, xdot[:3], sums, m, I, grav)
        xdot = ca.vertcat(nudot, q)
        pw = inertia.wing_powers(x, nudot, sums, grav)
        powers = ca.vertcat(*[pw[kk] for kk in WING_POWER_NAMES])
    ins, names = [x, dsym, p, wind, wind_rate], ["x", "d", "p", "wind_mps", "wind_rate_mps2"]
    fns["rhs_wind"] = ca.Function("rhs_wind", ins, [xdot], names, ["xdot"])
    fns["loads_wind"] = ca.Function("loads_wind", ins, [ca.vertcat(Fx, Fz, My)], names, ["loads"])
    winds, zero = [wind, wind_rate], [ca.SX.zeros(2), ca.SX.zeros(2)]
    xdot, loads, detail = ca.substitute([xdot, ca.vertcat(Fx, Fz, My), ca.vertcat(Gamma, alpha, vp, ca.vec(F))],
                                        winds, zero)
    # (x, d, p) -> the powers WING_POWER_NAMES [W] (and T_rel [J]) at one instant
    fns["wing_power_d"] = None if powers is None else ca.Function(
        "wing_power_d", [x, dsym, p], ca.substitute([powers], winds, zero), ["x", "d", "p"], ["powers"])
    if s.aero_extra:
        fns.update(_section_functions(s, x, dsym, p, lt, winds))
    else:
        fns.update(section_d=None, aero_guess_d=None, held_d=None)
    fns["rhs"] = ca.Function("rhs", [x, dsym, p], [xdot], ["x", "d", "p"], ["xdot"])
    fns["loads_d"] = ca.Function("loads_d", [x, dsym, p], [loads], ["x", "d", "p"], ["loads"])
    fns["detail_d"] = ca.Function("detail_d", [x, dsym, p], ca.vertsplit(detail, [0, s.n_elements, 2 * s.n_elements, 3 * s.n_elements, 3 * s.n_elements + 3]),
                                  ["x", "d", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])
    return fns


SECTION_OUTPUTS = ("alpha_E_rad", "alpha_eff_quasi_steady_rad", "f_sep", "Gamma_m2ps", "newton_residual",
                   "ds_m", "alpha_geo_rad")
"""Outputs of ``BirdModel.section_d(x, d, p)`` (unsteady/stall structures): per element (16) the angle
the section law sees alpha_E (lag and 3/4-chord term included), the quasi-steady effective angle of
the same state (today's definition), the separation point f (1 = attached), the circulation, then the
relative Newton residual max|R| / max|Gamma| of the stall circulation (0 for a linear section), the
element lengths and the geometric angles."""


def _section_functions(s: Structure, x, d, p, lt, winds) -> dict:
    """``section_d`` (:data:`SECTION_OUTPUTS`) and ``aero_guess_d(x4, d, p)``: the aerodynamic states on
    the quasi-steady manifold (z_i = eps A_i g with A0 = 1 and z = 0, f = f0(alpha_E)) at body state x4."""
    sec = lt["sec"]
    b = unpack_data(d)
    V, vind_qs = sec["V"], None
    # today's quasi-steady effective angle: the linear lifting line with A0 = 1, no lag, no 3/4 chord
    qs = unsteady.section_loads({"unsteady": "none", "section": "linear", "newton_steps": 0},
                                x[0:3], ca.SX.zeros(0, 1), {"r": b["r_m"], "v_kin": b["v_kin_mps"],
                                "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"], "ds": b["ds_m"],
                                                            "chord": b["chord_m"]},
                                {}, {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}, _unsteady_params(p))
    vind_qs = qs["vind"]
    a_qs, _ = aero.section_angle(V + vind_qs, b["c_hat"], b["up"], b["tau"])
    outs = [sec["alpha_E"], a_qs.T, sec["f"].T, sec["Gamma"], sec["newton_residual"], b["ds_m"], sec["alpha"].T]
    outs = ca.substitute(outs, winds, [ca.SX.zeros(2)] * len(winds))
    fns = {"section_d": ca.Function("section_d", [x, d, p], outs, ["x", "d", "p"], list(SECTION_OUTPUTS))}
    held = ca.substitute([lt["xdot_aero"], lt["loads_held"]], winds, [ca.SX.zeros(2)] * len(winds))
    fns["held_d"] = ca.Function("held_d", [x, d, p], held, ["x", "d", "p"], ["xdot_aero", "loads"])
    x4 = ca.SX.sym("x4", 4)
    k0 = unsteady_data_offset(s)
    z = quasi_steady_aero_states({"unsteady": s.unsteady, "section": s.section, "newton_steps": s.newton_steps},
                                 x4[0:3], d, k0, p)
    fns["aero_guess_d"] = ca.Function("aero_guess_d", [x4, d, p], [z], ["x", "d", "p"], ["z"])
    return fns


def quasi_steady_aero_states(opts: dict, nu, d, data_offset: int, p, flow: dict | None = None):
    """The aerodynamic states on the quasi-steady manifold at one instant: the lag states
    ``z_i = eps A_i g`` (the circulation ``g`` of the section law with A0 = 1 and z = 0) and the separation
    point ``f = f0(alpha_E)``, in :func:`birdocp.bird.unsteady.aero_state_names` order; the planar
    model's start of its aerodynamic states and, with ``flow``, the six-degree-of-freedom model's.

    Parameters
    ----------
    opts : dict
        ``unsteady``, ``section``, ``newton_steps`` (the model's section).
    nu : casadi.SX
        Air-relative (u, w, q) [m/s, m/s, rad/s].
    d : casadi.SX
        Data vector (the planar blocks, the unsteady blocks from ``data_offset``).
    data_offset : int
        Index of the first unsteady data value in ``d``.
    p : casadi.SX
        Planar parameter vector.
    flow : dict, optional
        Six degrees of freedom: ``V`` and ``Omega`` (:func:`birdocp.bird.unsteady.section_loads`).

    Returns
    -------
    casadi.SX
        The aerodynamic states (column).
    """
    b = unpack_data(d)
    prm = dict(_unsteady_params(p), a0=1.0)
    base = {"r": b["r_m"], "v_kin": b["v_kin_mps"], "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"],
            "ds": b["ds_m"], "chord": b["chord_m"]}
    ud = unsteady.unpack(d[data_offset:data_offset + unsteady.data_size(N_EL)], N_EL)
    lin = {"unsteady": opts["unsteady"], "section": "stall" if opts["section"] != "linear" else "linear",
           "newton_steps": opts["newton_steps"]}
    g0 = unsteady.section_loads(lin, nu, ca.SX.zeros(2 * N_EL if opts["unsteady"] == "wagner" else 0, 1), base, ud,
                                {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}, prm, flow=flow)
    vp = g0["Vp_norm"].T
    g = g0["alpha_E"] * vp  # with A0 = 1 and z = 0, g_E = g
    z = []
    if opts["unsteady"] == "wagner":
        z += [prm["eps"] * unsteady.A1 * g, prm["eps"] * unsteady.A2 * g]
    if opts["section"] == "dynamic-stall":
        z.append(unsteady.separation_point(g0["alpha_E"], prm["alpha1"]))
    return ca.vertcat(*z)

