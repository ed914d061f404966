"""The bird's geometry and lifting-line circulation at given times, as numpy arrays (for drawings).

:func:`motion` evaluates, for a flight state history, everything an animation draws: the right
wing's bones and trailing-edge feathers, its smoothed leading and trailing edges, the merged lifting
line of both wings and the circulation of its 16 elements. The left wing is the mirror image
(e1 -> -e1) of the right one.

Frame: the code frame of the specification (e1 span to the right wing tip, e2 up, e3 backwards),
body-fixed, **origin at the centre of mass G**. The forward body axis is x' = -e3. Lengths in metres.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from birdocp.bird import kinematics
from birdocp.bird.config import JOINT_NAMES, PARAM_NAMES, Config, param_vector
from birdocp.bird.model import GEOMETRY_OUTPUTS, get_model
from birdocp.engine.cache import owned_cache

__all__ = ["motion", "interpolate_states", "earth_path", "MOTION_KEYS"]

MOTION_KEYS = ("t_s", "x", "chain_m", "feather_base_m", "feather_tip_m", "minor_feather_base_m",
               "minor_feather_tip_m", "leading_edge_m",
               "trailing_edge_m", "leading_edge_raw_m", "line_m", "chord_m", "gamma_m2ps", "joint_angles_rad")
"""Keys of the dict returned by :func:`motion`."""

FEATHER_ORDER = (6, 4, 2, 0)  # the master feathers, shoulder to hand tip (trailing-edge points 0..3)


def _bones_function(frequency_hz: float) -> ca.Function:
    """``(t, p) -> (chain 3x4, feather bases 3x4, feather tips 3x4, minor bases 3x3, minor tips 3x3)``
    of the right wing, origin at the right shoulder: shoulder, elbow, wrist and hand tip; the four
    master feathers 6, 4, 2, 0; the feathers 1, 3, 5 (docs/model.md §3: computed like the others but
    with weight 0 in the trailing edge), drawn from the middle of the hand, forearm and arm."""
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", len(PARAM_NAMES))

    def par(name):
        return p[PARAM_NAMES.index(name)]

    joints = {j: tuple(par(f"gait.{j}.{k}") for k in ("offset_deg", "amplitude_deg", "phase_deg"))
              for j in JOINT_NAMES}
    q = kinematics.joint_angles(t, frequency_hz, joints)
    l1, l2, l4 = (par(f"wing.{k}") for k in ("arm_length_m", "forearm_length_m", "hand_length_m"))
    feathers = [par(f"wing.feather_lengths_m.{i}") for i in range(7)]
    sk = kinematics.skeleton(q, l1, l2, l4, feathers)
    _, TE = kinematics.raw_edges(sk, l1, l2, l4, par("wing.section_half_thickness_m"))
    tip = sk.E2 + sk.R4 @ kinematics.vec(l4, 0, 0)
    chain = ca.horzcat(ca.SX.zeros(3, 1), sk.E1, sk.E2, tip)
    tips = ca.horzcat(*TE)
    bases = ca.horzcat(*[TE[i] - sk.feathers[k] for i, k in enumerate(FEATHER_ORDER)])
    e_y, e_x = q["elbow_flex"], q["hand_twist"]
    w_y, w_z = q["wrist_flex"], q["wrist_spread"]
    rx, ry = kinematics.rot_x, kinematics.rot_y
    f1 = sk.R4 @ rx(w_z / 4) @ ry(3 * math.pi / 8) @ kinematics.vec(0, 0, feathers[1])
    f3 = sk.R2a @ rx(e_x / 2) @ ry(w_y / 2) @ rx(-w_z / 4) @ ry(math.pi / 8) @ kinematics.vec(0, 0, feathers[3])
    f5 = sk.R1 @ ry(e_y / 4) @ kinematics.vec(0, 0, feathers[5])
    minor_bases = ca.horzcat(sk.E2 + sk.R4 @ kinematics.vec(l4 / 2, 0, 0), sk.E1 + sk.R2a @ kinematics.vec(l2 / 2, 0, 0),
                             sk.R1 @ kinematics.vec(l1 / 2, 0, 0))
    minor_tips = minor_bases + ca.horzcat(f1, f3, f5)
    return ca.Function("bones", [t, p], [chain, bases, tips, minor_bases, minor_tips], ["t", "p"],
                       ["chain", "bases", "tips", "minor_bases", "minor_tips"])


def interpolate_states(t_s: np.ndarray, x: np.ndarray, times_s: np.ndarray, period_s: float) -> np.ndarray:
    """States at ``times_s`` by periodic cubic Hermite interpolation of a sampled cycle.

    Parameters
    ----------
    t_s : (K,) array
        Sample times [s] over one period, ``t_s[0] = 0`` and ``t_s[-1] = period_s``.
    x : (K, n) array
        States at those times (the cycle is periodic: ``x[-1] ~ x[0]``).
    times_s : (F,) array
        Times [s] wanted; taken modulo the period.
    period_s : float
        The period [s].

    Returns
    -------
    (F, n) array
        The interpolated states (slopes by central differences, periodic at the ends).
    """
    t_s = np.asarray(t_s, float)
    x = np.asarray(x, float)
    tau = np.mod(np.asarray(times_s, float), period_s)
    n = len(t_s)
    dt = np.diff(t_s)
    slope = np.empty_like(x)
    slope[1:-1] = (x[2:] - x[:-2]) / (t_s[2:] - t_s[:-2])[:, None]
    slope[0] = slope[-1] = (x[1] - x[-2]) / (dt[0] + dt[-1])
    i = np.clip(np.searchsorted(t_s, tau, side="right") - 1, 0, n - 2)
    h = dt[i][:, None]
    s = ((tau - t_s[i]) / dt[i])[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * x[i] + h10 * h * slope[i] + h01 * x[i + 1] + h11 * h * slope[i + 1]


def motion(cfg: Config, times_s, states=None, p=None) -> dict:
    """Geometry and circulation of the bird at each time, for drawing.

    Parameters
    ----------
    cfg : Config
        The configuration (its structure selects the model's graphs).
    times_s : (F,) array_like
        Times [s] in the flapping cycle.
    states : (F, 4) array_like, optional
        Flight states (u, w [m/s], q [rad/s], theta [rad]) at those times; they set the circulation.
        Without them the result has the geometry only (no ``x``, no ``gamma_m2ps``).
    p : (n_p,) array_like, optional
        Parameter vector (:data:`birdocp.bird.config.PARAM_NAMES`); default ``param_vector(cfg)``.
        A level-flight run passes its solved parameters here.

    Returns
    -------
    dict
        Arrays (leading axis: time), code frame with origin at G, metres:
        ``t_s`` (F,); ``x`` (F, 4); ``chain_m`` (F, 3, 4) right-wing shoulder, elbow, wrist and hand
        tip; ``feather_base_m`` and ``feather_tip_m`` (F, 3, 4) master feathers 6, 4, 2, 0;
        ``minor_feather_base_m`` and ``minor_feather_tip_m`` (F, 3, 3) feathers 1, 3, 5;
        ``leading_edge_m`` and ``trailing_edge_m`` (F, 3, K) smoothed edges of the right wing,
        ``leading_edge_raw_m`` (F, 3, 5) its raw leading edge (the last point is the wing tip);
        ``line_m`` (F, 3, 33) merged lifting line of both wings (nodes at even, element centres at
        odd columns) and ``chord_m`` (F, 33) its chords; ``gamma_m2ps`` (F, 16) circulation of the 16 elements [m^2/s], left tip to
        right tip; ``joint_angles_rad`` (F, 7) in the order of :data:`birdocp.bird.config.JOINT_NAMES`.
    """
    times = np.asarray(times_s, float).ravel()
    X = None if states is None else np.asarray(states, float).reshape(len(times), 4)
    m = get_model(cfg)
    pv = np.asarray(param_vector(cfg) if p is None else p, float).ravel()
    bones = owned_cache(m.model).build("bones", lambda: _bones_function(float(cfg.gait.frequency_hz)))
    x_ep = pv[PARAM_NAMES.index("wing.shoulder_half_separation_m")]
    root = pv[PARAM_NAMES.index("wing.root_ahead_m")]
    # right shoulder relative to G: x_ep along e1, root_ahead_m forward (= -e3)
    shoulder = np.array([[x_ep], [0.0], [-root]])
    centre = np.array([[0.0], [0.0], [-root]])   # the geometry's 'line' origin (body centre line)
    keys = [k for k in MOTION_KEYS if k not in ("t_s", "x") and (X is not None or k != "gamma_m2ps")]
    out = {k: [] for k in keys}
    for i, t in enumerate(times):
        g = dict(zip(GEOMETRY_OUTPUTS, m.geometry(float(t), pv)))
        chain, fb, ft, mb, mt = (np.array(v) for v in bones(float(t), pv))
        out["chain_m"].append(chain + shoulder)
        out["minor_feather_base_m"].append(mb + shoulder)
        out["minor_feather_tip_m"].append(mt + shoulder)
        out["feather_base_m"].append(fb + shoulder)
        out["feather_tip_m"].append(ft + shoulder)
        out["leading_edge_m"].append(np.array(g["leading_edge"]) + shoulder)
        out["trailing_edge_m"].append(np.array(g["trailing_edge"]) + shoulder)
        out["leading_edge_raw_m"].append(np.array(g["leading_edge_raw"]) + shoulder)
        out["line_m"].append(np.array(g["line"]) + centre)
        out["chord_m"].append(np.array(g["chord_m"]).ravel())
        out["joint_angles_rad"].append(np.array(g["joint_angles_rad"]).ravel())
        if X is not None:
            out["gamma_m2ps"].append(np.array(m.aero_detail(ca.DM(X[i]), float(t), pv)[0]).ravel())
    res = {k: np.array(v) for k, v in out.items()}
    res["t_s"] = times
    if X is not None:
        res["x"] = X
    if not all(np.all(np.isfinite(v)) for v in res.values()):
        raise FloatingPointError("the geometry or circulation is not finite at some time")
    return res


def earth_path(t_s, x) -> tuple[np.ndarray, np.ndarray]:
    """Path of the centre of mass G in the earth frame, integrated from the body-frame velocities.

    Parameters
    ----------
    t_s : (K,) array_like
        Sample times [s], increasing.
    x : (K, 4) array_like
        States (u, w [m/s], q [rad/s], theta [rad]) at those times.

    Returns
    -------
    forward_m, up_m : (K,) arrays
        Horizontal distance flown [m] (positive forward) and height gained [m] (positive up) since
        ``t_s[0]``, by the trapezoidal rule on ``dx_e/dt = u cos(theta) + w sin(theta)`` and
        ``dh/dt = u sin(theta) - w cos(theta)`` (body z' down, nose-up theta positive).
    """
    t = np.asarray(t_s, float)
    X = np.asarray(x, float)
    u, w, th = X[:, 0], X[:, 1], X[:, 3]
    vx = u * np.cos(th) + w * np.sin(th)
    vh = u * np.sin(th) - w * np.cos(th)
    dt = np.diff(t)
    fwd = np.concatenate([[0.0], np.cumsum(0.5 * dt * (vx[1:] + vx[:-1]))])
    up = np.concatenate([[0.0], np.cumsum(0.5 * dt * (vh[1:] + vh[:-1]))])
    return fwd, up
