"""Level (or steady climbing) flight as one NLP: a model parameter free, a period mean constrained.

The paper finds level flight by a Newton-Raphson search over the shoulder flapping amplitude, one
limit cycle per step. Here the amplitude (or any other entry of :data:`birdocp.bird.config.PARAM_NAMES`)
is a decision variable of the multiple-shooting problem, bounded, and one period-mean condition
closes the square system::

    shooting continuity + periodicity + mean(output) = target

``constrain`` chooses the condition (all are period means over the RK4 grid, exactly differentiated):

* ``"vertical_speed_mps"`` (default): mean ``W = u sin(theta) - w cos(theta)`` equals ``target``
  (``climb_rate_mps``; 0 = level flight);
* ``"forward_speed_mps"``: mean ``U = u cos(theta) + w sin(theta)`` equals ``target`` (m/s);
* ``"flight_path_angle_deg"``: ``atan(mean W / mean U) = beta``. A ratio of means is not a mean,
  but with ``mean U > 0`` it is equivalent to the mean of ``W - tan(beta) U`` being 0, which is one
  linear :class:`~birdocp.engine.problem.MeanCondition` (one output Function per beta, cached).

Default bounds of the free parameter (``bounds=None``):

* ``gait.shoulder_flap.amplitude_deg``: 20 .. 70 deg;
* any other ``..._deg`` key: its configured value +- 30 deg;
* ``wing.root_ahead_m``: -0.2 .. 0.3 m;
* anything else: ``bounds`` is required.

The free parameter makes the per-time data (the whole wing geometry and the lifting-line matrices)
symbolic, so the geometry graph is part of the NLP: a level solve costs several trims. Measured
(2 cores, 5 points, 148 steps, 5 IPOPT iterations): 15-18 s for the first solve in a process (about
5 s of it creating the IPOPT solver and its Jacobian graph, inside ``wall_s["solve"]``), 9-12 s for
a repeat (the constraint Jacobian, about 1.2 s per evaluation, dominates), against about 1.3 s for a
warm-started trim.
"""

from __future__ import annotations

import math

from typing import TYPE_CHECKING

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, get_value, suggest
from birdocp.bird.keys import AMPLITUDE_BOUNDS_DEG, AMPLITUDE_KEY, KEY_ALIASES, ROOT_AHEAD_KEY, resolve_key

if TYPE_CHECKING:  # the model and the engine are imported on first solve (key checks stay light)
    from birdocp.studies.trim import TrimResult

__all__ = ["level", "CONSTRAINTS", "default_bounds", "resolve_key", "resolve_constraint", "AMPLITUDE_KEY", "KEY_ALIASES"]

CONSTRAINTS = ("vertical_speed_mps", "forward_speed_mps", "flight_path_angle_deg")
_CONSTRAINT_ALIASES = {
    "vertical_speed": "vertical_speed_mps", "W": "vertical_speed_mps", "climb_rate": "vertical_speed_mps",
    "forward_speed": "forward_speed_mps", "U": "forward_speed_mps",
    "flight_path_angle": "flight_path_angle_deg", "beta": "flight_path_angle_deg",
}


def resolve_constraint(constrain: str, what: str = "constrain") -> str:
    """One of :data:`CONSTRAINTS` from a name or alias; ConfigError (did-you-mean) if unknown.

    Parameters
    ----------
    constrain : str
        Name or alias.
    what : str
        Key named by the error.

    Returns
    -------
    str
    """
    c = _CONSTRAINT_ALIASES.get(str(constrain).strip(), str(constrain).strip())
    if c not in CONSTRAINTS:
        raise ConfigError(what, f"unknown condition '{constrain}'" + suggest(c, CONSTRAINTS)
                          + f" (one of {', '.join(CONSTRAINTS)})")
    return c


