"""The bird in six degrees of freedom: rigid-body equations in body axes with the lifting line in
asymmetric flow (the equations are written out in ``docs/studies/lateral.md``).

State ``x`` (9), body frame x' forward, y' right, z' down, origin the centre of mass G:

====  =============  ==========================================================
 #    name           meaning
====  =============  ==========================================================
 0    ``u_mps``      velocity of G along x' (forward)
 1    ``v_mps``      velocity of G along y' (right)
 2    ``w_mps``      velocity of G along z' (down)
 3    ``p_radps``    roll rate about x' (right wing down positive)
 4    ``q_radps``    pitch rate about y' (nose up positive)
 5    ``r_radps``    yaw rate about z' (nose right positive)
 6    ``phi_rad``    bank angle (3-2-1 Euler angles: yaw psi, pitch theta, roll phi)
 7    ``theta_rad``  pitch angle
 8    ``psi_rad``    heading
====  =============  ==========================================================

The wing geometry, the kinematic velocities and the lifting-line matrices are the planar model's
per-time data ``d(t, p)`` (:class:`birdocp.bird.model.BirdModel`): the gait is symmetric, both wings
on one line of 16 elements. What changes is the air each element meets: ``V = U_inf - Omega x r -
v_kin`` with ``U_inf = (-v, w, u)`` and ``Omega = (q, -r, -p)`` in the code frame (e1 right, e2 up,
e3 back), so sideslip and roll and yaw rates load the two wings differently. The wake filaments stay
straight along the body axis e3 (as in the planar model, also in sideslip: a choice of the
lifting-line model, stated in the docs). Loads: ``(X, Y, Z) = (-F3, F1, -F2)`` and
``(L, M, N) = (-Mc3, Mc1, -Mc2)`` from the code-frame force ``F`` and moment ``Mc = sum r x dF``.

Asymmetric gaits (:mod:`birdocp.bird.sides`): with ``sides=True`` the parameter vector also holds
the 42 per-side joint offsets and the data is assembled from two differing wings; such a cycle is
periodic up to its heading (a turn), so ``ode_no_heading`` (the 8 states without psi, on which
nothing depends) is the ODE its trim solves.

The body has the inertia tensor ``[[I_xx, 0, -I_xz], [0, I_yy, 0], [-I_xz, 0, I_zz]]`` about G
(:class:`LateralInertia` adds I_xx, I_zz, I_xz to the configuration's ``body.pitch_inertia_kgm2`` =
I_yy). With ``wing.mass_kg`` > 0 the wings' mass points move with the gait and their 3-D inertial
terms (momentum, angular momentum, products of inertia) are added by
:mod:`birdocp.bird.sixdof_inertia`; ``body.mass_kg`` is then the whole bird and the inertias are the
body's own about its centre of mass G_b, as in the planar model with wing masses. With the tail
(``tail.opening_angle_deg`` > 0) its planar loads are added (:func:`tail_body_loads`); with the optional
drag (``[drag]``) the profile drag of every element and the body's parasite drag (:func:`drag_terms`). With the
stall-aware sections (``aero.section = "stall"``, ``"dynamic-stall"``) and Wagner's section (``aero.unsteady =
"wagner"``) the planar section law is called per element over both wings in the asymmetric flow
(:class:`SectionLaw`; lag and separation states after the 9 body states), Wagner's added mass a 6 x 6 matrix on
the left (:mod:`birdocp.bird.sixdof_unsteady`). For a symmetric cycle (v = p = r = phi = 0) the longitudinal equations
are the planar model's.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from birdocp.bird import aero, tail, unsteady
from birdocp.bird import sixdof_inertia as wing3
from birdocp.bird import sixdof_unsteady as am6
from birdocp.bird.config import PARAM_NAMES, Config, asymmetric
from birdocp.bird.loads import unsteady_params, unsteady_data_offset
from birdocp.bird.model import N_DATA, N_EL, BirdModel, Structure, get_model, unpack_data
from birdocp.bird.sides import SIDE_PARAM_NAMES, side_data_functions
from birdocp.engine.cache import owned_cache
from birdocp.engine.ode import ODE

__all__ = ["rhs_expression", "SectionLaw", "STATE_NAMES", "LONGITUDINAL", "LATERAL", "HEADING", "LATERAL_PARAM_NAMES", "LateralInertia",
           "SixDofModel", "sixdof_model", "embed_planar_state", "body_loads", "drag_terms", "air_velocity",
           "body_axis_loads"]

STATE_NAMES = ("u_mps", "v_mps", "w_mps", "p_radps", "q_radps", "r_radps", "phi_rad", "theta_rad", "psi_rad")
LONGITUDINAL = (0, 2, 4, 7)
"""Indices of (u, w, q, theta): the planar model's state, in its order."""
LATERAL = (1, 3, 5, 6)
"""Indices of (v, p, r, phi)."""
HEADING = 8
"""Index of psi: nothing depends on it, so it adds a Floquet multiplier 1 (reported apart)."""

