"""Unsteady and stall-aware section aerodynamics of the lifting line (docs/model_unsteady.md).

Three pieces, all on per-element matrices (3 x n vectors in the code frame, n x 1 columns):

* the section law: :func:`separation_point` f0(alpha), :func:`lift_coefficient` C_l(alpha, f) (the
  Oye / Hansen-Gaunaa-Madsen blend of the attached C_la alpha and the flat plate), the separated drag;
* :func:`element_data`: the time-only data of the unsteady terms (unit normals, kinematic pitch rate,
  mid-chord velocity, added-mass vectors and their time derivatives, the wake matrices), from the
  element geometry and a time-derivative operator ``ddt`` (AD in t);
* :func:`section_loads`: at one (state, data) the circulation (exact linear solve, or a fixed count of
  Newton steps for a stall section), the lag-state and separation-state derivatives, the circulatory,
  separated and non-circulatory loads and the added-mass matrix of the body rows (F_x', F_z', M_y').

The same functions serve the bird model (:mod:`birdocp.bird.model`) and the 2-D prescribed-kinematics
harness (:mod:`birdocp.bird.unsteady_harness`). Units SI, angles in rad.
"""

from __future__ import annotations

import math

import casadi as ca

from birdocp.bird.stall_section import (circulation, lift_coefficient, separated_drag_coefficient,
                                        separation_point)

A1, A2, B1, B2 = 0.165, 0.335, 0.0455, 0.3
"""Jones's two-exponential approximation of Wagner's function: phi(s) = 1 - A1 e^(-B1 s) - A2 e^(-B2 s)
(s in semichords travelled)."""

__all__ = ["A1", "A2", "B1", "B2", "jones_transfer", "wagner_indicial_jones", "separation_point",
           "lift_coefficient", "separated_drag_coefficient", "element_data", "section_loads",
           "solve_sym3", "DATA_BLOCKS", "n_aero_states", "aero_state_names", "unit_columns", "section_pitch_rate",
           "added_mass_loads"]


def jones_transfer(k: float, weight: float = 1.0) -> complex:
    """Jones's approximation C_J(k) = A0 + sum_i eps A_i b_i / (i k + b_i) of Theodorsen's function at
    reduced frequency k = omega c / (2 U); ``weight`` = eps (0: quasi-steady, C_J = 1).

    Parameters
    ----------
    k : float
        Reduced frequency [-].
    weight : float
        eps [-].

    Returns
    -------
    complex
    """
    a0 = 1.0 - weight * (A1 + A2)
    return a0 + weight * (A1 * B1 / (1j * k + B1) + A2 * B2 / (1j * k + B2))


def wagner_indicial_jones(s: float) -> float:
    """Jones's phi(s) = 1 - A1 exp(-B1 s) - A2 exp(-B2 s), s in semichords.

    Parameters
    ----------
    s : float
        Distance travelled [semichords].

    Returns
    -------
    float
    """
    return 1.0 - A1 * math.exp(-B1 * s) - A2 * math.exp(-B2 * s)


DATA_BLOCKS = (
    ("n_hat", 3), ("tau_hat", 3), ("omega_k", 1), ("omega_k_dot", 1), ("r_mid_dot", 3), ("a", 3),
    ("a_dot", 3), ("w0", 1), ("w0_dot", 1), ("m_a", 1), ("m_a_dot", 1), ("m_theta", 1), ("tau_hat1_dot", 1),
)
"""(name, rows) of the unsteady data blocks (n columns each). ``m_a``, ``m_a_dot``, ``m_theta`` are per
unit air density [m^3, m^3/s, m^5]: the density is a number of the state right-hand side."""


def block_sizes(n: int) -> list[tuple[str, int, int]]:
    """(name, rows, cols) of :data:`DATA_BLOCKS` for n elements.

    Parameters
    ----------
    n : int
        Number of elements.

    Returns
    -------
    list of (str, int, int)
    """
    return [(k, n, n) if r < 0 else (k, r, n) for k, r in DATA_BLOCKS]


def pack(blocks: dict, n: int):
    """The data blocks as one column (layout :func:`block_sizes`).

    Parameters
    ----------
    blocks : dict
        Block name to matrix.
    n : int
        Number of elements.

    Returns
    -------
    casadi.SX or MX
    """
    return ca.vertcat(*[ca.vec(blocks[k]) for k, _, _ in block_sizes(n)])


