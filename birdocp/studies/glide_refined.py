"""birdocp's lifting line of the frozen wing with every element cut into ``split`` pieces: how much of
a difference to a vortex-lattice model is the 16-element discretisation.

The model's lifting line has 16 elements (8 a wing), each with one circulation, its trailing
filaments at the nodes and its collocation point at the element centre. :func:`refined_line` cuts
every element into ``split`` sub-elements along the polyline node - centre - node (the centre at the
middle of the parameter; :func:`birdocp.bird.subdivide.refine_points`, the model's
``aero.span_subdivisions``: with the step planform the two agree to round-off, tested), each keeping
its element's chord direction, normal and span direction, its length the distance of its nodes, and
either its element's chord (``planform="step"``: the planform the
model flies) or the chord interpolated linearly between the nodes (``planform="linear"``: the
planform ``scripts/reference_aerosandbox`` gives the vortex lattice, node chords the mean of the
neighbouring elements', the tip extrapolated and clipped at 0). The same lifting-line code
(:func:`birdocp.bird.aero.circulation_matrices`, :func:`~birdocp.bird.aero.forces_from_velocity`) then
gives the loads; :func:`refined_load_derivatives` differentiates them exactly. ``split = 1`` with the
step planform is the model itself (tested: the derivatives of
:func:`birdocp.studies.glide.load_derivatives_at` to round-off).

``span_direction``: the model's sections take their span direction ``tau = n x c_hat`` from the
relaxed leading line through the neighbouring points (docs/model.md §4.5 and §5: the paper's
definition), which in the attached glide's pose is swept up to 11 deg more than the element's own chord
node to node, the line the bound and trailing vortices follow (and the only one a vortex lattice of the
same nodes can see).
``"element"`` turns every (sub-)element's section frame to the element's direction
(:func:`birdocp.bird.span.element_frames`, the model's ``aero.span_direction = "element"``; at
``split = 1`` it is that model, tested); ``"section"`` keeps the frames of ``cfg``'s model.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird import aero, subdivide
from birdocp.bird.config import Config, param_vector
from birdocp.bird.model import unpack_data
from birdocp.bird.span import element_frames
from birdocp.bird.sixdof import air_velocity, body_axis_loads, sixdof_model
from birdocp.studies.glide import frozen_config

__all__ = ["refined_line", "refined_load_derivatives", "section_law_terms"]


def _node_chords(chords: np.ndarray) -> np.ndarray:
    """Chords at the 17 nodes: the mean of the two neighbouring elements', the tips extrapolated
    linearly over half an element and clipped at 0 (the vortex-lattice script's sections)."""
    inner = 0.5 * (chords[1:] + chords[:-1])
    tip_r = max(0.0, chords[-1] + 0.5 * (chords[-1] - chords[-2]))
    tip_l = max(0.0, chords[0] + 0.5 * (chords[0] - chords[1]))
    return np.concatenate([[tip_l], inner, [tip_r]])


def refined_line(cfg: Config | None = None, split: int = 1, planform: str = "step",
                 span_direction: str = "section") -> dict:
    """The frozen wing's lifting line (:func:`~birdocp.studies.glide.frozen_config` of ``cfg``, at
    t = 0) with every element cut into ``split`` sub-elements.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the reference case); amplitudes set to 0 here.
    split : int
        Sub-elements per element (1: the model's line).
    planform : {"step", "linear"}
        The sub-elements' chords: their element's, or interpolated between the node chords.
    span_direction : {"section", "element"}
        The section frames: the model's (``section``), or turned to each sub-element's direction.

    Returns
    -------
    dict
        Code-frame arrays (e1 right, e2 up, e3 back, from G): ``nodes_m`` (3 x (16 split + 1)),
        ``r_m``, ``c_hat``, ``up``, ``tau`` (3 x 16 split; the section frames), ``chord_direction``
        (3 x 16 split; the wing's chord direction, before any turning of the frames), ``chord_m``,
        ``ds_m`` (16 split), and
        ``air_density_kgm3``, ``lift_slope_per_rad``.
    """
    if split < 1 or planform not in ("step", "linear") or span_direction not in ("section", "element"):
        raise ValueError(f"split must be >= 1, planform 'step' or 'linear', span_direction 'section' or "
                         f"'element', got {split!r}, {planform!r}, {span_direction!r}")
    cfg = frozen_config(cfg)
    b = {k: np.asarray(v) for k, v in unpack_data(sixdof_model(cfg).planar.data(0.0, param_vector(cfg))).items()}
    N, C, chords = b["nodes_m"], b["r_m"], b["chord_m"].ravel()
    cn = _node_chords(chords)

    line = [N[:, j // 2] if j % 2 == 0 else C[:, j // 2] for j in range(2 * chords.size + 1)]
    fine = np.array(subdivide.refine_points(line, split)).T  # the model's aero.span_subdivisions
    nodes, centres = fine[:, 0::2], fine[:, 1::2]
    s = np.tile((np.arange(split) + 0.5) / split, chords.size)
    j = np.repeat(np.arange(chords.size), split)
    ch = np.repeat(chords, split) if planform == "step" else (1 - s) * cn[j] + s * cn[j + 1]
    rep = lambda a: np.repeat(a, split, axis=-1)  # noqa: E731
    tau, c_hat, up = rep(b["tau"]), rep(b["c_hat"]), rep(b["up"])
    chord_direction = c_hat
    if span_direction == "element":
        tau, c_hat, up = (np.asarray(a) for a in element_frames(nodes, c_hat))
    ds = b["ds_m"].ravel() if split == 1 else np.linalg.norm(np.diff(nodes, axis=1), axis=0)
    return {"nodes_m": nodes, "r_m": centres, "chord_m": np.asarray(ch), "chord_direction": chord_direction,
            "ds_m": ds, "c_hat": c_hat, "up": up, "tau": tau,
            "air_density_kgm3": cfg.aero.air_density_kgm3, "lift_slope_per_rad": cfg.aero.lift_slope_per_rad}


def refined_load_derivatives(cfg: Config | None, u_mps: float, w_mps: float, split: int = 1,
                             planform: str = "step", span_direction: str = "section",
                             collocation: str = "quarter", normalwash: str = "angle") -> dict:
    """The body-axis lateral load derivatives (as :func:`birdocp.studies.glide.load_derivatives_at`)
    of the frozen wing's lifting line cut by :func:`refined_line`, at the body velocity (u, w).

    Parameters
    ----------
    cfg : Config or None
        The configuration (default: the reference case); amplitudes set to 0 here.
    u_mps, w_mps : float
        Body-axis velocity of the centre of mass [m/s] (v = p = q = r = 0).
    split : int
        Sub-elements per element.
    planform : {"step", "linear"}
        See :func:`refined_line`.
    span_direction : {"section", "element"}
        See :func:`refined_line`.
    collocation : {"quarter", "three_quarter"}
        Where the sections see the wake (the model's ``aero.collocation``, :mod:`birdocp.bird.collocation`).
    normalwash : {"angle", "tangency"}
        The section law (the model's ``aero.normalwash``, :data:`birdocp.bird.collocation.NORMALWASHES`):
        lift linear in the angle, or the flat plate's flow tangency that a vortex lattice solves (lift
        linear in its sine).

    Returns
    -------
    dict
        ``Y_v``, ``Y_p``, ``Y_r`` [N s/m, N s], ``L_*`` and ``N_*`` [N s, N m s]; ``elements`` (16 split).
    """
    xs, r, e, line = _refined_terms(cfg, split, planform, span_direction, collocation, normalwash)
    Fb, Mb = body_axis_loads(r, e["dF"])
    loads = ca.vertcat(Fb, Mb)
    J = np.asarray(ca.Function("dl", [xs], [ca.jacobian(loads, xs)])([u_mps, 0, w_mps, 0, 0, 0]))
    rows, cols = {"Y": 1, "L": 3, "N": 5}, {"v": 1, "p": 3, "r": 5}
    out = {f"{a}_{b}": float(J[i, j]) for a, i in rows.items() for b, j in cols.items()}
    out["elements"] = int(line["chord_m"].size)
    return out


def _refined_terms(cfg, split, planform, span_direction, collocation, normalwash):
    """``(xs, r, e, line)``: the 6-vector symbol (u, v, w, p, q, r), the element centres (DM), the
    element terms of :func:`birdocp.bird.aero.forces_from_velocity` as functions of ``xs`` and the
    :func:`refined_line`."""
    line = refined_line(cfg, split, planform, span_direction)
    nodes = [ca.DM(p) for p in line["nodes_m"].T]
    centres = [ca.DM(p) for p in line["r_m"].T]
    G, Wx, Wy = (ca.DM(ca.evalf(m)) for m in aero.circulation_matrices(
        centres, nodes, list(line["chord_m"]), line["lift_slope_per_rad"], collocation=collocation,
        c_hat=[ca.DM(c) for c in line["chord_direction"].T]))
    xs = ca.SX.sym("x", 6)
    r = ca.DM(line["r_m"])
    V = air_velocity(xs, r, ca.DM.zeros(*line["r_m"].shape))
    e = aero.forces_from_velocity(V, ca.DM(line["c_hat"]), ca.DM(line["up"]), ca.DM(line["tau"]),
                                  ca.DM(line["ds_m"]), G, Wx, Wy, line["air_density_kgm3"], normalwash)
    return xs, r, e, line


def section_law_terms(cfg: Config | None, u_mps: float, w_mps: float, normalwash: str = "angle", split: int = 1,
                      span_direction: str = "element", collocation: str = "three_quarter") -> dict:
    """Per element, how the section law (``aero.normalwash``) answers a roll rate p at the body velocity
    (u, w) of the frozen wing's lifting line (:func:`refined_line`, step planform): the roll-rate
    derivatives of the section's velocity components and of its normalwash ``q`` and circulation, and
    each element's share of the roll damping L_p, split into the circulation's answer and the turning of
    the Kutta-Joukowski force with the velocity at the steady circulation.

    Parameters
    ----------
    cfg : Config or None
        The configuration (default: the reference case); amplitudes set to 0 here.
    u_mps, w_mps : float
        Body-axis velocity of the centre of mass [m/s] (v = p = q = r = 0).
    normalwash : {"angle", "tangency"}
        The section law (:data:`birdocp.bird.collocation.NORMALWASHES`).
    split : int
        Sub-elements per element.
    span_direction : {"section", "element"}
        See :func:`refined_line`.
    collocation : {"quarter", "three_quarter"}
        Where the sections see the wake.

    Returns
    -------
    dict
        Lists over the elements (left tip to right tip): ``alpha_deg`` (geometric section angle),
        ``speed_mps`` (section speed ``|Vp|``), ``dVn_dp``, ``dVc_dp``, ``dVs_dp`` [m/s per rad/s] (the
        roll-rate derivatives of the velocity along the section normal, the chord and the span
        direction), ``dalpha_dp`` [rad per rad/s], ``dspeed_dp`` [m/s per rad/s], ``dq_dp`` [m/s per
        rad/s], ``Gamma_m2ps``, ``dGamma_dp`` [m^2/s per rad/s], ``L_p`` [N m s] (each element's roll
        moment by p), ``L_p_circulation`` (its part from the circulation's change) and
        ``L_p_force_turning`` (from the velocity's change at the steady circulation); ``L_p_total``.
    """
    xs, r, e, line = _refined_terms(cfg, split, "step", span_direction, collocation, normalwash)
    x0 = [u_mps, 0.0, w_mps, 0.0, 0.0, 0.0]
    frames = {k: ca.DM(line[k]) for k in ("up", "c_hat", "tau")}
    Vn, Vc, Vs = (ca.sum1(e["V"] * frames[k]).T for k in ("up", "c_hat", "tau"))
    q = aero.section_normalwash(e["Vp_norm"], e["alpha"], normalwash).T
    steady = ca.Function("steady", [xs], [e["Gamma"], e["vind"]])(x0)
    # the force with the circulation (and its induced velocity) held at the steady values
    held = _kutta_joukowski(e["V"] + steady[1], frames["tau"], steady[0], line)
    rows = [e["alpha"].T, e["Vp_norm"].T, e["Gamma"]]
    rates = [Vn, Vc, Vs, e["alpha"].T, e["Vp_norm"].T, q, e["Gamma"], _roll_moments(r, e["dF"]),
             _roll_moments(r, held)]
    f = ca.Function("terms", [xs], rows + [ca.jacobian(v, xs)[:, 3] for v in rates])
    out = [np.asarray(v).ravel() for v in f(x0)]
    alpha, speed, gamma = out[:3]
    dVn, dVc, dVs, dalpha, dspeed, dq, dgamma, lp, lp_turn = out[3:]
    lists = {"alpha_deg": np.degrees(alpha), "speed_mps": speed, "dVn_dp": dVn, "dVc_dp": dVc, "dVs_dp": dVs,
             "dalpha_dp": dalpha, "dspeed_dp": dspeed, "dq_dp": dq, "Gamma_m2ps": gamma, "dGamma_dp": dgamma,
             "L_p": lp, "L_p_circulation": lp - lp_turn, "L_p_force_turning": lp_turn}
    res = {k: [float(x) for x in v] for k, v in lists.items()}
    res["L_p_total"] = float(lp.sum())
    return res


def _kutta_joukowski(W, tau, gamma, line):
    """``rho (W x tau) Gamma ds`` (3 x n, code frame, N): the lifting-line force of
    :func:`birdocp.bird.aero.forces_from_velocity` at the velocity ``W`` (induced part included)."""
    cross = ca.vertcat(W[1, :] * tau[2, :] - W[2, :] * tau[1, :], W[2, :] * tau[0, :] - W[0, :] * tau[2, :],
                       W[0, :] * tau[1, :] - W[1, :] * tau[0, :])
    return line["air_density_kgm3"] * cross * ca.repmat((ca.DM(gamma) * ca.DM(line["ds_m"])).T, 3, 1)


def _roll_moments(r, dF):
    """Each element's body-axis roll moment about G [N m] (n x 1; :func:`birdocp.bird.sixdof.body_axis_loads`'
    L = -(r x dF)_3 in the code frame)."""
    return -(r[0, :] * dF[1, :] - r[1, :] * dF[0, :]).T