LATERAL_PARAM_NAMES = ("model.roll_inertia_kgm2", "model.yaw_inertia_kgm2", "model.product_inertia_xz_kgm2")
"""Parameters appended to :data:`birdocp.bird.config.PARAM_NAMES` in the six-degree-of-freedom ODE."""


@dataclass(frozen=True)
class LateralInertia:
    """Roll and yaw inertia about G [kg m^2] and the product I_xz, as the configuration's ``[model]``
    section (:class:`birdocp.bird.config.Model`, where the default estimates are explained). Every
    value is a parameter of the ODE (sweepable, differentiable)."""

    roll_inertia_kgm2: float = 0.011
    yaw_inertia_kgm2: float = 0.11
    product_inertia_xz_kgm2: float = 0.0

    @staticmethod
    def of(cfg: Config) -> "LateralInertia":
        """The inertia of ``cfg.model``."""
        m = cfg.model
        return LateralInertia(m.roll_inertia_kgm2, m.yaw_inertia_kgm2, m.product_inertia_xz_kgm2)

    def vector(self) -> list[float]:
        """The values in the order of :data:`LATERAL_PARAM_NAMES`."""
        return [self.roll_inertia_kgm2, self.yaw_inertia_kgm2, self.product_inertia_xz_kgm2]

    def __post_init__(self):
        ixx, izz, ixz = self.vector()
        if not (ixx > 0 and izz > 0 and ixx * izz - ixz ** 2 > 0):
            raise ValueError("LateralInertia: roll_inertia_kgm2 and yaw_inertia_kgm2 must be > 0 and "
                             "roll*yaw > product_inertia_xz_kgm2**2 (a positive definite inertia)")


def _p(p, name):
    return p[PARAM_NAMES.index(name)]


@dataclass(frozen=True)
class SectionLaw:
    """The planar model's unsteady or stall-aware section (``aero.unsteady``, ``aero.section``) as the
    6-DOF loads call it: the section options and where the unsteady data blocks
    (:func:`birdocp.bird.unsteady.element_data`) start in the 6-DOF data vector."""

    unsteady: str
    section: str
    newton_steps: int
    data_offset: int

    @staticmethod
    def of(structure: Structure, data_offset: int) -> "SectionLaw | None":
        """The section law of ``structure`` (None for the linear quasi-steady section).

        Parameters
        ----------
        structure : Structure
            Structure of the model.
        data_offset : int
            Index of the first unsteady data value in the 6-DOF data vector.

        Returns
        -------
        SectionLaw or None
        """
        if not structure.aero_extra:
            return None
        return SectionLaw(structure.unsteady, structure.section, int(structure.newton_steps), int(data_offset))

    @property
    def n_states(self) -> int:
        """Aerodynamic states (lag and separation states) after the 9 body states."""
        return unsteady.n_aero_states(self.unsteady, self.section, N_EL)