def unpack(d, n: int) -> dict:
    """Inverse of :func:`pack` on a column (SX/MX/DM).

    Parameters
    ----------
    d : casadi.SX, MX or DM
        Packed column.
    n : int
        Number of elements.

    Returns
    -------
    dict
    """
    out, k = {}, 0
    for name, r, c in block_sizes(n):
        out[name] = ca.reshape(d[k:k + r * c], r, c)
        k += r * c
    return out


def data_size(n: int) -> int:
    """Length of the packed data column for n elements.

    Parameters
    ----------
    n : int
        Number of elements.

    Returns
    -------
    int
    """
    return sum(r * c for _, r, c in block_sizes(n))


def unit_columns(M):
    """The columns of M scaled to unit length.

    Parameters
    ----------
    M : casadi.SX
        Matrix (3 x n).

    Returns
    -------
    casadi.SX
        3 x n.
    """
    return M / ca.repmat(ca.sqrt(ca.sum1(M * M)), M.shape[0], 1)


def section_pitch_rate(omega_k, Omega, tau_hat):
    """The nose-up pitch rate of every section, omega_j = omega_k,j + Omega . tau_hat_j [rad/s]: the
    kinematic (flapping) part plus the body rotation about the element's spanwise axis; with the
    rates of the data (``omega_k_dot``, d tau_hat / dt) the part of omega_j' that holds the body
    accelerations at zero.

    Parameters
    ----------
    omega_k : casadi.SX
        Kinematic section pitch rate [rad/s] (1 x n).
    Omega : casadi.SX
        Body rotation rate in the code frame [rad/s], its first k components (k x 1): the planar model
        gives (q), six degrees of freedom (q, -r, -p).
    tau_hat : casadi.SX
        The first k rows of the unit spanwise vectors (k x n).

    Returns
    -------
    casadi.SX
        1 x n.
    """
    omega = omega_k
    for i in range(Omega.shape[0]):
        omega = omega + Omega[i] * tau_hat[i, :]
    return omega


def element_data(r, v_kin, c_hat, up, tau, chord, ds, ddt) -> dict:
    """The unsteady data blocks (:data:`DATA_BLOCKS`) of one instant, as expressions.

    ``r``, ``v_kin``, ``c_hat``, ``up``, ``tau``: 3 x n (quarter-chord centres relative to G [m], their
    kinematic velocity [m/s], chord direction, up normal, spanwise vector; code frame); ``chord``,
    ``ds`` n x 1 [m]; ``ddt(e)`` the time derivative of an expression (AD in t). Geometry only: no
    parameter of the state right-hand side enters (the C export keeps the two apart).

    Parameters
    ----------
    r, v_kin, c_hat, up, tau : casadi.SX, shape (3, n)
        See above.
    chord, ds : casadi.SX, shape (n, 1)
        Chords and element lengths [m].
    ddt : callable
        Time derivative of an expression.

    Returns
    -------
    dict
        Block name to expression.
    """
    n_hat, tau_hat = unit_columns(up), unit_columns(tau)
    c_dot = ddt(c_hat)
    omega_k = -ca.sum1(c_dot * n_hat)                     # nose-up section pitch rate [rad/s]
    crow = chord.T
    r_mid_dot = v_kin + 0.25 * (ca.repmat(ddt(crow), 3, 1) * c_hat + ca.repmat(crow, 3, 1) * c_dot)
    a = ca.vertcat(n_hat[2, :], n_hat[1, :],
                   r[2, :] * n_hat[1, :] - r[1, :] * n_hat[2, :] + 0.25 * crow * tau_hat[0, :])
    w0 = -ca.sum1(v_kin * n_hat) + 0.25 * crow * omega_k
    m_a = math.pi * crow ** 2 * ds.T / 4
    m_theta = math.pi * (crow / 2) ** 4 * ds.T / 8
    return {"n_hat": n_hat, "tau_hat": tau_hat, "omega_k": omega_k, "omega_k_dot": ddt(omega_k),
            "r_mid_dot": r_mid_dot, "a": a, "a_dot": ddt(a), "w0": w0, "w0_dot": ddt(w0), "m_a": m_a,
            "m_a_dot": ddt(m_a), "m_theta": m_theta, "tau_hat1_dot": ddt(tau_hat[0, :])}


