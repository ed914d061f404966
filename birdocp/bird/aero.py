"""Quasi-steady lifting-line aerodynamics (docs/model.md §5).

Two halves, following the data/right-hand-side split of ``docs/model.md``:

* :func:`circulation_matrices` depends on the geometry only (time and gait parameters): the wake
  influence matrix of the straight semi-infinite vortex tubes and the solve of the lifting-line
  equation, folded into matrices that map ``|Vp| * alpha`` per element to the circulation and to the
  induced velocity;
* :func:`_element_loads` depends on the flight state: relative velocity, angle of attack,
  Kutta-Joukowski forces and the pitching moment about the centre of mass.

Vectors are in the code frame (e1 span to the right, e2 up, e3 backwards), forces in N, moments N m.
"""

from __future__ import annotations

import math

import casadi as ca

from birdocp.bird.collocation import NORMALWASHES, three_quarter_downwash

N_ELEMENTS = 16


def induced_matrices(centres, nodes, collocation="quarter", chord=None, c_hat=None):
    """Induced velocity per unit circulation at the element centres.

    Returns (Vx, Vy, K) (16 x 16 SX): e1 and e2 components of the induced velocity at centre j per
    unit Gamma_m, and the downwash per unit circulation K = v . d_j (docs/model.md §5.6). Only the (e1, e2)
    coordinates are used: the wake filaments are straight and parallel to e3. With ``collocation =
    "three_quarter"`` K is Weissinger's three-quarter-chord downwash instead
    (:func:`birdocp.bird.collocation.three_quarter_downwash`; Vx, Vy, used by the forces, unchanged).

    Parameters
    ----------
    centres : sequence of 3-vectors
        The 16 element centres (code frame) [m].
    nodes : sequence of 3-vectors
        The 17 element end nodes (code frame) [m].
    collocation : {"quarter", "three_quarter"}
        ``aero.collocation``: where the sections see the wake.
    chord : sequence, optional
        Chords [m] (``three_quarter`` only).
    c_hat : sequence of 3-vectors, optional
        Chord directions (``three_quarter`` only).

    Returns
    -------
    tuple of casadi.SX
        ``(Vx, Vy, K)``, each 16 x 16: ``Vx[j, m]`` and ``Vy[j, m]`` the e1 and e2 components [1/m]
        of the velocity induced at centre j by a unit circulation Gamma_m of element m, and
        ``K[j, m]`` the downwash (the induced velocity along the section normal d_j) per unit Gamma_m.
    """
    n_c, n_n = len(centres), len(nodes)
    # Tube strengths from circulations: gamma = D Gamma (17 x 16).
    D = ca.DM.zeros(n_n, n_c)
    for m in range(n_n):
        if m < n_c:
            D[m, m] = 1.0
        if m >= 1:
            D[m, m - 1] = -1.0
    kx = ca.SX(n_c, n_n)
    ky = ca.SX(n_c, n_n)
    for j, C in enumerate(centres):
        for m, N in enumerate(nodes):
            d1 = C[0] - N[0]
            d2 = C[1] - N[1]
            r2 = d1 ** 2 + d2 ** 2
            kx[j, m] = d2 / r2 / (4 * math.pi)
            ky[j, m] = -d1 / r2 / (4 * math.pi)
    Vx = kx @ D
    Vy = ky @ D
    rows = []
    for j in range(n_c):
        s = nodes[j + 1][0:2] - nodes[j][0:2]
        s = s / ca.norm_2(s)
        # d_j = (s2, -s1, 0); downwash w_j = v_j . d_j
        rows.append(s[1] * Vx[j, :] - s[0] * Vy[j, :])
    K = ca.vertcat(*rows)
    if collocation == "three_quarter":
        K = three_quarter_downwash(centres, nodes, chord, c_hat)
    return Vx, Vy, K


