"""Wing kinematics: harmonic joint laws, the rotation chain, bone end points and master feathers.

All vectors are in the wing frame: the code frame of ``docs/model.md`` §1 (e1 spanwise to the right
wing tip, e2 up, e3 backwards, towards the tail) translated to the right shoulder. Lengths in m,
angles in rad inside this module (the configuration gives degrees). Every function works on CasADi
SX expressions and returns SX, so the same code serves numbers and symbols.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca

from birdocp.bird.config import JOINT_NAMES


def rot_x(a):
    """Rotation matrix about x by the angle ``a`` [rad].

    Parameters
    ----------
    a : casadi.SX or float
        Angle [rad].

    Returns
    -------
    casadi.SX, shape (3, 3)
    """
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a):
    """Rotation matrix about y by the angle ``a`` [rad].

    Parameters
    ----------
    a : casadi.SX or float
        Angle [rad].

    Returns
    -------
    casadi.SX, shape (3, 3)
    """
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def _rot_z(a):
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def vec(x, y, z):
    """The column 3-vector (x, y, z).

    Parameters
    ----------
    x, y, z : casadi.SX or float
        Components.

    Returns
    -------
    casadi.SX, shape (3, 1)
    """
    return ca.vertcat(x, y, z)


def joint_angles(t, frequency_hz: float, joints: dict) -> dict:
    """Joint angles [rad] at time t [s]: ``q = offset + amplitude sin(2 pi f t + phase)``.

    Parameters
    ----------
    t : casadi.SX or float
        Time [s].
    frequency_hz : float
        Flapping frequency f [Hz].
    joints : dict
        Each name of :data:`~birdocp.bird.config.JOINT_NAMES` to (offset_deg, amplitude_deg, phase_deg),
        numbers or SX.

    Returns
    -------
    dict
        Joint name to angle [rad].
    """
    omega = 2.0 * math.pi * frequency_hz
    deg = math.pi / 180.0
    out = {}
    for name in JOINT_NAMES:
        off, amp, ph = joints[name]
        out[name] = off * deg + amp * deg * ca.sin(omega * t + ph * deg)
    return out


@dataclass
class Skeleton:
    """Rotation matrices of the bones and the joint positions (wing frame, m)."""

    R1: ca.SX   # arm (shoulder)
    R2a: ca.SX  # forearm bone
    R2b: ca.SX  # frame carried to the hand side of the elbow (after the hand twist)
    R4: ca.SX   # hand
    S3: ca.SX   # straight-arm frame stretched by kx (leading-edge skin)
    E1: ca.SX   # elbow
    E2: ca.SX   # wrist
    feathers: dict  # index -> feather vector (m), for the 4 that shape the trailing edge (0, 2, 4, 6)


def shoulder_rotation(q: dict):
    """R1 = R_x(incidence) R_z(flap) R_y(sweep): the arm's rotation (docs/model.md §2.2).

    Parameters
    ----------
    q : dict
        Joint angles [rad] (``shoulder_incidence``, ``shoulder_flap``, ``shoulder_sweep``).

    Returns
    -------
    casadi.SX, shape (3, 3)
    """
    return rot_x(q["shoulder_incidence"]) @ _rot_z(q["shoulder_flap"]) @ rot_y(q["shoulder_sweep"])


def skeleton(q: dict, arm_m, forearm_m, hand_m, feather_lengths_m, with_shoulder: bool = True) -> Skeleton:
    """Bones and the four trailing-edge feathers for joint angles ``q`` (docs/model.md §2.2 and 3).

    Every bone, feather and skin point is the shoulder rotation R1 applied to a shape in the arm's
    frame; ``with_shoulder=False`` returns that shape (R1 = I), which depends on the elbow and wrist
    joints and the morphology only.

    Parameters
    ----------
    q : dict
        Joint angles [rad] by joint name.
    arm_m, forearm_m, hand_m : float
        Bone lengths [m].
    feather_lengths_m : sequence of float
        The seven feather lengths [m].
    with_shoulder : bool
        Apply the shoulder rotation R1.

    Returns
    -------
    Skeleton
    """
    e_y, e_x = q["elbow_flex"], q["hand_twist"]
    w_y, w_z = q["wrist_flex"], q["wrist_spread"]

    R1 = shoulder_rotation(q) if with_shoulder else ca.SX.eye(3)
    R2a = R1 @ rot_y(e_y)
    R2b = R2a @ rot_x(e_x)
    R4 = R2b @ rot_y(w_y) @ _rot_z(w_z)

    E1 = R1 @ vec(arm_m, 0, 0)
    E2 = E1 + R2a @ vec(forearm_m, 0, 0)

    # Straight-arm frame: ex3 along shoulder->wrist, ey3 the arm's second axis.
    ex3 = E2 / ca.norm_2(E2)
    ey3 = R1[:, 1]
    ez3 = ca.cross(ex3, ey3)
    kx = ca.norm_2(E2) / (arm_m + forearm_m)
    S3 = ca.horzcat(ex3 * kx, ey3, ez3)

    L = feather_lengths_m
    feathers = {
        # f_i = P_i R_y(pY_i) R_x(pX_i) (0, 0, L_i), pX_i = 0
        0: R4 @ rot_y(math.pi / 2) @ vec(0, 0, L[0]),
        2: R2b @ rot_y(w_y / 2) @ rot_x(-w_z / 2) @ rot_y(math.pi / 4) @ vec(0, 0, L[2]),
        4: R1 @ rot_y(e_y / 2) @ vec(0, 0, L[4]),
        6: R1 @ vec(0, 0, L[6]),
    }
    return Skeleton(R1=R1, R2a=R2a, R2b=R2b, R4=R4, S3=S3, E1=E1, E2=E2, feathers=feathers)


def raw_edges(sk: Skeleton, arm_m, forearm_m, hand_m, half_thickness_m):
    """Raw leading edge (5 points) and trailing edge (4 points) of the right wing (docs/model.md §4.1).

    Parameters
    ----------
    sk : Skeleton
        Bones and feathers (:func:`skeleton`).
    arm_m, forearm_m, hand_m : float
        Bone lengths [m].
    half_thickness_m : float
        Half-thickness of the wing section [m].

    Returns
    -------
    LE : list
        Leading-edge points.
    TE : list
        Trailing-edge points.
    """
    h = half_thickness_m
    l1, l2, l4 = arm_m, forearm_m, hand_m
    LE = [
        sk.S3 @ vec(0, 0, -h),
        sk.S3 @ vec(l1, 0, -h),
        0.5 * (sk.S3 @ vec(l1 + l2, 0, -h)) + 0.5 * (sk.R4 @ vec(0, 0, -h) + sk.E2),
        sk.R4 @ vec(l4, 0, -h) + sk.E2,
    ]
    TE = [
        sk.R1 @ vec(0, 0, h) + sk.feathers[6],
        0.5 * (sk.R1 @ vec(l1, 0, h)) + 0.5 * (sk.R2a @ vec(0, 0, h) + sk.E1) + sk.feathers[4],
        0.5 * (sk.R2b @ vec(l2, 0, h) + sk.E1) + 0.5 * (sk.R4 @ vec(0, 0, h) + sk.E2) + sk.feathers[2],
        sk.R4 @ vec(l4, 0, h) + sk.E2 + sk.feathers[0],
    ]
    LE.append(TE[3])  # the leading edge ends at the tip of the outermost feather
    return LE, TE
