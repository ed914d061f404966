"""Optional tail: a slender delta wing behind the centre of mass (docs/model.md §7), off by default.

The tail is a flat delta of length ``l_t`` whose span ``b_t = 2 l_t tan(beta/2)`` follows its opening
angle beta; with beta = 0 (the default) every tail term is exactly zero, as in the reference
implementation. Loads, after the reference's slender-wing model:

* flow at the tail ``U_t = U_inf - Omega x r_tail + V_ind`` (code frame; ``r_tail`` the tail root),
  where ``V_ind`` is the velocity the wing's horseshoe vortices (bound segments between the element
  nodes and semi-infinite trailing legs along e3) induce at the tail's neutral point
  ``NP = root + (0, 0, 2/3 l_t)`` (3-D Biot-Savart);
* ``alpha_t = atan2(U_t,2, U_t,3) + i_t`` with the tail's own incidence ``i_t`` (``tail.incidence_deg``,
  leading edge up positive; 0 in the reference model, where the delta lies in the body axis), normal force ``N_t = (pi/4) rho |U_t|^2 alpha_t b_t^2``, lift
  ``L_t = N_t cos(alpha_t)`` (up, e2), drag ``D_t = 1/2 L_t alpha_t + D_f + N_t sin(alpha_t)`` with the
  flat-plate friction ``D_f = 1/2 rho |U_t|^2 (b_t l_t / 2) 1.328 / sqrt(Re)``, ``Re = V_ref l_t / nu``;
* body loads: ``Fz' -= L_t``, ``Fx' -= D_t`` and the moment of the lift at the neutral point about G,
  ``My' -= x_NP L_t`` (the drag acts along the body axis through G: no moment).

Deviations from the reference implementation (documented in docs/studies/sensitivity.md, the tail): the pitch-rate term uses
the same sign as the wing (``- Omega x r``: a nose-up rotation moves the tail down, so the air meets
it from below); the reference adds ``+ Omega x r``, which would make the tail destabilise pitch. The
induced velocity is the plain 3-D Biot-Savart sum (the reference's semi-infinite-leg loop has an
index error). The reference returns the tail drag only through the moment lever (zero there, the
neutral point being on the body axis) and drops it from the force; birdocp adds it to Fx'.
"""

from __future__ import annotations

import math

import casadi as ca


def _segment_velocity(P, A, B, strength):
    """Velocity at P induced by a straight vortex segment A->B of circulation ``strength``."""
    r1 = P - A
    r2 = P - B
    r0 = B - A
    c = ca.cross(r1, r2)
    c2 = ca.dot(c, c)
    n1 = ca.norm_2(r1)
    n2 = ca.norm_2(r2)
    return strength / (4 * math.pi) * c / c2 * ca.dot(r0, r1 / n1 - r2 / n2)


def _semi_infinite_velocity(P, A, direction, strength):
    """Velocity at P induced by a semi-infinite vortex filament from A along the unit ``direction``."""
    r = P - A
    along = ca.dot(r, direction)
    perp = r - along * direction
    d2 = ca.dot(perp, perp)
    # (1 + cos(angle between the filament and A->P)) / (4 pi d) in the direction direction x perp
    return strength / (4 * math.pi) * ca.cross(direction, perp) / d2 * (1 + along / ca.norm_2(r))


def induced_velocity(P, nodes, gamma):
    """Velocity (code frame, m/s) induced at P by the wing's vortex system.

    ``nodes`` 3 x 17 element end nodes (relative to G), ``gamma`` 16 circulations: bound segment j
    from node j to node j+1 carries Gamma_j; the trailing leg from node m along +e3 carries
    Gamma_{m-1} - Gamma_m (Helmholtz).

    Parameters
    ----------
    P : casadi.SX
        Point [m].
    nodes : casadi.SX, shape (3, 17)
        Element end nodes relative to G [m].
    gamma : casadi.SX
        The 16 circulations [m^2/s].

    Returns
    -------
    casadi.SX
        Velocity [m/s].
    """
    n = gamma.shape[0]
    v = ca.DM.zeros(3, 1)
    e3 = ca.DM([0, 0, 1])
    for j in range(n):
        v = v + _segment_velocity(P, nodes[:, j], nodes[:, j + 1], gamma[j])
    for m in range(n + 1):
        left = gamma[m - 1] if m >= 1 else 0
        right = gamma[m] if m < n else 0
        v = v + _semi_infinite_velocity(P, nodes[:, m], e3, left - right)
    return v


def tail_loads(state, nodes, gamma, rho, opening_angle_deg, root_behind_m, length_m,
               kinematic_viscosity_m2ps, reynolds_speed_mps, incidence_deg=0.0):
    """(lift L_t [N, up], drag D_t [N, backwards], pitching moment about G [N m, nose-up positive]).

    ``incidence_deg``: the tail's own incidence, added to the flow angle (at 0 the sum is the flow
    angle exactly: the reference model bit for bit).

    Parameters
    ----------
    state : casadi.SX
        Planar state (u, w, q, ...): the first three entries are used.
    nodes : casadi.SX, shape (3, 17)
        Element end nodes relative to G [m].
    gamma : casadi.SX
        The 16 circulations [m^2/s].
    rho : float
        Air density [kg/m^3].
    opening_angle_deg : float
        Tail opening angle [deg].
    root_behind_m : float
        Tail root behind G [m].
    length_m : float
        Tail length [m].
    kinematic_viscosity_m2ps : float
        Kinematic viscosity of the air [m^2/s].
    reynolds_speed_mps : float
        Speed of the Reynolds number [m/s].
    incidence_deg : float
        The tail's own incidence [deg].

    Returns
    -------
    tuple of casadi.SX
    """
    u, w, q = state[0], state[1], state[2]
    beta = opening_angle_deg * math.pi / 180
    span = 2 * length_m * ca.tan(beta / 2)
    x_np = root_behind_m + 2.0 / 3.0 * length_m
    NP = ca.vertcat(0, 0, x_np)
    v_ind = induced_velocity(NP, nodes, gamma)
    # U_inf - Omega x r_root, Omega = (q, 0, 0), r_root = (0, 0, root_behind)
    U = ca.vertcat(0, w + q * root_behind_m, u) + v_ind
    U2 = ca.dot(U, U)
    alpha = ca.atan2(U[1], U[2]) + incidence_deg * (math.pi / 180)
    N = math.pi / 4 * rho * U2 * alpha * span ** 2
    L = N * ca.cos(alpha)
    reynolds = reynolds_speed_mps * length_m / kinematic_viscosity_m2ps
    Df = 0.5 * rho * U2 * (span * length_m / 2) * 1.328 / ca.sqrt(reynolds)
    D = 0.5 * L * alpha + Df + N * ca.sin(alpha)
    # moment of the force (0, L, D) applied at NP: (NP x F)_1 = NP_2 F_3 - NP_3 F_2
    M = -x_np * L
    return L, D, M
