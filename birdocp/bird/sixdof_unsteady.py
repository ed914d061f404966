"""Wagner's unsteady section (``aero.unsteady = "wagner"``) in six degrees of freedom: the
non-circulatory (added-mass) loads on the six body rows and the 6 x 6 added-mass matrix
(docs/model_unsteady.md, docs/studies/lateral.md).

The planar model's added mass (:func:`birdocp.bird.unsteady.section_loads`) acts on (u, w, q) through
the added-mass vectors ``a_j = d w_mid,j / d(u, w, q)`` of every element, w_mid,j = V_j . n_hat_j +
c_j omega_j / 4 the normal air velocity at mid-chord. In six degrees of freedom the same w_mid,j also
depends on v, p, r: with ``V = U_inf - Omega x r - v_kin``, ``U_inf = (-v, w, u)``, ``Omega = (q, -r, -p)``
(code frame e1 right, e2 up, e3 back) and omega_j = omega_k,j + Omega . tau_hat_j, its gradient over
nu = (u, v, w, p, q, r) is

    a_j = (n3, -n1, n2, m3 - c tau3 / 4, -m1 + c tau1 / 4, m2 - c tau2 / 4),   m = r x n_hat

(n = n_hat_j, tau = tau_hat_j, r the element's quarter-chord point from G). The force
(m_a w_mid)' n_hat at mid-chord has the generalised force -m_a w_mid' a_j on the body rows (X, Y, Z, L,
M, N), and the couple C_j tau_hat_j (its pitch acceleration Omega' . tau_hat_j) the force C_j a_theta,j
with a_theta,j = (0, 0, 0, -tau3, tau1, -tau2). So the body accelerations solve

    (M_rb + M_A) nu' = M_rb nu'_0 + b_nc,   M_A = chi_nc [sum_j m_a,j a_j a_j^T + sum_j m_theta,j a_theta,j a_theta,j^T]

(M_rb = diag(m, m, m, J_b), nu'_0 the accelerations without the added mass, b_nc the added-mass
generalised force with nu' = 0): M_A is symmetric positive semi-definite, on (u, w, q) the planar
one. The rows (u, w, q) of a_j and their rates are the planar data's; the 6-DOF data appends the rates
of the three other rows and of tau_hat (:func:`added_mass_data`, AD in t through the assembly). The
element law (the force, the couple, b_nc and M_A) is the planar model's,
:func:`birdocp.bird.unsteady.added_mass_loads`, on the six rows (:func:`added_mass_terms`), and so is the
section pitch rate :func:`birdocp.bird.unsteady.section_pitch_rate`.
"""

from __future__ import annotations

import casadi as ca

from birdocp.bird import unsteady

__all__ = ["N_ROWS", "added_mass_data", "extra_data_function", "lateral_rows", "added_mass_terms",
           "solve_spd", "accelerations", "wagner_accelerations"]

N_ROWS = 6
"""Rows per element of the 6-DOF added-mass data: d/dt of a_v, a_p, a_r, then d/dt of tau_hat (3)."""


def lateral_rows(r, n_hat, tau_hat, crow):
    """The rows (v, p, r) of the added-mass vectors a_j (3 x n; module docstring): ``-n1``,
    ``m3 - c tau3 / 4``, ``m2 - c tau2 / 4`` with ``m = r x n_hat``.

    Parameters
    ----------
    r : casadi.SX
        Quarter-chord points from G, code frame [m] (3 x n).
    n_hat, tau_hat : casadi.SX
        Unit normals and unit spanwise vectors (3 x n).
    crow : casadi.SX
        Chords [m] (1 x n).

    Returns
    -------
    casadi.SX
        3 x n, units (1, m, m).
    """
    m2 = r[2, :] * n_hat[0, :] - r[0, :] * n_hat[2, :]
    m3 = r[0, :] * n_hat[1, :] - r[1, :] * n_hat[0, :]
    return ca.vertcat(-n_hat[0, :], m3 - 0.25 * crow * tau_hat[2, :], m2 - 0.25 * crow * tau_hat[1, :])


