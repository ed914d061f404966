"""Where the model holds: the validity check of a cycle.

The bird model is a quasi-steady lifting line with a linear lift slope (no stall) and a straight
wake along the body axis. A periodic solution of it is a *flight* only where these assumptions
hold. :func:`cycle_validity` measures, on the states of a cycle at the RK4 grid times of one period:

* the **effective angle of attack** of each lifting-line element (16, or 16 k when cut k times): the
  angle, in the element's section plane, of the relative air velocity plus the lifting line's induced velocity
  (``aero.section_angle(V + vind)``; the section lift coefficient is the lift slope times it);
* the **stalled fraction**: the share of the span-time area (element lengths times time) whose
  effective angle exceeds the stall angle in absolute value, and, for information, the largest
  stalled share of the span at one instant and the share of the period with any element stalled.
  The verdict uses the span-time share, so a brief excursion at the wingtip does not make a stalled
  wing;
* the **minimum forward speed** u along the body axis;
* the **pitch** range (min and max of theta) and the largest ``|theta|``;
* the largest **angle between the airflow and the body axis** ``|atan2(w, u)|`` (the wake's
  direction in the model).

Thresholds: :class:`birdocp.bird.config.Validity` (section ``[validity]`` of a configuration, with
their sources). The verdict is ``valid`` (every threshold respected) and ``reasons`` (one sentence
per violated threshold, empty when valid).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.engine.cache import owned_cache, register_cache
from birdocp.engine.results import result_dict, serial

if TYPE_CHECKING:
    import casadi as ca

# casadi, numpy and the model are imported inside the functions that compute: the verdict helpers for
# tables (validity_text, validity_columns) stay light to import.

from birdocp.bird.validity_report import VALIDITY_COLUMNS, validity_columns, validity_text  # noqa: F401

__all__ = ["CycleValidity", "cycle_validity", "model_angles", "grid_validity", "periodic_validity",
           "element_angles_function", "effective_angles", "invalid", "validity_text", "VALIDITY_COLUMNS",
           "validity_columns", "validity_margins", "LIMIT_NAMES", "SIDE_ELEMENTS", "side_elements",
           "sixdof_angles"]


def effective_angles(n_data: int | None = None, normalwash: str = "angle") -> "ca.Function":
    """``angles(x, d, p) -> (alpha_eff_rad nx1, alpha_geo_rad nx1, ds_m nx1)`` for one time, n elements.

    ``alpha_eff``: the angle of the relative velocity plus the induced velocity in each element's
    section plane; ``alpha_geo``: the same without the induced velocity (the model's ``alpha``);
    ``ds_m``: the element lengths (span weights). ``n_data``: the size of the model's data vector
    (default: the massless model's; wing masses append their terms after the aerodynamic blocks):
    it gives n (16, or 16 k with ``aero.span_subdivisions = k``). A new Function on each call (a
    model keeps its own: :func:`model_angles`).

    Parameters
    ----------
    n_data : int, optional
        Length of the data vector.
    normalwash : {"angle", "tangency"}
        ``aero.normalwash``, the section law of the induced velocity.

    Returns
    -------
    casadi.Function
    """
    from birdocp.bird.model import N_DATA

    import casadi as ca

    from birdocp.bird import aero
    from birdocp.bird.model import unpack_data

    x = ca.SX.sym("x", 4)
    d = ca.SX.sym("d", int(n_data or N_DATA))
    p = ca.SX.sym("p", len(PARAM_NAMES))
    b = unpack_data(d)
    V, _, alpha, vind = aero.inflow(x, b["r_m"], b["v_kin_mps"], b["c_hat"], b["up"], b["tau"], b["Wx"], b["Wy"],
                                  normalwash)
    alpha_eff, _ = aero.section_angle(V + vind, b["c_hat"], b["up"], b["tau"])
    return ca.Function("effective_angles", [x, d, p], [alpha_eff.T, alpha.T, b["ds_m"]],
                       ["x", "d", "p"], ["alpha_eff_rad", "alpha_geo_rad", "ds_m"])


def model_angles(model) -> "ca.Function":
    """``(x, d, p) -> (alpha_eff 16, alpha_geo 16, ds 16, alpha_eff_quasi_steady 16, f_sep 16,
    newton_residual)`` for a
    :class:`~birdocp.bird.model.BirdModel`: with an unsteady or stall section ``alpha_eff`` is the angle
    the section law sees (alpha_E: lag and 3/4-chord term included) and ``f_sep`` the separation point;
    otherwise alpha_eff_quasi_steady = alpha_eff, f_sep = 1 and the residual 0 (the relative residual
    max|R| / max|Gamma| of the stall circulation after its Newton steps). Built once, kept by the model.

    Parameters
    ----------
    model : BirdModel
        Model.

    Returns
    -------
    casadi.Function
    """
    return owned_cache(model).build("model_angles", lambda: _model_angles(model))


def _model_angles(model) -> "ca.Function":
    import casadi as ca

    if not model.structure.aero_extra:
        ea = effective_angles(model.ode.nd, model.structure.normalwash)
        x, d, p = (ca.SX.sym(k, *ea.size_in(i)) for i, k in enumerate(("x", "d", "p")))
        ae, ag, ds = ea(x, d, p)
        return ca.Function("model_angles", [x, d, p], [ae, ag, ds, ae, ca.DM.ones(ae.shape), ca.DM.zeros(1, 1)])
    sd = model.section_d
    x, d, p = (ca.SX.sym(k, *sd.size_in(i)) for i, k in enumerate(("x", "d", "p")))
    o = sd(x=x, d=d, p=p)
    return ca.Function("model_angles", [x, d, p], [o["alpha_E_rad"], o["alpha_geo_rad"], o["ds_m"],
                                                   o["alpha_eff_quasi_steady_rad"], o["f_sep"], o["newton_residual"]])


def element_angles_function(cfg: Config, n_times: int, extended: bool = False) -> "ca.Function":
    """``f(X[nx x n], T[1 x n], p) -> (alpha_eff, alpha_geo, ds)`` (elements x n; rad, m) for
    the model of ``cfg``; built once per (n, extended), kept by the model. ``extended``: also
    ``alpha_eff_quasi_steady`` (16 x n), ``f_sep`` (16 x n) and ``newton_residual`` (1 x n) of
    :func:`model_angles`.

    Parameters
    ----------
    cfg : Config
        Configuration.
    n_times : int
        Number of times n.
    extended : bool
        Also the quasi-steady angle, the separation point and the Newton residual.

    Returns
    -------
    casadi.Function
    """
    from birdocp.bird.model import get_model

    model = get_model(cfg).model
    n, extended = int(n_times), bool(extended)
    return owned_cache(model).build(("element_angles", n, extended), lambda: _element_angles(model, n, extended))


def _element_angles(model, n: int, extended: bool) -> "ca.Function":
    import casadi as ca

    X = ca.MX.sym("X", model.ode.nx, n)
    T = ca.MX.sym("T", 1, n)
    p = ca.MX.sym("p", len(PARAM_NAMES))
    D = model.ode.data.map(n)(T, p)  # post(pre(t, p)): no need to read the whole data graph
    outs = model_angles(model).map(n)(X, D, p)
    names = ["alpha_eff_rad", "alpha_geo_rad", "ds_m", "alpha_eff_quasi_steady_rad", "f_sep", "newton_residual"]
    k = 6 if extended else 3
    return ca.Function("element_angles", [X, T, p], list(outs[:k]), ["X", "T", "p"], names[:k])


@dataclass
class CycleValidity:
    """The validity of one cycle: verdict, reasons and the measured numbers (see the module)."""

    valid: bool
    reasons: list = field(default_factory=list)
    measures: dict = field(default_factory=dict, metadata=serial(flatten=True))
    thresholds: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """``{"valid", "reasons", <measures>..., "thresholds": {...}}``
        (:func:`birdocp.engine.results.result_dict`; None for NaN)."""
        return result_dict(self)

    def summary(self) -> str:
        """One line: the verdict, then the reasons (or the key numbers when valid)."""
        return validity_text(self.to_dict())


def _thresholds(cfg: Config) -> dict:
    v = cfg.validity
    return {"stall_angle_deg": v.stall_angle_deg, "max_stalled_fraction": v.max_stalled_fraction,
            "min_forward_speed_mps": v.min_forward_speed_mps, "max_abs_pitch_deg": v.max_abs_pitch_deg,
            "max_airflow_body_angle_deg": v.max_airflow_body_angle_deg}


LIMIT_NAMES = {"max_stalled_fraction": "stalled share of the span-time area",
               "min_forward_speed_mps": "minimum forward speed u",
               "max_abs_pitch_deg": "largest |theta|",
               "max_airflow_body_angle_deg": "largest airflow-to-body angle"}
"""The validity limits (their ``[validity]`` keys) and what each bounds, for messages."""


def validity_margins(v: "CycleValidity | dict") -> dict:
    """The margin of each validity limit on a cycle, positive (or 0) where it is respected:
    ``{limit key: margin}`` with ``max_stalled_fraction - stalled_fraction``, ``min_forward_speed_mps
    (measured) - limit`` [m/s], ``max_abs_pitch_deg - |theta|max`` [deg] and
    ``max_airflow_body_angle_deg - angle`` [deg] (keys: :data:`LIMIT_NAMES`, the ``[validity]`` keys).

    The cycle is valid exactly when every margin is >= 0 (the verdict of :func:`cycle_validity`);
    NaN when the cycle was not measured. The stall margin is piecewise constant (a share of the
    grid's element-times), the others are continuous in the cycle.

    Parameters
    ----------
    v : CycleValidity or dict
        Verdict with its measurements.

    Returns
    -------
    dict
    """
    d = v.to_dict() if isinstance(v, CycleValidity) else dict(v or {})
    th = d.get("thresholds") or {}

    def get(key):
        x = d.get(key)
        return float("nan") if x is None else float(x)

    def lim(key):
        x = th.get(key)
        return float("nan") if x is None else float(x)

    return {"max_stalled_fraction": lim("max_stalled_fraction") - get("stalled_fraction"),
            "min_forward_speed_mps": get("min_forward_speed_mps") - lim("min_forward_speed_mps"),
            "max_abs_pitch_deg": lim("max_abs_pitch_deg") - get("max_abs_pitch_deg"),
            "max_airflow_body_angle_deg": lim("max_airflow_body_angle_deg") - get("max_airflow_body_angle_deg")}


def invalid(cfg: Config | None, reason: str) -> CycleValidity:
    """A verdict without measurements (e.g. no finite cycle to measure).

    Parameters
    ----------
    cfg : Config or None
        Configuration (its thresholds; default the reference case).
    reason : str
        Why the cycle is not valid.

    Returns
    -------
    CycleValidity
    """
    return CycleValidity(False, [reason], {}, _thresholds(cfg or Config()))


def cycle_validity(cfg: Config, t_s, x, p=None) -> CycleValidity:
    """Validity of a cycle given by its states ``x`` (n x 4: u, w, q, theta) at times ``t_s`` (n).

    The states should cover one period on a uniform grid without repeating the closing point (a
    closing point equal to the first is dropped). ``p``: the parameter vector (default: ``cfg``'s).

    Parameters
    ----------
    cfg : Config
        The configuration (its ``[validity]`` thresholds and model).
    t_s : array_like (n,)
        Times [s].
    x : array_like (n, 4)
        States (u, w [m/s], q [rad/s], theta [rad]) at those times.
    p : array_like, optional
        The parameter vector (default: ``cfg``'s).

    Returns
    -------
    CycleValidity
        ``valid``, ``reasons`` (one sentence per crossed limit) and the measured numbers.
    """
    import casadi as ca
    import numpy as np

    from birdocp.bird.model import get_model

    cfg = cfg or Config()
    t = np.asarray(t_s, float).ravel()
    X = np.asarray(x, float).reshape(-1, get_model(cfg).ode.nx)
    if len(t) != X.shape[0]:
        raise ValueError(f"{len(t)} times for {X.shape[0]} states")
    if X.shape[0] > 2 and np.allclose(X[-1], X[0], rtol=0, atol=1e-6) and math.isclose(
            t[-1] - t[0], 1.0 / cfg.gait.frequency_hz, rel_tol=1e-9):
        t, X = t[:-1], X[:-1]
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(t))):
        return invalid(cfg, "the cycle's states are not finite (no cycle to check)")
    p = get_model(cfg).p0 if p is None else np.asarray(p, float).ravel()
    f = element_angles_function(cfg, len(t), extended=True)
    ae, ag, ds, aq, fs, nr = (np.asarray(v) for v in f(ca.DM(X.T), ca.DM(t[None, :]), ca.DM(p)))
    return _verdict(cfg, t, X, np.degrees(ae), np.degrees(ag), ds, _section_measures(cfg, aq, fs, ds, nr))


def _section_measures(cfg: Config, aq, fs, ds, nr) -> dict:
    """With an unsteady or stall section: the quasi-steady effective angle's range [deg], the
    separated fraction sum_j int (1 - f_j) ds_j dt / (span T), the smallest f and, with a stall section,
    the largest relative Newton residual of the circulation over the cycle."""
    import numpy as np

    if cfg.aero.unsteady == "none" and cfg.aero.section == "linear":
        return {}
    span = ds.sum(axis=0)
    return {"alpha_eff_quasi_steady_min_deg": float(np.degrees(aq.min())),
            "alpha_eff_quasi_steady_max_deg": float(np.degrees(aq.max())),
            "separated_fraction": float((((1.0 - fs) * ds).sum(axis=0) / span).mean()),
            "min_separation_point": float(fs.min()),
            **({"max_newton_residual": float(np.max(nr))} if cfg.aero.section != "linear" else {})}


def _verdict(cfg: Config, t, X, ae_deg, ag_deg, ds, extra: dict | None = None, airflow_deg=None,
             sides: dict | None = None) -> CycleValidity:
    """The measures and the verdict; ``X`` the (u, w, q, theta) columns; ``airflow_deg``: the angle of
    the airflow to the body axis per time (default the planar ``|atan2(w, u)|``); ``sides``: element
    index slices per wing, whose stalled shares are reported and whose largest is ``stalled_fraction``."""
    import numpy as np

    th = _thresholds(cfg)
    stall = th["stall_angle_deg"]
    stalled = np.abs(ae_deg) > stall                       # 16 x n
    span = ds.sum(axis=0)                                   # n
    stalled_span = (stalled * ds).sum(axis=0) / span        # n: stalled share of the span at each time
    per_side = {f"stalled_fraction_{k}": float(((stalled[j] * ds[j]).sum(axis=0) / ds[j].sum(axis=0)).mean())
                for k, j in (sides or {}).items()}
    u, w, theta = X[:, 0], X[:, 1], X[:, 3]
    airflow_deg = np.degrees(np.abs(np.arctan2(w, u))) if airflow_deg is None else np.asarray(airflow_deg)
    # the two wings are mirror images: their angles agree to round-off (1e-14 deg), so every element
    # within 1e-9 deg of the largest is a tie and the first one (element index, then time) is reported,
    # the same whatever the last bits (rounding to 1e-9 instead flipped between the wings where a
    # value straddled a rounding boundary)
    a_abs = np.abs(ae_deg)
    ties = np.argwhere(a_abs >= a_abs.max() - 1e-9)
    i_max = tuple(ties[np.lexsort((ties[:, 1], ties[:, 0]))[0]])
    m = {
        "alpha_eff_min_deg": float(ae_deg.min()), "alpha_eff_max_deg": float(ae_deg.max()),
        "alpha_eff_max_abs_element": int(i_max[0]),
        "alpha_eff_max_abs_time_s": float(t[i_max[1]]),
        "alpha_geometric_min_deg": float(ag_deg.min()), "alpha_geometric_max_deg": float(ag_deg.max()),
        "stalled_fraction": max(per_side.values()) if per_side else float(stalled_span.mean()), **per_side,
        "stalled_span_fraction_max": float(stalled_span.max()),
        "stalled_time_fraction": float(np.mean(stalled.any(axis=0))),
        "min_forward_speed_mps": float(u.min()),
        "min_airspeed_mps": float(np.hypot(u, w).min()),
        "pitch_min_deg": float(np.degrees(theta.min())), "pitch_max_deg": float(np.degrees(theta.max())),
        "max_abs_pitch_deg": float(np.degrees(np.abs(theta).max())),
        "max_airflow_body_angle_deg": float(airflow_deg.max()),
        "n_times": int(X.shape[0]),
        **(extra or {}),
    }
    reasons = []
    if m["stalled_fraction"] > th["max_stalled_fraction"]:
        worst = f" of the {max(per_side, key=per_side.get)[17:]} wing" if per_side else ""
        reasons.append(f"stall: {m['stalled_fraction']:.1%} of the span-time area{worst} beyond the stall angle "
                       f"{stall:g} deg (limit {th['max_stalled_fraction']:.0%}; effective angle of attack "
                       f"{m['alpha_eff_min_deg']:.1f}..{m['alpha_eff_max_deg']:.1f} deg)")
    if not m["min_forward_speed_mps"] >= th["min_forward_speed_mps"]:
        reasons.append(f"forward speed u falls to {m['min_forward_speed_mps']:.2f} m/s "
                       f"(limit {th['min_forward_speed_mps']:g} m/s; quasi-steady aerodynamics needs forward flight)")
    if m["max_abs_pitch_deg"] > th["max_abs_pitch_deg"]:
        reasons.append(f"pitch angle reaches {m['max_abs_pitch_deg']:.1f} deg "
                       f"(theta {m['pitch_min_deg']:.1f}..{m['pitch_max_deg']:.1f} deg; limit "
                       f"{th['max_abs_pitch_deg']:g} deg)")
    if m["max_airflow_body_angle_deg"] > th["max_airflow_body_angle_deg"]:
        reasons.append(f"airflow at {m['max_airflow_body_angle_deg']:.1f} deg to the body axis (the modelled "
                       f"wake direction; limit {th['max_airflow_body_angle_deg']:g} deg)")
    return CycleValidity(not reasons, reasons, m, th)


def periodic_validity(cfg: Config, x0, p=None, t0_s: float = 0.0, steps_per_period: int | None = None,
                      ode=None) -> CycleValidity:
    """Validity of the periodic orbit through ``x0`` at ``t0_s``: one RK4 period from it (the same
    grid as the solver, ``cfg.solve.steps_per_period`` by default), then :func:`grid_validity`.
    For cycles stored without their trajectory (branch points, results on disk). ``ode``: the
    model's ODE (default) or an equivalent one (e.g. with compiled Functions) to integrate with.

    Parameters
    ----------
    cfg : Config
        The configuration.
    x0 : array_like (4,)
        The state on the orbit at ``t0_s``.
    p : array_like, optional
        The parameter vector (default: ``cfg``'s).
    t0_s : float
        The time of ``x0`` [s].
    steps_per_period : int, optional
        RK4 steps of the period integrated.
    ode : ODE, optional
        The ODE to integrate with (default the model's).

    Returns
    -------
    CycleValidity
        As :func:`cycle_validity`.

    Examples
    --------
    >>> from birdocp import Config, periodic_validity
    >>> v = periodic_validity(Config(), [18.04, -2.0, -0.113, -0.117], steps_per_period=60)
    >>> v.valid, v.reasons
    (True, [])
    """
    import casadi as ca
    import numpy as np

    cfg = cfg or Config()
    x0 = np.asarray(x0, float).ravel()
    if not np.all(np.isfinite(x0)):
        return invalid(cfg, "the cycle's states are not finite (no cycle to check)")
    n = int(steps_per_period or cfg.solve.steps_per_period)
    grid, p = _grid_and_p(cfg, n, p, ode)
    D = grid.blocks_numeric(float(t0_s), p)
    X = np.asarray(grid.period_map(ca.DM(x0), D, ca.DM(p))[1]).T   # states after each step
    X = np.vstack([x0[None, :], X[:-1]])                            # x(t0 + k h), k = 0..n-1
    return grid_validity(cfg, X, p, t0_s, n, ode)


def _grid_and_p(cfg: Config, n: int, p, ode=None):
    # the engine's cached one-segment grid of the ODE (one cache of grids for every user)
    import numpy as np

    from birdocp.bird.model import get_model
    from birdocp.engine.method import OrbitMethod
    from birdocp.engine.shooting import rk4_grid

    m = get_model(cfg)
    ode = m.ode if ode is None else ode
    p = m.p0 if p is None else np.asarray(p, float).ravel()
    return rk4_grid(ode, OrbitMethod(points=2, steps_per_period=n), ()), p


def grid_validity(cfg: Config, x, p=None, t0_s: float = 0.0, steps_per_period: int | None = None,
                  ode=None) -> CycleValidity:
    """Validity of a cycle given by its states at the RK4 step times ``t0_s + k T/N`` (k = 0..N-1,
    N = ``steps_per_period``; a closing state k = N is dropped), as a solver returns it.

    The same measures as :func:`cycle_validity`, with the data at those times taken from the stage
    data of the solver's grid (:meth:`birdocp.engine.integrate.RK4Grid.blocks_numeric`, memoised:
    after a solve of the same gait the wing is not evaluated again; ``ode`` as in
    :func:`periodic_validity`).

    Parameters
    ----------
    cfg : Config
        Configuration.
    x : array_like, shape (N, nx) or (N + 1, nx)
        States at the step times.
    p : array_like, optional
        Parameter vector.
    t0_s : float
        Time of the first state [s].
    steps_per_period : int, optional
        N.
    ode : ODE, optional
        The ODE (the model's or its compiled twin).

    Returns
    -------
    CycleValidity
    """
    import casadi as ca
    import numpy as np

    cfg = cfg or Config()
    n = int(steps_per_period or cfg.solve.steps_per_period)
    grid, p = _grid_and_p(cfg, n, p, ode)
    X = np.asarray(x, float).reshape(-1, grid.ode.nx)
    if X.shape[0] == n + 1:
        X = X[:n]
    if X.shape[0] != n:
        raise ValueError(f"{X.shape[0]} states for {n} steps per period")
    if not np.all(np.isfinite(X)):
        return invalid(cfg, "the cycle's states are not finite (no cycle to check)")
    t = float(t0_s) + grid.h * np.arange(n)
    # the data at the step starts t0 + k h are the first columns of the stage blocks (no second
    # evaluation of the wing on the time grid)
    D = grid.blocks_numeric(float(t0_s), p)
    if grid.ode.state_names[:2] == ("u_mps", "v_mps"):  # the six-degree-of-freedom ODE (9 or 8 states)
        return _sixdof_verdict(cfg, grid, X, t, D, p)
    from birdocp.bird.model import get_model

    model = get_model(cfg).model
    hit = owned_cache(model).build(("model_angles_map", n), lambda: model_angles(model).map(n))
    ae, ag, ds, aq, fs, nr = (np.asarray(v) for v in hit(ca.DM(X.T), grid.step_start_data(D), ca.DM(p)))
    return _verdict(cfg, t, X, np.degrees(ae), np.degrees(ag), ds, _section_measures(cfg, aq, fs, ds, nr))


def side_elements(n_elements: int) -> dict:
    """The lifting-line elements of each wing: the left half of the line, then the right (the code
    frame's e1 points right), for the model's element count.

    Parameters
    ----------
    n_elements : int
        Elements of both wings (16, or 16 k with ``aero.span_subdivisions = k``).

    Returns
    -------
    dict
        ``{"left": slice, "right": slice}``.
    """
    half = int(n_elements) // 2
    return {"left": slice(0, half), "right": slice(half, 2 * half)}


SIDE_ELEMENTS = side_elements(16)
"""The elements of each wing of the 16-element line (left 0..7, right 8..15); :func:`side_elements`
for a subdivided one."""


@functools.lru_cache(maxsize=8)
def sixdof_angles(nx: int, nd: int, n_times: int, section=None, normalwash: str = "angle") -> "ca.Function":
    """``(X nx x n, D nd x n, p6) -> (alpha_eff_rad, alpha_geo_rad, ds_m)`` (elements x n) of the
    six-degree-of-freedom model (:func:`birdocp.bird.sixdof.body_loads`: sideslip and roll and yaw
    rates in every element's velocity, both wings apart) for ``nx`` = 9 or 8 (the heading dropped)
    states (then the aerodynamic states of ``section``) and data vectors of ``nd`` values, mapped over
    ``n_times`` times (built once). With a stall ``section`` (:class:`birdocp.bird.sixdof.SectionLaw`)
    the effective angle is the one its section law sees (alpha_E); ``normalwash``: ``aero.normalwash``
    of the linear section."""
    import casadi as ca

    from birdocp.bird import aero
    from birdocp.bird.sixdof import HEADING, body_loads

    x, d, p = ca.SX.sym("x", nx), ca.SX.sym("d", nd), ca.SX.sym("p", len(PARAM_NAMES))
    x9 = x if section is None or nx - section.n_states == 9 else ca.vertcat(x[:HEADING], 0, x[HEADING:])
    _, _, e = body_loads(x9, d, p, section=section, normalwash=normalwash)
    if section is None:
        ae, _ = aero.section_angle(e["V"] + e["vind"], *(unpack_blocks(d, ("c_hat", "up", "tau"))))
    else:
        ae = e["sec"]["alpha_E"].T
    b = unpack_blocks(d, ("ds_m",))[0]
    one = ca.Function("angles6", [x, d, p], [ae.T, e["alpha"].T, b])
    X, D = ca.MX.sym("X", nx, n_times), ca.MX.sym("D", nd, n_times)
    pm = ca.MX.sym("p", len(PARAM_NAMES))
    return ca.Function("angles6_map", [X, D, pm], list(one.map(n_times)(X, D, pm)))


register_cache("bird.validity_angles_6dof", sixdof_angles)


def unpack_blocks(d, names):
    """The data blocks ``names`` (:data:`birdocp.bird.model.DATA_BLOCKS`) of a data vector.

    Parameters
    ----------
    d : casadi.SX, MX or DM
        Data vector.
    names : sequence of str
        Block names.

    Returns
    -------
    dict
        Block name to matrix.
    """
    from birdocp.bird.model import unpack_data

    b = unpack_data(d)
    return [b[k] for k in names]


def _section_of(cfg: Config, ode):
    """The stall section (:class:`birdocp.bird.sixdof.SectionLaw`) of the 6-DOF ``ode`` of ``cfg``, or None."""
    from birdocp.bird.sides import SIDE_PARAM_NAMES
    from birdocp.bird.sixdof import sixdof_model

    if cfg.aero.section == "linear":
        return None
    return sixdof_model(cfg, sides=SIDE_PARAM_NAMES[0] in ode.param_names).section


def _sixdof_verdict(cfg: Config, grid, X, t, D, p6) -> CycleValidity:
    """The validity measures of a six-degree-of-freedom cycle (states ``X`` n x 9 or 8 at the step
    starts): the effective angles of both wings in the asymmetric flow, the stalled share of each wing
    (the larger one is ``stalled_fraction``), the 3-D angle between the airflow and the body axis
    ``atan2(sqrt(v^2 + w^2), u)`` (the modelled wake direction: sideslip included), the largest sideslip
    ``|atan2(v, sqrt(u^2 + w^2))|`` and bank ``|phi|``."""
    import casadi as ca
    import numpy as np

    from birdocp.bird.sixdof import LONGITUDINAL

    n = X.shape[0]
    f = sixdof_angles(int(grid.ode.nx), int(grid.ode.nd), n, _section_of(cfg, grid.ode), cfg.aero.normalwash)
    ae, ag, ds = (np.asarray(v) for v in f(ca.DM(X.T), grid.step_start_data(D), ca.DM(p6[:len(PARAM_NAMES)])))
    u, v, w = X[:, 0], X[:, 1], X[:, 2]
    extra = {"max_sideslip_deg": float(np.degrees(np.abs(np.arctan2(v, np.hypot(u, w)))).max()),
             "max_abs_bank_deg": float(np.degrees(np.abs(X[:, 6])).max()),
             "min_airspeed_mps": float(np.sqrt(u * u + v * v + w * w).min())}
    airflow = np.degrees(np.arctan2(np.hypot(v, w), u))
    return _verdict(cfg, t, X[:, list(LONGITUDINAL)], np.degrees(ae), np.degrees(ag), ds, extra, airflow_deg=airflow,
                    sides=side_elements(ae.shape[0]))
