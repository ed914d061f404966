"""Where the model holds, as smooth constraints: the limits of ``[validity]`` as differentiable
period means of the cycle.

:mod:`birdocp.bird.validity` measures a cycle exactly (indicator of stall, minimum and maximum over
the grid); those measures are not differentiable. For an optimiser each limit is written as the
period mean of a smooth *integrand* ``g(x, d, p)`` of the state, the wing data and the parameters.
The integrands are outputs of the same RK4 grid as the cycle (quadrature over the RK4 stages, the
stage data the cycle itself uses), so a level cycle's exact gradients (implicit function theorem,
variational equations) carry over to them unchanged.

The four smooth measures (names as the exact measures of
:class:`birdocp.bird.validity.CycleValidity`):

* ``stalled_fraction``: the span-time share beyond the stall angle ``a_s``, the indicator of
  ``|alpha_eff| > a_s`` replaced by the logistic ``s(z) = 1 / (1 + exp(-z))`` (the derivative of the
  softplus ``log(1 + exp(z))``) with the smoothing width :data:`STALL_WIDTH_DEG`::

      g = sum_e ds_e [s((alpha_e - a_s) / w) + s((-alpha_e - a_s) / w)] / sum_e ds_e

  (effective angles ``alpha_e`` of the lifting-line elements in degrees, element lengths
  ``ds_e``); the measure is the period mean of g. An element 1 width beyond stall counts 0.73,
  one width below 0.27;
* ``min_forward_speed_mps``, ``max_abs_pitch_deg``, ``max_airflow_body_angle_deg``: the
  Kreisselmeier-Steinhauser (KS) aggregate of the period, in its integral (mean) form::

      KS = b + (1 / rho) log(mean_t exp(rho (f(t) - b)))

  with the limit ``b`` as the shift (no overflow near the limit; the exponent is capped at 600) and
  ``f`` = ``-u``, ``+-theta`` or ``+-atan2(w, u)`` (both signs summed for the absolute values; the
  minimum speed is ``-KS`` of ``-u``). The integral form lies *below* the true maximum by about
  ``log(1 / share of the period near the peak) / rho``; the sharpness is :data:`KS_RHO` (per degree,
  per m/s).

Neither smooth measure bounds the exact one from the safe side; the optimisers therefore check the
exact validity at the optimum and, where a limit is still crossed, tighten that smooth bound by the
difference and solve again (:func:`birdocp.studies.gait.optimize_gait`).
"""

from __future__ import annotations

import math

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.engine.cache import owned_cache

__all__ = ["SMOOTH_LIMITS", "STALL_WIDTH_DEG", "KS_RHO", "smooth_integrands", "integrand_names",
           "smooth_measures", "limit_bounds", "smoothing_info", "cycle_smooth_measures", "sixdof_integrands"]

SMOOTH_LIMITS = ("stalled_fraction", "min_forward_speed_mps", "max_abs_pitch_deg", "max_airflow_body_angle_deg")
"""The limits of ``[validity]`` as smooth measures (names of the exact measures)."""
STALL_WIDTH_DEG = 1.0
"""Width w of the logistic step that replaces 'the element is stalled' [deg]."""
KS_RHO = {"min_forward_speed_mps": 3.0, "max_abs_pitch_deg": 3.0, "max_airflow_body_angle_deg": 3.0}
"""Sharpness rho of the KS aggregates (per m/s for the speed, per degree for the angles)."""
_CAP = 600.0
_UPPER = {"stalled_fraction": True, "min_forward_speed_mps": False, "max_abs_pitch_deg": True,
          "max_airflow_body_angle_deg": True}


def integrand_names() -> tuple:
    """Names of the rows of :func:`smooth_integrands`' output (``valid_<limit>``).

    Returns
    -------
    tuple of str
    """
    return tuple("valid_" + k for k in SMOOTH_LIMITS)


def limit_bounds(cfg: Config) -> dict:
    """limit -> (configured bound, 'max' or 'min') from ``cfg.validity``.

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    dict
    """
    v = cfg.validity
    return {"stalled_fraction": (v.max_stalled_fraction, "max"),
            "min_forward_speed_mps": (v.min_forward_speed_mps, "min"),
            "max_abs_pitch_deg": (v.max_abs_pitch_deg, "max"),
            "max_airflow_body_angle_deg": (v.max_airflow_body_angle_deg, "max")}


