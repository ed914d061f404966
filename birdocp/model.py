"""The bird model as CasADi Functions, built once per structural configuration.

Split (``design.md`` 5): everything that depends only on time and parameters (wing geometry,
kinematic velocity, lifting-line matrices) is the per-time data ``d = data(t, p)``; the state right-hand
side ``rhs(x, d, p)`` is small. ``f(x, t, p) = rhs(x, data(t, p), p)`` is offered for users and tests.

State x = (u [m/s] forward along x', w [m/s] down along z', q [rad/s] pitch rate nose-up, theta [rad]
pitch angle). Body frame: x' forward, z' down; loads ``Fx_N``, ``Fz_N`` and ``My_Nm`` (nose-up
positive) about the centre of mass G. Parameters ``p``: :data:`birdocp.config.PARAM_NAMES`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from . import aero, kinematics, wing
from .config import JOINT_NAMES, PARAM_NAMES, Config, param_vector
from .problem import PeriodicODE

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
    ("G", (N_EL, N_EL)),         # Gamma = G (|Vp| alpha)
    ("Wx", (N_EL, N_EL)),        # induced velocity e1 = Wx (|Vp| alpha)
    ("Wy", (N_EL, N_EL)),        # induced velocity e2 = Wy (|Vp| alpha)
)


def _offsets():
    out, k = {}, 0
    for name, (r, c) in DATA_BLOCKS:
        out[name] = (k, r, c)
        k += r * c
    return out, k


DATA_OFFSETS, N_DATA = _offsets()


def unpack_data(d):
    """Blocks of a data vector (SX/MX/DM) as a dict of matrices."""
    return {name: ca.reshape(d[k:k + r * c], r, c) for name, (k, r, c) in DATA_OFFSETS.items()}


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

    @staticmethod
    def of(cfg: Config) -> "Structure":
        a = cfg.aero
        return Structure(cfg.gait.frequency_hz, a.circulation, a.relaxed_evaluations,
                         a.kinematic_velocity, a.backward_step_s)


def _geometry_expr(t, p, frequency_hz):
    """Geometry SX expressions at time t for parameters p (dict of named outputs)."""
    joints = {j: tuple(_p(p, f"gait.{j}.{k}") for k in ("offset_deg", "amplitude_deg", "phase_deg"))
              for j in JOINT_NAMES}
    q = kinematics.joint_angles(t, frequency_hz, joints)
    l1, l2, l4 = (_p(p, f"wing.{k}") for k in ("arm_length_m", "forearm_length_m", "hand_length_m"))
    feathers = [_p(p, f"wing.feather_lengths_m.{i}") for i in range(7)]
    sk = kinematics.skeleton(q, l1, l2, l4, feathers)
    LE, TE = kinematics.raw_edges(sk, l1, l2, l4, _p(p, "wing.section_half_thickness_m"))
    radius = _p(p, "wing.smoothing_radius_m")
    LEs, dle = wing.smooth_line(LE, radius)
    TEs, dte = wing.smooth_line(TE, radius)
    P, E, T, Lr, change = wing.lifting_line(LEs, TEs)
    chord, c_hat, up = wing.sections(P, E, T, Lr)
    x_ep = _p(p, "wing.shoulder_half_separation_m")
    Q, ch, cd, nu = wing.merge(P, chord, c_hat, up, x_ep)
    n_mid = ca.ceil(2 * x_ep / wing.mean_spacing(P))
    diag = {k: dle[k] + dte[k] for k in dle}
    diag["improve_change"] = change
    diag["n_mid"] = n_mid
    return {
        "joint_angles_rad": ca.vertcat(*[q[j] for j in JOINT_NAMES]),
        "leading_edge_raw": ca.horzcat(*LE),
        "trailing_edge_raw": ca.horzcat(*TE),
        "leading_edge": ca.horzcat(*LEs),
        "trailing_edge": ca.horzcat(*TEs),
        "line": ca.horzcat(*Q),
        "chord_m": ca.horzcat(*ch),
        "chord_dir": ca.horzcat(*cd),
        "up_dir": ca.horzcat(*nu),
        "diagnostics": ca.vertcat(*[diag[k] for k in wing.DIAGNOSTICS]),
    }


GEOMETRY_OUTPUTS = ("joint_angles_rad", "leading_edge_raw", "trailing_edge_raw", "leading_edge",
                    "trailing_edge", "line", "chord_m", "chord_dir", "up_dir", "diagnostics")


class BirdModel:
    """CasADi Functions of the bird for one :class:`Structure`; numbers go in ``p``.

    Functions (all built once):

    * ``geometry(t, p)``: named outputs :data:`GEOMETRY_OUTPUTS` (merged line 3x33 in the code frame
      with origin on the body centre line at the shoulders, chords, directions, diagnostics);
    * ``data(t, p) -> d`` (:data:`N_DATA` values, layout :data:`DATA_BLOCKS`);
    * ``rhs(x, d, p) -> xdot`` and ``loads_d(x, d, p) -> [Fx_N, Fz_N, My_Nm]``;
    * ``f(x, t, p) -> xdot``, ``loads(x, t, p)`` and ``aero_detail(x, t, p)`` (circulations, angles of
      attack) composed in MX.
    """

    def __init__(self, structure: Structure):
        self.structure = structure
        s = structure
        t = ca.SX.sym("t")
        p = ca.SX.sym("p", len(PARAM_NAMES))
        g = _geometry_expr(t, p, s.frequency_hz)
        self.geometry = ca.Function("geometry", [t, p], [g[k] for k in GEOMETRY_OUTPUTS],
                                    ["t", "p"], list(GEOMETRY_OUTPUTS))
        line = g["line"]
        centres = line[:, 1::2]
        nodes = line[:, 0::2]
        if s.kinematic_velocity == "exact":
            v_kin = ca.reshape(ca.jtimes(ca.vec(centres), t, ca.SX(1)), 3, N_EL)
        elif s.kinematic_velocity == "backward-difference":
            line_prev = self.geometry(t - s.backward_step_s, p)[GEOMETRY_OUTPUTS.index("line")]
            v_kin = (centres - line_prev[:, 1::2]) / s.backward_step_s
        else:
            raise ValueError(f"aero.kinematic_velocity must be 'exact' or 'backward-difference', got {s.kinematic_velocity!r}")
        c_hat = g["chord_dir"][:, 1::2]
        up = g["up_dir"][:, 1::2]
        chord = g["chord_m"][1::2]
        tau = ca.horzcat(*[ca.cross(up[:, j], c_hat[:, j]) for j in range(N_EL)])
        ds = ca.vertcat(*[ca.norm_2(nodes[:, j + 1] - nodes[:, j]) for j in range(N_EL)])
        r_w = ca.vertcat(0, 0, -_p(p, "wing.root_ahead_m"))
        r = centres + ca.repmat(r_w, 1, N_EL)
        G, Wx, Wy = aero.circulation_matrices(
            [centres[:, j] for j in range(N_EL)], [nodes[:, j] for j in range(N_EL + 1)],
            [chord[j] for j in range(N_EL)], _p(p, "aero.lift_slope_per_rad"),
            s.circulation, s.relaxed_evaluations)
        blocks = {"r_m": r, "v_kin_mps": v_kin, "c_hat": c_hat, "up": up, "tau": tau, "ds_m": ds,
                  "G": G, "Wx": Wx, "Wy": Wy}
        d = ca.vertcat(*[ca.vec(blocks[name]) for name, _ in DATA_BLOCKS])
        self.data = ca.Function("data", [t, p], [d], ["t", "p"], ["d"])

        # State part.
        x = ca.SX.sym("x", 4)
        dsym = ca.SX.sym("d", N_DATA)
        b = unpack_data(dsym)
        F, M, Gamma, alpha, vp = aero.element_loads(
            x, b["r_m"], b["v_kin_mps"], b["c_hat"], b["up"], b["tau"], b["ds_m"],
            b["G"], b["Wx"], b["Wy"], _p(p, "aero.air_density_kgm3"))
        m = _p(p, "body.mass_kg")
        I = _p(p, "body.pitch_inertia_kgm2")
        grav = _p(p, "body.gravity_mps2")
        u, w, q, theta = x[0], x[1], x[2], x[3]
        Fx, Fz, My = -F[2], -F[1], M
        xdot = ca.vertcat(-q * w - grav * ca.sin(theta) + Fx / m,
                          q * u + grav * ca.cos(theta) + Fz / m,
                          My / I,
                          q)
        self.rhs = ca.Function("rhs", [x, dsym, p], [xdot], ["x", "d", "p"], ["xdot"])
        self.loads_d = ca.Function("loads_d", [x, dsym, p], [ca.vertcat(Fx, Fz, My)],
                                   ["x", "d", "p"], ["loads"])
        self.detail_d = ca.Function("detail_d", [x, dsym, p], [Gamma, alpha, vp, F],
                                    ["x", "d", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])

        xm = ca.MX.sym("x", 4)
        tm = ca.MX.sym("t")
        pm = ca.MX.sym("p", len(PARAM_NAMES))
        dm = self.data(tm, pm)
        self.f = ca.Function("f", [xm, tm, pm], [self.rhs(xm, dm, pm)], ["x", "t", "p"], ["xdot"])
        self.loads = ca.Function("loads", [xm, tm, pm], [self.loads_d(xm, dm, pm)],
                                 ["x", "t", "p"], ["loads"])
        self.aero_detail = ca.Function("aero_detail", [xm, tm, pm], self.detail_d(xm, dm, pm),
                                       ["x", "t", "p"], ["gamma", "alpha_rad", "vp_mps", "F_code"])
        self.period_s = 1.0 / s.frequency_hz
        self.ode = PeriodicODE(rhs=self.rhs, data=self.data, period_s=self.period_s,
                               state_names=STATE_NAMES, param_names=PARAM_NAMES)

    def evaluate(self, state, t, p) -> dict:
        """Body-frame loads and the state derivative at one (state, t) for parameters p."""
        x = ca.DM(np.asarray(state, float))
        d = self.data(float(t), ca.DM(np.asarray(p, float)))
        loads = np.array(self.loads_d(x, d, p)).ravel()
        xdot = np.array(self.rhs(x, d, p)).ravel()
        return {"Fx_N": float(loads[0]), "Fz_N": float(loads[1]), "My_Nm": float(loads[2]),
                "xdot": xdot.tolist()}


@functools.lru_cache(maxsize=8)
def _model_for(structure: Structure) -> BirdModel:
    return BirdModel(structure)


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
    """The model for cfg: graphs cached per :class:`Structure`, numbers from cfg in ``p0``."""
    return ConfiguredModel(_model_for(Structure.of(cfg)), cfg)


__all__ = ["BirdModel", "get_model", "param_vector", "STATE_NAMES", "DATA_BLOCKS", "N_DATA",
           "unpack_data", "GEOMETRY_OUTPUTS", "Structure"]
