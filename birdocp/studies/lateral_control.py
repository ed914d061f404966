"""Lateral feedback of the six-degree-of-freedom bird: per-side gait corrections, the periodic LQR of the
wingbeat map (the planar mechanism of :mod:`birdocp.studies.control`), and many-beat simulations with a
side gust or a roll perturbation, open or closed loop.

Controls: offsets of one wing's joint laws (:mod:`birdocp.bird.sides`), by default the amplitude, the
sweep offset and the incidence offset of the right and of the left wing (:data:`LATERAL_CONTROLS`);
any per-side key or symmetric gait key may be given. Equal corrections on both sides act on the
longitudinal states, opposite ones on the lateral states, so one design covers both.

The map: the 8 states (u, v, w, p, q, r, phi, theta) at the beat start: the heading psi is EXCLUDED.
Nothing depends on it (its multiplier is 1 in every cycle, closed loop included), and holding a
heading is a guidance task on top of this loop (a turn is commanded through the bank). The
linearisation is exact (forward AD through the per-time data of both wings and every RK4 step), the
controller is :func:`birdocp.studies.control.periodic_lqr` with Bryson weights
(:data:`ACCEPTABLE_STATE_6DOF`; 5 deg per joint).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, param_vector, with_values
from birdocp.bird.sides import SIDE_PARAM_NAMES
from birdocp.bird.sixdof import HEADING, STATE_NAMES, sixdof_model
from birdocp.studies.control import (DEFAULT_LIMIT_DEG, Controller, WingbeatMap, bryson_weights,
                                     controller_on_map, default_limits, linearise, resolve_controls)
from birdocp.studies.control_aero import pad_weight
from birdocp.studies.lateral_simulate_aero import complete_state6, manifold_slopes6, n_aero_states

__all__ = ["LATERAL_CONTROLS", "LATERAL_ALIASES", "ACCEPTABLE_STATE_6DOF", "resolve_lateral_controls",
           "lateral_wingbeat_map", "design_lateral_controller", "lateral_reference_cycle", "sides_parameters", "sides_parameter_vector"]

LATERAL_CONTROLS = tuple(f"gait.{side}_offset.{key}" for side in ("right", "left") for key in (
    "shoulder_flap.amplitude_deg", "shoulder_sweep.offset_deg", "shoulder_incidence.offset_deg"))
"""Default controls: each wing's flapping amplitude, sweep offset and incidence offset [deg]."""
LATERAL_ALIASES = {f"{side}_{name}": f"gait.{side}_offset.{key}" for side in ("right", "left") for name, key in (
    ("amplitude", "shoulder_flap.amplitude_deg"), ("sweep", "shoulder_sweep.offset_deg"),
    ("incidence", "shoulder_incidence.offset_deg"))}
"""Short names of the per-side controls: right_amplitude, left_sweep, ..."""
ACCEPTABLE_STATE_6DOF = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0, math.radians(5.0), math.radians(5.0))
"""Bryson's acceptable deviations of the 8 states: u, v, w [m/s], p, q, r [rad/s], phi, theta [rad]."""


def resolve_lateral_controls(keys) -> list[str]:
    """Control keys of the six-degree-of-freedom map: per-side keys (:data:`SIDE_PARAM_NAMES`), gait
    keys of :data:`PARAM_NAMES` or aliases (:data:`LATERAL_ALIASES`); ConfigError on ``--controls``
    for an unknown or repeated key.

    Parameters
    ----------
    keys : iterable of str
        Keys or aliases.

    Returns
    -------
    list of str
    """
    allowed = list(SIDE_PARAM_NAMES) + [n for n in PARAM_NAMES if n.startswith("gait.")]
    return resolve_controls(keys, LATERAL_ALIASES, allowed,
                            " (six degrees of freedom: a per-side key such as gait.right_offset.shoulder_flap."
                            "amplitude_deg, a gait key, or right_amplitude, left_sweep, ...)")


def sides_parameters(cycle_p) -> np.ndarray:
    """The parameter vector of the per-side model (:data:`PARAM_NAMES`, the lateral inertias, the 42
    offsets) of a 6-DOF cycle's ``p`` (a symmetric cycle's gets zero offsets appended).

    Parameters
    ----------
    cycle_p : array_like
        The cycle's parameter vector.

    Returns
    -------
    ndarray
    """
    p = np.asarray(cycle_p, float)
    n = len(PARAM_NAMES) + 3
    return np.concatenate([p, np.zeros(len(SIDE_PARAM_NAMES))]) if p.size == n else p


