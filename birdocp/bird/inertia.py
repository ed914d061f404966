"""Wings with mass: mass points on the skeleton, their sums, the equations of motion and the powers.

Specification: ``docs/studies/inertia.md``. Longitudinal plane, **body frame** x' forward, y' right, z' down,
origin **G_b, the centre of mass of the body alone** (the G of the massless model, about which the
aerodynamic moment is taken). The code frame of the wing geometry maps to it as x' = -e3, y' = e1,
z' = -e2. The bird is the rigid body (mass m_b, pitch inertia I_b about G_b) plus point masses m_i
moving on the prescribed wing paths r_i(t); M = m_b + sum m_i is ``body.mass_kg``.

Distribution (docs/studies/inertia.md, mass distribution): one wing of mass ``wing.mass_kg`` is split over uniform rods along the arm
(shoulder -> elbow), forearm (elbow -> wrist) and hand (wrist -> hand tip E4), and rods along the seven
master feathers whose mass per length falls linearly to zero at the tip (primaries 0-2, secondaries
3-6). Every sum the equations need is at most quadratic in the coordinate along a rigid segment, so
two Gauss points per segment reproduce the rods exactly: 2 x (3 bones + 7 feathers) = 20 points per
wing. Point masses would put each segment's mass at one place and get I_w wrong by the segment's own
moment; rods with two Gauss points are exact at the same cost.
"""

from __future__ import annotations

import math

import casadi as ca

from birdocp.bird import kinematics
from birdocp.bird.kinematics import rot_x, rot_y, vec

__all__ = [
    "PRIMARY_SPLIT", "SECONDARY_SPLIT", "N_POINTS_PER_WING", "MASS_BLOCK", "local_mass_points",
    "segment_masses", "mass_sums", "accelerations", "wing_powers", "total_shoulder_power_W",
]

PRIMARY_SPLIT = (0.45, 0.30, 0.25)
"""Shares of the primaries' mass on feathers 0, 1, 2 (docs/studies/inertia.md, mass distribution)."""
SECONDARY_SPLIT = (0.30, 0.30, 0.25, 0.15)
"""Shares of the secondaries' mass on feathers 3, 4, 5, 6."""

_ROD = (0.5 - math.sqrt(3.0) / 6.0, 0.5 + math.sqrt(3.0) / 6.0)          # uniform rod, fraction of length
_TAPER = (1.0 / 3.0 - math.sqrt(2.0) / 6.0, 1.0 / 3.0 + math.sqrt(2.0) / 6.0)  # linear taper to zero at the tip

N_POINTS_PER_WING = 20

MASS_BLOCK = ("m_w_kg", "S_x_kgm", "S_z_kgm", "dS_x_kgmps", "dS_z_kgmps", "ddS_x_kgmps2", "ddS_z_kgmps2",
              "I_w_kgm2", "J_w_kgm2ps", "h_kgm2ps", "k_kgm2ps2", "T_rel_J", "P_rel_W")
"""The per-time sums (both wings) appended to the data vector of a model with wing masses (docs/studies/inertia.md, frames):
m_w = sum m_i; S = sum m_i r_i (x', z'); S', S'' its body-frame time derivatives; I_w = sum m (x^2+z^2);
J_w = sum m (x x' + z z'); h = sum m (z x' - x z') (pitch angular momentum of the relative motion,
nose-up); k = h'; T_rel = 1/2 sum m |r'|^2 (relative kinetic energy, y' included); P_rel = T_rel'."""


def local_mass_points(q: dict, arm_m, forearm_m, hand_m, feather_lengths_m):
    """The 20 mass points of the right wing in the arm's frame (shoulder rotation R1 = I, wing frame
    at the shoulder, code-frame axes), with the index of the segment each belongs to.

    Segments: 0 arm, 1 forearm, 2 hand, 3+i feather i (i = 0..6). Feathers as in docs/model.md §3 (all seven,
    with their pre-rotations); bases: f_0 at E4, f_1 mid-hand, f_2 at E2, f_3 mid-forearm, f_4 at E1,
    f_5 mid-arm, f_6 at the shoulder. The world position is R1 times each point.

    Parameters
    ----------
    q : dict
        Joint angles by name (``elbow_flex``, ``wrist_flex``, ...) [rad].
    arm_m, forearm_m, hand_m : float
        Bone lengths [m].
    feather_lengths_m : sequence of float
        The seven feather lengths [m].

    Returns
    -------
    points : list
        The 20 points (3-vectors) [m].
    seg : list of int
        Segment index of each point.
    """
    sk = kinematics.skeleton(q, arm_m, forearm_m, hand_m, feather_lengths_m, with_shoulder=False)
    e_y, e_x = q["elbow_flex"], q["hand_twist"]
    w_y, w_z = q["wrist_flex"], q["wrist_spread"]
    R1, R2a, R2b, R4 = sk.R1, sk.R2a, sk.R2b, sk.R4
    O = vec(0, 0, 0)
    E1, E2 = sk.E1, sk.E2
    E4 = E2 + R4 @ vec(hand_m, 0, 0)
    L = feather_lengths_m
    pre = [R4, R4 @ rot_x(w_z / 4), R2b @ rot_y(w_y / 2) @ rot_x(-w_z / 2),
           R2a @ rot_x(e_x / 2) @ rot_y(w_y / 2) @ rot_x(-w_z / 4), R1 @ rot_y(e_y / 2), R1 @ rot_y(e_y / 4), R1]
    spread = [math.pi / 2, 3 * math.pi / 8, math.pi / 4, math.pi / 8, 0.0, 0.0, 0.0]
    feathers = [pre[i] @ rot_y(spread[i]) @ vec(0, 0, L[i]) for i in range(7)]
    bases = [E4, 0.5 * (E2 + E4), E2, 0.5 * (E1 + E2), E1, 0.5 * E1, O]
    points, seg = [], []
    for k, (A, B) in enumerate(((O, E1), (E1, E2), (E2, E4))):
        for s in _ROD:
            points.append(A + s * (B - A))
            seg.append(k)
    for i in range(7):
        for s in _TAPER:
            points.append(bases[i] + s * feathers[i])
            seg.append(3 + i)
    return points, seg


