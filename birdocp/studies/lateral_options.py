"""The level-flight options of a six-degree-of-freedom solve, checked without the model (no CasADi
import: bad options are refused before anything is built)."""

from __future__ import annotations

from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.io.errors import ConfigError

__all__ = ["level_keywords"]


def level_keywords(level_options: dict | None) -> dict:
    """:func:`birdocp.studies.lateral.lateral_trim` keywords of level flight from the planar level's
    options (``free``, ``constrain``, ``bounds``, ``climb_rate_mps``, ``target``): in six degrees of
    freedom level flight solves the flapping amplitude for a mean vertical speed; any other free key
    or condition is a :class:`~birdocp.io.errors.ConfigError` naming the option.

    Parameters
    ----------
    level_options : dict or None
        The planar level's options.

    Returns
    -------
    dict
        ``level``, ``climb_rate_mps`` and, if given, ``bounds``.
    """
    o = dict(level_options or {})
    if o.get("free", AMPLITUDE_KEY) not in (AMPLITUDE_KEY, "amplitude"):
        raise ConfigError("--free", "with model.degrees_of_freedom = 6 level flight solves the amplitude only; "
                                    "drop --free")
    if o.get("constrain", "vertical_speed_mps") != "vertical_speed_mps" or o.get("target") is not None:
        raise ConfigError("--constrain", "with model.degrees_of_freedom = 6 level flight holds the mean vertical "
                                         "speed only; drop --constrain and --target")
    out = {"level": True, "climb_rate_mps": float(o.get("climb_rate_mps", 0.0))}
    if o.get("bounds") is not None:
        out["bounds"] = tuple(o["bounds"])
    return out