def _section_element_terms(law: SectionLaw, x, V, b: dict, d, p) -> dict:
    """The planar section law (:func:`birdocp.bird.unsteady.section_loads`, the same functions) over the
    16 elements of both wings in the asymmetric flow ``V`` with the body rates of the 9-state ``x``
    and its aerodynamic states ``x[9:]``: the element terms of :func:`body_loads` (``dF`` the attached
    force at the quarter chord, ``dF_mid`` at ``r_mid``)."""
    k0 = law.data_offset
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    base = {"r": b["r_m"], "v_kin": b["v_kin_mps"], "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"],
            "ds": b["ds_m"], "chord": b["chord_m"]}
    wake = {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}
    opts = {"unsteady": law.unsteady, "section": law.section, "newton_steps": law.newton_steps}
    flow = {"V": V, "Omega": ca.vertcat(x[4], -x[5], -x[3])}
    sec = unsteady.section_loads(opts, ca.vertcat(x[0], x[2], x[4]), x[9:], base, ud, wake, unsteady_params(p),
                                 flow=flow)
    e = {k: sec[k] for k in ("V", "Vp", "vind", "Vp_norm", "alpha", "Gamma", "dF_mid", "r_mid", "zdot")}
    e["dF"] = sec["dF_att"]
    e["sec"] = sec
    return e


def body_loads(x, d, p, with_tail=False, with_drag=False, section: SectionLaw | None = None,
               normalwash: str = "angle"):
    """Body-axis aerodynamic force (X, Y, Z) [N] and moment (L, M, N) [N m] about G at the 9-state
    ``x`` (then the aerodynamic states of ``section``), planar data ``d`` and parameters ``p`` (SX),
    with the per-element terms.

    ``with_tail``: add the tail's loads (:func:`tail_body_loads`). ``with_drag``: add the optional drag
    terms of the planar model in 3-D (:func:`drag_terms`). ``section``: the unsteady or stall-aware
    section of the planar model (:class:`SectionLaw`), per element over both wings in the asymmetric
    flow (the attached force at the quarter chord, the separated one at mid-chord).

    Returns ``(F_body 3x1, M_body 3x1, terms)``; ``terms`` is the dict of
    :func:`birdocp.bird.aero.forces_from_velocity` (code frame), with ``dD`` and ``F_par`` when
    ``with_drag`` and, with a ``section``, ``dF_mid``, ``r_mid``, ``zdot`` (the aerodynamic-state
    derivatives) and ``sec`` (:func:`birdocp.bird.unsteady.section_loads`).

    Parameters
    ----------
    x : casadi.SX
        9-state (and the section's aerodynamic states).
    d : casadi.SX
        Planar data vector.
    p : casadi.SX
        Parameter vector.
    with_tail : bool
        Add the tail's loads.
    with_drag : bool
        Add the optional drag terms.
    section : SectionLaw, optional
        The unsteady or stall-aware section (default: the linear quasi-steady lifting line).
    normalwash : {"angle", "tangency"}
        ``aero.normalwash``, the linear section's law (:data:`birdocp.bird.collocation.NORMALWASHES`).

    Returns
    -------
    tuple
        ``(F_body, M_body, terms)``.
    """
    u, v, w = x[0], x[1], x[2]
    b = unpack_data(d)
    r = b["r_m"]
    V = air_velocity(x, r, b["v_kin_mps"])
    if section is None:
        e = aero.forces_from_velocity(V, b["c_hat"], b["up"], b["tau"], b["ds_m"], b["G"], b["Wx"], b["Wy"],
                                      _p(p, "aero.air_density_kgm3"), normalwash)
    else:
        e = _section_element_terms(section, x, V, b, d, p)
    dF = e["dF"]
    if with_drag:
        e.update(drag_terms(e, b, u, v, w, p))
        dF = dF + e["dD"]  # the profile drag acts at the element centres, as the lifting-line force
    Fb, Mb = body_axis_loads(r, dF)
    if section is not None:  # the separated force at mid-chord
        Fm, Mm = body_axis_loads(e["r_mid"], e["dF_mid"])
        Fb, Mb = Fb + Fm, Mb + Mm
    if with_drag:  # the body's parasite drag at G (no moment)
        Fb = Fb + ca.vertcat(-e["F_par"][2], e["F_par"][0], -e["F_par"][1])
    if with_tail:
        Lt, Dt, Mt = tail_body_loads(x, b, e["Gamma"], p)
        Fb, Mb = Fb - ca.vertcat(Dt, 0, Lt), Mb + ca.vertcat(0, Mt, 0)
    return Fb, Mb, e