def segment_masses(wing_mass_kg, shares):
    """Mass [kg] of each of the 10 segments of one wing (arm, forearm, hand, feathers 0..6) from the
    wing mass and the shares (arm, forearm, hand, primaries, secondaries).

    Parameters
    ----------
    wing_mass_kg : float
        Mass of one wing [kg].
    shares : sequence of float
        Shares of (arm, forearm, hand, primaries, secondaries).

    Returns
    -------
    list
        The 10 masses [kg].
    """
    arm, forearm, hand, prim, sec = shares
    out = [wing_mass_kg * arm, wing_mass_kg * forearm, wing_mass_kg * hand]
    out += [wing_mass_kg * prim * s for s in PRIMARY_SPLIT]
    out += [wing_mass_kg * sec * s for s in SECONDARY_SPLIT]
    return out


def mass_sums(masses, r, v, a):
    """The sums of :data:`MASS_BLOCK` (both wings) from the right wing's points. The left wing is the
    mirror image in y', which doubles every in-plane sum and the kinetic energy.

    Parameters
    ----------
    masses : list
        Point masses [kg].
    r, v, a : list
        Body-frame 3-vectors (x', y', z') of the positions [m], velocities [m/s] and accelerations
        [m/s^2] relative to the body.

    Returns
    -------
    dict
        Name to sum (both wings).
    """
    tot = {k: 0 for k in MASS_BLOCK}
    for m, ri, vi, ai in zip(masses, r, v, a):
        x, z, xd, zd, xdd, zdd = ri[0], ri[2], vi[0], vi[2], ai[0], ai[2]
        tot["m_w_kg"] += m
        tot["S_x_kgm"] += m * x
        tot["S_z_kgm"] += m * z
        tot["dS_x_kgmps"] += m * xd
        tot["dS_z_kgmps"] += m * zd
        tot["ddS_x_kgmps2"] += m * xdd
        tot["ddS_z_kgmps2"] += m * zdd
        tot["I_w_kgm2"] += m * (x * x + z * z)
        tot["J_w_kgm2ps"] += m * (x * xd + z * zd)
        tot["h_kgm2ps"] += m * (z * xd - x * zd)
        tot["k_kgm2ps2"] += m * (z * xdd - x * zdd)
        tot["T_rel_J"] += 0.5 * m * ca.dot(vi, vi)
        tot["P_rel_W"] += m * ca.dot(vi, ai)
    return {k: 2 * val for k, val in tot.items()}


