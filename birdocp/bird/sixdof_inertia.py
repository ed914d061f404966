"""Wings with mass in six degrees of freedom: the 3-D sums of the wing mass points and the rigid body's
accelerations with them (the equations are in ``docs/studies/lateral.md``, wing masses).

The planar model (:mod:`birdocp.bird.inertia`) keeps the in-plane sums of mirror-symmetric wings. In
three dimensions every sum is a vector or a tensor, and nothing cancels once the wings move
differently or the body rolls and yaws. Body frame x' forward, y' right, z' down, origin **G_b, the
centre of mass of the body alone** (where the aerodynamic moment is taken). The wing points
``r_i(t)`` (both wings, each listed on its own side, so an asymmetric gait needs no other code) have
relative velocities and accelerations ``r_i'``, ``r_i''`` (AD in t). The sums (:data:`MASS3_BLOCK`):

* ``S = sum m r``, ``S'``, ``S''`` (3 each);
* ``I_w = sum m (|r|^2 1 - r r^T)`` (the wings' inertia tensor about G_b, products of inertia
  included) and its time derivative ``I_w'`` (6 entries each, upper triangle xx, xy, xz, yy, yz, zz);
* ``h = sum m r x r'`` (angular momentum of the relative motion about G_b) and ``k = h' = sum m r x r''``.

With ``M = body.mass_kg`` (the whole bird), ``J_b`` the body's own inertia tensor about G_b,
``omega = (p, q, r)``, ``v = (u, v, w)`` and ``g_b`` gravity in body axes, Newton and Euler read::

    M (v' + omega x v) - S x omega' = F + M g_b - omega x (omega x S) - 2 omega x S' - S''
    S x v' + (J_b + I_w) omega'     = M_aero + S x g_b - S x (omega x v) - I_w' omega - k
                                      - omega x ((J_b + I_w) omega + h)

a symmetric positive definite 6 x 6 system ``𝕄 nu' = b``. As in the planar model it is solved as
"the massless right-hand side plus a correction": ``nu' = f_0 + delta`` with ``f_0`` the rigid body
of mass M and inertia J_b and ``𝕄 delta = b_w - (𝕄 - diag(M, M, M, J_b)) f_0`` (``b_w``: the wing
terms of b), by the Schur complement over the inertia about the whole bird's centre of mass
``J_C = J_b + I_w + (S S^T - |S|^2 1) / M``. With massless wings every wing term is an exact zero and
``delta = 0.0``. For a symmetric gait at a symmetric state the longitudinal rows are the planar
model's section 4 (:func:`birdocp.bird.inertia.accelerations`).
"""

from __future__ import annotations

import casadi as ca

__all__ = ["MASS3_BLOCK", "N_MASS3", "mass_sums_3d", "unpack_mass3", "wing_corrected_accelerations",
           "momenta", "sums_function"]

_TRI = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))

MASS3_BLOCK = (("m_w_kg", 1), ("S_kgm", 3), ("dS_kgmps", 3), ("ddS_kgmps2", 3), ("I_w_kgm2", 6),
               ("dI_w_kgm2ps", 6), ("h_kgm2ps", 3), ("k_kgm2ps2", 3))
"""Names and sizes of the 3-D wing-mass sums appended to the 6-DOF data vector (both wings, body frame,
about G_b); tensors as their upper triangle (xx, xy, xz, yy, yz, zz)."""

N_MASS3 = sum(n for _, n in MASS3_BLOCK)