def drag_terms(e: dict, b: dict, u, v, w, p) -> dict:
    """The optional drag of the planar model (``[drag]``; docs/studies/energetics.md) in asymmetric
    flow, code frame: ``dD`` (3 x 16) the profile drag of every element along its section velocity
    ``Vp`` (sideslip and roll and yaw rates included, :func:`birdocp.bird.aero.profile_drag`), acting at
    the element centre (it adds roll and yaw moments where the wings meet the air differently), and
    ``F_par`` (3 x 1) the body's parasite drag at G along the free stream ``U_inf = (-v, w, u)``,
    ``1/2 rho S_b C_Db |U_inf| U_inf`` (no moment). For v = 0 both are the planar model's.

    Parameters
    ----------
    e : dict
        Element terms (:func:`birdocp.bird.aero.forces_from_velocity`).
    b : dict
        Data blocks.
    u, v, w : casadi.SX
        Body velocities (forward, right, down) [m/s].
    p : casadi.SX
        Parameter vector.

    Returns
    -------
    dict
        ``dD`` and ``F_par`` [N].
    """
    rho = _p(p, "aero.air_density_kgm3")
    dD = aero.profile_drag(e["Vp"], e["Vp_norm"], b["chord_m"], b["ds_m"], rho, _p(p, "drag.profile_drag_coefficient"))
    U_inf = ca.vertcat(-v, w, u)
    F_par = 0.5 * rho * _p(p, "drag.body_frontal_area_m2") * _p(p, "drag.body_drag_coefficient") \
        * ca.norm_2(U_inf) * U_inf
    return {"dD": dD, "F_par": F_par}


def air_velocity(x, r, v_kin):
    """The air velocity ``V = U_inf - Omega x r - v_kin`` (3 x n, code frame, m/s, without the
    induced part) of the points ``r`` (3 x n, from G) moving at ``v_kin`` (3 x n) relative to the
    body, at the state ``x`` (u, v, w, p, q, r, ...): ``U_inf = (-v, w, u)``, ``Omega = (q, -r, -p)``.

    Parameters
    ----------
    x : casadi.SX
        9-state (body axes).
    r : casadi.SX
        Points from G, code frame [m] (3 x n).
    v_kin : casadi.SX
        Their velocities relative to the body, code frame [m/s] (3 x n).

    Returns
    -------
    casadi.SX
        Air velocity at the points [m/s] (3 x n).
    """
    u, v, w, pr, q, rr = (x[i] for i in range(6))
    ones = ca.DM.ones(1, r.shape[1])
    om1, om2, om3 = q, -rr, -pr
    return ca.vertcat(-v * ones - (om2 * r[2, :] - om3 * r[1, :]) - v_kin[0, :],
                      w * ones - (om3 * r[0, :] - om1 * r[2, :]) - v_kin[1, :],
                      u * ones - (om1 * r[1, :] - om2 * r[0, :]) - v_kin[2, :])


def body_axis_loads(r, dF):
    """Body-axis force (X, Y, Z) = (-F3, F1, -F2) [N] and moment (L, M, N) = (-Mc3, Mc1, -Mc2) [N m]
    about G of the element forces ``dF`` (3 x n, code frame) acting at ``r`` (3 x n, from G).

    Parameters
    ----------
    r : casadi.SX
        Points of action from G, code frame [m] (3 x n).
    dF : casadi.SX
        Element forces, code frame [N] (3 x n).

    Returns
    -------
    tuple of casadi.SX
        Body-axis force [N] (3 x 1) and moment about G [N m] (3 x 1).
    """
    F = ca.sum2(dF)
    Mc = ca.sum2(ca.vertcat(r[1, :] * dF[2, :] - r[2, :] * dF[1, :],
                            r[2, :] * dF[0, :] - r[0, :] * dF[2, :],
                            r[0, :] * dF[1, :] - r[1, :] * dF[0, :]))
    return ca.vertcat(-F[2], F[0], -F[1]), ca.vertcat(-Mc[2], Mc[0], -Mc[1])