def smoothing_info() -> dict:
    """The smoothing parameters, for a result's ``validity_constraints``.

    Returns
    -------
    dict
    """
    return {"stall_width_deg": STALL_WIDTH_DEG, "ks_rho": dict(KS_RHO), "ks_form": "integral (period mean)",
            "quadrature": "RK4 stages of the cycle's grid"}


def smooth_integrands(cfg: Config, n_data: int, model=None):
    """``g(x, d, p) -> 4 x 1``: the integrands of :data:`SMOOTH_LIMITS` (see the module) for the
    thresholds of ``cfg.validity``, for a model with data of size ``n_data``; built once per
    (thresholds, size) and kept by ``model`` (a new Function when ``model`` is None). ``model``: a
    :class:`~birdocp.bird.model.BirdModel`; when it has aerodynamic states, x is its full state and the
    angle is the one its section law sees (:func:`birdocp.bird.validity.model_angles`, as the exact
    measure); otherwise x is the body state (u, w, q, theta).

    Parameters
    ----------
    cfg : Config
        Configuration (its ``[validity]`` thresholds).
    n_data : int
        Length of the data vector.
    model : BirdModel, optional
        The model, when it may have aerodynamic states.

    Returns
    -------
    casadi.Function
    """
    v = cfg.validity
    aero_model = model if model is not None and model.ode.nx > 4 else None
    args = (float(v.stall_angle_deg), float(v.min_forward_speed_mps), float(v.max_abs_pitch_deg),
            float(v.max_airflow_body_angle_deg), int(n_data), str(cfg.aero.normalwash))
    if model is None:
        return _integrands(*args)
    return owned_cache(model).build(("smooth_integrands",) + args, lambda: _integrands(*args, aero_model))


def _integrands(stall_deg, umin, pitch_deg, airflow_deg, n_data, normalwash="angle", aero_model=None):
    import casadi as ca

    from birdocp.bird.validity import effective_angles, model_angles

    nx = 4 if aero_model is None else aero_model.ode.nx
    x, d, p = ca.SX.sym("x", nx), ca.SX.sym("d", n_data), ca.SX.sym("p", len(PARAM_NAMES))
    angles = effective_angles(n_data, normalwash) if aero_model is None else model_angles(aero_model)
    ae, _, ds = angles(x, d, p)[:3]
    g = _integrand_rows((stall_deg, umin, pitch_deg, airflow_deg), ae, ds, x[0], x[3], ca.atan2(x[1], x[0]))
    return ca.Function("validity_integrands", [x, d, p], [g], ["x", "d", "p"], ["g"])


def _integrand_rows(thresholds, ae_rad, ds, u, theta_rad, airflow_rad):
    """The four integrands of :data:`SMOOTH_LIMITS` from the elements' effective angles and lengths,
    the forward speed u, the pitch and the airflow-to-body angle (CasADi expressions)."""
    import casadi as ca

    stall_deg, umin, pitch_deg, airflow_deg = thresholds
    a = ae_rad * (180.0 / math.pi)
    w = STALL_WIDTH_DEG
    logistic = lambda z: 1.0 / (1.0 + ca.exp(-z))  # noqa: E731
    stall = ca.sum1(ds * (logistic((a - stall_deg) / w) + logistic((-a - stall_deg) / w))) / ca.sum1(ds)
    e = lambda z: ca.exp(ca.fmin(z, _CAP))  # noqa: E731
    th, phi = theta_rad * (180.0 / math.pi), airflow_rad * (180.0 / math.pi)
    r = KS_RHO
    speed = e(r["min_forward_speed_mps"] * (umin - u))
    pitch = e(r["max_abs_pitch_deg"] * (th - pitch_deg)) + e(r["max_abs_pitch_deg"] * (-th - pitch_deg))
    air = e(r["max_airflow_body_angle_deg"] * (phi - airflow_deg)) + e(r["max_airflow_body_angle_deg"] * (-phi - airflow_deg))
    return ca.vertcat(stall, speed, pitch, air)


