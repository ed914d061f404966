"""The gliding limit of the six-degree-of-freedom bird: every flapping amplitude 0, the wing frozen
at the gait's offsets, the model autonomous and its cycles steady glides.

* :func:`frozen_config`: the configuration with every joint amplitude set to 0.
* :func:`attached_config`: the frozen wing of the comparison with a vortex-lattice model
  (:data:`ATTACHED_POSE`: the paper's mid-stroke pose with one degree less sweep-back), whose steady
  glide is attached; the paper's own pose glides stalled (every section at about 36 deg).
* :func:`steady_glide`: the steady glide (the engine's :func:`~birdocp.engine.equilibria.find_equilibrium`
  on the 8 states without the heading), its eigenvalues, the lateral (v, p, r, phi) block of the
  Jacobian and its modes (roll subsidence, spiral, Dutch roll), and the body-axis lateral
  derivatives of the aerodynamic loads (Y, L, N by v, p, r) from CasADi's exact Jacobian, and the
  glide's verdict by the project's validity check (:func:`glide_validity`).
* :func:`glide_geometry`: the frozen lifting line (nodes, element centres, chords, chord and span
  directions, in the code frame e1 right, e2 up, e3 back, from the centre of mass) with the glide's
  state, mass, inertia and air density: the input of an independent vortex-lattice model
  (``scripts/reference_aerosandbox``).

For a symmetric glide the Jacobian is block diagonal (longitudinal u, w, q, theta; lateral v, p, r,
phi), so the lateral eigenvalues are those of the 4 x 4 lateral block. Labels: the complex pair is the
Dutch roll, of the two real roots the more negative is the roll subsidence and the other the spiral.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import JOINT_NAMES, PARAM_NAMES, Config, param_vector, with_values
from birdocp.bird.model import unpack_data
from birdocp.bird.sixdof import LATERAL, STATE_NAMES, LateralInertia, body_loads, embed_planar_state, sixdof_model
from birdocp.bird.validity import cycle_validity
from birdocp.engine.equilibria import find_equilibrium
from birdocp.engine.ode import ODE

__all__ = ["ATTACHED_POSE", "attached_config", "frozen_config", "glide_validity", "steady_glide", "glide_geometry", "lateral_glide_modes", "check_states",
           "load_derivatives_at", "lateral_matrix_with"]

SMALL_SECTION_ANGLE_DEG = 4.0
"""Section angle of attack of the diagnostic state of :func:`check_states` (small: where a section's
lift linear in the angle and one linear in its sine agree)."""

ATTACHED_POSE = {"gait.shoulder_sweep.offset_deg": -18.0}
"""The frozen pose of the gliding-limit comparison: the paper's gait offsets (its mid-stroke pose)
with the shoulder sweep at -18 deg instead of -19 deg. The tailless frozen wing trims where its force
passes through the centre of mass, and that angle is steep in the sweep: -19 deg glides at 24.5 deg
body angle of attack with every section near 36 deg (stalled: neither a lifting line nor a vortex
lattice holds there), -18 deg at 0.2 deg with effective section angles of 8-14 deg (valid), -17.8 deg
at -5.4 deg. At 0.2 deg the airflow runs along the body axis, so the lifting line's straight wake
along the body axis is also the wake aligned with the wind."""

GLIDE_STATES = tuple(range(8))
"""Indices of the glide's states: all but the heading psi (nothing depends on it)."""


def frozen_config(cfg: Config | None = None) -> Config:
    """``cfg`` (default: the reference case) with every joint's ``amplitude_deg`` set to 0: the wing
    held at the gait's offsets.

    Parameters
    ----------
    cfg : Config, optional
        Configuration (default: the reference case).

    Returns
    -------
    Config
    """
    return with_values(cfg or Config(), {f"gait.{j}.amplitude_deg": 0.0 for j in JOINT_NAMES})


def attached_config(cfg: Config | None = None) -> Config:
    """:func:`frozen_config` of ``cfg`` (default: the reference case) in :data:`ATTACHED_POSE`: the
    frozen wing whose steady glide is attached (the configuration of ``results/lateral/glide``).

    Parameters
    ----------
    cfg : Config, optional
        Configuration (default: the reference case).

    Returns
    -------
    Config
        The frozen, attached-glide configuration.
    """
    return with_values(frozen_config(cfg), ATTACHED_POSE)


