"""Branches of the bird's periodic flight in one parameter: the stability margin (wing-root
position), the amplitude or any dotted model key, at fixed gait or holding level flight.

The generic pseudo-arclength continuation is :func:`birdocp.engine.continuation.continuation`; this
module poses the bird's problem for it and converts the stability margin to the root position.
"""
from __future__ import annotations

import numpy as np

from birdocp.bird.config import SIDE_KEYS, Config, ConfigError
from birdocp.bird.flight import flight_outputs
from birdocp.bird.keys import AMPLITUDE_KEY, resolve_key
from birdocp.bird.model import get_model
from birdocp.engine.continuation import Branch, continuation
from birdocp.engine.problem import MeanCondition, OrbitProblem
from birdocp.studies.level import default_bounds
from birdocp.studies.trim import TrimResult, solver_ode

__all__ = ["STABILITY_MARGIN", "PARAM_ALIASES", "resolve_parameter", "sm_percent", "root_of_sm", "bird_branch",
           "bird_problem", "forward_flight", "validity_events", "add_validity"]

STABILITY_MARGIN = "stability_margin"
PARAM_ALIASES = ("root_ahead_m", "stability_margin", "amplitude_deg")


def resolve_parameter(key: str) -> tuple[str, str]:
    """(model key, display) for a continuation parameter: ``stability_margin`` (SM in percent, continued
    as the root position ``root_ahead_m = -SM/100 * body.reference_chord_m``), an alias or a dotted key.

    Parameters
    ----------
    key : str
        ``stability_margin`` (or SM), an alias or a dotted key.

    Returns
    -------
    model_key, display : str
    """
    k = str(key).strip()
    if k in (STABILITY_MARGIN, "SM", "sm"):
        return "wing.root_ahead_m", STABILITY_MARGIN
    if k in SIDE_KEYS:  # a per-side offset: six degrees of freedom only (the configuration check says so)
        return k, k
    rk = resolve_key(k, "PARAM")
    return rk, rk


def sm_percent(root_ahead_m: float, chord_m: float) -> float:
    """Stability margin SM = (G - O'w)/c = -root_ahead_m / c, in percent.

    Parameters
    ----------
    root_ahead_m : float
        Wing-root position ahead of G_b [m].
    chord_m : float
        Reference chord c [m].

    Returns
    -------
    float
        SM [%].
    """
    return -100.0 * float(root_ahead_m) / float(chord_m)


def root_of_sm(sm_pct: float, chord_m: float) -> float:
    """The wing-root position ``root_ahead_m`` (m) of a stability margin in percent.

    Parameters
    ----------
    sm_pct : float
        Stability margin [%].
    chord_m : float
        Reference chord c [m].

    Returns
    -------
    float
        ``root_ahead_m`` [m].
    """
    return -float(sm_pct) / 100.0 * float(chord_m)