def lateral_wingbeat_map(res, cfg: Config | None = None, controls=LATERAL_CONTROLS,
                         updates_per_beat: int = 1) -> WingbeatMap:
    """The exact linearised wingbeat map of a converged 6-DOF cycle on its 8 states (heading excluded).

    Parameters
    ----------
    res : LateralTrimResult
        A converged :func:`birdocp.studies.lateral.lateral_trim` (symmetric or asymmetric gait).
    cfg : Config, optional
        Its configuration (default: the reference case in six degrees of freedom).
    controls : sequence of str
        Per-side or gait keys, or aliases (default :data:`LATERAL_CONTROLS`), per deg.
    updates_per_beat : int
        N >= 1 intervals; must divide the RK4 steps per period.

    Returns
    -------
    WingbeatMap
        ``A`` (N, n, n), ``B`` (N, n, m) with n = 8, or 8 + the aerodynamic states of ``aero.unsteady =
        "wagner"`` / ``aero.section = "dynamic-stall"`` (then ``manifold`` holds the slope of their
        quasi-steady manifold over the 8 body states); ``param_names`` the per-side model's.
    """
    cfg = cfg or with_values(Config(), {"model.degrees_of_freedom": 6})
    controls = resolve_lateral_controls(controls)
    c = res.cycle
    if not c.success:
        raise ValueError("the 6-DOF cycle did not converge: the wingbeat map needs a converged cycle")
    steps, N = int(c.method["steps_per_period"]), int(updates_per_beat)
    if N < 1 or steps % N:
        raise ConfigError("--updates-per-beat", f"must be >= 1 and divide the RK4 steps per period ({steps}), got {N}")
    six = sixdof_model(cfg, sides=True)
    names = list(six.ode.param_names)
    p = sides_parameters(c.p)
    x0 = np.delete(complete_state6(six, c.x0, p), HEADING)  # the heading dropped; then the aerodynamic states
    model = SimpleNamespace(ode=six.ode_no_heading, data=six.data, model=six)
    xs, A, B = linearise(model, x0, p, steps, N, [names.index(k) for k in controls])
    v = res.validity
    S = manifold_slopes6(six, xs, np.arange(N) * (six.period_s / N), p) if n_aero_states(six) else None
    return WingbeatMap(list(controls), N, steps, x0, p, xs, A, B, v.to_dict() if v is not None else None,
                       param_names=tuple(names), state_names=STATE_NAMES[:HEADING], manifold=S)


def design_lateral_controller(res, cfg: Config | None = None, controls=LATERAL_CONTROLS,
                              updates_per_beat: int = 1, *, Q=None, R=None,
                              limit_deg: float = DEFAULT_LIMIT_DEG) -> Controller:
    """The periodic LQR of the 6-DOF wingbeat map (heading excluded) and each control's analysis.

    Parameters
    ----------
    res : LateralTrimResult
        A converged 6-DOF cycle (:func:`lateral_reference_cycle`).
    cfg : Config, optional
        Its configuration.
    controls : sequence of str
        Per-side or gait keys, or aliases (default :data:`LATERAL_CONTROLS`).
    updates_per_beat : int
        N corrections per beat.
    Q, R : array, optional
        Weights (default Bryson's rule: :data:`ACCEPTABLE_STATE_6DOF`, 5 deg per joint).
    limit_deg : float
        Joint range of each control around its cycle value [deg] (the simulation saturates there).

    Returns
    -------
    Controller
        Gains ``K`` (N, m, 8) in deg per state unit; ``to_dict`` as the planar controller's, with
        ``state_names``. With aerodynamic states the LQR is designed on the full map (their memory
        from beat to beat is part of the dynamics) with no weight on them, and the gains applied are on
        the 8 body states, the aerodynamic columns folded in through the quasi-steady manifold's slope
        (:func:`birdocp.studies.control_aero.body_gains`; ``K_full`` keeps the full-state gains, the
        closed loop is evaluated on the full map).
    """
    cfg = cfg or with_values(Config(), {"model.degrees_of_freedom": 6})
    wm = lateral_wingbeat_map(res, cfg, controls, updates_per_beat)
    Qd, Rd = bryson_weights(cfg, wm.controls, ACCEPTABLE_STATE_6DOF)
    Q = pad_weight(Qd if Q is None else Q, wm.n_states)  # no weight on the aerodynamic states
    R = Rd if R is None else np.asarray(R, float)
    limits = default_limits(cfg, wm.controls, wm.p, limit_deg, names=wm.param_names)
    return controller_on_map(wm, Q, R, limits)


def lateral_reference_cycle(cfg: Config, level: bool = False):
    """The 6-DOF cycle to control: :func:`birdocp.studies.lateral.lateral_trim` of ``cfg``, or with
    ``level`` the level-flight amplitude solved first and the cycle re-trimmed at it (a fixed
    amplitude, the one the per-side amplitude corrections add to). Returns ``(result, cfg)``.

    Parameters
    ----------
    cfg : Config
        Six-degree-of-freedom configuration.
    level : bool
        Solve the level-flight amplitude first.

    Returns
    -------
    result : cycle result
        The 6-DOF trim, or the failed level result.
    cfg : Config
        The configuration of the cycle.
    """
    from birdocp.bird.keys import AMPLITUDE_KEY
    from birdocp.studies.lateral import lateral_trim

    if not level:
        return lateral_trim(cfg), cfg
    lv = lateral_trim(cfg, level=True)
    if not lv.success:
        return lv, cfg
    cfg2 = with_values(cfg, {AMPLITUDE_KEY: lv.amplitude_deg})
    return lateral_trim(cfg2, x_guess=lv.cycle.x0), cfg2


def sides_parameter_vector(cfg: Config) -> np.ndarray:
    """The per-side model's parameter vector of ``cfg`` (:data:`PARAM_NAMES`, the lateral inertias,
    the 42 offsets of :data:`birdocp.bird.sides.SIDE_PARAM_NAMES`).

    Parameters
    ----------
    cfg : Config
        Six-degree-of-freedom configuration.

    Returns
    -------
    ndarray
    """
    from birdocp.bird.sides import side_vector
    from birdocp.bird.sixdof import LateralInertia

    six = sixdof_model(cfg, sides=True)
    return np.asarray(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg)), float)