def default_bounds(cfg: Config, key: str) -> tuple[float, float]:
    """Default bounds of a free parameter (see the module docstring).

    Parameters
    ----------
    cfg : Config
        Configuration.
    key : str
        Dotted key of the free parameter.

    Returns
    -------
    (float, float)
        In the key's unit.
    """
    if key == AMPLITUDE_KEY:
        return AMPLITUDE_BOUNDS_DEG
    if key == ROOT_AHEAD_KEY:
        return -0.2, 0.3
    if key.endswith("_deg"):
        v = float(get_value(cfg, key))
        return v - 30.0, v + 30.0
    raise ConfigError("bounds", f"no default range for '{key}'; give bounds=(lo, hi)")


def _checked_target(c: str, target) -> float:
    """The finite target of condition ``c`` (ConfigError on ``target`` otherwise)."""
    if target is None:
        raise ConfigError("target", f"constrain='{c}' needs target=...")
    target = float(target)
    if not math.isfinite(target):
        raise ConfigError("target", f"must be finite, got {target!r}")
    if c == "flight_path_angle_deg" and not -89.0 < target < 89.0:
        raise ConfigError("target", f"flight path angle must lie in (-89, 89) deg, got {target!r}")
    return target


def _checked_bounds(bounds) -> tuple[float, float]:
    """(lo, hi) finite with lo < hi (ConfigError on ``bounds`` otherwise)."""
    try:
        lo, hi = (float(b) for b in bounds)
    except (TypeError, ValueError):
        raise ConfigError("bounds", f"expected (lo, hi), got {bounds!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ConfigError("bounds", f"need finite lo < hi, got ({lo}, {hi})")
    return lo, hi


def _condition(constrain: str, target: float, nd: int | None = None, nx: int = 4):
    """(MeanCondition, extra outputs) for a constraint name; ``nd``, ``nx``: the model's data and state
    sizes."""
    from birdocp.bird.flight import flight_outputs, path_angle_output
    from birdocp.bird.model import N_DATA
    from birdocp.engine.problem import MeanCondition

    c = resolve_constraint(constrain)
    outputs = flight_outputs(nd or N_DATA, nx)
    if c == "flight_path_angle_deg":
        return MeanCondition(path_angle_output(target, nd or N_DATA, nx), 0.0, "path_angle_residual"), dict(outputs)
    other = {k: v for k, v in outputs.items() if k != c}
    return MeanCondition(outputs[c], float(target), c), other


def level(cfg: Config | None = None, free: str = AMPLITUDE_KEY, bounds=None, climb_rate_mps: float = 0.0,
          constrain: str = "vertical_speed_mps", x_guess=None, warm_start=None, *, target: float | None = None,
          compiled: bool = False, **method_over) -> "TrimResult":
    """Level (or climbing) periodic flight: ``free`` solved so that the mean of ``constrain`` is met.

    Parameters
    ----------
    cfg : Config, optional
        Configuration (default: the paper's reference case); the free parameter starts from its
        configured value (or from ``warm_start``'s value, if given).
    free : str
        A :data:`PARAM_NAMES` key or alias (``amplitude``, ``root_ahead_m``).
    bounds : (float, float), optional
        (lo, hi) of the free parameter; default per :func:`default_bounds`.
    climb_rate_mps : float
        Target mean vertical speed (``constrain="vertical_speed_mps"``) [m/s].
    constrain : str
        The period mean held: ``vertical_speed_mps``, ``forward_speed_mps`` or
        ``flight_path_angle_deg``.
    x_guess : array_like (4,), optional
        State at t = 0 to start from (default ``cfg.solve.initial_guess``).
    warm_start : TrimResult or OrbitResult, optional
        A previous result (shooting points and free value).
    target : float, optional
        Target of the condition for the other constraints (forward speed in m/s, flight path angle in
        deg); for the vertical speed it overrides ``climb_rate_mps``.
    compiled : bool
        Use the RHS and data compiled to C (:func:`birdocp.studies.trim.solver_ode`; the same
        numbers, faster).
    **method_over
        Overrides of :class:`~birdocp.engine.method.OrbitMethod` (default ``cfg.solve``).

    Returns
    -------
    TrimResult
        ``free_values`` holds the solved parameter, ``amplitude_deg`` the (solved or fixed) amplitude.

    Examples
    --------
    >>> from birdocp import Config, level
    >>> flat = level(Config(), steps_per_period=60)
    >>> flat.success, 40 < flat.amplitude_deg < 46, abs(flat.mean_vertical_speed_mps) < 1e-6
    (True, True, True)
    """
    cfg = cfg or Config()
    key = resolve_key(free, "free")
    c = resolve_constraint(constrain)
    target = _checked_target(c, climb_rate_mps if target is None and c == "vertical_speed_mps" else target)
    lo, hi = default_bounds(cfg, key) if bounds is None else _checked_bounds(bounds)

    from birdocp.bird.model import get_model
    from birdocp.engine.problem import OrbitProblem
    from birdocp.engine.orbit_front import solve as _solve
    from birdocp.studies.trim import TrimResult, method_of, solver_ode

    m = get_model(cfg)
    cond, outputs = _condition(c, target, m.ode.nd, m.ode.nx)
    guess = m.complete_state(cfg.solve.initial_guess if x_guess is None else x_guess, m.p0)
    problem = OrbitProblem(ode=solver_ode(m, compiled), p=m.p0, x_guess=guess, free={key: (lo, hi)}, means=[cond],
                           outputs=outputs)
    ws = warm_start.cycle if isinstance(warm_start, TrimResult) else warm_start
    if ws is not None and not all(hasattr(ws, a) for a in ("p", "shooting_points", "x0")):
        raise TypeError(f"warm_start must be a TrimResult or OrbitResult, got {type(ws).__name__}")
    res = _solve(problem, method_of(cfg, free=True, **method_over), warm_start=ws)
    return TrimResult(res, cfg)


def mean_sensitivity(result, key: str = AMPLITUDE_KEY, output: str = "vertical_speed_mps") -> dict:
    """Derivative of a period mean with respect to a parameter along the family of periodic orbits.

    At a solved cycle ``x0 = Phi(x0, a)`` (RK4 period map on the result's grid), the implicit function
    theorem gives ``dx0/da = (I - Phi_x)^-1 Phi_a`` and ``d mean/da = mean_a + mean_x dx0/da``; all
    partial derivatives by CasADi AD through the whole model (the geometry included), on one
    single-shooting period.

    Parameters
    ----------
    result : TrimResult
        Solved cycle (its ``cfg`` gives the model).
    key : str
        Dotted key of the parameter a.
    output : str
        Flight output whose period mean is differentiated.

    Returns
    -------
    dict
        ``{"derivative", "dx0_da", "mean"}``.
    """
    import casadi as ca
    import numpy as np

    from birdocp.engine.integrate import RK4Grid
    from birdocp.engine.sensitivity import orbit_state_derivative, total_derivative
    from birdocp.bird.model import get_model
    from birdocp.bird.flight import flight_outputs

    key = resolve_key(key, "key")
    cyc = result.cycle
    ode = get_model(result.cfg).ode
    grid = RK4Grid(ode, int(cyc.method["steps_per_period"]), 1, outputs=(flight_outputs(ode.nd, ode.nx)[output],))
    i = PARAM_NAMES.index(key)
    x = ca.MX.sym("x", ode.nx)
    a = ca.MX.sym("a")
    pn = [float(v) for v in np.asarray(cyc.p)]
    pels = [ca.MX(v) for v in pn]
    pels[i] = a
    p = ca.vertcat(*pels)
    D = grid.blocks_symbolic(float(cyc.trajectory_t[0]), p)
    xT, _, q = grid.period_map(x, D, p)
    mean = q / ode.forcing_period
    F = ca.Function("sens", [x, a], [mean, ca.jacobian(xT, x), ca.jacobian(xT, a), ca.jacobian(mean, x),
                                     ca.jacobian(mean, a)])
    mv, Px, Pa, mx, ma = (np.asarray(v) for v in F(np.asarray(cyc.x0, float), pn[i]))
    dx0 = orbit_state_derivative(Px, Pa.ravel())
    return {"derivative": float(total_derivative(ma.ravel()[0], mx.ravel(), dx0)), "dx0_da": dx0.tolist(),
            "mean": float(mv.ravel()[0])}
