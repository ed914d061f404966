"""The CasADi graphs of the reduced-space level cycle (:class:`birdocp.studies.gait_cycle.ReducedLevelCycle`):
its outputs, RK4 grid, sensitivities and data, built once per problem and kept by the model."""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.engine.cache import owned_cache

__all__ = ["level_cycle_graphs", "OUTPUT_NAMES", "POSITIVE_EPS_W", "DOMINANT_COLUMNS"]

DOMINANT_COLUMNS = 4
"""Columns of the dominant block (:func:`birdocp.studies.jury.dominant_block`): with aerodynamic states the
second-order pass carries the monodromy on them only (``Evaluation.d_monodromy`` is then d(M V)/dtheta)."""
POSITIVE_EPS_W = 0.05
"""Smoothing of max(P, 0) in the positive-power objective, 1/2 (P + sqrt(P^2 + eps^2)), error <= eps/2."""

OUTPUT_NAMES = ("vertical_speed_mps", "forward_speed_mps", "flapping_power_W", "aerodynamic_power_W",
        "positive_power_smooth_W")
"""Rows of the quadrature output vector of :func:`level_cycle_graphs` (validity integrands follow)."""


def level_cycle_graphs(m, cfg: Config, N: int, vidx: tuple, nt: int, second: bool, valid: bool) -> dict:
    """The CasADi Functions of a :class:`birdocp.studies.gait_cycle.ReducedLevelCycle`.

    Outputs, RK4 grid, first- and second-order sensitivities, the monodromy alone, the data and its
    directions, built once per (steps, free parameters, order, validity thresholds, the wing's arm-frame
    shape), kept by the model (the last 4) and reused by every later cycle of the same problem in this
    process (e.g. every point of a Pareto front a worker solves): a build costs seconds, a point's solve
    tens of them.

    Parameters
    ----------
    m : object
        The configured bird model (``model``, ``ode``, ``p0``, ``pre``, ``post``).
    cfg : Config
        Its configuration (validity thresholds when ``valid``).
    N : int
        RK4 steps per period.
    vidx : tuple of int
        Indices of the free parameters in :data:`birdocp.bird.config.PARAM_NAMES`.
    nt : int
        Total directions of the second-order pass (x0 and the amplitude moving with theta).
    second : bool
        Build the second-order and monodromy-only passes.
    valid : bool
        Add the smooth validity integrands to the outputs.

    Returns
    -------
    dict
        The graphs by name (``outputs``, ``grid``, ``sens``, ``sens2``, ``sens_mono``, ``data``, ...).
    """
    p0 = np.asarray(m.p0, float)
    thresholds = None
    if valid:
        v = cfg.validity
        thresholds = (v.stall_angle_deg, v.min_forward_speed_mps, v.max_abs_pitch_deg, v.max_airflow_body_angle_deg)
    key = (N, vidx, second, thresholds, p0[list(m.ode.pre_params)].tobytes())
    return owned_cache(m.model, "gait_graphs", 4).build(key, lambda: _build_graphs(m, cfg, N, vidx, nt, second, valid))


def _build_graphs(m, cfg: Config, N: int, vidx: tuple, nt: int, second: bool, valid: bool) -> dict:
    from birdocp.bird.energetics import power_functions
    from birdocp.engine.integrate import RK4Grid
    from birdocp.engine.variational import PeriodSensitivities

    p0 = np.asarray(m.p0, float)
    nv = len(vidx)
    pf = power_functions(m)
    x, d, p = ca.SX.sym("x", m.ode.nx), ca.SX.sym("d", m.ode.nd), ca.SX.sym("p", len(PARAM_NAMES))
    pw = pf.power(x, d, p)
    Pf = pw[1]  # the shoulder power: flapping (aerodynamic) + the wings' inertial part if any
    if "shoulder_inertial_power_W" in pf.names:
        Pf = Pf + pw[pf.names.index("shoulder_inertial_power_W")]
    out = ca.vertcat(pw[8], pw[7], Pf, pw[0], 0.5 * (Pf + ca.sqrt(Pf ** 2 + POSITIVE_EPS_W ** 2)))
    out_names = OUTPUT_NAMES
    if valid:  # the smooth validity integrands, on the same RK4 stages (bird.validity_smooth)
        from birdocp.bird.validity_smooth import integrand_names, smooth_integrands

        out = ca.vertcat(out, smooth_integrands(cfg, m.ode.nd, m.model)(x, d, p))
        out_names = OUTPUT_NAMES + integrand_names()
    outputs = ca.Function("gait_outputs", [x, d, p], [out])
    grid = RK4Grid(m.ode, N, 1, outputs=(outputs,))
    sens = PeriodSensitivities(m.ode, N, (outputs,), nv)
    g = {"model": m.model, "out_names": out_names, "outputs": outputs, "grid": grid, "sens": sens,
         # second order only along the nt total directions (x0 and A moving with theta), known once
         # the first-order pass gave dy/dtheta: about half the cost of all 4 + nt + 1 directions
         # with aerodynamic states only the dominant block's derivatives count (jury_values: P dM V),
         # so the state Jacobian is carried on V's 4 columns: 4 / nx of the cost (nx 36: a 9th)
         "sens2": (PeriodSensitivities(m.ode, N, (outputs,), nt, True, combined=True, n_data=nv,
                                       state_columns=DOMINANT_COLUMNS if m.ode.nx > DOMINANT_COLUMNS else None)
                   if second else None),
         # the monodromy alone (the 4 state directions): what a line-search trial point's stability
         # constraint needs, at a fraction of a gradient evaluation's cost
         "sens_mono": PeriodSensitivities(m.ode, N, (), 0) if second else None,
         "times": ca.DM(grid.times(0.0)).reshape((1, -1)), "local": grid.pre_numeric(0.0, p0)}
    L, t, ps = ca.SX.sym("local", m.pre.size1_out(0)), ca.SX.sym("t"), ca.SX.sym("p", len(PARAM_NAMES))
    dd = m.post(L, t, ps)
    # the data and its Jacobian along the free parameters (forward mode, shared nominal values)
    post_jac = ca.Function("post_jac", [L, t, ps], [dd, ca.jacobian(dd, ca.vertcat(*[ps[j] for j in vidx]))])
    seeds = np.zeros((len(PARAM_NAMES), nv))
    for k, j in enumerate(vidx):
        seeds[j, k] = 1.0
    # data and its directions in the variational layout, as one MX Function (the reordering of
    # ~10^6 numbers stays in CasADi: through numpy it cost more than the sensitivities)
    pm = ca.MX.sym("p", len(PARAM_NAMES))
    blk = grid.block_index
    Dg, Jg = post_jac.map(2 * N + 1)(g["local"], g["times"], pm)  # Jg: nv columns per time
    cols = sens.direction_columns([Jg[:, [tk * nv + k for tk in blk]] for k in range(nv)])
    g |= {"seeds": seeds, "data": ca.Function("gait_data", [pm], [Dg[:, blk], cols])}
    return g


