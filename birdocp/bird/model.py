"""The bird model as CasADi Functions, built once per structural configuration.

Split (the data/right-hand-side split of ``docs/model.md``): everything that depends only on time and parameters (wing geometry,
kinematic velocity, lifting-line matrices) is the per-time data ``d = data(t, p)``; the state right-hand
side ``rhs(x, d, p)`` is small. ``f(x, t, p) = rhs(x, data(t, p), p)`` is offered for users and tests.

State x = (u [m/s] forward along x', w [m/s] down along z', q [rad/s] pitch rate nose-up, theta [rad]
pitch angle). Body frame: x' forward, z' down; loads ``Fx_N``, ``Fz_N`` and ``My_Nm`` (nose-up
positive) about the centre of mass G. Parameters ``p``: :data:`birdocp.bird.config.PARAM_NAMES`.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from birdocp.bird import aero
from birdocp.bird import inertia
from birdocp.bird import kinematics
from birdocp.bird import tail
from birdocp.bird import unsteady
from birdocp.bird import wing
from birdocp.bird.config import JOINT_NAMES, PARAM_NAMES, WING_MASS_SHARES, Config, param_vector
from birdocp.engine.cache import register_cache
from birdocp.engine.lazy import LazyFunction
from birdocp.engine.problem import PeriodicODE

N_EL = aero.N_ELEMENTS
STATE_NAMES = ("u_mps", "w_mps", "q_radps", "theta_rad")

# Layout of the per-time data vector d (column-major blocks).
DATA_BLOCKS = (
    ("r_m", (3, N_EL)),          # element centres relative to G, code frame
    ("v_kin_mps", (3, N_EL)),    # kinematic velocity of the centres
    ("c_hat", (3, N_EL)),        # chord directions (leading -> trailing edge)
    ("up", (3, N_EL)),           # 'up' normals
    ("tau", (3, N_EL)),          # spanwise directions n x c_hat
    ("ds_m", (N_EL, 1)),         # element lengths
    ("G", (N_EL, N_EL)),         # Gamma = G (|Vp| alpha); unsteady/stall structures: K (downwash per unit Gamma)
    ("Wx", (N_EL, N_EL)),        # induced velocity e1 = Wx (|Vp| alpha); unsteady/stall: per unit Gamma
    ("Wy", (N_EL, N_EL)),        # induced velocity e2 = Wy (|Vp| alpha); unsteady/stall: per unit Gamma
    ("nodes_m", (3, N_EL + 1)),  # element end nodes relative to G (the tail's induced velocity)
    ("chord_m", (N_EL, 1)),      # element chords (the optional profile drag)
)


def _offsets():
    out, k = {}, 0
    for name, (r, c) in DATA_BLOCKS:
        out[name] = (k, r, c)
        k += r * c
    return out, k


DATA_OFFSETS, N_DATA = _offsets()

N_MASS = len(inertia.MASS_BLOCK)
"""A model with wing masses appends the sums :data:`birdocp.bird.inertia.MASS_BLOCK` to the data
vector: its data has N_DATA + N_MASS values, the first N_DATA laid out as :data:`DATA_BLOCKS`."""


def unpack_mass(d):
    """The wing-mass sums of a data vector of a model with wing masses, as a dict of scalars."""
    return {k: d[N_DATA + i] for i, k in enumerate(inertia.MASS_BLOCK)}


def unpack_data(d):
    """Blocks of a data vector (SX/MX/DM) as a dict of matrices."""
    return {name: ca.reshape(d[k:k + r * c], r, c) for name, (k, r, c) in DATA_OFFSETS.items()}


def air_state(x, wind_mps):
    """The state as the aerodynamics sees it: (u - wind_u, w - wind_w, q, theta).

    ``wind_mps`` = (W_X, W_Z): the air's velocity in the inertial frame (X forward horizontal, Z down,
    m/s), uniform over the bird; rotated into the body frame (x' forward, z' down) by the pitch angle
    theta: ``wind_u = cos(theta) W_X - sin(theta) W_Z``, ``wind_w = sin(theta) W_X + cos(theta) W_Z``.
    The state's u, w stay the inertial velocity of G in the body frame (the equations of motion are
    unchanged); a zero wind gives back x exactly."""
    th = x[3]
    c, s = ca.cos(th), ca.sin(th)
    return ca.vertcat(x[0] - (c * wind_mps[0] - s * wind_mps[1]),
                      x[1] - (s * wind_mps[0] + c * wind_mps[1]), x[2], th)


def _p(p, name):
    return p[PARAM_NAMES.index(name)]


@dataclass(frozen=True)
class Structure:
    """What changes the graphs (everything else is a number in ``p``)."""

    frequency_hz: float
    circulation: str
    relaxed_evaluations: int
    kinematic_velocity: str
    backward_step_s: float
    tail: bool = False
    wing_mass: bool = False
    drag: bool = False
    unsteady: str = "none"
    section: str = "linear"
    newton_steps: int = 5

    @property
    def aero_extra(self) -> bool:
        """True when the unsteady or stall-aware section is on (``aero.unsteady``, ``aero.section``)."""
        return self.unsteady != "none" or self.section != "linear"

    @property
    def n_aero_states(self) -> int:
        """Aerodynamic states after (u, w, q, theta): lag states and separation states."""
        return unsteady.n_aero_states(self.unsteady, self.section, N_EL)

    @property
    def state_names(self) -> tuple[str, ...]:
        return STATE_NAMES + unsteady.aero_state_names(self.unsteady, self.section, N_EL)

    @staticmethod
    def of(cfg: Config) -> "Structure":
        a = cfg.aero
        dr = cfg.drag
        return Structure(cfg.gait.frequency_hz, a.circulation, a.relaxed_evaluations,
                         a.kinematic_velocity, a.backward_step_s,
                         bool(cfg.tail.enabled or cfg.tail.opening_angle_deg > 0),
                         bool(cfg.wing.inertial_terms or cfg.wing.mass_kg > 0),
                         drag=bool(dr.enabled or dr.body_drag_coefficient > 0 or dr.profile_drag_coefficient > 0),
                         unsteady=a.unsteady, section=a.section,
                         newton_steps=int(a.newton_steps) if a.section != "linear" else 5)


def _joint_angles(t, p, frequency_hz):
    joints = {j: tuple(_p(p, f"gait.{j}.{k}") for k in ("offset_deg", "amplitude_deg", "phase_deg"))
              for j in JOINT_NAMES}
    return kinematics.joint_angles(t, frequency_hz, joints)


def _local_expr(t, p, frequency_hz):
    """The wing in the arm's frame (shoulder rotation R1 = I): every non-smooth step of the
    reference (resampling, corner smoothing, nearest points) happens here, and it depends on the
    elbow and wrist joints and the morphology only (docs/model.md §2-4; lengths and angles are invariant under
    the shoulder rotation, so the wing in the wing frame is R1 times this shape)."""
    q = _joint_angles(t, p, frequency_hz)
    l1, l2, l4 = (_p(p, f"wing.{k}") for k in ("arm_length_m", "forearm_length_m", "hand_length_m"))
    feathers = [_p(p, f"wing.feather_lengths_m.{i}") for i in range(7)]
    sk = kinematics.skeleton(q, l1, l2, l4, feathers, with_shoulder=False)
    LE, TE = kinematics.raw_edges(sk, l1, l2, l4, _p(p, "wing.section_half_thickness_m"))
    radius = _p(p, "wing.smoothing_radius_m")
    LEs, dle = wing.smooth_line(LE, radius)
    TEs, dte = wing.smooth_line(TE, radius)
    P, E, T, Lr, change = wing.lifting_line(LEs, TEs)
    chord, c_hat, up = wing.sections(P, E, T, Lr)
    diag = {k: dle[k] + dte[k] for k in dle}
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


def _unsteady_params(p) -> dict:
    a0 = 1.0 - _p(p, "aero.wagner_weight") * (unsteady.A1 + unsteady.A2)
    return {"rho": _p(p, "aero.air_density_kgm3"), "cla": _p(p, "aero.lift_slope_per_rad"),
            "eps": _p(p, "aero.wagner_weight"), "a0": a0, "kappa": _p(p, "aero.wagner_time_scale"),
            "chi_w": _p(p, "aero.pitch_rate_weight"), "chi_nc": _p(p, "aero.added_mass_weight"),
            "alpha1": _p(p, "aero.separation_angle_deg") * (ca.pi / 180), "cd90": _p(p, "aero.flat_plate_cd90"),
            "Tf": _p(p, "aero.separation_lag_semichords"), "T2": _p(p, "aero.separation_delay_semichords")}


def _opts(structure: Structure) -> dict:
    return {"unsteady": structure.unsteady, "section": structure.section, "newton_steps": structure.newton_steps}


def unsteady_data_offset(structure: Structure) -> int:
    """Where the unsteady data blocks start in the data vector (after the wing-mass sums)."""
    return N_DATA + (N_MASS if structure.wing_mass else 0)


def section_terms(structure: Structure, x, d, p) -> dict:
    """:func:`birdocp.bird.unsteady.section_loads` of an unsteady/stall structure at the air-relative
    state x (4 + aerodynamic states) and data d."""
    b = unpack_data(d)
    k0 = unsteady_data_offset(structure)
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    base = {"r": b["r_m"], "v_kin": b["v_kin_mps"], "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"],
            "ds": b["ds_m"], "chord": b["chord_m"]}
    wake = {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}
    return unsteady.section_loads(_opts(structure), x[0:3], x[4:], base, ud, wake, _unsteady_params(p))


def load_terms(structure: Structure, x, d, p, x_inertial=None) -> dict:
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
    added mass on the left) and ``xdot_aero``; the body loads include the added-mass reaction.
    """
    b = unpack_data(d)
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
                                b["G"], b["Wx"], b["Wy"], rho)
        F = ca.sum2(e["dF"])
        M = aero.moment_about_G(r, e["dF"])
    out = {"r": r, "v_kin": b["v_kin_mps"], "V": e["V"], "Vp": e["Vp"], "vind": e["vind"], "dF": e["dF"],
           "dD": ca.SX.zeros(3, N_EL), "F_par": ca.SX.zeros(3, 1), "tail": None,
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
        Fx, Fz, My = _with_added_mass(out, sec, Fx, Fz, My, x if x_inertial is None else x_inertial, p)
        F = F + ca.sum2(out["dF_mid"] - sec["dF_mid"])  # the added-mass force (code frame)
    out.update(F_code=F, Fx_N=Fx, Fz_N=Fz, My_Nm=My)
    return out


def _with_added_mass(out, sec, Fx, Fz, My, xi, p):
    """Body accelerations with the added mass on the left, (M_b + M_A) nu' = b + b_nc, and the body loads
    with the added-mass reaction; fills ``nudot``, ``xdot_aero``, ``dF_mid``, ``couple``, ``sec`` of ``out``."""
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
    MA = sec["M_A"]
    nudot = unsteady.solve_sym3(ca.diag(ca.vertcat(m, m, I)) + MA, bvec)
    react = sec["b_nc"] - MA @ nudot
    out["nudot"] = nudot
    out["loads_held"] = ca.vertcat(Fx, Fz, My) + sec["b_nc"]  # body accelerations held at zero
    # added-mass force per element along n_hat and the couples, with the solved accelerations
    nc = sec["nc_coef"] + sec["m_a_chi"] * (nudot.T @ sec["a"])
    out["dF_mid"] = sec["dF_mid"] + ca.repmat(nc, 3, 1) * sec["n_hat"]
    out["couple"] = sec["couple0"] - sec["m_theta_chi"] * sec["tau1"] * nudot[2]
    return Fx + react[0], Fz + react[1], My + react[2]


GRAPH_FUNCTIONS = ("pre", "post", "rhs", "data", "geometry", "loads_d", "detail_d", "rhs_wind",
                   "loads_wind")
"""The SX Functions of a :class:`BirdModel` that the graph cache stores (the MX compositions ``f``,
``loads``, ``aero_detail`` are rebuilt from them in milliseconds)."""

OPTIONAL_FUNCTIONS = ("mass_points", "wing_power_d", "section_d", "aero_guess_d", "held_d")
"""Functions only some structures have (wing masses; unsteady or stall sections); None otherwise."""

_EAGER = ("pre", "post", "rhs")  # what every solve needs; the rest is read from the cache on first use
_LAZY = ("pre",)  # of those, read only when evaluated (LazyFunction): its stage-grid values are on disk


def graph_key(structure: Structure) -> dict:
    """Everything that changes the model's graphs: the source of :mod:`birdocp.bird` and
    :mod:`birdocp.engine` (hashed), the :class:`Structure` (frequency, circulation, relaxed
    evaluations, kinematic velocity, its backward step, tail on/off, wing masses on/off; every other
    configuration value
    is a number in ``p``), the parameter layout and the birdocp version (CasADi's version and the
    cache format are added by :mod:`birdocp.engine.graphcache`)."""
    from pathlib import Path

    from birdocp import __version__
    from birdocp.engine import graphcache

    here = Path(__file__).resolve().parent
    sources = list(here.rglob("*.py")) + list((here.parent / "engine").rglob("*.py"))
    return {"model": "bird", "sources_sha256": graphcache.source_digest(sources),
            "structure": {k: getattr(structure, k) for k in structure.__dataclass_fields__},
            "param_names": list(PARAM_NAMES), "n_data": N_DATA, "birdocp": __version__}


def _arm_blocks(L):
    """(P, c_hat, up, chord, aux) of one wing from the first values of a ``pre`` output ``L``."""
    k, out = 0, []
    for rows, n in ((3, 48), (3, 48), (3, 48), (1, 16), (3, 48)):
        out.append(ca.reshape(L[k:k + n], rows, N_EL))
        k += n
    return out


def aero_blocks(s: Structure, L, t, p, left=None) -> dict:
    """The aerodynamic data blocks (:data:`DATA_BLOCKS`, SX) from the arm-frame wing ``L`` (a ``pre``
    output) at time ``t`` and parameters ``p``: shoulder rotation, merge, kinematic velocity,
    lifting-line matrices. ``left`` = (L, p) of a left wing with its own joint laws (an asymmetric
    gait, :mod:`birdocp.bird.sides`); None: the mirror image of the right wing (the planar model)."""
    f_hz = s.frequency_hz
    x_ep = _p(p, "wing.shoulder_half_separation_m")
    R1 = _shoulder(t, p, f_hz)
    P_s, c_s, u_s, ch_s, aux_s = _arm_blocks(L)
    if left is None:
        Q, ch, cd, nu = _merged(R1, P_s, c_s, u_s, ch_s, x_ep)
    else:
        R1l = _shoulder(t, left[1], f_hz)
        Pl, cl, ul, chl, auxl = _arm_blocks(left[0])
        Q, ch, cd, nu = wing.merge(_columns(R1 @ P_s), [ch_s[j] for j in range(N_EL)], _columns(R1 @ c_s),
                                   _columns(R1 @ u_s), x_ep,
                                   left=(_columns(R1l @ Pl), [chl[j] for j in range(N_EL)], _columns(R1l @ cl),
                                         _columns(R1l @ ul)))
    line = ca.horzcat(*Q)
    centres, nodes = line[:, 1::2], line[:, 0::2]
    if s.kinematic_velocity == "exact":
        Pdot = ca.jtimes(R1, t, ca.SX(1)) @ P_s + R1 @ aux_s
        lv = None if left is None else (_columns(ca.jtimes(R1l, t, ca.SX(1)) @ Pl + R1l @ auxl), [0] * N_EL,
                                        _columns(Pl), _columns(Pl))
        Qd = wing.merge(_columns(Pdot), [0] * N_EL, _columns(P_s), _columns(P_s), 0.0, left=lv)[0]
        v_kin = ca.horzcat(*Qd)[:, 1::2]
    else:
        R1_prev = _shoulder(t - s.backward_step_s, p, f_hz)
        lv = None if left is None else (_columns(_shoulder(t - s.backward_step_s, left[1], f_hz) @ auxl),
                                        [0] * N_EL, _columns(Pl), _columns(Pl))
        Qp = wing.merge(_columns(R1_prev @ aux_s), [0] * N_EL, _columns(P_s), _columns(P_s), x_ep, left=lv)[0]
        v_kin = (centres - ca.horzcat(*Qp)[:, 1::2]) / s.backward_step_s
    c_hat = ca.horzcat(*cd)[:, 1::2]
    up = ca.horzcat(*nu)[:, 1::2]
    chord = ca.horzcat(*ch)[1::2]
    tau = ca.horzcat(*[ca.cross(up[:, j], c_hat[:, j]) for j in range(N_EL)])
    ds = ca.vertcat(*[ca.norm_2(nodes[:, j + 1] - nodes[:, j]) for j in range(N_EL)])
    r_w = ca.vertcat(0, 0, -_p(p, "wing.root_ahead_m"))
    r = centres + ca.repmat(r_w, 1, N_EL)
    if s.aero_extra:  # per unit circulation: the state right-hand side solves the lifting line
        Wx, Wy, G = aero.induced_matrices(_columns(centres), _columns(nodes))
    else:
        G, Wx, Wy = aero.circulation_matrices(
            _columns(centres), _columns(nodes), [chord[j] for j in range(N_EL)],
            _p(p, "aero.lift_slope_per_rad"), s.circulation, s.relaxed_evaluations)
    return {"r_m": r, "v_kin_mps": v_kin, "c_hat": c_hat, "up": up, "tau": tau, "ds_m": ds,
            "G": G, "Wx": Wx, "Wy": Wy, "nodes_m": nodes + ca.repmat(r_w, 1, N_EL + 1),
            "chord_m": chord.T}


def _build(s: Structure) -> tuple[dict, tuple]:
    """The SX Functions of structure ``s`` (:data:`GRAPH_FUNCTIONS`, and
    :data:`OPTIONAL_FUNCTIONS` or None) and ``pre_params``."""
    fns = {}
    f_hz = s.frequency_hz
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", len(PARAM_NAMES))
    x_ep = _p(p, "wing.shoulder_half_separation_m")

    # Arm-frame shape ("pre") and its kinematic-velocity companion.
    loc = _local_expr(t, p, f_hz)
    P, c_hat_l, up_l, chord_l = loc["P"], loc["c_hat"], loc["up"], loc["chord"]
    if s.kinematic_velocity == "exact":
        aux = ca.jtimes(ca.vec(P), t, ca.SX(1))       # dP/dt in the arm frame
    elif s.kinematic_velocity == "backward-difference":
        aux = ca.vec(ca.Function("P_local", [t, p], [P])(t - s.backward_step_s, p))  # P(t - delta)
    else:
        raise ValueError(f"aero.kinematic_velocity must be 'exact' or 'backward-difference', got {s.kinematic_velocity!r}")
    ell = ca.vertcat(ca.vec(P), ca.vec(c_hat_l), ca.vec(up_l), ca.vec(chord_l), aux)
    n_aero_local = ell.numel()
    ell_aero = ell
    if s.wing_mass:
        # wing mass points in the arm's frame with their time derivatives (AD in t): smooth
        # functions of the elbow and wrist joints, so they belong to the numeric 'pre' part
        rho = ca.horzcat(*_local_mass_points(t, p, f_hz))
        rho_d = ca.jtimes(rho, t, ca.SX(1))
        rho_dd = ca.jtimes(rho_d, t, ca.SX(1))
        ell = ca.vertcat(ell, ca.vec(rho), ca.vec(rho_d), ca.vec(rho_dd))
    n_before_deriv = ell.numel()
    if s.aero_extra:
        # first and second time derivatives of the arm-frame aerodynamic shape (AD in t): the
        # unsteady data (pitch rates, added-mass rates) are time derivatives of the assembled geometry
        ell_d = ca.jtimes(ell_aero, t, ca.SX(1))
        ell = ca.vertcat(ell, ell_d, ca.jtimes(ell_d, t, ca.SX(1)))
    fns["pre"] = ca.Function("wing_local", [t, p], [ell], ["t", "p"], ["local"])
    pre_params = tuple(int(k) for k in np.nonzero(
        np.asarray(ca.DM(ca.jacobian_sparsity(ell, p), 1)).sum(axis=0))[0])

    # Geometry for users and plots: the arm-frame shape rotated by R1, merged.
    R1 = _shoulder(t, p, f_hz)
    Q, ch, cd, nu = _merged(R1, P, c_hat_l, up_l, chord_l, x_ep)
    diag = dict(loc["diag"], n_mid=ca.ceil(2 * x_ep / loc["dx"]))
    geo = {
        "joint_angles_rad": loc["joint_angles_rad"],
        "leading_edge_raw": R1 @ loc["leading_edge_raw"], "trailing_edge_raw": R1 @ loc["trailing_edge_raw"],
        "leading_edge": R1 @ loc["leading_edge"], "trailing_edge": R1 @ loc["trailing_edge"],
        "line": ca.horzcat(*Q), "chord_m": ca.horzcat(*ch), "chord_dir": ca.horzcat(*cd),
        "up_dir": ca.horzcat(*nu), "diagnostics": ca.vertcat(*[diag[k] for k in wing.DIAGNOSTICS]),
    }
    fns["geometry"] = ca.Function("geometry", [t, p], [geo[k] for k in GEOMETRY_OUTPUTS],
                                ["t", "p"], list(GEOMETRY_OUTPUTS))

    # Assembly ("post"): shoulder rotation, merge, kinematic velocity, lifting-line matrices.
    L = ca.SX.sym("local", ell.numel())
    blocks = aero_blocks(s, L, t, p)
    r, v_kin, c_hat, up, tau, ds = (blocks[k] for k in ("r_m", "v_kin_mps", "c_hat", "up", "tau", "ds_m"))
    chord = blocks["chord_m"].T
    k = n_aero_local
    d = ca.vertcat(*[ca.vec(blocks[name]) for name, _ in DATA_BLOCKS])
    if s.wing_mass:
        npt = inertia.N_POINTS_PER_WING
        rho_s = [ca.reshape(L[k + 3 * npt * j:k + 3 * npt * (j + 1)], 3, npt) for j in range(3)]
        R1d = ca.jtimes(R1, t, ca.SX(1))
        R1dd = ca.jtimes(R1d, t, ca.SX(1))
        rb, vb, ab = _wing_points_body(R1, R1d, R1dd, *rho_s, p)
        sums = inertia.mass_sums(_point_masses(p), rb, vb, ab)
        d = ca.vertcat(d, *[sums[kk] for kk in inertia.MASS_BLOCK])
        mpts = ell[n_aero_local:]
        mr = [ca.reshape(mpts[3 * npt * j:3 * npt * (j + 1)], 3, npt) for j in range(3)]
        rb, vb, ab = _wing_points_body(R1, R1d, R1dd, *mr, p)
        mirror = ca.diag(ca.DM([1, -1, 1]))
        both = [ca.horzcat(ca.horzcat(*z), mirror @ ca.horzcat(*z)) for z in (rb, vb, ab)]
        mm = ca.vertcat(*_point_masses(p))
        # both wings' mass points relative to G_b in the body frame (x', y', z'), 3 x 40 each
        # (right wing then left), their velocities and accelerations relative to the body, masses
        fns["mass_points"] = ca.Function(
            "wing_mass_points", [t, p], both + [ca.vertcat(mm, mm)], ["t", "p"],
            ["r_m", "v_mps", "a_mps2", "m_kg"])
    else:
        fns["mass_points"] = None
    if s.aero_extra:
        na = n_aero_local
        tangent = ca.vertcat(L[n_before_deriv:n_before_deriv + na], ca.SX.zeros(n_before_deriv - na),
                             L[n_before_deriv + na:n_before_deriv + 2 * na], ca.SX.zeros(na))

        def ddt(e):
            return ca.jtimes(e, L, tangent) + ca.jtimes(e, t, ca.SX(1))

        ud = unsteady.element_data(r, v_kin, c_hat, up, tau, chord.T, ds, ddt)
        d = ca.vertcat(d, unsteady.pack(ud, N_EL))
    fns["post"] = ca.Function("wing_assemble", [L, t, p], [d], ["local", "t", "p"], ["d"])
    fns["data"] = ca.Function("data", [t, p], [fns["post"](ell, t, p)], ["t", "p"], ["d"])

    # State part. The aerodynamics sees the air-relative state (``air_state``: the wind in the
    # inertial frame, rotated into the body frame, subtracted from u, w); rhs/loads_d/detail_d
    # are the same graphs with the wind substituted by zero (the exact graphs of before).
    x = ca.SX.sym("x", 4 + s.n_aero_states)
    wind = ca.SX.sym("wind_mps", 2)
    xa = ca.vertcat(air_state(x, wind), x[4:])
    dsym = ca.SX.sym("d", unsteady_data_offset(s) + (unsteady.data_size(N_EL) if s.aero_extra else 0))
    lt = load_terms(s, xa, dsym, p, x_inertial=x)
    Fx, Fz, My, Gamma, alpha, vp, F = (lt[k] for k in ("Fx_N", "Fz_N", "My_Nm", "Gamma", "alpha", "Vp_norm",
                                                      "F_code"))
    m = _p(p, "body.mass_kg")
    I = _p(p, "body.pitch_inertia_kgm2")
    grav = _p(p, "body.gravity_mps2")
    u, w, q, theta = x[0], x[1], x[2], x[3]
    xdot = ca.vertcat(-q * w - grav * ca.sin(theta) + Fx / m,
                      q * u + grav * ca.cos(theta) + Fz / m,
                      My / I,
                      q)
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
    fns["rhs_wind"] = ca.Function("rhs_wind", [x, dsym, p, wind], [xdot], ["x", "d", "p", "wind_mps"], ["xdot"])
    fns["loads_wind"] = ca.Function("loads_wind", [x, dsym, p, wind], [ca.vertcat(Fx, Fz, My)],
                                  ["x", "d", "p", "wind_mps"], ["loads"])
    zero = [ca.SX.zeros(2)]
    xdot, loads, detail = ca.substitute([xdot, ca.vertcat(Fx, Fz, My), ca.vertcat(Gamma, alpha, vp, ca.vec(F))],
                                        [wind], zero)
    if powers is not None:
        # (x, d, p) -> the powers WING_POWER_NAMES [W] (and T_rel [J]) at one instant
        fns["wing_power_d"] = ca.Function("wing_power_d", [x, dsym, p], ca.substitute([powers], [wind], zero),
                                        ["x", "d", "p"], ["powers"])
    else:
        fns["wing_power_d"] = None
    if s.aero_extra:
        fns.update(_section_functions(s, x, dsym, p, lt, wind))
    else:
        fns.update(section_d=None, aero_guess_d=None, held_d=None)
    fns["rhs"] = ca.Function("rhs", [x, dsym, p], [xdot], ["x", "d", "p"], ["xdot"])
    fns["loads_d"] = ca.Function("loads_d", [x, dsym, p], [loads], ["x", "d", "p"], ["loads"])
    fns["detail_d"] = ca.Function("detail_d", [x, dsym, p], ca.vertsplit(detail, [0, N_EL, 2 * N_EL, 3 * N_EL, 3 * N_EL + 3]),
                                ["x", "d", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])
    return fns, pre_params


SECTION_OUTPUTS = ("alpha_E_rad", "alpha_eff_quasi_steady_rad", "f_sep", "Gamma_m2ps", "newton_residual",
                   "ds_m", "alpha_geo_rad")
"""Outputs of ``BirdModel.section_d(x, d, p)`` (unsteady/stall structures): per element (16) the angle
the section law sees alpha_E (lag and 3/4-chord term included), the quasi-steady effective angle of
the same state (today's definition), the separation point f (1 = attached), the circulation, then the
relative Newton residual max|R| / max|Gamma| of the stall circulation (0 for a linear section), the
element lengths and the geometric angles."""


def _section_functions(s: Structure, x, d, p, lt, wind) -> dict:
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
    outs = ca.substitute(outs, [wind], [ca.SX.zeros(2)])
    fns = {"section_d": ca.Function("section_d", [x, d, p], outs, ["x", "d", "p"], list(SECTION_OUTPUTS))}
    held = ca.substitute([lt["xdot_aero"], lt["loads_held"]], [wind], [ca.SX.zeros(2)])
    fns["held_d"] = ca.Function("held_d", [x, d, p], held, ["x", "d", "p"], ["xdot_aero", "loads"])
    x4 = ca.SX.sym("x4", 4)
    prm = dict(_unsteady_params(p), a0=1.0)
    base = {"r": b["r_m"], "v_kin": b["v_kin_mps"], "c_hat": b["c_hat"], "up": b["up"], "tau": b["tau"],
            "ds": b["ds_m"], "chord": b["chord_m"]}
    k0 = unsteady_data_offset(s)
    ud = unsteady.unpack(d[k0:k0 + unsteady.data_size(N_EL)], N_EL)
    lin = {"unsteady": s.unsteady, "section": "stall" if s.section != "linear" else "linear",
           "newton_steps": s.newton_steps}
    g0 = unsteady.section_loads(lin, x4[0:3], ca.SX.zeros(2 * N_EL if s.unsteady == "wagner" else 0, 1), base, ud,
                                {"K": b["G"], "Vx": b["Wx"], "Vy": b["Wy"]}, prm)
    vp = g0["Vp_norm"].T
    g = g0["alpha_E"] * vp  # with A0 = 1 and z = 0, g_E = g
    z = []
    if s.unsteady == "wagner":
        z += [prm["eps"] * unsteady.A1 * g, prm["eps"] * unsteady.A2 * g]
    if s.section == "dynamic-stall":
        z.append(unsteady.separation_point(g0["alpha_E"], prm["alpha1"]))
    fns["aero_guess_d"] = ca.Function("aero_guess_d", [x4, d, p], [ca.vertcat(*z)], ["x", "d", "p"], ["z"])
    return fns


class BirdModel:
    """CasADi Functions of the bird for one :class:`Structure`; numbers go in ``p``.

    Functions (built once, or read from the graph cache :mod:`birdocp.engine.graphcache` keyed by
    :func:`graph_key`; Functions other than ``pre``, ``post``, ``rhs`` are read on first use):

    * ``geometry(t, p)``: named outputs :data:`GEOMETRY_OUTPUTS` (merged line 3x33 in the code frame
      with origin on the body centre line at the shoulders, chords, directions, diagnostics);
    * ``data(t, p) -> d`` (:data:`N_DATA` values, layout :data:`DATA_BLOCKS`);
    * ``pre(t, p)`` (the wing in the arm frame) and ``post(local, t, p) -> d``, with
      ``data = post(pre(t, p), t, p)``; ``pre`` depends on the parameters ``pre_params`` only;
    * ``rhs(x, d, p) -> xdot`` and ``loads_d(x, d, p) -> [Fx_N, Fz_N, My_Nm]``;
    * ``rhs_wind(x, d, p, wind_mps)`` and ``loads_wind``: the same with a uniform wind (inertial frame,
      X forward, Z down, m/s) in the air velocity of every wing element and of the tail
      (:func:`air_state`); with a zero wind they equal ``rhs`` and ``loads_d`` exactly;
    * ``f(x, t, p) -> xdot``, ``loads(x, t, p)`` and ``aero_detail(x, t, p)`` (circulations, angles of
      attack) composed in MX;
    * with wing masses, ``mass_points(t, p)`` and ``wing_power_d(x, d, p)`` (else None).

    ``ode`` (the :class:`~birdocp.engine.problem.PeriodicODE` the engine solves) has the data as the
    MX composition of ``pre`` and ``post`` (the same numbers as ``data``).

    ``graph_source`` says where the graphs came from: ``"built"``, ``"cache"`` (read) or
    ``"built+stored"``; ``graph_s`` the seconds it took. Most users call :func:`get_model`, which
    shares one model per structure.

    Parameters
    ----------
    structure : Structure
        What changes the graphs (not the numbers): the frequency, circulation and kinematic-velocity variants,
        tail, drag and wing-mass switches (``Structure.of(cfg)``).
    use_cache : bool
        Read and store the graphs in the on-disk graph cache (when it is enabled).
    """

    def __init__(self, structure: Structure, use_cache: bool = True):
        from birdocp.engine import graphcache

        self.structure = structure
        t0 = time.perf_counter()
        self._entry = None
        self._fns: dict = {}
        use_cache = use_cache and graphcache.enabled()
        key = graph_key(structure) if use_cache else None
        if use_cache:
            entry = graphcache.load("bird-model", key)
            if entry is not None and set(GRAPH_FUNCTIONS) <= set(entry.names):
                try:
                    for name in _EAGER:
                        sig = entry.signature(name) if name in _LAZY else None
                        # pre (0.25 s to read) only when it is evaluated: its stage-grid values are
                        # usually on disk (engine.datastore)
                        self._fns[name] = (LazyFunction(functools.partial(self._read, name), sig) if sig
                                           else entry.function(name))
                    self.pre_params = tuple(int(i) for i in entry.meta["pre_params"])
                    self._entry = entry
                except (graphcache.CacheMiss, KeyError, TypeError, ValueError):
                    self._fns = {}
                    entry.discard()
            elif entry is not None:  # written without every Function: replace it
                entry.discard()
        if self._entry is None:
            self._fns, self.pre_params = _build(structure)
            self.graph_source = "built"
            if use_cache and graphcache.store("bird-model", key, {k: f for k, f in self._fns.items() if f is not None},
                                              {"pre_params": list(self.pre_params)}) is not None:
                self.graph_source = "built+stored"
        else:
            self.graph_source = "cache"
        self.period_s = 1.0 / structure.frequency_hz
        data_sig = {"name": "data", "size_in": [[1, 1], [len(PARAM_NAMES), 1]],
                    "size_out": [list(self.post.size_out(0))]}
        data_mx = LazyFunction(self._compose_data, data_sig) if isinstance(self.pre, LazyFunction) \
            else self._compose_data()
        self.ode = PeriodicODE(rhs=self.rhs, data=data_mx, period_s=self.period_s,
                               state_names=structure.state_names, param_names=PARAM_NAMES,
                               pre=self.pre, post=self.post, pre_params=self.pre_params,
                               graph_key=graphcache.key_digest(key) if use_cache else "")
        self.graph_s = time.perf_counter() - t0

    def _compose_data(self) -> ca.Function:
        # data(t, p) = post(pre(t, p), t, p), composed in MX (the same numbers as the full data graph)
        tm, pm = ca.MX.sym("t"), ca.MX.sym("p", len(PARAM_NAMES))
        return ca.Function("data", [tm, pm], [self.post(self.pre(tm, pm), tm, pm)], ["t", "p"], ["d"])

    def _read(self, name: str) -> ca.Function:
        """``name`` from the cache entry, rebuilt (and re-stored) if the entry broke since it was opened."""
        from birdocp.engine import graphcache

        try:
            return self._entry.function(name)
        except graphcache.CacheMiss:
            built, _ = _build(self.structure)
            graphcache.store("bird-model", graph_key(self.structure), {k: v for k, v in built.items() if v is not None},
                             {"pre_params": list(self.pre_params)})
            return built[name]

    def _function(self, name: str) -> ca.Function | None:
        if name in self._fns:
            return self._fns[name]
        if name in OPTIONAL_FUNCTIONS and self._entry is not None and name not in self._entry.names:
            self._fns[name] = None  # this structure has none
            return None
        from birdocp.engine import graphcache
        try:
            f = self._entry.function(name)
        except graphcache.CacheMiss:  # broken after the manifest check: rebuild (and re-store)
            built, _ = _build(self.structure)
            graphcache.store("bird-model", graph_key(self.structure),
                             {k: v for k, v in built.items() if v is not None},
                             {"pre_params": list(self.pre_params)})
            self._fns.update((k, v) for k, v in built.items() if k not in self._fns)
            f = self._fns[name]
        self._fns[name] = f
        return f

    def __getattr__(self, name):
        if name in GRAPH_FUNCTIONS or name in OPTIONAL_FUNCTIONS:
            return self._function(name)
        if name in ("f", "loads", "aero_detail"):
            xm, tm, pm = ca.MX.sym("x", self.ode.nx), ca.MX.sym("t"), ca.MX.sym("p", len(PARAM_NAMES))
            dm = self._function("data")(tm, pm)
            if name == "f":
                f = ca.Function("f", [xm, tm, pm], [self.rhs(xm, dm, pm)], ["x", "t", "p"], ["xdot"])
            elif name == "loads":
                f = ca.Function("loads", [xm, tm, pm], [self.loads_d(xm, dm, pm)], ["x", "t", "p"], ["loads"])
            else:
                f = ca.Function("aero_detail", [xm, tm, pm], self.detail_d(xm, dm, pm),
                                ["x", "t", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])
            self.__dict__[name] = f
            return f
        raise AttributeError(name)

    def wing_power_history(self, t, X, p) -> dict:
        """The wing powers :data:`WING_POWER_NAMES` along a trajectory (numbers).

        t: times [s] (K); X: states (K x 4); p: parameter vector. Returns a dict of arrays (K), all
        zeros for a model without wing masses (massless wings do no inertial work)."""
        t = np.asarray(t, float).ravel()
        X = np.asarray(X, float).reshape(len(t), -1)
        if self.wing_power_d is None:
            return {k: np.zeros(len(t)) for k in WING_POWER_NAMES}
        pd = ca.DM(np.asarray(p, float))
        K = len(t)
        D = self.data.map(K)(ca.DM(t).T, ca.repmat(pd, 1, K))
        P = np.asarray(self.wing_power_d.map(K)(ca.DM(X.T), D, ca.repmat(pd, 1, K)))
        return {k: P[i].copy() for i, k in enumerate(WING_POWER_NAMES)}

    def complete_state(self, x, p, t_s: float = 0.0) -> np.ndarray:
        """The full state (u, w, q, theta, aerodynamic states) from a body state x (4 numbers) at time
        ``t_s``: the lag and separation states on the quasi-steady manifold (``aero_guess_d``). A full
        state is returned as it is."""
        x = np.asarray(x, float).ravel()
        nx = self.ode.nx
        if x.size == nx or x.size != 4:
            return x
        pd = ca.DM(np.asarray(p, float))
        z = np.asarray(self.aero_guess_d(ca.DM(x), self.data(float(t_s), pd), pd)).ravel()
        return np.concatenate([x, z])

    def evaluate(self, state, t, p) -> dict:
        """Body-frame loads and the state derivative at one (state, t) for parameters p."""
        x = ca.DM(self.complete_state(state, p, t))
        d = self.data(float(t), ca.DM(np.asarray(p, float)))
        loads = np.array(self.loads_d(x, d, p)).ravel()
        xdot = np.array(self.rhs(x, d, p)).ravel()
        return {"Fx_N": float(loads[0]), "Fz_N": float(loads[1]), "My_Nm": float(loads[2]),
                "xdot": xdot.tolist()}


@functools.lru_cache(maxsize=8)
def _model_for(structure: Structure) -> BirdModel:
    return BirdModel(structure)


register_cache("bird.models", _model_for)


class ConfiguredModel:
    """A (shared, cached) :class:`BirdModel` together with one configuration's parameter vector
    ``p0``. Attribute access falls through to the model's Functions."""

    def __init__(self, model: BirdModel, cfg: Config):
        self.model = model
        self.cfg = cfg
        self.p0 = param_vector(cfg)

    def evaluate(self, state, t, p=None) -> dict:
        return self.model.evaluate(state, t, self.p0 if p is None else p)

    def __getattr__(self, name):
        return getattr(self.model, name)


def get_model(cfg: Config) -> ConfiguredModel:
    """The model for ``cfg``: graphs cached per :class:`Structure`, numbers from ``cfg`` in ``p0``.

    Parameters
    ----------
    cfg : Config
        The configuration.

    Returns
    -------
    ConfiguredModel
        The shared :class:`BirdModel` (``.model``) with this configuration's parameter vector.
    """
    return ConfiguredModel(_model_for(Structure.of(cfg)), cfg)


__all__ = ["BirdModel", "get_model", "air_state", "load_terms", "param_vector", "STATE_NAMES", "DATA_BLOCKS", "N_DATA",
           "unpack_data", "GEOMETRY_OUTPUTS", "Structure", "N_MASS", "unpack_mass", "WING_POWER_NAMES",
           "GRAPH_FUNCTIONS", "OPTIONAL_FUNCTIONS", "graph_key"]