def n_aero_states(unsteady: str, section: str, n: int = 16) -> int:
    """Number of aerodynamic states: 2 n lag states with ``wagner``, n separation states with
    ``dynamic-stall``.

    Parameters
    ----------
    unsteady, section : str
        ``aero.unsteady`` and ``aero.section``.
    n : int
        Number of elements.

    Returns
    -------
    int
    """
    return n * ((2 if unsteady == "wagner" else 0) + (1 if section == "dynamic-stall" else 0))


def aero_state_names(unsteady: str, section: str, n: int = 16) -> tuple[str, ...]:
    """``z1_mps_j``, ``z2_mps_j`` (wagner), ``f_sep_j`` (dynamic-stall), j = 0..n-1.

    Parameters
    ----------
    unsteady, section : str
        ``aero.unsteady`` and ``aero.section``.
    n : int
        Number of elements.

    Returns
    -------
    tuple of str
    """
    names = []
    if unsteady == "wagner":
        names += [f"z1_mps_{j}" for j in range(n)] + [f"z2_mps_{j}" for j in range(n)]
    if section == "dynamic-stall":
        names += [f"f_sep_{j}" for j in range(n)]
    return tuple(names)


def _cross(W, tau):
    return ca.vertcat(W[1, :] * tau[2, :] - W[2, :] * tau[1, :],
                      W[2, :] * tau[0, :] - W[0, :] * tau[2, :],
                      W[0, :] * tau[1, :] - W[1, :] * tau[0, :])


def section_loads(opts: dict, nu, zs, base: dict, ud: dict, wake: dict, prm: dict, flow: dict | None = None) -> dict:
    """Loads and aerodynamic-state derivatives at one instant (see the module and docs).

    ``opts``: ``unsteady``, ``section``, ``newton_steps``. ``nu`` = (u, w, q) air-relative body
    velocities [m/s, m/s, rad/s]; ``zs``: the aerodynamic states (:func:`aero_state_names` order);
    ``base``: ``r``, ``v_kin``, ``c_hat``, ``up``, ``tau`` (3 x n), ``ds``, ``chord`` (n x 1); ``ud``:
    :func:`element_data`; ``wake``: ``K``, ``Vx``, ``Vy`` (n x n: downwash and induced e1, e2
    velocity per unit circulation); ``prm``: ``rho``, ``cla``, ``eps``, ``a0``, ``kappa``, ``chi_w``, ``chi_nc``,
    ``alpha1`` [rad], ``cd90``, ``Tf``, ``T2``; ``flow`` (six degrees of freedom): ``V`` the air velocity
    of every element without the induced part (3 x n, code frame, m/s: sideslip and roll and yaw rates
    included) and ``Omega`` the body's rotation rate (3 x 1, code frame, rad/s), which replace the planar
    velocity and pitch rate made from ``nu`` (``nu`` is then unused, and the added-mass keys are left
    out: the six body rows take them from :func:`added_mass_loads` through
    :func:`birdocp.bird.sixdof_unsteady.added_mass_terms`).

    Returns a dict: ``dF_att`` (at r), ``dF_mid`` (at r_mid), ``r_mid`` (3 x n, N and m); ``F`` (3 x 1,
    code frame, circulatory + separated), ``M`` (moment about G, N m, nose-up); the non-circulatory
    ``M_A`` (3 x 3, kg / kg m on (u, w, q)), ``b_nc`` (3, generalised force with nu' = 0), the pieces
    ``nc_coef`` (per element: dF_nc = (nc_coef + m_a a . nu') n_hat) and ``couple0`` (couple with
    q' = 0); ``zdot``; ``Gamma``, ``alpha_E`` (n x 1), ``f`` (1 x n), ``vind``, ``v_s``, ``V``, ``Vp``,
    ``Vp_norm``, ``alpha``, ``omega``, ``newton_residual``.

    Parameters
    ----------
    opts, nu, zs, base, ud, wake, prm, flow
        See above.

    Returns
    -------
    dict
        The keys listed above.
    """
    from birdocp.bird import aero

    n = base["chord"].shape[0]
    wag = opts["unsteady"] == "wagner"
    dyn = opts["section"] == "dynamic-stall"
    kin = _section_flow(nu, base, ud, prm, wag, flow)
    Vn, chord = kin["Vp_norm"], base["chord"]
    k = 2 * n if wag else 0
    z1, z2 = (zs[0:n], zs[n:2 * n]) if wag else (ca.SX.zeros(n, 1), ca.SX.zeros(n, 1))
    f_state = zs[k:k + n].T if dyn else None
    a0 = prm["a0"] if wag else 1.0
    prm = dict(prm, a0=a0)
    zsum = z1 + z2
    K = wake["K"]
    Gamma, rel = circulation(opts, prm, kin["q_t"], zsum, Vn.T, chord, K, None if f_state is None else f_state.T)
    g = kin["q_t"] - K @ Gamma
    gE = a0 * g + zsum
    aE = gE / Vn.T
    if opts["section"] == "linear":
        f = ca.DM.ones(1, n)
    elif dyn:
        f = f_state
    else:
        f = separation_point(aE.T, prm["alpha1"])
    zdot = _state_rates(prm, g, z1, z2, aE, f_state, Vn, chord.T, wag, dyn)
    out = _circulatory_forces(opts["section"], prm, base, ud, wake, kin, Gamma, g, gE, aE, f, wag)
    out["M"] = aero.moment_about_G(base["r"], out["dF_att"]) + aero.moment_about_G(out["r_mid"], out["dF_mid"])
    out.update({"zdot": ca.vertcat(*zdot), "Gamma": Gamma, "alpha_E": aE, "f": f, "V": kin["V"], "Vp": kin["Vp"],
                "Vp_norm": Vn, "alpha": kin["alpha"], "omega": kin["omega"], "newton_residual": rel,
                "wagner": wag, "n_hat": ud["n_hat"] if wag else None,
                "r_mid_dot": ud["r_mid_dot"] if ud else None, "omega_k": ud["omega_k"] if wag else None})
    if flow is None:  # six degrees of freedom: the caller's rows (sixdof_unsteady.added_mass_terms)
        out.update(_non_circulatory(nu, ud, prm, Vn, chord.T, base["ds"], kin["omega"]) if wag else
                   {"M_A": ca.SX.zeros(3, 3), "b_nc": ca.SX.zeros(3, 1)})
    return out