def circulation_matrices(centres, nodes, chord, lift_slope_per_rad, mode="exact", relaxed_evaluations=39,
                         collocation="quarter", c_hat=None):
    """Matrices (G, Wx, Wy) with ``Gamma = G q`` and induced velocity ``(Wx q, Wy q, 0)``, where
    ``q_j = |Vp_j| alpha_j``.

    The lifting-line equation ``(I + H K) Gamma = H q`` with ``H = diag(c_j C_la / 2)`` is linear.
    ``exact`` solves it; ``relaxed`` reproduces the reference's under-relaxed iteration
    ``Gamma <- 0.1 Gamma_hat + 0.9 Gamma`` with a fixed count n of evaluations from zero, whose closed
    form is ``Gamma_n = (I - Mr^n) Gamma*`` with ``Mr = 0.9 I - 0.1 H K``; the induced velocity kept for
    the forces is the one of the last evaluation, computed from ``Gamma_{n-1}``.

    Parameters
    ----------
    centres : sequence of 3-vectors
        The 16 element centres (code frame) [m].
    nodes : sequence of 3-vectors
        The 17 element end nodes (code frame) [m].
    chord : sequence
        Chord c_j of each element [m].
    lift_slope_per_rad : float
        Section lift slope C_la [1/rad].
    mode : {"exact", "relaxed"}
        Solution of the lifting-line equation.
    relaxed_evaluations : int
        n, the evaluations of the relaxed iteration.
    collocation : {"quarter", "three_quarter"}
        ``aero.collocation`` (:func:`induced_matrices`).
    c_hat : sequence of 3-vectors, optional
        Chord directions (``three_quarter`` only).

    Returns
    -------
    G, Wx, Wy : casadi.SX, shape (16, 16)
    """
    Vx, Vy, K = induced_matrices(centres, nodes, collocation, chord, c_hat)
    n = len(centres)
    h = ca.vertcat(*[0.5 * c * lift_slope_per_rad for c in chord])
    HK = ca.diag(h) @ K
    A = ca.SX.eye(n) + HK
    G_star = ca.solve(A, ca.diag(h))
    if mode == "exact":
        return G_star, Vx @ G_star, Vy @ G_star
    if mode != "relaxed":
        raise ValueError(f"aero.circulation must be 'exact' or 'relaxed', got {mode!r}")
    Mr = 0.9 * ca.SX.eye(n) - 0.1 * HK
    P_last = _matrix_power(Mr, relaxed_evaluations - 1)
    P_n = Mr @ P_last
    G_n = (ca.SX.eye(n) - P_n) @ G_star
    G_prev = (ca.SX.eye(n) - P_last) @ G_star
    return G_n, Vx @ G_prev, Vy @ G_prev


def _matrix_power(M, k):
    """M**k by repeated squaring."""
    result = None
    base = M
    while k > 0:
        if k & 1:
            result = base if result is None else result @ base
        k >>= 1
        if k:
            base = base @ base
    return result if result is not None else ca.SX.eye(M.shape[0])


def element_forces(state, r, v_kin, c_hat, up, tau, ds, G, Wx, Wy, rho, normalwash="angle") -> dict:
    """Per-element velocities and Kutta-Joukowski forces (code frame), the terms of :func:`_element_loads`.

    Returns a dict of 3 x 16 matrices ``V`` (relative air velocity U_inf - Omega x r - v_kin, m/s,
    no induced part), ``Vp`` (its section part, without the spanwise component), ``vind`` (induced
    velocity used in the force, m/s), ``dF`` (force of the air on each element, N), and the 1 x 16 rows
    ``Vp_norm`` (m/s), ``alpha`` (rad) and the 16 x 1 column ``Gamma`` (m^2/s).

    Parameters
    ----------
    state : casadi.SX
        Body state (u, w, q, theta).
    r : casadi.SX, shape (3, 16)
        Element centres relative to G (code frame) [m].
    v_kin : casadi.SX, shape (3, 16)
        Kinematic velocity of the centres relative to the body [m/s].
    c_hat, up, tau : casadi.SX, shape (3, 16)
        Chordwise, section-normal and spanwise unit vectors.
    ds : casadi.SX, shape (16, 1)
        Element lengths [m].
    G, Wx, Wy : casadi.SX, shape (16, 16)
        Lifting-line matrices (:func:`circulation_matrices`).
    rho : float
        Air density [kg/m^3].
    normalwash : {"angle", "tangency"}
        ``aero.normalwash``, the section law (:data:`~birdocp.bird.collocation.NORMALWASHES`).

    Returns
    -------
    dict
        The matrices and rows above.
    """
    return forces_from_velocity(_body_velocity(state, r, v_kin), c_hat, up, tau, ds, G, Wx, Wy, rho, normalwash)