def sixdof_integrands(cfg: Config, nx: int, n_data: int, section=None):
    """``g(x, d, p) -> 4 x 1``: the integrands of :data:`SMOOTH_LIMITS` of a six-degree-of-freedom
    cycle (``nx`` = 9 states, or 8 without the heading; then the aerodynamic states of ``section``):
    the effective angles of all elements of both wings in the asymmetric flow (as the exact 6-DOF
    check, :func:`birdocp.bird.validity.sixdof_angles`; the stall integrand is the share of the whole
    span, the exact measure the larger of the two wings' shares), the forward speed u, the pitch theta
    and the 3-D airflow-to-body angle ``atan2(sqrt(v^2 + w^2), u)`` (sideslip counts). ``p``: the
    planar parameters (the first :data:`PARAM_NAMES` of the 6-DOF vector). A new Function per call.

    Parameters
    ----------
    cfg : Config
        Configuration (its ``[validity]`` thresholds).
    nx : int
        Number of states (9, or 8 without the heading, then the section's).
    n_data : int
        Length of the data vector.
    section : SectionLaw, optional
        The stall-aware section of the model.

    Returns
    -------
    casadi.Function
    """
    import casadi as ca

    from birdocp.bird.validity import sixdof_angles

    v = cfg.validity
    x, d, p = ca.SX.sym("x", nx), ca.SX.sym("d", n_data), ca.SX.sym("p", len(PARAM_NAMES))
    ae, _, ds = sixdof_angles(nx, n_data, 1, section)(x, d, p)
    air = ca.atan2(ca.sqrt(x[1] ** 2 + x[2] ** 2 + 1e-12), x[0])
    g = _integrand_rows((float(v.stall_angle_deg), float(v.min_forward_speed_mps), float(v.max_abs_pitch_deg),
                         float(v.max_airflow_body_angle_deg)), ae, ds, x[0], x[7], air)
    return ca.Function("validity_integrands6", [x, d, p], [g], ["x", "d", "p"], ["g"])


def smooth_measures(cfg: Config, means, grads=None):
    """(values, gradients) of the smooth measures from the period means of the integrands (``means``:
    4 numbers in the order of :data:`SMOOTH_LIMITS`; ``grads``: their gradients, 4 x n, or None).
    Returns ``({limit: value}, {limit: gradient or None})``.

    Parameters
    ----------
    cfg : Config
        Configuration.
    means : sequence of float
        Period means of the integrands.
    grads : array_like, optional
        Their gradients.

    Returns
    -------
    values, gradients : dict
    """
    import numpy as np

    m = np.asarray(means, float).ravel()
    b = limit_bounds(cfg)
    vals, der = {}, {}
    for i, k in enumerate(SMOOTH_LIMITS):
        g = None if grads is None else np.asarray(grads[i], float)
        if k == "stalled_fraction":
            vals[k], der[k] = float(m[i]), g
            continue
        rho, (bound, _) = KS_RHO[k], b[k]
        mi = max(float(m[i]), 1e-300)
        sign = 1.0 if _UPPER[k] else -1.0
        vals[k] = bound + sign * math.log(mi) / rho
        der[k] = None if g is None else sign * g / (rho * mi)
    return vals, der


def cycle_smooth_measures(cfg: Config, x0, p=None, steps_per_period: int | None = None) -> dict:
    """{limit: smooth value} of the periodic cycle through ``x0`` at t = 0 (one RK4 period on the
    solver's grid, ``cfg.solve.steps_per_period`` by default, with the integrands as quadrature
    outputs): the values an optimiser with ``valid=True`` constrains, for a cycle found otherwise.

    Parameters
    ----------
    cfg : Config
        Configuration.
    x0 : array_like
        State at t = 0.
    p : array_like, optional
        Parameter vector.
    steps_per_period : int, optional
        RK4 steps per period.

    Returns
    -------
    dict
    """
    import casadi as ca
    import numpy as np

    from birdocp.bird.model import get_model
    from birdocp.engine.integrate import RK4Grid

    m = get_model(cfg)
    n = int(steps_per_period or cfg.solve.steps_per_period)
    p = m.p0 if p is None else np.asarray(p, float).ravel()
    key = ("smooth_validity_grid", n, tuple(limit_bounds(cfg).items()), float(cfg.validity.stall_angle_deg))
    grid = owned_cache(m.ode).build(key, lambda: RK4Grid(m.ode, n, 1, outputs=(smooth_integrands(cfg, m.ode.nd, m.model),)))
    D = grid.blocks_numeric(0.0, p)
    _, _, q = grid.period_map(ca.DM(m.complete_state(x0, p)), D, ca.DM(p))
    return smooth_measures(cfg, np.asarray(q).ravel() / m.period_s)[0]