def _section_flow(nu, base, ud, prm, wag, flow=None) -> dict:
    """Air velocity V at the elements (3 x n), its part Vp normal to the span and |Vp| (1 x n), the
    section angle alpha, the section pitch rate omega (``wagner``) and the quasi-steady normalwash
    q~ (n x 1, with the 3/4-chord term under ``wagner``); ``flow``: the 6-DOF V and Omega
    (:func:`section_loads`), the section pitch rate then omega_k + Omega . tau_hat."""
    from birdocp.bird import aero

    r, v_kin, tau = base["r"], base["v_kin"], base["tau"]
    if flow is None:
        u, w, q = nu[0], nu[1], nu[2]
        ones = ca.DM.ones(1, base["chord"].shape[0])
        V = ca.vertcat(-v_kin[0, :], w * ones + q * r[2, :] - v_kin[1, :], u * ones - q * r[1, :] - v_kin[2, :])
    else:
        V = flow["V"]
    alpha, Vn = aero.section_angle(V, base["c_hat"], base["up"], tau)
    Vp = V - tau * ca.repmat(ca.sum1(tau * V), 3, 1)
    omega = None
    if wag:  # the planar body turns about e1 only
        Om = nu[2] if flow is None else flow["Omega"]
        omega = section_pitch_rate(ud["omega_k"], Om, ud["tau_hat"][0:Om.shape[0], :])
    q_t = (Vn * alpha).T
    if wag:
        q_t = q_t + prm["chi_w"] * 0.5 * base["chord"] * omega.T
    return {"V": V, "alpha": alpha, "Vp_norm": Vn, "Vp": Vp, "omega": omega, "q_t": q_t}