def forces_from_velocity(V, c_hat, up, tau, ds, G, Wx, Wy, rho, normalwash="angle") -> dict:
    """:func:`element_forces` from the relative air velocity ``V`` (3 x n, code frame, m/s, without
    the induced part) of every element centre, whatever motion of the body made it (the planar
    state of :func:`_body_velocity` or the six-degree-of-freedom one of :mod:`birdocp.bird.sixdof`).

    Parameters
    ----------
    V : casadi.SX, shape (3, n)
        Relative air velocity without the induced part [m/s].
    c_hat, up, tau : casadi.SX, shape (3, n)
        Chordwise, section-normal and spanwise unit vectors.
    ds : casadi.SX, shape (n, 1)
        Element lengths [m].
    G, Wx, Wy : casadi.SX, shape (n, n)
        Lifting-line matrices (:func:`circulation_matrices`).
    rho : float
        Air density [kg/m^3].
    normalwash : {"angle", "tangency"}
        The section's normalwash ``q_j`` of ``Gamma = G q`` (``aero.normalwash``, :data:`~birdocp.bird.collocation.NORMALWASHES`):
        ``|Vp_j| alpha_j`` (the paper's section law, lift linear in the angle) or ``|Vp_j| sin(alpha_j)``
        (the flow tangency of a flat plate, the law a vortex lattice solves).

    Returns
    -------
    dict
        As :func:`element_forces`.
    """
    Vp_norm, alpha, vind = _inflow_from_velocity(V, c_hat, up, tau, Wx, Wy, normalwash)
    Gamma = G @ section_normalwash(Vp_norm, alpha, normalwash).T
    W = V + vind
    # (V + v) x tau
    cross = ca.vertcat(W[1, :] * tau[2, :] - W[2, :] * tau[1, :],
                       W[2, :] * tau[0, :] - W[0, :] * tau[2, :],
                       W[0, :] * tau[1, :] - W[1, :] * tau[0, :])
    dF = rho * cross * ca.repmat((Gamma * ds).T, 3, 1)
    Vp = V - tau * ca.repmat(ca.sum1(tau * V), 3, 1)  # as in section_angle
    return {"V": V, "Vp": Vp, "Vp_norm": Vp_norm, "alpha": alpha, "Gamma": Gamma, "vind": vind, "dF": dF}


def moment_about_G(r, dF):
    """Pitching moment (r x dF)_1 summed over the elements (N m, nose-up positive).

    Parameters
    ----------
    r : casadi.SX, shape (3, n)
        Element centres relative to G (code frame) [m].
    dF : casadi.SX, shape (3, n)
        Element forces [N].

    Returns
    -------
    casadi.SX
        Moment [N m].
    """
    return ca.sum2(r[1, :] * dF[2, :] - r[2, :] * dF[1, :])


def profile_drag(Vp, Vp_norm, chord, ds, rho, cd_profile):
    """Wing profile drag per element (docs/studies/energetics.md, the optional drag), 3 x 16 in N, code frame (``chord``, ``ds`` 16 x 1):
    ``dD_j = 1/2 rho C_Dpro c_j ds_j |Vp_j| Vp_j`` along the section's relative wind.

    Parameters
    ----------
    Vp : casadi.SX, shape (3, 16)
        Section part of the relative air velocity [m/s].
    Vp_norm : casadi.SX, shape (1, 16)
        Its magnitude [m/s].
    chord, ds : casadi.SX, shape (16, 1)
        Chords and element lengths [m].
    rho : float
        Air density [kg/m^3].
    cd_profile : float
        Profile-drag coefficient C_Dpro [-].

    Returns
    -------
    casadi.SX, shape (3, 16)
    """
    return 0.5 * rho * cd_profile * Vp * ca.repmat(Vp_norm * (chord * ds).T, 3, 1)


def _element_loads(state, r, v_kin, c_hat, up, tau, ds, G, Wx, Wy, rho):
    """Total aerodynamic force (code frame, N) and pitching moment about G (N m, nose-up positive).

    ``state`` = (u, w, q, theta); ``r``, ``v_kin``, ``c_hat``, ``up``, ``tau`` are 3 x 16 (element centres
    relative to G, kinematic velocities, chord directions, up normals, spanwise unit vectors), ``ds``
    16 x 1 element lengths. Returns (F 3x1, M, Gamma 16x1, alpha 16x1 [rad], |Vp| 16x1).
    """
    e = element_forces(state, r, v_kin, c_hat, up, tau, ds, G, Wx, Wy, rho)
    F = ca.sum2(e["dF"])
    M = moment_about_G(r, e["dF"])
    return F, M, e["Gamma"], e["alpha"].T, e["Vp_norm"].T


def section_angle(V, c_hat, up, tau):
    """Angle of attack [rad] (1 x n) of the velocities V (3 x n) in each element's section plane:
    ``atan2(Vp . up, Vp . c_hat)`` with ``Vp`` = V without its spanwise component along ``tau``.

    Parameters
    ----------
    V : casadi.SX, shape (3, n)
        Velocities [m/s].
    c_hat, up, tau : casadi.SX, shape (3, n)
        Chordwise, section-normal and spanwise unit vectors.

    Returns
    -------
    casadi.SX, shape (1, n)
    """
    Vp = V - tau * ca.repmat(ca.sum1(tau * V), 3, 1)
    return ca.atan2(ca.sum1(Vp * up), ca.sum1(Vp * c_hat)), ca.sqrt(ca.sum1(Vp * Vp))