def _cross(a, b):
    return ca.vertcat(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _sym(tri):
    """The symmetric 3 x 3 matrix of an upper triangle (xx, xy, xz, yy, yz, zz)."""
    return ca.blockcat([[tri[0], tri[1], tri[2]], [tri[1], tri[3], tri[4]], [tri[2], tri[4], tri[5]]])


def mass_sums_3d(m, r, v, a) -> dict:
    """The sums of :data:`MASS3_BLOCK` of the points ``m`` (n masses [kg]) at body-frame positions
    ``r`` (3 x n [m], relative to G_b), relative velocities ``v`` [m/s] and accelerations ``a``
    [m/s^2] (both wings, every point listed once).

    Parameters
    ----------
    m : sequence
        Point masses [kg].
    r : casadi.SX, shape (3, n)
        Positions [m].
    v : casadi.SX, shape (3, n)
        Relative velocities [m/s].
    a : casadi.SX, shape (3, n)
        Relative accelerations [m/s^2].

    Returns
    -------
    dict
    """
    n = r.shape[1]
    out = {"m_w_kg": ca.sum1(m)}
    mr = r * ca.repmat(m.T, 3, 1)
    mv = v * ca.repmat(m.T, 3, 1)
    ma = a * ca.repmat(m.T, 3, 1)
    out["S_kgm"], out["dS_kgmps"], out["ddS_kgmps2"] = ca.sum2(mr), ca.sum2(mv), ca.sum2(ma)
    rr = ca.sum1(r * mr)                       # m |r|^2 per point
    rv = ca.sum1(r * mv)                       # m r . r' per point
    I_w, dI_w = [], []
    for i, j in _TRI:
        mrr = ca.dot(mr[i, :].T, r[j, :].T)
        I_w.append((ca.sum2(rr) if i == j else 0) - mrr)
        dm = ca.dot(mv[i, :].T, r[j, :].T) + ca.dot(mr[i, :].T, v[j, :].T)
        dI_w.append((2 * ca.sum2(rv) if i == j else 0) - dm)
    out["I_w_kgm2"], out["dI_w_kgm2ps"] = ca.vertcat(*I_w), ca.vertcat(*dI_w)
    out["h_kgm2ps"] = ca.sum2(ca.horzcat(*[_cross(mr[:, k], v[:, k]) for k in range(n)]))
    out["k_kgm2ps2"] = ca.sum2(ca.horzcat(*[_cross(mr[:, k], a[:, k]) for k in range(n)]))
    return out


def sums_function(mass_points: ca.Function, sides: bool = False) -> ca.Function:
    """``(t, p) -> the 3-D sums`` (one vector laid out as :data:`MASS3_BLOCK`) from a planar model's
    ``mass_points(t, p) -> (r, v, a, m)`` (both wings, body frame about G_b, the right wing's points
    first). ``sides``: ``(t, p_right, p_left) -> the sums`` of two wings with their own joint laws (an
    asymmetric gait, :mod:`birdocp.bird.sides`): the right wing's points from ``mass_points`` at
    ``p_right``, the left wing's (its mirrored half) at ``p_left``.

    Parameters
    ----------
    mass_points : casadi.Function
        ``mass_points(t, p) -> (r, v, a, m)`` of a planar model.
    sides : bool
        Two wings with their own joint laws.

    Returns
    -------
    casadi.Function
    """
    t = ca.SX.sym("t")
    p = ca.SX.sym("p", mass_points.size1_in(1))
    r, v, a, m = mass_points(t, p)
    inputs, names = [t, p], ["t", "p"]
    if sides:
        pl = ca.SX.sym("p_left", mass_points.size1_in(1))
        rl, vl, al, ml = mass_points(t, pl)
        h = r.shape[1] // 2
        r, v, a = (ca.horzcat(z[:, :h], zl[:, h:]) for z, zl in ((r, rl), (v, vl), (a, al)))
        m = ca.vertcat(m[:h], ml[h:])
        inputs, names = [t, p, pl], ["t", "p_right", "p_left"]
    s = mass_sums_3d(m, r, v, a)
    return ca.Function("wing_sums_3d", inputs, [ca.vertcat(*[s[k] for k, _ in MASS3_BLOCK])], names, ["sums"])


def unpack_mass3(block) -> dict:
    """The sums of a data block laid out as :data:`MASS3_BLOCK`: a dict of column vectors, with the
    tensors ``I_w`` and ``dI_w`` as 3 x 3 matrices.

    Parameters
    ----------
    block : casadi.SX
        Data block.

    Returns
    -------
    dict
    """
    out, k = {}, 0
    for name, n in MASS3_BLOCK:
        out[name] = block[k:k + n]
        k += n
    out["I_w_kgm2"] = _sym(out["I_w_kgm2"])
    out["dI_w_kgm2ps"] = _sym(out["dI_w_kgm2ps"])
    out["m_w_kg"] = out["m_w_kg"][0]
    return out


def _solve3(A, b):
    """x = A^-1 b for a symmetric 3 x 3 ``A`` by its adjugate (closed form, no solve in the graph)."""
    c0, c1, c2 = A[:, 0], A[:, 1], A[:, 2]
    x0, x1, x2 = _cross(c1, c2), _cross(c2, c0), _cross(c0, c1)
    det = ca.dot(c0, x0)
    return ca.vertcat(ca.dot(x0, b), ca.dot(x1, b), ca.dot(x2, b)) / det


def wing_corrected_accelerations(f0, x, s: dict, total_mass_kg, body_inertia, gravity_b):
    """(u', v', w', p', q', r') with moving wing masses: ``f0`` (6) is the rigid body's with mass M and
    the body's inertia tensor ``body_inertia`` (3 x 3, about G_b) under the same loads; ``x`` the
    9-state; ``s`` the sums (:func:`unpack_mass3`); ``gravity_b`` the gravity vector in body axes
    [m/s^2]. Returns ``f0 + delta`` (the module's equations).

    Parameters
    ----------
    f0 : casadi.SX
        Rigid body's (u', v', w', p', q', r').
    x : casadi.SX
        9-state.
    s : dict
        Mass sums.
    total_mass_kg : float
        M [kg].
    body_inertia : casadi.SX, shape (3, 3)
        Body's inertia tensor about G_b [kg m^2].
    gravity_b : casadi.SX
        Gravity vector in body axes [m/s^2].

    Returns
    -------
    casadi.SX, shape (6, 1)
    """
    vel, om = ca.vertcat(x[0], x[1], x[2]), ca.vertcat(x[3], x[4], x[5])
    M = total_mass_kg
    S, dS, ddS = s["S_kgm"], s["dS_kgmps"], s["ddS_kgmps2"]
    Iw = s["I_w_kgm2"]
    bw1 = -_cross(om, _cross(om, S)) - 2 * _cross(om, dS) - ddS
    bw2 = (_cross(S, gravity_b) - _cross(S, _cross(om, vel)) - s["dI_w_kgm2ps"] @ om - s["k_kgm2ps2"]
           - _cross(om, Iw @ om + s["h_kgm2ps"]))
    fv, fw = f0[0:3], f0[3:6]
    # (𝕄 - diag(M, M, M, J_b)) f0 = (-S x fw, S x fv + I_w fw)
    r1 = bw1 + _cross(S, fw)
    r2 = bw2 - (_cross(S, fv) + Iw @ fw)
    # M dv - S x dw = r1,  S x dv + (J_b + I_w) dw = r2  ->  J_C dw = r2 - S x r1 / M
    J_C = body_inertia + Iw + (S @ S.T - ca.dot(S, S) * ca.DM.eye(3)) / M
    dw = _solve3(J_C, r2 - _cross(S, r1) / M)
    dv = (r1 + _cross(S, dw)) / M
    return ca.vertcat(fv + dv, fw + dw)


def momenta(x, s: dict, total_mass_kg, body_inertia):
    """Linear momentum ``P = M v + omega x S + S'`` [kg m/s] and the angular momentum about G_b with
    absolute velocities ``H_abs = (J_b + I_w) omega + h + S x v`` [kg m^2/s] of body plus wings, in body
    axes (the conserved quantities, rotated to the inertial frame, of a bird in vacuum).

    Parameters
    ----------
    x : casadi.SX
        9-state.
    s : dict
        Mass sums.
    total_mass_kg : float
        M [kg].
    body_inertia : casadi.SX, shape (3, 3)
        Body's inertia tensor about G_b [kg m^2].

    Returns
    -------
    P, H : casadi.SX
    """
    vel, om = ca.vertcat(x[0], x[1], x[2]), ca.vertcat(x[3], x[4], x[5])
    S = s["S_kgm"]
    P = total_mass_kg * vel + _cross(om, S) + s["dS_kgmps"]
    H = (body_inertia + s["I_w_kgm2"]) @ om + s["h_kgm2ps"] + _cross(S, vel)
    return P, H