def _state_rates(prm, g, z1, z2, aE, f_state, Vn, crow, wag, dyn) -> list:
    """The lag-state rates (``wagner``) and the separation-state rate (``dynamic-stall``), as columns."""
    zdot = []
    if wag:
        lam1 = 2 * B1 * Vn / (prm["kappa"] * crow)
        lam2 = 2 * B2 * Vn / (prm["kappa"] * crow)
        z2dot = lam2.T * (prm["eps"] * A2 * g - z2)
        zdot += [lam1.T * (prm["eps"] * A1 * g - z1), z2dot]
    if dyn:
        a_f = aE.T
        if wag:
            tau2 = prm["T2"] * crow / (2 * Vn)
            a_f = a_f - tau2 * z2dot.T / (A2 * Vn)
        tau1 = prm["Tf"] * crow / (2 * Vn)
        zdot.append(((separation_point(a_f, prm["alpha1"]) - f_state) / tau1).T)
    return zdot


def _circulatory_forces(section, prm, base, ud, wake, kin, Gamma, g, gE, aE, f, wag) -> dict:
    """Kutta-Joukowski forces of the attached circulation at r (``dF_att``) and of the separated
    circulation with the separated pressure drag at mid-chord (``dF_mid``, ``r_mid``), their sum ``F``,
    the induced and shed-wake velocities ``vind``, ``v_s`` and ``Gamma_att``."""
    n = base["chord"].shape[0]
    crow, ds, Vn = base["chord"].T, base["ds"], kin["Vp_norm"]
    vind = ca.vertcat((wake["Vx"] @ Gamma).T, (wake["Vy"] @ Gamma).T, ca.DM.zeros(1, n))
    v_s = ca.repmat((gE - g).T, 3, 1) * ud["n_hat"] if wag else ca.DM.zeros(3, n)
    cross = _cross(kin["V"] + vind + v_s, base["tau"])
    rho = prm["rho"]
    r_mid = base["r"] + 0.25 * ca.repmat(crow, 3, 1) * base["c_hat"]
    if section == "linear":
        dF_att = rho * cross * ca.repmat((Gamma * ds).T, 3, 1)
        dF_mid = ca.DM.zeros(3, n)
        G_att = Gamma
    else:
        G_att = (0.5 * crow * Vn * f * prm["cla"] * aE.T).T
        dF_att = rho * cross * ca.repmat(((G_att) * ds).T, 3, 1)
        cd = separated_drag_coefficient(aE.T, f, prm["cd90"])
        dF_mid = rho * cross * ca.repmat(((Gamma - G_att) * ds).T, 3, 1) \
            + 0.5 * rho * kin["Vp"] * ca.repmat(crow * ds.T * Vn * cd, 3, 1)
    return {"dF_att": dF_att, "dF_mid": dF_mid, "r_mid": r_mid, "F": ca.sum2(dF_att + dF_mid),
            "Gamma_att": G_att, "vind": vind, "v_s": v_s}


def _non_circulatory(nu, ud, prm, Vn, crow, ds, omega) -> dict:
    """The planar added-mass terms (:func:`added_mass_loads` on (u, w, q): the couple acts on the q row
    through tau_hat's e1 component)."""
    n = crow.shape[1]
    t1 = ud["tau_hat"][0, :]
    rows = {"a": ud["a"], "a_dot": ud["a_dot"], "a_theta": ca.vertcat(ca.SX.zeros(2, n), t1)}
    omega_dot0 = section_pitch_rate(ud["omega_k_dot"], nu[2], ud["tau_hat1_dot"])
    out = added_mass_loads(ca.vertcat(nu[0], nu[1], nu[2]), rows, ud, prm,
                           {"Vp_norm": Vn, "chord": crow, "ds": ds, "omega": omega, "omega_dot0": omega_dot0})
    return dict(out, a=ud["a"], tau1=t1)