def _body_velocity(state, r, v_kin):
    """Relative air velocity ``V = U_inf - Omega x r - v_kin`` (3 x n, code frame, m/s) of the element
    centres ``r`` (3 x n, from G) for the planar state (u, w, q, ...): ``U_inf = (0, w, u)``,
    ``Omega = (q, 0, 0)``."""
    u, w, q = state[0], state[1], state[2]
    ones = ca.DM.ones(1, r.shape[1])
    return ca.vertcat(-v_kin[0, :],
                      w * ones + q * r[2, :] - v_kin[1, :],
                      u * ones - q * r[1, :] - v_kin[2, :])


def _inflow_from_velocity(V, c_hat, up, tau, Wx, Wy, normalwash="angle"):
    """``(|Vp| 1xn, alpha 1xn [rad], vind 3xn)`` of the relative air velocity ``V`` (3 x n): the
    section speed, the geometric angle of attack and the induced velocity ``(Wx q, Wy q, 0)`` of the
    lifting line with ``q = |Vp| alpha`` (``normalwash = "tangency"``: ``|Vp| sin(alpha)``)."""
    alpha, Vp_norm = section_angle(V, c_hat, up, tau)
    qv = section_normalwash(Vp_norm, alpha, normalwash).T
    vind = ca.vertcat((Wx @ qv).T, (Wy @ qv).T, ca.DM.zeros(1, V.shape[1]))
    return Vp_norm, alpha, vind


def section_normalwash(Vp_norm, alpha, normalwash="angle"):
    """The section law's normalwash ``q`` of ``Gamma = G q`` (:data:`~birdocp.bird.collocation.NORMALWASHES`):
    ``|Vp| alpha`` or ``|Vp| sin(alpha)``.

    Parameters
    ----------
    Vp_norm : casadi.SX, shape (1, n)
        Section speed ``|Vp|`` [m/s].
    alpha : casadi.SX, shape (1, n)
        Section angle of attack [rad].
    normalwash : {"angle", "tangency"}
        ``aero.normalwash``.

    Returns
    -------
    casadi.SX, shape (1, n)
        ``q`` [m/s].
    """
    if normalwash not in NORMALWASHES:
        raise ValueError(f"aero.normalwash must be one of {', '.join(NORMALWASHES)}, got {normalwash!r}")
    return Vp_norm * (alpha if normalwash == "angle" else ca.sin(alpha))


def inflow(state, r, v_kin, c_hat, up, tau, Wx, Wy, normalwash="angle"):
    """Relative air velocity at the element centres (code frame) and its angles.

    Returns ``(V 3xn, |Vp| 1xn, alpha 1xn [rad], vind 3xn)``: ``V = U_inf - Omega x r - v_kin`` without
    the induced velocity (:func:`_body_velocity`), ``alpha`` its (geometric) angle of attack,
    ``vind = (Wx q, Wy q, 0)`` the induced velocity of the lifting line with ``q = |Vp| alpha``. The
    *effective* angle of attack of a section is :func:`section_angle` of ``V + vind``.

    Parameters
    ----------
    state : casadi.SX
        Body state (u, w, q, theta).
    r : casadi.SX, shape (3, n)
        Element centres relative to G (code frame) [m].
    v_kin : casadi.SX, shape (3, n)
        Kinematic velocity of the centres relative to the body [m/s].
    c_hat, up, tau : casadi.SX, shape (3, n)
        Chordwise, section-normal and spanwise unit vectors.
    Wx, Wy : casadi.SX, shape (n, n)
        Induced-velocity matrices (:func:`circulation_matrices`).
    normalwash : {"angle", "tangency"}
        ``aero.normalwash``, the section law (:data:`~birdocp.bird.collocation.NORMALWASHES`).

    Returns
    -------
    tuple of casadi.SX
        ``(V, |Vp|, alpha, vind)``: ``V`` (3 x n) the relative air velocity [m/s] at the centres
        without the induced velocity, ``|Vp|`` (1 x n) its speed in the section plane [m/s],
        ``alpha`` (1 x n) its geometric angle of attack [rad], ``vind`` (3 x n) the induced velocity
        ``(Wx q, Wy q, 0)`` [m/s] with ``q = |Vp| alpha``.
    """
    V = _body_velocity(state, r, v_kin)
    Vp_norm, alpha, vind = _inflow_from_velocity(V, c_hat, up, tau, Wx, Wy, normalwash)
    return V, Vp_norm, alpha, vind