def added_mass_data(blocks: dict, ddt):
    """The 6-DOF added-mass data of one instant (one column):
    the time derivatives of :func:`lateral_rows` (3 x n) then of tau_hat (3 x n), from the assembled
    data ``blocks`` (:func:`birdocp.bird.graphs.aero_blocks`) and the time-derivative operator ``ddt``
    (:func:`birdocp.bird.graphs.time_derivative`).

    Parameters
    ----------
    blocks : dict
        Assembled data blocks (``r_m``, ``up``, ``tau``, ``chord_m``).
    ddt : callable
        Time derivative of an expression.

    Returns
    -------
    casadi.SX
        Column of :data:`N_ROWS` n values.
    """
    n_hat, tau_hat = unsteady.unit_columns(blocks["up"]), unsteady.unit_columns(blocks["tau"])
    lat = lateral_rows(blocks["r_m"], n_hat, tau_hat, blocks["chord_m"].T)
    return ca.vertcat(ca.vec(ddt(lat)), ca.vec(ddt(tau_hat)))


def extra_data_function(structure, n_local: int) -> ca.Function:
    """``extra(local, t, p) -> d6`` (:func:`added_mass_data`) of a symmetric gait from the planar
    model's ``pre`` output ``local`` (``n_local`` values, its last two thirds of the aerodynamic shape
    the time derivatives).

    Parameters
    ----------
    structure : Structure
        Structure of the planar model.
    n_local : int
        Length of the ``pre`` output.

    Returns
    -------
    casadi.Function
    """
    from birdocp.bird.config import PARAM_NAMES
    from birdocp.bird.graphs import aero_blocks, time_derivative
    from birdocp.bird.model import N_EL

    L, t, p = ca.SX.sym("local", n_local), ca.SX.sym("t"), ca.SX.sym("p", len(PARAM_NAMES))
    n_aero = 4 * 3 * N_EL + N_EL
    ddt = time_derivative([L], n_aero, n_local - 2 * n_aero, t)
    return ca.Function("added_mass_data6", [L, t, p], [added_mass_data(aero_blocks(structure, L, t, p), ddt)],
                       ["local", "t", "p"], ["d6"])


def added_mass_terms(sec: dict, ud: dict, d6, base: dict, nu, prm: dict) -> dict:
    """The added-mass terms of the six body rows at one instant: ``M_A`` (6 x 6 over (u, v, w, p, q,
    r), kg, kg m, kg m^2), ``b_nc`` (6 x 1, generalised force with nu' = 0: N, N m), and per element
    ``nc_coef`` [N] (the force along n_hat with nu' = 0), ``couple0`` [N m] (the couple with nu' = 0),
    ``a`` and ``a_theta`` (6 x n).

    Parameters
    ----------
    sec : dict
        The section terms (:func:`birdocp.bird.unsteady.section_loads` with ``flow``: ``omega``,
        ``Vp_norm``).
    ud : dict
        The planar unsteady data (:func:`birdocp.bird.unsteady.unpack`).
    d6 : casadi.SX
        The 6-DOF added-mass data (:func:`added_mass_data`).
    base : dict
        ``r``, ``chord`` (n x 1), ``ds`` (n x 1).
    nu : casadi.SX
        Air-relative (u, v, w) [m/s] and body rates (p, q, r) [rad/s].
    prm : dict
        ``rho``, ``chi_nc`` (:func:`birdocp.bird.loads.unsteady_params`).

    Returns
    -------
    dict
    """
    n = base["chord"].shape[0]
    crow, ds = base["chord"].T, base["ds"]
    th = ud["tau_hat"]
    lat = lateral_rows(base["r"], ud["n_hat"], th, crow)
    lat_dot, th_dot = ca.reshape(d6[:3 * n], 3, n), ca.reshape(d6[3 * n:6 * n], 3, n)
    a, a_dot = ud["a"], ud["a_dot"]
    a6 = ca.vertcat(a[0, :], lat[0, :], a[1, :], lat[1, :], a[2, :], lat[2, :])
    a6_dot = ca.vertcat(a_dot[0, :], lat_dot[0, :], a_dot[1, :], lat_dot[1, :], a_dot[2, :], lat_dot[2, :])
    a_th = ca.vertcat(ca.SX.zeros(3, n), -th[2, :], th[0, :], -th[1, :])
    om = ca.vertcat(nu[4], -nu[5], -nu[3])   # Omega in the code frame
    geo = {"Vp_norm": sec["Vp_norm"], "chord": crow, "ds": ds, "omega": sec["omega"],
           "omega_dot0": unsteady.section_pitch_rate(ud["omega_k_dot"], om, th_dot)}
    out = unsteady.added_mass_loads(nu, {"a": a6, "a_dot": a6_dot, "a_theta": a_th}, ud, prm, geo)
    return dict(out, a=a6, a_theta=a_th)