def glide_validity(cfg: Config, state: dict) -> dict:
    """The project's validity check of a steady glide: :func:`birdocp.bird.validity.cycle_validity`
    of the constant cycle (``state``'s u, w, q, theta at 4 times of a period) of ``cfg``'s frozen wing.

    Parameters
    ----------
    cfg : Config
        The configuration (amplitudes set to 0 here; its ``[validity]`` thresholds).
    state : dict
        The glide's state, names as :func:`steady_glide`'s ``state`` (u_mps, w_mps, q_radps, theta_rad).

    Returns
    -------
    dict
        :meth:`~birdocp.bird.validity.CycleValidity.to_dict`: ``valid``, ``reasons`` and the measures
        (effective section angles, airflow angle to the body axis, ...).
    """
    cfg = frozen_config(cfg)
    x = [state["u_mps"], state["w_mps"], state["q_radps"], state["theta_rad"]]
    t = np.arange(4) / (4.0 * cfg.gait.frequency_hz)
    return cycle_validity(cfg, t, np.tile(x, (4, 1))).to_dict()


def _glide_ode(six, p6) -> ODE:
    """The autonomous 8-state ODE of the frozen wing (the data at t = 0 of ``p6``, constant)."""
    d0 = six.data(0.0, p6)
    return ODE.from_function(lambda x, t, p: six.rhs(ca.vertcat(x, 0), d0, p)[:8], 8, len(p6),
                             state_names=STATE_NAMES[:8], name="glide")


def lateral_glide_modes(A) -> dict:
    """The modes of a 4 x 4 lateral state matrix ``A`` over (v, p, r, phi) [1/s].

    Parameters
    ----------
    A : array_like, shape (4, 4)
        Lateral state matrix [1/s].

    Returns
    -------
    dict
        ``eigenvalues`` ([re, im] pairs, 1/s), ``roll_subsidence_per_s`` (the more negative real
        root), ``spiral_per_s`` (the other real root), ``dutch_roll`` (``real_per_s``,
        ``frequency_radps`` the damped frequency |Im|, ``natural_frequency_radps``, ``damping_ratio``),
        or ``None`` for a mode the matrix does not have (two complex pairs or four real roots).
    """
    lam = np.linalg.eigvals(np.asarray(A, dtype=float))
    cplx = [z for z in lam if abs(z.imag) > 1e-9 * max(1.0, abs(z))]
    real = sorted(float(z.real) for z in lam if abs(z.imag) <= 1e-9 * max(1.0, abs(z)))
    out = {"eigenvalues": [[float(z.real), float(z.imag)] for z in sorted(lam, key=lambda z: (z.real, z.imag))],
           "roll_subsidence_per_s": None, "spiral_per_s": None, "dutch_roll": None}
    if len(real) == 2 and len(cplx) == 2:
        out["roll_subsidence_per_s"], out["spiral_per_s"] = real
        z = cplx[0]
        wn = abs(z)
        out["dutch_roll"] = {"real_per_s": float(z.real), "frequency_radps": float(abs(z.imag)),
                             "natural_frequency_radps": float(wn), "damping_ratio": float(-z.real / wn)}
    return out


def steady_glide(cfg: Config | None = None, inertia: LateralInertia | None = None,
                 x_guess=(15.0, 1.0, 0.0, -0.1)) -> dict:
    """The steady glide of ``cfg``'s frozen wing (:func:`frozen_config`) and its linear dynamics.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the reference case); its amplitudes are set to 0 here.
    inertia : LateralInertia, optional
        Roll and yaw inertia [kg m^2] (default ``cfg.model``'s).
    x_guess : sequence of 4 floats
        Planar start (u, w, q, theta) of the Newton iteration [m/s, m/s, rad/s, rad].

    Returns
    -------
    dict
        ``success``, ``residual`` (max |f|), ``state`` (name -> value, 8 states), ``speed_mps``,
        ``alpha_body_deg`` (atan2(w, u)), ``flight_path_angle_deg`` (theta - alpha, negative
        descending), ``eigenvalues`` (all 8, [re, im] 1/s), ``lateral_matrix`` (4 x 4 over v, p, r,
        phi), the lateral modes of :func:`lateral_glide_modes` and ``derivatives`` (body-axis
        dY/dv [N s/m], dL/dp [N m s], ... of the aerodynamic loads: keys ``Y_v``, ``Y_p``, ``Y_r``,
        ``L_v``, ``L_p``, ``L_r``, ``N_v``, ``N_p``, ``N_r``) and ``section_angles_deg`` (the 16
        elements' geometric angles of attack, left tip to right tip), ``validity``
        (:func:`glide_validity`).
    """
    cfg = frozen_config(cfg)
    six = sixdof_model(cfg)
    inertia = inertia or LateralInertia.of(cfg)
    p6 = six.params(param_vector(cfg), inertia)
    eq = find_equilibrium(_glide_ode(six, p6), p6, np.array(embed_planar_state(x_guess))[:8])
    x = eq.x
    J = np.asarray(_glide_ode(six, p6).jacobian_function()(ca.DM(x), 0.0, ca.DM(p6))[0])
    lat = list(LATERAL)
    A = J[np.ix_(lat, lat)]
    u, w, th = x[0], x[2], x[7]
    out = {"success": bool(eq.success), "residual": float(eq.residual),
           "state": {STATE_NAMES[i]: float(x[i]) for i in GLIDE_STATES},
           "speed_mps": float(np.hypot(u, w)), "alpha_body_deg": float(np.degrees(np.arctan2(w, u))),
           "flight_path_angle_deg": float(np.degrees(th - np.arctan2(w, u))),
           "eigenvalues": [[float(z.real), float(z.imag)] for z in eq.eigenvalues],
           "lateral_matrix": A.tolist(), "derivatives": _load_derivatives(six, x, p6),
           "section_angles_deg": _section_angles_deg(six, x, p6)}
    out["validity"] = glide_validity(cfg, out["state"])
    out.update({k: v for k, v in lateral_glide_modes(A).items() if k != "eigenvalues"})
    out["lateral_eigenvalues"] = lateral_glide_modes(A)["eigenvalues"]
    return out