def added_mass_loads(nu, rows: dict, ud: dict, prm: dict, sec: dict) -> dict:
    """The non-circulatory (added-mass) loads of every element on k body velocity rows nu (Theodorsen's
    flat-plate apparent mass, docs/model_unsteady.md), with the body accelerations nu' = 0, and the
    added-mass matrix: the one element-level law of the planar (k = 3: u, w, q) and the 6-DOF (k = 6)
    models.

    Element j carries the force (m_a w_mid)' along n_hat at mid-chord, w_mid = a_j . nu + w0_j, and the
    couple C_j = -pi rho (c/2)^3 ds (Vp omega / 2 + (c/2) omega' / 8) about tau_hat, acting on the
    body rows along a_theta,j. With nu' = 0: ``nc_coef`` = chi (m_a (a_j' . nu + w0') + m_a' w_mid) [N],
    ``couple0`` [N m]; ``b_nc = -sum_j nc_coef_j a_j + sum_j couple0_j a_theta,j``; ``M_A = chi sum_j
    m_a,j a_j a_j^T + chi rho sum_j m_theta,j a_theta,j a_theta,j^T`` (symmetric positive
    semi-definite), so that (M_rb + M_A) nu' = M_rb nu'_0 + b_nc.

    Parameters
    ----------
    nu : casadi.SX
        Air-relative body velocities (k x 1) [m/s, rad/s].
    rows : dict
        ``a``, ``a_dot`` (k x n: d w_mid / d nu and its time derivative) and ``a_theta`` (k x n: the
        body rows of a unit couple about tau_hat).
    ud : dict
        The unsteady data blocks (:func:`unpack`): ``w0``, ``w0_dot``, ``m_a``, ``m_a_dot``, ``m_theta``.
    prm : dict
        ``rho`` [kg/m^3], ``chi_nc`` [-].
    sec : dict
        ``Vp_norm`` (1 x n) [m/s], ``chord`` (1 x n) [m], ``ds`` (n x 1) [m], ``omega`` (1 x n) the
        section pitch rate and ``omega_dot0`` (1 x n) its rate with nu' = 0 [rad/s, rad/s^2]
        (:func:`section_pitch_rate`).

    Returns
    -------
    dict
        ``M_A`` (k x k), ``b_nc`` (k x 1), per element ``nc_coef``, ``couple0``, ``w_mid`` (1 x n),
        ``m_a_chi`` = chi rho m_a [kg] and ``m_theta_chi`` = chi rho m_theta [kg m^2] (1 x n).
    """
    chi, rho = prm["chi_nc"], prm["rho"]
    a, a_dot, a_th = rows["a"], rows["a_dot"], rows["a_theta"]
    crow = sec["chord"]
    nu_row = ca.repmat(nu, 1, a.shape[1])
    w_mid = ca.sum1(a * nu_row) + ud["w0"]
    wdot0 = ca.sum1(a_dot * nu_row) + ud["w0_dot"]
    m_a = rho * ud["m_a"]
    nc_coef = chi * (m_a * wdot0 + rho * ud["m_a_dot"] * w_mid)        # dF_nc with nu' = 0, along n_hat [N]
    couple0 = -chi * rho * math.pi * (crow / 2) ** 3 * sec["ds"].T * (0.5 * sec["Vp_norm"] * sec["omega"]
                                                                      + (crow / 2) * sec["omega_dot0"] / 8)
    b_nc = -(a @ nc_coef.T) + a_th @ couple0.T
    m_th = chi * rho * ud["m_theta"]
    M_A = chi * (a @ ca.diag(m_a) @ a.T) + a_th @ ca.diag(m_th) @ a_th.T
    return {"M_A": M_A, "b_nc": b_nc, "nc_coef": nc_coef, "couple0": couple0, "w_mid": w_mid,
            "m_a_chi": chi * m_a, "m_theta_chi": m_th}


def solve_sym3(M, b):
    """x = M^-1 b for a 3 x 3 symmetric positive-definite M, in closed form (adjugate; no branches).

    Parameters
    ----------
    M : casadi.SX, shape (3, 3)
        Symmetric positive-definite matrix.
    b : casadi.SX, shape (3, 1)
        Right-hand side.

    Returns
    -------
    casadi.SX, shape (3, 1)
    """
    a, bb, c, d, e, f = M[0, 0], M[0, 1], M[0, 2], M[1, 1], M[1, 2], M[2, 2]
    A = d * f - e * e
    B = c * e - bb * f
    C = bb * e - c * d
    D = a * f - c * c
    E = bb * c - a * e
    F = a * d - bb * bb
    det = a * A + bb * B + c * C
    return ca.vertcat(A * b[0] + B * b[1] + C * b[2], B * b[0] + D * b[1] + E * b[2],
                      C * b[0] + E * b[1] + F * b[2]) / det