def solve_spd(A, b):
    """x = A^-1 b for a symmetric positive-definite A (n x n, SX) by its LDL^T factorisation written
    out (no pivoting, no branches: the pivots of an SPD matrix are positive).

    Parameters
    ----------
    A : casadi.SX
        Symmetric positive-definite matrix (n x n).
    b : casadi.SX
        Right-hand side (n x 1).

    Returns
    -------
    casadi.SX
        n x 1.
    """
    n = A.shape[0]
    L = [[None] * n for _ in range(n)]
    D = [None] * n
    for j in range(n):
        D[j] = A[j, j] - sum((L[j][k] * L[j][k] * D[k] for k in range(j)), ca.SX(0))
        for i in range(j + 1, n):
            L[i][j] = (A[i, j] - sum((L[i][k] * L[j][k] * D[k] for k in range(j)), ca.SX(0))) / D[j]
    y = [None] * n
    for i in range(n):
        y[i] = b[i] - sum((L[i][k] * y[k] for k in range(i)), ca.SX(0))
    x = [None] * n
    for i in reversed(range(n)):
        x[i] = y[i] / D[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), ca.SX(0))
    return ca.vertcat(*x)


def accelerations(nudot0, m, J_b, terms: dict):
    """Body accelerations (u', v', w', p', q', r') with the added mass on the left, and the added-mass
    reaction on the body rows: ``(M_rb + M_A) nu' = M_rb nu'_0 + b_nc``, reaction ``b_nc - M_A nu'``.

    Parameters
    ----------
    nudot0 : casadi.SX
        Accelerations without the added mass (6 x 1).
    m : casadi.SX
        Mass [kg].
    J_b : casadi.SX
        Inertia tensor about G [kg m^2] (3 x 3).
    terms : dict
        :func:`added_mass_terms`.

    Returns
    -------
    tuple of casadi.SX
        ``(nudot 6 x 1, reaction 6 x 1)``: the reaction's force [N] then moment [N m].
    """
    M_rb = ca.diagcat(m, m, m, J_b)
    M_A = terms["M_A"]
    nudot = solve_spd(M_rb + M_A, M_rb @ nudot0 + terms["b_nc"])
    return nudot, terms["b_nc"] - M_A @ nudot


def wagner_accelerations(nudot0, x_air, d, p, sec: dict, data_offset: int, m, J_b):
    """The 6-DOF body accelerations with Wagner's added mass and its reaction on the body rows
    (:func:`accelerations`), from the 6-DOF data ``d`` (the planar unsteady blocks from ``data_offset``,
    then :func:`added_mass_data`) at the air-relative state ``x_air``.

    Parameters
    ----------
    nudot0 : casadi.SX
        Accelerations (u', v', w', p', q', r') without the added mass.
    x_air : casadi.SX
        The state as the air sees it (its first six values: u, v, w [m/s], p, q, r [rad/s]).
    d : casadi.SX
        6-DOF data vector.
    p : casadi.SX
        Planar parameter vector.
    sec : dict
        The section terms (:func:`birdocp.bird.unsteady.section_loads` with ``flow``).
    data_offset : int
        Index of the first planar unsteady data value in ``d``.
    m : casadi.SX
        Mass [kg].
    J_b : casadi.SX
        Inertia tensor about G [kg m^2] (3 x 3).

    Returns
    -------
    tuple of casadi.SX
        ``(nudot 6 x 1, reaction 6 x 1)``.
    """
    from birdocp.bird.loads import unsteady_params
    from birdocp.bird.model import N_EL, unpack_data

    n_u = unsteady.data_size(N_EL)
    ud = unsteady.unpack(d[data_offset:data_offset + n_u], N_EL)
    d6 = d[data_offset + n_u:data_offset + n_u + N_ROWS * N_EL]
    b = unpack_data(d)
    base = {"r": b["r_m"], "chord": b["chord_m"], "ds": b["ds_m"]}
    terms = added_mass_terms(sec, ud, d6, base, x_air[0:6], unsteady_params(p))
    return accelerations(nudot0, m, J_b, terms)
