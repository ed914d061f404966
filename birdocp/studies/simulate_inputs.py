"""The inputs of a nonlinear simulation (:mod:`birdocp.studies.simulate`): the state deviations
(``--perturb``), the gusts (``--gust``) and the ranges they must lie in.

Split from :mod:`birdocp.studies.simulate` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from birdocp.bird.config import ConfigError
from birdocp.bird.model import STATE_NAMES


STATE_ALIASES = {"u": 0, "w": 1, "q": 2, "theta": 3, **{n: i for i, n in enumerate(STATE_NAMES)}}
DIRECTIONS = ("vertical", "horizontal")

MAX_SPEED_MPS = 340.0
"""Largest speed (state u, w; a wind, a gust or a perturbation of them) in the model's range: the
speed of sound at sea level. The model's air is incompressible, so beyond it nothing it computes
is physics; a simulation whose speed passes it has diverged."""
MAX_PITCH_RATE_RADPS = 1000.0
"""Largest pitch rate |q| in the model's range (about 160 turns per second)."""
MAX_PITCH_PERTURBATION_RAD = math.pi
"""Largest pitch perturbation (a pitch beyond +-180 deg is the same attitude)."""
GUST_LENGTH_BEATS = (0.01, 1.0e4)
"""A gust's length in beats: from a hundredth of a beat (shorter is not resolved by the RK4 grid) to
10,000 beats (a constant wind: use --wind)."""
GUST_LENGTH_M = (0.01, 1.0e6)
"""A gust's length in metres (1 cm to 1,000 km)."""
MAX_GUST_START_BEATS = 1.0e4
"""Farthest gust start, in beats (no simulation flies farther: ``--beats`` is at most 10,000)."""


def check_speed(flag: str, what: str, value: float) -> float:
    """``value`` [m/s] if finite and at most :data:`MAX_SPEED_MPS` in size, else ConfigError on ``flag``.

    Parameters
    ----------
    flag : str
        Flag named by the error.
    what : str
        What the speed is, for the message.
    value : float
        Speed [m/s].

    Returns
    -------
    float
    """
    if not math.isfinite(value) or abs(value) > MAX_SPEED_MPS:
        raise ConfigError(flag, f"{what} must lie within +-{MAX_SPEED_MPS:g} m/s (the speed of sound: the model's "
                                f"air is incompressible), got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Gust:
    """A 1 - cos gust, frozen in the air.

    Attributes
    ----------
    direction
        'vertical' (positive up) or 'horizontal' (positive along the flight direction, i.e. a
        tailwind; negative = headwind).
    amplitude_mps
        peak wind speed of the gust [m/s].
    length_beats, length_m
        its length in wingbeats (of the cycle's flight distance) or in metres (``length_m`` wins
        when given).
    start_beats, start_m
        how far ahead of the bird it starts, in beats or in metres (``start_m`` wins when given).
    """

    direction: str
    amplitude_mps: float
    length_beats: float | None = 1.0
    length_m: float | None = None
    start_beats: float = 1.0
    start_m: float | None = None

    def __post_init__(self):
        if self.direction not in DIRECTIONS:
            raise ConfigError("--gust", f"direction must be vertical or horizontal, got '{self.direction}'")
        check_speed("--gust", "the amplitude", self.amplitude_mps)
        in_m = self.length_m is not None
        length = self.length_m if in_m else self.length_beats
        lo, hi = GUST_LENGTH_M if in_m else GUST_LENGTH_BEATS
        unit = "m" if in_m else "beats"
        if length is None or not (math.isfinite(length) and lo <= length <= hi):
            raise ConfigError("--gust", f"the length must lie in {lo:g}..{hi:g} {unit} (shorter is not resolved by "
                                        f"the RK4 grid, longer is a constant wind: --wind), got {length}")
        start = self.start_m if self.start_m is not None else self.start_beats
        top = MAX_GUST_START_BEATS * (1e3 if self.start_m is not None else 1.0)
        if not (math.isfinite(start) and 0 <= start <= top):
            raise ConfigError("--gust-start", f"must lie in 0..{top:g} (no simulation flies farther), got {start}")

    def span_m(self, beat_m: float) -> tuple[float, float]:
        """(start, length) in metres given the distance flown per beat.

        Parameters
        ----------
        beat_m : float
            Distance flown per beat [m].

        Returns
        -------
        start_m, length_m : float
        """
        start = self.start_m if self.start_m is not None else self.start_beats * beat_m
        length = self.length_m if self.length_m is not None else self.length_beats * beat_m
        return float(start), float(length)


def parse_gust(text: str) -> Gust:
    """``vertical|horizontal=MPS:LENGTH`` (LENGTH in beats, or metres with a trailing 'm').

    Parameters
    ----------
    text : str
        The gust's text.

    Returns
    -------
    Gust
    """
    try:
        direction, rest = text.split("=", 1)
        amp, length = rest.split(":", 1)
        length = length.strip()
        kw = ({"length_m": float(length[:-1]), "length_beats": None} if length.endswith("m")
              else {"length_beats": float(length)})
        return Gust(direction.strip(), float(amp), **kw)
    except ValueError as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError("--gust", f"expected vertical|horizontal=MPS:BEATS (or MPS:METRESm), got '{text}'") from None


def parse_state_values(items, aliases: dict, n: int, known: str, check) -> np.ndarray:
    """The sum of ``KEY=VALUE`` state deviations (``--perturb``) as a vector of ``n`` states: each KEY
    looked up in ``aliases`` (name -> index; ``known`` lists them in the error), each value checked by
    ``check(key, index, value, text)`` (raises :class:`ConfigError` naming ``--perturb``).

    Parameters
    ----------
    items : sequence of str
        ``KEY=VALUE`` texts.
    aliases : dict of str to int
        State name to index.
    n : int
        Number of states.
    known : str
        The names, for the error.
    check : callable
        ``check(key, index, value, text)``.

    Returns
    -------
    ndarray, shape (n,)
    """
    dx = np.zeros(n)
    for text in items or []:
        try:
            key, val = text.split("=", 1)
            v = float(val)
        except ValueError:
            raise ConfigError("--perturb", f"expected KEY=VALUE, got '{text}'") from None
        key = key.strip()
        if key not in aliases:
            raise ConfigError("--perturb", f"unknown state '{key}' ({known})")
        check(key, aliases[key], v, val)
        dx[aliases[key]] += v
    return dx


def _check_planar_deviation(key: str, i: int, v: float, val: str) -> None:
    if i < 2:
        check_speed("--perturb", f"'{key}'", v)
        return
    top, unit, why = ((MAX_PITCH_RATE_RADPS, "rad/s", "the model's range of pitch rates") if i == 2 else
                      (MAX_PITCH_PERTURBATION_RAD, "rad", "a larger pitch is the same attitude"))
    if not (math.isfinite(v) and abs(v) <= top):
        raise ConfigError("--perturb", f"'{key}' must lie within +-{top:g} {unit} ({why}), got {val}")


def parse_perturbation(items) -> np.ndarray:
    """``KEY=VALUE`` state perturbations (u, w [m/s], q [rad/s], theta [rad]; or the state names).

    Parameters
    ----------
    items : sequence of str
        ``KEY=VALUE`` texts (``--perturb``).

    Returns
    -------
    ndarray, shape (4,)
    """
    return parse_state_values(items, STATE_ALIASES, 4, f"one of u, w, q, theta or {', '.join(STATE_NAMES)}",
                              _check_planar_deviation)
