"""Exact checks of the six-degree-of-freedom model with wing masses: a bird in vacuum (no air, no
gravity) conserves the momentum and the angular momentum of body plus wings (docs/studies/lateral.md,
wing masses). One wing may carry all the mass, or the gait itself may be asymmetric (per-side joint
offsets): the wing motion then loads roll, yaw and the products of inertia."""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird import sixdof_inertia as w3
from birdocp.bird.config import PARAM_NAMES, Config, param_vector
from birdocp.bird.sides import side_vector
from birdocp.bird.sixdof import LateralInertia, sixdof_model

__all__ = ["VACUUM_START", "vacuum_drift"]

VACUUM_START = (3.0, 0.5, -0.4, 0.8, -0.6, 0.5, 0.2, 0.1, 0.3)
"""A tumbling start (u, v, w [m/s], p, q, r [rad/s], phi, theta, psi [rad]): momentum and angular
momentum in every direction."""


def _rotation(phi, th, psi):
    """Body-to-inertial rotation of the 3-2-1 Euler angles (inertial z down)."""
    cf, sf, ct, st, cp, sp = ca.cos(phi), ca.sin(phi), ca.cos(th), ca.sin(th), ca.cos(psi), ca.sin(psi)
    return ca.blockcat([[ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp],
                        [ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp], [-st, sf * ct, cf * ct]])


def _one_wing_sums(six) -> ca.Function:
    """``(t, p) -> the 3-D sums`` with only the right wing's mass points weighted (a symmetric gait)."""
    t, ps = ca.SX.sym("t"), ca.SX.sym("p", len(PARAM_NAMES))
    r, v, a, m = six.planar.mass_points(t, ps)
    half = r.shape[1] // 2
    s = w3.mass_sums_3d(m * ca.vertcat(ca.DM.ones(half), ca.DM.zeros(half)), r, v, a)
    return ca.Function("sums_one_wing", [t, ps], [ca.vertcat(*[s[k] for k, _ in w3.MASS3_BLOCK])])


def vacuum_drift(cfg: Config, steps_per_beat=(50, 100, 200), *, one_wing: bool = True,
                 product_inertia_xz_kgm2: float = 0.004, x0=VACUUM_START) -> dict:
    """Integrate one wingbeat of ``cfg``'s 6-DOF model with wing masses in vacuum (air density and
    gravity set to 0) by fixed-step RK4 at each of ``steps_per_beat``, from ``x0`` and the origin, and
    measure the largest change of the inertial momentum and of the angular momentum about the inertial
    origin of body plus wings along the beat.

    Parameters
    ----------
    cfg : Config
        A configuration with wing masses (``wing.mass_kg`` > 0).
    steps_per_beat : sequence of int
        RK4 step counts, each dividing the largest.
    one_wing : bool
        Only the right wing has mass (asymmetric wing motion from a symmetric gait). With an asymmetric
        gait (per-side offsets) pass False: both wings have mass and move differently.
    product_inertia_xz_kgm2 : float
        The body's I_xz for the check (the configuration's roll and yaw inertias otherwise).
    x0 : sequence of 9 floats
        The start state.

    Returns
    -------
    dict
        ``steps_per_beat``, ``drift`` (largest |change| of the six conserved components, per step
        count), ``ratios`` (drift of a step count over the next's: 16 for RK4), ``initial`` (P_X, P_Y,
        P_Z [kg m/s], H_X, H_Y, H_Z [kg m^2/s], inertial axes), ``final_state`` (per step count).
    """
    six = sixdof_model(cfg)
    if not six.structure.wing_mass:
        raise ValueError("vacuum_drift needs a configuration with wing masses (wing.mass_kg > 0)")
    if one_wing and six.sides:
        raise ValueError("vacuum_drift: one_wing is for a symmetric gait; an asymmetric gait moves its wings "
                         "differently by itself (one_wing=False)")
    p = np.array(param_vector(cfg), float)
    p[[PARAM_NAMES.index("aero.air_density_kgm3"), PARAM_NAMES.index("body.gravity_mps2")]] = 0.0
    inertia = LateralInertia(cfg.model.roll_inertia_kgm2, cfg.model.yaw_inertia_kgm2, product_inertia_xz_kgm2)
    p6 = six.params(p, inertia, side_vector(cfg) if six.sides else None)
    x = ca.SX.sym("x", 12)
    d = ca.SX.sym("d", six.rhs.size1_in(1))
    R = _rotation(x[6], x[7], x[8])
    f = ca.Function("f", [x, d], [ca.vertcat(six.rhs(x[:9], d, p6), R @ x[:3])])  # + position of G_b
    ixz = product_inertia_xz_kgm2
    Jb = ca.DM([[inertia.roll_inertia_kgm2, 0, -ixz], [0, p[PARAM_NAMES.index("body.pitch_inertia_kgm2")], 0],
                [-ixz, 0, inertia.yaw_inertia_kgm2]])
    P, H = w3.momenta(x[:9], w3.unpack_mass3(d[-w3.N_MASS3:]), p[PARAM_NAMES.index("body.mass_kg")], Jb)
    cons = ca.Function("cons", [x, d], [ca.vertcat(R @ P, ca.cross(x[9:], R @ P) + R @ H)])
    T, n_fine = six.period_s, max(steps_per_beat)
    ts = np.linspace(0.0, T, 2 * n_fine + 1)
    dd = np.array(six.data.map(len(ts))(ts, p6))  # the model's own data: aerodynamic blocks, then the 3-D sums
    if one_wing:
        dd[-w3.N_MASS3:, :] = np.array(_one_wing_sums(six).map(len(ts))(ts, p))
    xs0 = np.append(np.asarray(x0, float), np.zeros(3))
    c0 = np.array(cons(xs0, dd[:, 0])).ravel()
    drift, finals = [], []
    for n in steps_per_beat:
        k, xx, h, worst = n_fine // n, xs0.copy(), T / n, 0.0
        for i in range(n):
            j = 2 * k * i
            k1 = np.array(f(xx, dd[:, j])).ravel()
            k2 = np.array(f(xx + h / 2 * k1, dd[:, j + k])).ravel()
            k3 = np.array(f(xx + h / 2 * k2, dd[:, j + k])).ravel()
            k4 = np.array(f(xx + h * k3, dd[:, j + 2 * k])).ravel()
            xx = xx + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            worst = max(worst, float(np.abs(np.array(cons(xx, dd[:, j + 2 * k])).ravel() - c0).max()))
        drift.append(worst)
        finals.append([float(v) for v in xx[:9]])
    return {"steps_per_beat": list(steps_per_beat), "drift": drift,
            "ratios": [a_ / b_ for a_, b_ in zip(drift, drift[1:])], "initial": [float(v) for v in c0],
            "final_state": finals, "one_wing": one_wing}