def tail_body_loads(x, b, gamma, p):
    """The tail's lift (up), drag (backwards) and pitching moment about G (:func:`birdocp.bird.tail.tail_loads`)
    in six degrees of freedom: the planar tail fed with the symmetry-plane velocities (u, w, q) and the
    induced velocity of the whole (possibly asymmetric) wake at its neutral point. The flat tail in
    the plane x'y' carries no side force; the crossflow of sideslip and yaw rate (v - r x_tail along
    y') and the roll rate are not seen by it (its loads are even in sideslip and it adds no roll or
    yaw moment: slender-wing theory to first order, docs/studies/lateral.md).

    Parameters
    ----------
    x : casadi.SX
        9-state.
    b : dict
        Data blocks (:func:`birdocp.bird.layout.unpack_data`).
    gamma : casadi.SX
        The 16 circulations [m^2/s].
    p : casadi.SX
        Parameter vector.

    Returns
    -------
    tuple
        As :func:`birdocp.bird.tail.tail_loads`.
    """
    return tail.tail_loads(ca.vertcat(x[0], x[2], x[4]), b["nodes_m"], gamma, _p(p, "aero.air_density_kgm3"),
                           *[_p(p, f"tail.{k}") for k in ("opening_angle_deg", "root_behind_m", "length_m",
                                                          "kinematic_viscosity_m2ps", "reynolds_speed_mps",
                                                          "incidence_deg")])


def rhs_expression(x, d, p6, x_air=None, structure: Structure | None = None, section: SectionLaw | None = None,
                   wind_rate=None):
    """The state derivative (9, then the aerodynamic states') of the rigid body with the aerodynamic
    loads of :func:`body_loads` at ``x_air`` (the state as the air sees it, with a wind; default ``x``)
    and, with ``structure.wing_mass``, the wing masses of :mod:`birdocp.bird.sixdof_inertia` (whose
    sums follow the planar data in ``d``); ``structure.tail`` adds the tail; ``section`` the planar
    model's unsteady or stall-aware section (its lag and separation states after the 9 body states).
    With Wagner's added mass and a wind, ``wind_rate`` is the time derivative of the wind's body-axis
    components along the motion (``C dW/dt - omega x C W``, uniform air: no air rotation): the added
    mass then reacts to the air-relative acceleration ``nu' - (wind_rate, 0, 0, 0)``.

    Parameters
    ----------
    x : casadi.SX
        9-state (then the section's aerodynamic states).
    d : casadi.SX
        Data vector.
    p6 : casadi.SX
        6-DOF parameter vector.
    x_air : casadi.SX, optional
        State as the air sees it (default ``x``).
    structure : Structure, optional
        Structure of the model.
    section : SectionLaw, optional
        The unsteady or stall-aware section (default: the linear quasi-steady lifting line).
    wind_rate : casadi.SX, optional
        Rate of the wind's body-axis components (u, v, w) along the motion [m/s^2] (default: none, the
        graph without it).

    Returns
    -------
    casadi.SX, shape (9 + aerodynamic states, 1)
    """
    return _dynamics(x, d, p6, x_air, structure, section, wind_rate)[0]