def accelerations(x, f_today, sums, total_mass_kg, body_inertia_kgm2, gravity_mps2):
    """(u', w', q') of the body with moving wing masses, as the massless right-hand side plus a
    correction (docs/studies/inertia.md, equations: the massless limit).

    ``f_today`` = (u', w', q') of the massless model with m = M (total mass) and I = I_b (body's
    own pitch inertia about G_b), i.e. diag(M, M, I_b) f_today = (F_x' - M g sin th - M q w,
    F_z' + M g cos th + M q u, M_y'). The correction solves 𝕄 delta = r with
    r = b - 𝕄 f_today = b_w - (𝕄 - diag(M, M, I_b)) f_today, where b_w collects the wing terms of b:

        b_w1 = q^2 S_x - 2 q S'_z - S''_x
        b_w2 = q^2 S_z + 2 q S'_x - S''_z
        b_w3 = -S_z (q w + g sin th) - S_x (q u + g cos th) - 2 q J_w - k

    in closed form (Schur complement, det 𝕄 = M^2 I_G). With all masses zero every wing term is an
    exact zero, delta = 0.0 and the result is f_today bit for bit.

    Parameters
    ----------
    x : casadi.SX
        Body state (u, w, q, theta).
    f_today : casadi.SX
        (u', w', q') of the massless model.
    sums : dict
        Mass sums (:func:`mass_sums`).
    total_mass_kg : float
        M [kg].
    body_inertia_kgm2 : float
        I_b [kg m^2].
    gravity_mps2 : float
        g [m/s^2].

    Returns
    -------
    casadi.SX
        (u', w', q').
    """
    u, w, q, th = x[0], x[1], x[2], x[3]
    M, Ib, g = total_mass_kg, body_inertia_kgm2, gravity_mps2
    Sx, Sz = sums["S_x_kgm"], sums["S_z_kgm"]
    dSx, dSz = sums["dS_x_kgmps"], sums["dS_z_kgmps"]
    bw1 = q * q * Sx - 2 * q * dSz - sums["ddS_x_kgmps2"]
    bw2 = q * q * Sz + 2 * q * dSx - sums["ddS_z_kgmps2"]
    bw3 = (-Sz * (q * w + g * ca.sin(th)) - Sx * (q * u + g * ca.cos(th))
           - 2 * q * sums["J_w_kgm2ps"] - sums["k_kgm2ps2"])
    f1, f2, f3 = f_today[0], f_today[1], f_today[2]
    # (𝕄 - diag(M, M, I_b)) f_today = (S_z f3, -S_x f3, S_z f1 - S_x f2 + I_w f3)
    r1 = bw1 - Sz * f3
    r2 = bw2 + Sx * f3
    r3 = bw3 - (Sz * f1 - Sx * f2 + sums["I_w_kgm2"] * f3)
    I_G = Ib + sums["I_w_kgm2"] - (Sx * Sx + Sz * Sz) / M
    dq = (r3 - (Sz * r1 - Sx * r2) / M) / I_G
    du = (r1 - Sz * dq) / M
    dw = (r2 + Sx * dq) / M
    return ca.vertcat(f1 + du, f2 + dw, f3 + dq)


def wing_powers(x, nudot, sums, gravity_mps2):
    """Powers of the wing masses [W] at one instant (docs/studies/inertia.md, powers), as a dict of scalars.

    * ``inertial_power_W`` = P_rel = d/dt (1/2 sum m |r'|^2): the rate of change of the
      wings' kinetic energy relative to the body (inertial power of van den Berg & Rayner 1995); its
      cycle mean is zero.
    * ``shoulder_inertial_power_W`` = P_in + P_grav = sum m_i (a_i - g_b) . r'_i: the power the wing
      joints deliver to accelerate the wing masses (absolute acceleration a_i) and lift them against
      gravity. The shoulder power of the whole wing is this plus the aerodynamic flapping power
      -sum F_j . r'_j (:func:`total_shoulder_power_W`).
    * ``wing_relative_kinetic_energy_J`` = T_rel.

    Parameters
    ----------
    x : casadi.SX
        Body state (u, w, q, theta).
    nudot : casadi.SX
        (u', w', q') of the body.
    sums : dict
        Mass sums (:func:`mass_sums`).
    gravity_mps2 : float
        g [m/s^2].

    Returns
    -------
    dict
    """
    u, w, q, th = x[0], x[1], x[2], x[3]
    du, dw, dq = nudot[0], nudot[1], nudot[2]
    g = gravity_mps2
    dSx, dSz = sums["dS_x_kgmps"], sums["dS_z_kgmps"]
    # sum m a_i . r'_i = a_Gb . S' + q' h - q^2 J_w + P_rel (the Coriolis term does no work)
    P_in = ((du + q * w) * dSx + (dw - q * u) * dSz + dq * sums["h_kgm2ps"]
            - q * q * sums["J_w_kgm2ps"] + sums["P_rel_W"])
    P_grav = -g * (-ca.sin(th) * dSx + ca.cos(th) * dSz)
    return {"inertial_power_W": sums["P_rel_W"], "shoulder_inertial_power_W": P_in + P_grav,
            "wing_acceleration_power_W": P_in, "wing_gravity_power_W": P_grav,
            "wing_relative_kinetic_energy_J": sums["T_rel_J"]}


def total_shoulder_power_W(shoulder_inertial_power_W, flapping_aerodynamic_power_W):
    """Shoulder power of both wings [W] = inertial part (:func:`wing_powers`, key
    ``shoulder_inertial_power_W``) + aerodynamic flapping part -sum F_j . r'_j (docs/studies/energetics.md);
    works on numbers, arrays and CasADi expressions alike (time histories or period means).

    Parameters
    ----------
    shoulder_inertial_power_W : float, array or casadi.SX
        Inertial part [W].
    flapping_aerodynamic_power_W : float, array or casadi.SX
        Aerodynamic flapping part [W].

    Returns
    -------
    float, array or casadi.SX
    """
    return shoulder_inertial_power_W + flapping_aerodynamic_power_W
