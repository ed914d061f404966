"""The controls of the wingbeat-to-wingbeat feedback (:mod:`birdocp.studies.control`): control keys and
their aliases, Bryson's-rule weights and the joint limits.

Split from :mod:`birdocp.studies.control` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

import math

import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, get_value, suggest

__all__ = ["DEFAULT_CONTROLS", "ACCEPTABLE_STATE", "ACCEPTABLE_CONTROL_DEG", "DEFAULT_LIMIT_DEG", "CONTROL_ALIASES",
           "GAIT_HINT", "resolve_controls", "bryson_weights", "default_limits"]


DEFAULT_CONTROLS = ("gait.shoulder_incidence.offset_deg", "gait.shoulder_flap.amplitude_deg",
                    "gait.shoulder_sweep.offset_deg")
"""Shoulder incidence offset (wing pitch), flapping amplitude and sweep offset."""
ACCEPTABLE_STATE = (1.0, 1.0, 1.0, math.radians(5.0))
"""Acceptable deviations at a beat start for Bryson's rule: u [m/s], w [m/s], q [rad/s], theta [rad]."""
ACCEPTABLE_CONTROL_DEG = 5.0
"""Acceptable correction of a joint angle (offset or amplitude) for Bryson's rule [deg]."""
DEFAULT_LIMIT_DEG = 15.0
"""Joint range of a control around its cycle value [deg] (the simulation saturates there)."""

CONTROL_ALIASES = {
    "incidence": "gait.shoulder_incidence.offset_deg", "amplitude": "gait.shoulder_flap.amplitude_deg",
    "sweep": "gait.shoulder_sweep.offset_deg", "flap_offset": "gait.shoulder_flap.offset_deg",
}


GAIT_HINT = " (a gait key such as gait.shoulder_sweep.offset_deg, or incidence, amplitude, sweep)"


def resolve_controls(keys, aliases: dict = CONTROL_ALIASES, allowed=None, hint: str = GAIT_HINT) -> list[str]:
    """Control keys (dotted :data:`PARAM_NAMES` entries of the gait, or an alias).

    Parameters
    ----------
    keys : iterable of str
        Keys or aliases; an unknown, non-gait or repeated key is a ConfigError.
    aliases : dict
        Alias to dotted key (default :data:`CONTROL_ALIASES`; other maps, e.g. the 6-DOF per-side ones).
    allowed : sequence of str, optional
        The keys accepted (default: the gait keys of :data:`PARAM_NAMES`).
    hint : str
        Text appended to the error.

    Returns
    -------
    list of str
    """
    allowed = [n for n in PARAM_NAMES if n.startswith("gait.")] if allowed is None else list(allowed)
    out = []
    for key in keys:
        k = aliases.get(str(key).strip(), str(key).strip())
        if k not in allowed:
            raise ConfigError("--controls", f"unknown control '{key}'" + suggest(k, allowed + list(aliases)) + hint)
        if k in out:
            raise ConfigError("--controls", f"control '{k}' given twice")
        out.append(k)
    if not out:
        raise ConfigError("--controls", "give at least one control key")
    return out


def _acceptable(cfg: Config, key: str) -> float:
    if key.endswith("_deg"):
        return ACCEPTABLE_CONTROL_DEG
    return max(0.05 * abs(float(get_value(cfg, key))), 1e-6)


def bryson_weights(cfg: Config, controls, acceptable_state=ACCEPTABLE_STATE, acceptable_control=None):
    """(Q, R) = (diag(1/dx_max^2), diag(1/du_max^2)): Bryson's rule in the state's and controls' own units.

    Parameters
    ----------
    cfg : Config
        Configuration (the controls' units).
    controls : sequence of str
        Control keys.
    acceptable_state : sequence of float
        One value per state (default :data:`ACCEPTABLE_STATE`, the planar 4).
    acceptable_control : sequence of float, optional
        One value per control (default :data:`ACCEPTABLE_CONTROL_DEG`).

    Returns
    -------
    Q, R : ndarray
    """
    dx = np.asarray(acceptable_state, float)
    du = (np.array([_acceptable(cfg, k) for k in controls]) if acceptable_control is None
          else np.asarray(acceptable_control, float))
    if dx.ndim != 1 or not np.all(dx > 0) or du.shape != (len(controls),) or not np.all(du > 0):
        raise ConfigError("weights", "acceptable deviations must be positive: one per state, one per control")
    return np.diag(1.0 / dx ** 2), np.diag(1.0 / du ** 2)


def default_limits(cfg: Config, controls, p, limit_deg: float = DEFAULT_LIMIT_DEG, names=PARAM_NAMES) -> np.ndarray:
    """(m, 2) absolute joint limits: the cycle value +- ``limit_deg`` (amplitudes not below 0, angles within
    [-180, 180] deg); other units +- 20 %. A per-side offset's limits are those of the offset itself.

    Parameters
    ----------
    cfg : Config
        Configuration.
    controls : sequence of str
        Control keys.
    p : array_like
        Parameter vector of the cycle.
    limit_deg : float
        Half-width of an angle's range [deg].
    names : sequence of str
        Names of ``p`` (default :data:`PARAM_NAMES`).

    Returns
    -------
    ndarray, shape (m, 2)
    """
    out = []
    for k in controls:
        v = float(p[list(names).index(k)])
        if k.endswith("_deg"):
            lo, hi = max(v - limit_deg, -180.0), min(v + limit_deg, 180.0)
            if k.endswith("amplitude_deg") and "_offset." not in k:
                lo = max(lo, 0.0)
        else:
            lo, hi = v - 0.2 * abs(v), v + 0.2 * abs(v)
        out.append((lo, hi))
    return np.array(out, float)