def bird_branch(cfg=None, key: str = "root_ahead_m", start_value: float = 0.05, stop_value: float = 0.035, *,
                level: bool = False, climb_rate_mps: float = 0.0, bounds=None, points: int | None = None,
                steps_per_period: int | None = None, start=None, progress=None, validity: bool = True,
                stop_at_invalid: bool = False, compiled: bool = False, **options) -> Branch:
    """Continue the bird's periodic flight in one parameter by pseudo-arclength continuation.

    The branch's ``parameter`` is the model parameter (``wing.root_ahead_m`` for SM); the SM of every
    point is added to ``settings['stability_margin_percent']`` when ``key`` is ``stability_margin``.
    A point whose shooting points have u <= 0 is rejected (not a forward flight). With ``validity``
    every point also gets the margins of the validity limits as ``event_values``
    (:func:`birdocp.bird.validity.validity_margins`); where a margin changes sign between two points a
    ``validity_boundary`` special point is located on the branch (its ``event``: the limit's
    ``[validity]`` key, ``direction`` -1 where the branch leaves the model's validity, +1 where it comes
    back). The branch goes on through it, its points marked invalid, or, with ``stop_at_invalid``, ends
    there (``end_reason`` ``stopped_at_event``; at the start if the start is not valid).

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    key : str
        The parameter: a dotted key, an alias (``root_ahead_m``, ``amplitude_deg``) or
        ``stability_margin`` (values in percent).
    start_value, stop_value : float
        The interval (model units; percent for ``stability_margin``).
    level : bool
        Hold level flight: the flapping amplitude is an unknown too, with the mean vertical speed held
        at ``climb_rate_mps``.
    climb_rate_mps : float
        The mean vertical speed held with ``level`` [m/s].
    bounds : (float, float), optional
        Amplitude bounds with ``level`` [deg] (default the level-flight defaults, 20..70 deg).
    points : int, optional
        Shooting points (default ``cfg.solve.points``).
    steps_per_period : int, optional
        RK4 steps per period (default ``cfg.solve.steps_per_period``).
    start : TrimResult or OrbitResult, optional
        A converged cycle at the start value (default: Newton from ``cfg.solve.initial_guess``).
    progress : callable, optional
        ``progress(text)``, one line per point.
    validity : bool
        Give every point its ``validity`` (:func:`birdocp.bird.validity.periodic_validity`: one RK4
        period from its x0 with its parameters) and its validity margins.
    stop_at_invalid : bool
        End the branch where it leaves the model's validity.
    compiled : bool
        The RHS and data compiled to C (:func:`birdocp.studies.trim.solver_ode`; the same
        numbers, faster).
    **options
        Settings of :class:`~birdocp.engine.continuation.options.ContinuationOptions` (``step``,
        ``max_points``, ``max_dparam``, ``error_estimate`` (every point's ``error_estimate``), ...) and
        the callbacks of :func:`~birdocp.engine.continuation.continuation` (``on_point``, ...).

    Returns
    -------
    Branch
        The points, the special points located on the branch and why it ended.
    """
    cfg = cfg or Config()
    model_key, display = resolve_parameter(key)
    chord = cfg.body.reference_chord_m
    a, b = _model_units(display, float(start_value), float(stop_value), options, chord)
    if stop_at_invalid and not validity:
        raise ValueError("stop_at_invalid needs validity=True (the validity of every point)")
    points, steps = int(points or cfg.solve.points), int(steps_per_period or cfg.solve.steps_per_period)
    ode, prob = _problem(cfg, compiled, model_key, level, climb_rate_mps, bounds)
    ws = start.cycle if isinstance(start, TrimResult) else start
    options.setdefault("scales", {"states": 1.0, "free": 10.0})
    events = validity_events(cfg, steps, ode, stop_at_invalid) if validity else None
    br = continuation(prob, model_key, a, b, points=points, steps_per_period=steps, start=ws, accept=forward_flight,
                      progress=progress, events=events, **options)
    br.settings.update({"key": key, "display": display, "level": bool(level), "climb_rate_mps": climb_rate_mps,
                        "stop_at_invalid": bool(stop_at_invalid), "reference_chord_m": chord,
                        "config_amplitude_deg": cfg.gait.shoulder_flap.amplitude_deg})
    if display == STABILITY_MARGIN:
        br.settings["stability_margin_percent"] = [sm_percent(p.parameter, chord) for p in br.points]
    if validity:
        add_validity(cfg, br, steps, ode)
    return _with_lateral_split(cfg, br, steps, points, ode)


def _with_lateral_split(cfg, br: Branch, steps: int, points: int, ode=None) -> Branch:
    """``br``, with six degrees of freedom given its per-point longitudinal/lateral split
    (:func:`birdocp.studies.lateral_branch.add_lateral_split` on the branch's ODE)."""
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.studies.lateral_branch import add_lateral_split

        add_lateral_split(cfg, br, steps, points, ode)
    return br


def _problem(cfg, compiled, model_key: str, level: bool, climb_rate_mps: float, bounds):
    """``(ode, problem)`` of a branch: the planar bird's (:func:`bird_problem`) or, with six degrees of
    freedom, the heading-free 6-DOF model's (:func:`birdocp.studies.lateral_branch.branch_problem`)."""
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.studies.lateral_branch import branch_problem

        return branch_problem(cfg, model_key, level, climb_rate_mps, bounds)
    if model_key in SIDE_KEYS:
        raise ConfigError(model_key, "a per-side offset (an asymmetric gait) needs six degrees of freedom; "
                                     "set model.degrees_of_freedom = 6")
    m = get_model(cfg)
    ode = solver_ode(m, compiled)
    return ode, bird_problem(cfg, m, ode, model_key, level, climb_rate_mps, bounds)


def _model_units(display: str, a: float, b: float, options: dict, chord: float) -> tuple:
    """The interval (and ``step``, ``max_dparam`` in ``options``, in place) in the model parameter's
    units: a stability margin in percent becomes the root position in metres."""
    if display != STABILITY_MARGIN:
        return a, b
    if options.get("step"):
        options["step"] = abs(root_of_sm(options["step"], chord))  # SM percent -> metres
    if options.get("max_dparam"):
        options["max_dparam"] = abs(root_of_sm(options["max_dparam"], chord))
    return root_of_sm(a, chord), root_of_sm(b, chord)


