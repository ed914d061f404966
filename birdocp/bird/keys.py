"""Parameter keys of the bird model (the named ones and their aliases) and the constants that go with
them, each defined here once and imported everywhere else."""
from __future__ import annotations

from birdocp.bird.config import PARAM_NAMES, ConfigError, suggest

__all__ = ["AMPLITUDE_KEY", "AMPLITUDE_BOUNDS_DEG", "ROOT_AHEAD_KEY", "KEY_ALIASES", "JURY_MARGIN", "resolve_key"]

AMPLITUDE_KEY = "gait.shoulder_flap.amplitude_deg"
"""The flapping amplitude (degrees): the decision variable of level flight."""
AMPLITUDE_BOUNDS_DEG = (20.0, 70.0)
"""Default bounds of the flapping amplitude [deg] wherever it is solved for (level flight, the gait
and stability optimisations, continuation with level flight held)."""
ROOT_AHEAD_KEY = "wing.root_ahead_m"
"""The wing root's distance ahead of the centre of mass (metres): minus the stability margin times
the reference chord."""
JURY_MARGIN = 1e-6
"""The Jury quantities are bounded below by this margin, not 0: the criterion needs the strict
inequalities, and with ``>= 0`` an optimiser finds degenerate points of the Jury table (an equality in
an intermediate row) where multipliers lie outside the circle (seen: r = 0.944 with a multiplier of
modulus 1.034). With the margin every feasible point has all multipliers strictly inside the circle
of radius r, at the cost of r exceeding the spectral radius by about the margin."""
KEY_ALIASES = {
    "amplitude": AMPLITUDE_KEY, "amplitude_deg": AMPLITUDE_KEY,
    "root_ahead_m": ROOT_AHEAD_KEY, "root-ahead": ROOT_AHEAD_KEY, "root_ahead": ROOT_AHEAD_KEY,
}


def resolve_key(key: str, what: str = "free") -> str:
    """A :data:`~birdocp.bird.config.PARAM_NAMES` entry from a dotted key or an alias.

    Parameters
    ----------
    key : str
        Dotted key or alias (e.g. ``amplitude``, ``root_ahead_m``).
    what : str
        Key named by the error.

    Returns
    -------
    str
        The dotted key.

    Raises
    ------
    ConfigError
        On ``what`` (the field at fault), with a did-you-mean suggestion, if the key is unknown.
    """
    k = KEY_ALIASES.get(str(key).strip(), str(key).strip())
    if k not in PARAM_NAMES:
        raise ConfigError(what, f"unknown parameter '{key}'" + suggest(k, list(PARAM_NAMES) + list(KEY_ALIASES))
                          + " (a model parameter: a number of body, wing, gait or aero.air_density_kgm3/"
                            "lift_slope_per_rad, or an alias: amplitude, root_ahead_m)")
    return k