def check_states(cfg: Config | None = None, glide: dict | None = None) -> list[dict]:
    """Flight states (besides the glide) at which the lateral load derivatives are compared with an
    independent model: ``small_angle``, the glide's speed with the body angle of attack that puts the
    root section at :data:`SMALL_SECTION_ANGLE_DEG` (the offset incidence subtracted). Not equilibria:
    a diagnostic of the section law, not of the dynamics. Each: ``name``, ``u_mps``, ``w_mps``.

    Parameters
    ----------
    cfg : Config, optional
        Configuration (default: the reference case).
    glide : dict, optional
        The glide (default: solved here).

    Returns
    -------
    list of dict
    """
    cfg = frozen_config(cfg)
    glide = glide or steady_glide(cfg)
    a = np.radians(SMALL_SECTION_ANGLE_DEG - cfg.gait.shoulder_incidence.offset_deg)
    V = glide["speed_mps"]
    return [{"name": "small_angle", "u_mps": float(V * np.cos(a)), "w_mps": float(V * np.sin(a))}]


def load_derivatives_at(cfg: Config | None, u_mps: float, w_mps: float, inertia: LateralInertia | None = None) -> dict:
    """The lateral load derivatives of :func:`steady_glide` (``Y_v`` ... ``N_r``) of ``cfg``'s frozen
    wing at the body velocity (u, w) [m/s] (v = p = q = r = 0), whether or not it is an equilibrium.

    Parameters
    ----------
    cfg : Config or None
        The configuration (default: the reference case); amplitudes set to 0 here.
    u_mps, w_mps : float
        Body-axis velocity of the centre of mass [m/s].
    inertia : LateralInertia, optional
        Roll and yaw inertia (no effect on the loads; default ``cfg.model``'s).

    Returns
    -------
    dict
        ``Y_v``, ``Y_p``, ``Y_r`` [N s/m, N s], ``L_*`` and ``N_*`` [N s, N m s].
    """
    cfg = frozen_config(cfg)
    six = sixdof_model(cfg)
    p6 = six.params(param_vector(cfg), inertia or LateralInertia.of(cfg))
    return _load_derivatives(six, np.array(embed_planar_state([u_mps, w_mps, 0.0, 0.0]))[:8], p6)


def _section_angles_deg(six, x8, p6) -> list[float]:
    """The geometric angle of attack of each of the 16 elements at the glide [deg], left tip to right tip."""
    xs = ca.SX.sym("x", 9)
    alpha = body_loads(xs, six.data(0.0, p6), p6[:len(PARAM_NAMES)], section=six.section)[2]["alpha"]
    return np.degrees(np.asarray(ca.Function("alpha", [xs], [alpha])(np.append(x8, 0.0)))).ravel().tolist()


def _load_derivatives(six, x8, p6) -> dict:
    """Exact derivatives of the body-axis side force Y and roll/yaw moments L, N by v, p, r."""
    xs = ca.SX.sym("x", 9)
    loads = six.loads_d(xs, six.data(0.0, p6), p6)
    J = np.asarray(ca.Function("dl", [xs], [ca.jacobian(loads, xs)])(np.append(x8, 0.0)))
    rows, cols = {"Y": 1, "L": 3, "N": 5}, {"v": 1, "p": 3, "r": 5}
    return {f"{a}_{b}": float(J[i, j]) for a, i in rows.items() for b, j in cols.items()}