def bird_problem(cfg, m, ode, model_key: str, level: bool, climb_rate_mps: float, bounds) -> OrbitProblem:
    """The bird's limit-cycle problem of a branch: at fixed gait, or (``level``) with the amplitude
    free (within ``bounds``, default the level-flight bounds) and the mean vertical speed held at
    ``climb_rate_mps``.

    Parameters
    ----------
    cfg : Config
        Configuration.
    m : BirdModel
        Model of ``cfg``.
    ode : ODE
        The ODE solved (``m.ode`` or its compiled twin).
    model_key : str
        Dotted key of the continuation parameter.
    level : bool
        Amplitude free, mean vertical speed held.
    climb_rate_mps : float
        Mean vertical speed held with ``level`` [m/s].
    bounds : (float, float) or None
        Amplitude bounds [deg] with ``level``.

    Returns
    -------
    OrbitProblem
    """
    guess = m.complete_state(cfg.solve.initial_guess, m.p0)
    if not level:
        return OrbitProblem(ode, m.p0, guess, outputs=flight_outputs(m.ode.nd, m.ode.nx))
    if model_key == AMPLITUDE_KEY:
        raise ValueError("with level flight held the amplitude is solved for: continue another parameter")
    lo, hi = bounds if bounds is not None else default_bounds(cfg, AMPLITUDE_KEY)
    outputs = flight_outputs(m.ode.nd, m.ode.nx)
    cond = MeanCondition(outputs["vertical_speed_mps"], float(climb_rate_mps), "vertical_speed_mps")
    return OrbitProblem(ode, m.p0, guess, free={AMPLITUDE_KEY: (float(lo), float(hi))}, means=[cond],
                        outputs={"forward_speed_mps": outputs["forward_speed_mps"]})


def forward_flight(pt) -> str | None:
    """Why a branch point is not a forward flight (u <= 0 at a shooting point), or None.

    Parameters
    ----------
    pt : branch point
        With ``shooting_points`` (u [m/s] first).

    Returns
    -------
    str or None
    """
    u = np.asarray(pt.shooting_points)[:, 0]
    return None if np.all(u > 0) else f"u <= 0 at a shooting point (min {u.min():.3g} m/s)"


VALIDITY_LOCATE_TOL = 1e-7
"""Validity boundaries are located to this scaled arclength (the parameter interval is one unit)."""


def validity_events(cfg, steps_per_period: int, ode=None, stop: bool = False):
    """The validity limits of ``cfg`` as continuation test functions
    (:class:`birdocp.engine.continuation.BranchEvents`, kind ``validity_boundary``): at each point the
    exact validity (:func:`birdocp.bird.validity.periodic_validity`, stored in the point's
    ``validity``) and its margins (:func:`birdocp.bird.validity.validity_margins`) as the values.

    Parameters
    ----------
    cfg : Config
        Configuration (its ``[validity]`` limits).
    steps_per_period : int
        RK4 steps of the validity period.
    ode : ODE, optional
        The ODE integrated (default: the model's).
    stop : bool
        Stop the continuation at the located boundary.

    Returns
    -------
    BranchEvents
    """
    from birdocp.bird.validity import LIMIT_NAMES, periodic_validity, validity_margins
    from birdocp.engine.continuation import BranchEvents

    def evaluate(pt):
        x0, p, o = _planar_of(cfg, pt, ode)
        v = periodic_validity(cfg, x0, p, steps_per_period=steps_per_period, ode=o)
        pt.validity = v.to_dict()
        return validity_margins(v)

    def describe(limit: str, direction: int, pt) -> str:
        margin = (pt.event_values or {}).get(limit, float("nan"))
        th = (pt.validity or {}).get("thresholds", {}).get(limit)
        return (f"{'leaves' if direction < 0 else 'comes back into'} the model's validity: {LIMIT_NAMES[limit]} "
                f"at its limit {limit} = {th:g} (margin {margin:.3g} at the located point)")

    return BranchEvents(evaluate, kind="validity_boundary", stop=stop, tol=VALIDITY_LOCATE_TOL, describe=describe)


def add_validity(cfg, br: Branch, steps_per_period: int | None = None, ode=None) -> Branch:
    """Fill ``validity`` (a dict, :meth:`birdocp.bird.validity.CycleValidity.to_dict`) of every point of
    ``br`` that has none: one RK4 period from the point's x0 with the point's parameter vector
    (``ode``: the model's ODE or its compiled twin, :func:`birdocp.studies.trim.solver_ode`).

    Parameters
    ----------
    cfg : Config
        Configuration.
    br : Branch
        Branch, changed in place.
    steps_per_period : int, optional
        RK4 steps of the validity period (default: the branch's).
    ode : ODE, optional
        The ODE integrated.

    Returns
    -------
    Branch
        ``br``.
    """
    from birdocp.bird.validity import periodic_validity

    n = int(steps_per_period or br.settings.get("steps_per_period") or cfg.solve.steps_per_period)
    for pt in br.points:
        if pt.validity is None:
            x0, p, o = _planar_of(cfg, pt, ode)
            pt.validity = periodic_validity(cfg, x0, p, steps_per_period=n, ode=o).to_dict()
    return br


def _planar_of(cfg, pt, ode):
    """(x0, p, ode) for the validity of a branch point: as is, or for a 6-DOF point
    :func:`birdocp.studies.lateral_branch.validity_point` (the planar cycle's, or with per-side joint laws the
    6-DOF check over both wings)."""
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.studies.lateral_branch import validity_point

        return validity_point(pt.x0, pt.p, ode)
    return pt.x0, np.asarray(pt.p, float) if len(pt.p) else None, ode