def _dynamics(x, d, p6, x_air, structure, section, wind_rate=None):
    """``(xdot, F_body, M_body)`` of :func:`rhs_expression`; with ``wagner`` the loads include the
    added-mass reaction at the solved accelerations (relative to the air with a ``wind_rate``:
    ``(M_rb + M_A) nu_air' = M_rb (nu'_0 - wind_rate) + b_nc``, ``nu' = nu_air' + wind_rate``)."""
    p = p6[:len(PARAM_NAMES)]
    ixx, izz, ixz = (p6[len(PARAM_NAMES) + i] for i in range(3))
    m, iyy, g = _p(p, "body.mass_kg"), _p(p, "body.pitch_inertia_kgm2"), _p(p, "body.gravity_mps2")
    u, v, w, pr, q, rr, phi, th = (x[i] for i in range(8))
    Fb, Mb, e = body_loads(x if x_air is None else x_air, d, p, with_tail=bool(structure and structure.tail),
                           with_drag=bool(structure and structure.drag), section=section,
                           normalwash=getattr(structure, "normalwash", "angle"))
    X, Y, Z = Fb[0], Fb[1], Fb[2]
    L, M, N = Mb[0], Mb[1], Mb[2]
    cth, sth, cph, sph = ca.cos(th), ca.sin(th), ca.cos(phi), ca.sin(phi)
    udot = rr * v - q * w - g * sth + X / m
    vdot = pr * w - rr * u + g * sph * cth + Y / m
    wdot = q * u - pr * v + g * cph * cth + Z / m
    # Euler: I omega' = M - omega x (I omega), I = [[ixx, 0, -ixz], [0, iyy, 0], [-ixz, 0, izz]]
    h1, h2, h3 = ixx * pr - ixz * rr, iyy * q, izz * rr - ixz * pr
    rl = L - (q * h3 - rr * h2)
    rm = M - (rr * h1 - pr * h3)
    rn = N - (pr * h2 - q * h1)
    det = ixx * izz - ixz ** 2
    pdot = (izz * rl + ixz * rn) / det
    qdot = rm / iyy
    rdot = (ixz * rl + ixx * rn) / det
    if structure is not None and structure.wing_mass:
        J_b = ca.blockcat([[ixx, 0, -ixz], [0, iyy, 0], [-ixz, 0, izz]])
        s = wing3.unpack_mass3(d[d.shape[0] - wing3.N_MASS3:])
        udot, vdot, wdot, pdot, qdot, rdot = ca.vertsplit(wing3.wing_corrected_accelerations(
            ca.vertcat(udot, vdot, wdot, pdot, qdot, rdot), x, s, m, J_b, g * ca.vertcat(-sth, sph * cth, cph * cth)))
    if section is not None and section.unsteady == "wagner":  # the added mass on the left (6 x 6)
        J_b = ca.blockcat([[ixx, 0, -ixz], [0, iyy, 0], [-ixz, 0, izz]])
        nudot0 = ca.vertcat(udot, vdot, wdot, pdot, qdot, rdot)
        shift = None if wind_rate is None else ca.vertcat(wind_rate, ca.SX.zeros(3))  # none: the graph of before
        nudot, react = am6.wagner_accelerations(nudot0 if shift is None else nudot0 - shift,
                                                x if x_air is None else x_air, d, p, e["sec"], section.data_offset,
                                                m, J_b)
        udot, vdot, wdot, pdot, qdot, rdot = ca.vertsplit(nudot if shift is None else nudot + shift)
        Fb, Mb = Fb + react[:3], Mb + react[3:]
    turn = q * sph + rr * cph
    return ca.vertcat(udot, vdot, wdot, pdot, qdot, rdot,
                      pr + turn * ca.tan(th), q * cph - rr * sph, turn / cth,
                      *([e["zdot"]] if section is not None and section.n_states else [])), Fb, Mb