def glide_geometry(cfg: Config | None = None, glide: dict | None = None,
                   inertia: LateralInertia | None = None) -> dict:
    """The frozen lifting line of ``cfg`` and the glide it flies: the configuration of an
    independent vortex-lattice model of the same geometry.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the reference case); amplitudes set to 0 here.
    glide : dict, optional
        Its :func:`steady_glide` (computed when not given).
    inertia : LateralInertia, optional
        Roll and yaw inertia [kg m^2] (default ``cfg.model``'s).

    Returns
    -------
    dict
        ``frame`` (a sentence), ``nodes_m`` (17 points [e1, e2, e3] of the lifting line from the
        centre of mass), per element (16) ``centres_m``, ``chords_m``, ``chord_directions``
        (leading to trailing edge), ``span_directions``, ``lengths_m``; ``area_m2`` (sum of chord x
        length); ``glide_state`` (u, w [m/s], theta [rad]); ``mass_kg``, ``gravity_mps2``,
        ``roll_inertia_kgm2``, ``yaw_inertia_kgm2``, ``product_inertia_xz_kgm2``,
        ``air_density_kgm3``, ``lift_slope_per_rad``; ``check_states`` (:func:`check_states`);
        ``joint_offsets_deg`` (the frozen pose: every joint's offset) and ``validity`` (the glide's).
    """
    cfg = frozen_config(cfg)
    inertia = inertia or LateralInertia.of(cfg)
    glide = glide or steady_glide(cfg, inertia)
    b = {k: np.asarray(v) for k, v in unpack_data(sixdof_model(cfg).planar.data(0.0, param_vector(cfg))).items()}
    chords, ds = b["chord_m"].ravel(), b["ds_m"].ravel()
    s = glide["state"]
    return {
        "frame": "code frame: e1 to the right wing, e2 up, e3 backwards, origin the centre of mass; "
                 "the wake of the lifting line is straight along e3 (the body axis)",
        "nodes_m": b["nodes_m"].T.tolist(), "centres_m": b["r_m"].T.tolist(), "chords_m": chords.tolist(),
        "chord_directions": b["c_hat"].T.tolist(), "span_directions": b["tau"].T.tolist(),
        "lengths_m": ds.tolist(), "area_m2": float(np.sum(chords * ds)),
        "glide_state": {"u_mps": s["u_mps"], "w_mps": s["w_mps"], "theta_rad": s["theta_rad"]},
        "mass_kg": cfg.body.mass_kg, "gravity_mps2": cfg.body.gravity_mps2,
        "roll_inertia_kgm2": inertia.roll_inertia_kgm2, "yaw_inertia_kgm2": inertia.yaw_inertia_kgm2,
        "product_inertia_xz_kgm2": inertia.product_inertia_xz_kgm2,
        "air_density_kgm3": cfg.aero.air_density_kgm3, "lift_slope_per_rad": cfg.aero.lift_slope_per_rad,
        "check_states": check_states(cfg, glide),
        "joint_offsets_deg": {j: getattr(cfg.gait, j).offset_deg for j in JOINT_NAMES},
        "validity": {k: glide["validity"][k] for k in ("valid", "reasons")}}


def lateral_matrix_with(glide: dict, derivatives: dict, cfg: Config | None = None,
                        inertia: LateralInertia | None = None) -> np.ndarray:
    """The glide's lateral matrix (over v, p, r, phi) with some load derivatives replaced: birdocp's
    exact matrix plus the change the new values make through the rigid body (dv/dt by Y/m,
    (dp/dt, dr/dt) by the inverse inertia times (L, N)). With all nine replaced by another model's,
    it is that model's lateral matrix at the same glide, mass and inertia.

    Parameters
    ----------
    glide : dict
        :func:`steady_glide`'s result.
    derivatives : dict
        Some of ``Y_v`` ... ``N_r`` (the keys of ``glide["derivatives"]``) with their new values.
    cfg : Config, optional
        The configuration of the glide (its mass; default the reference case).
    inertia : LateralInertia, optional
        Roll and yaw inertia (default ``cfg.model``'s).

    Returns
    -------
    ndarray, shape (4, 4)
    """
    cfg = cfg or Config()
    inertia = inertia or LateralInertia.of(cfg)
    ixx, izz, ixz = inertia.roll_inertia_kgm2, inertia.yaw_inertia_kgm2, inertia.product_inertia_xz_kgm2
    Iinv = np.linalg.inv(np.array([[ixx, -ixz], [-ixz, izz]]))
    A = np.array(glide["lateral_matrix"], float)
    cols = {"v": 0, "p": 1, "r": 2}
    for key, value in derivatives.items():
        force, var = key.split("_")
        d = float(value) - glide["derivatives"][key]
        j = cols[var]
        if force == "Y":
            A[0, j] += d / cfg.body.mass_kg
        else:
            A[1:3, j] += Iinv[:, 0 if force == "L" else 1] * d
    return A