class SixDofModel:
    """The six-degree-of-freedom ODE of one planar :class:`~birdocp.bird.model.Structure`.

    ``ode`` is the :class:`~birdocp.engine.ode.ODE` the engine solves: state
    :data:`STATE_NAMES`, parameters :data:`~birdocp.bird.config.PARAM_NAMES` +
    :data:`LATERAL_PARAM_NAMES`, the planar model's data (its ``pre``/``post`` split kept);
    ``rhs(x, d, p)`` and ``loads_d(x, d, p) -> (X, Y, Z, L, M, N)`` are SX Functions built once;
    ``data(t, p)`` is the planar model's data with the 6-DOF parameter vector.
    """

    def __init__(self, planar: BirdModel, sides: bool = False):
        structure = planar.structure
        if structure.unsteady == "wagner" and structure.wing_mass:
            raise ValueError("six degrees of freedom: aero.unsteady = 'wagner' with wing masses is not supported; "
                             "set wing.mass_kg = 0")
        self.planar = planar
        self.sides = bool(sides)
        n = len(PARAM_NAMES)
        names = tuple(PARAM_NAMES) + LATERAL_PARAM_NAMES + (SIDE_PARAM_NAMES if self.sides else ())
        # per-side data: the aerodynamic blocks (then the unsteady blocks of a stall section) only (the
        # planar model's in-plane mass sums, which the 3-D equations do not read, are not assembled for
        # two differing wings)
        self.section = SectionLaw.of(structure, N_DATA if self.sides else unsteady_data_offset(structure))
        n_sec = self.section.n_states if self.section else 0
        self.state_names = STATE_NAMES + tuple(structure.state_names[4:])
        x = ca.SX.sym("x", 9 + n_sec)
        n_planar = (N_DATA + (unsteady.data_size(N_EL) if self.section else 0)) if self.sides \
            else planar.rhs.size1_in(1)
        wag = structure.unsteady == "wagner"  # the 6-DOF added-mass data after the planar data
        n_planar += am6.N_ROWS * N_EL if wag else 0
        d = ca.SX.sym("d", n_planar + (wing3.N_MASS3 if structure.wing_mass else 0))
        p6 = ca.SX.sym("p", len(names))
        self.structure = structure
        self.rhs = ca.Function("rhs6", [x, d, p6], [rhs_expression(x, d, p6, structure=structure, section=self.section)],
                               ["x", "d", "p"], ["xdot"])
        if wag:  # the loads with the added-mass reaction at the solved accelerations
            _, Fb, Mb = _dynamics(x, d, p6, None, structure, self.section)
        else:
            Fb, Mb, _ = body_loads(x, d, p6[:n], with_tail=structure.tail, with_drag=structure.drag,
                                   section=self.section, normalwash=getattr(structure, "normalwash", "angle"))
        self.loads_d = ca.Function("loads6", [x, d, p6], [ca.vertcat(Fb, Mb)], ["x", "d", "p"], ["loads"])
        self.wing_sums = None
        if self.sides:
            pre, post, data, pre_params = side_data_functions(planar, len(names), n + len(LATERAL_PARAM_NAMES))
        else:
            tm, pm = ca.MX.sym("t"), ca.MX.sym("p", len(names))
            pb = pm[:n]
            pre = ca.Function("pre6", [tm, pm], [planar.pre(tm, pb)], ["t", "p"], ["local"])
            loc = ca.MX.sym("local", planar.pre.size1_out(0))
            d_post = planar.post(loc, tm, pb)
            if wag:
                d_post = ca.vertcat(d_post, am6.extra_data_function(structure, loc.shape[0])(loc, tm, pb))
            if structure.wing_mass:  # the 3-D wing-mass sums after the planar data
                self.wing_sums = wing3.sums_function(planar.mass_points)
                d_post = ca.vertcat(d_post, self.wing_sums(tm, pb))
            post = ca.Function("post6", [loc, tm, pm], [d_post], ["local", "t", "p"], ["d"])
            data = ca.Function("data6", [tm, pm], [post(pre(tm, pm), tm, pm)], ["t", "p"], ["d"])
            pre_params = planar.pre_params
        self.data = data
        self.period_s = planar.period_s
        self.ode = ODE(rhs=self.rhs, data=data, forcing_period=planar.period_s, state_names=self.state_names,
                               param_names=names, pre=pre, post=post, pre_params=pre_params)
        # the heading excluded (nothing depends on it): the ODE of a cycle periodic up to its heading
        x8 = ca.SX.sym("x", 8 + n_sec)
        f8 = rhs_expression(ca.vertcat(x8[:HEADING], 0, x8[HEADING:]), d, p6, structure=structure, section=self.section)
        rhs8 = ca.Function("rhs6_no_heading", [x8, d, p6], [ca.vertcat(f8[:HEADING], f8[HEADING + 1:])],
                           ["x", "d", "p"], ["xdot"])
        self.ode_no_heading = ODE(rhs=rhs8, data=data, forcing_period=planar.period_s,
                                  state_names=self.state_names[:HEADING] + self.state_names[HEADING + 1:],
                                  param_names=names, pre=pre, post=post, pre_params=pre_params)

    @property
    def model(self) -> "SixDofModel":
        """The model itself (the identity the sensitivity maps are cached by, as a configured planar
        model's ``model``)."""
        return self

    def params(self, p_planar, inertia: LateralInertia = LateralInertia(), offsets=None) -> list[float]:
        """The 6-DOF parameter vector: the planar ``p_planar`` followed by ``inertia``'s values and,
        for a model with per-side joint laws, the 42 ``offsets`` (:data:`SIDE_PARAM_NAMES`, default 0)."""
        out = [float(v) for v in p_planar] + inertia.vector()
        if self.sides:
            out += [0.0] * len(SIDE_PARAM_NAMES) if offsets is None else [float(v) for v in offsets]
        elif offsets is not None and any(float(v) != 0 for v in offsets):
            raise ValueError("per-side offsets need a model with sides=True (sixdof_model(cfg, sides=True))")
        return out

    def evaluate(self, state, t, p) -> dict:
        """Body-axis loads and the state derivative at one 9-state ``state`` (:data:`STATE_NAMES`) and
        time ``t`` [s] for the parameter vector ``p`` (:meth:`params`): the aerodynamic (and tail) force
        (X, Y, Z) [N] along (x' forward, y' right, z' down) and moment (L, M, N) [N m] about G (roll right
        wing down, pitch nose up, yaw nose right positive) as ``Fx_N, Fy_N, Fz_N, Mx_Nm, My_Nm, Mz_Nm``,
        and ``xdot`` (9). For a symmetric state the planar :meth:`BirdModel.evaluate`'s Fx, Fz, My."""
        import numpy as np

        x, pd = ca.DM(np.asarray(state, float)), ca.DM(np.asarray(p, float))
        d = self.data(float(t), pd)
        loads = np.asarray(self.loads_d(x, d, pd), float).ravel()
        names = ("Fx_N", "Fy_N", "Fz_N", "Mx_Nm", "My_Nm", "Mz_Nm")
        return {**{k: float(v) for k, v in zip(names, loads)},
                "xdot": np.asarray(self.rhs(x, d, pd), float).ravel().tolist()}

    def flight_outputs(self, n_states: int = 9) -> dict:
        """``{"vertical_speed_mps": W, "forward_speed_mps": U}`` as Functions ``(x, d, p)`` of the
        9-state (or of the 8 states of ``ode_no_heading`` with ``n_states = 8``; built once per model):
        the inertial climb rate ``W = u sin(theta) - (v sin(phi) + w cos(phi)) cos(theta)`` and the
        horizontal speed along the heading ``U = u cos(theta) + (v sin(phi) + w cos(phi)) sin(theta)``;
        for phi = 0 they are the planar model's."""
        cache = self.__dict__.setdefault("_outputs", {})
        if n_states not in cache:
            x = ca.SX.sym("x", n_states + len(self.state_names) - len(STATE_NAMES))  # then the aerodynamic states
            d = ca.SX.sym("d", self.rhs.size1_in(1))
            p = ca.SX.sym("p", self.ode.np)
            u, v, w, phi, th = x[0], x[1], x[2], x[6], x[7]
            side = v * ca.sin(phi) + w * ca.cos(phi)
            W = u * ca.sin(th) - side * ca.cos(th)
            U = u * ca.cos(th) + side * ca.sin(th)
            cache[n_states] = {"vertical_speed_mps": ca.Function("vertical_speed_mps", [x, d, p], [W]),
                               "forward_speed_mps": ca.Function("forward_speed_mps", [x, d, p], [U])}
        return cache[n_states]


def sixdof_model(cfg: Config, sides: bool | None = None) -> SixDofModel:
    """The :class:`SixDofModel` of ``cfg``'s structure (built once, kept by the planar model); its numbers come from
    ``SixDofModel.params(param_vector(cfg), inertia, offsets)``. ``sides``: a model with per-side
    joint laws (default: when ``cfg``'s gait is asymmetric, :func:`birdocp.bird.config.asymmetric`).

    Parameters
    ----------
    cfg : Config
        Configuration.
    sides : bool, optional
        Per-side joint laws.

    Returns
    -------
    SixDofModel
    """
    sides = asymmetric(cfg) if sides is None else bool(sides)
    planar = get_model(cfg).model
    return owned_cache(planar).build(("sixdof", sides), lambda: SixDofModel(planar, sides))


def embed_planar_state(x4) -> list[float]:
    """The 9-state of a planar state (u, w, q, theta): v = p = r = phi = psi = 0.

    Parameters
    ----------
    x4 : sequence of float
        (u, w, q, theta).

    Returns
    -------
    list of float
    """
    u, w, q, th = (float(v) for v in x4)
    return [u, 0.0, w, 0.0, q, 0.0, 0.0, th, 0.0]
