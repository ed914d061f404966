"""Configuration checks: the allowed values and physical limits of every key, and :func:`validate`.

Part of :mod:`birdocp.bird.config` (which re-exports the public names): the section dataclasses live
there, this module knows them only by their attributes (no import of the dataclasses), so that
:class:`~birdocp.bird.config.Config` can run :func:`validate` on construction. Every problem is a
:class:`~birdocp.io.errors.ConfigError` whose one-line message names the dotted key, the value and
what is allowed.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import fields, is_dataclass
from typing import Any

from birdocp.bird.collocation import COLLOCATIONS, NORMALWASHES
from birdocp.bird.span import SPAN_DIRECTIONS
from birdocp.bird.subdivide import MAX_SUBDIVISIONS
from birdocp.io.errors import ConfigError

__all__ = [
    "JOINT_NAMES", "CIRCULATION_MODES", "KINEMATIC_VELOCITY_MODES", "UNSTEADY_MODES", "SECTION_MODES",
    "UNSTEADY_PARAMS", "SIX_DOF_UNSUPPORTED", "WING_MASS_SHARES", "ANGLE_LIMIT_DEG", "MAX_POINTS",
    "MAX_STEPS_PER_PERIOD", "MAX_SOLVE_ITERATIONS", "MAX_GUESS_SPEED_MPS", "get_value", "flat_keys", "suggest", "coerce",
    "check_number", "parse_scalar", "validate", "require_body_states", "has_aero_states", "SIDE_KEYS", "asymmetric",
    "SOLVE_SOLVERS",
]


# Joint names in the order of the model's slots (docs/model.md §2.1). Docstrings carry the paper's names.
JOINT_NAMES = (
    "shoulder_incidence", "shoulder_flap", "shoulder_sweep",
    "elbow_flex", "hand_twist", "wrist_flex", "wrist_spread",
)

CIRCULATION_MODES = ("exact", "relaxed")
KINEMATIC_VELOCITY_MODES = ("exact", "backward-difference")
UNSTEADY_MODES = ("none", "wagner")
SECTION_MODES = ("linear", "stall", "dynamic-stall")
UNSTEADY_PARAMS = ("wagner_weight", "wagner_time_scale", "pitch_rate_weight", "added_mass_weight",
                   "separation_angle_deg", "flat_plate_cd90", "separation_lag_semichords",
                   "separation_delay_semichords")
"""The numeric keys of the unsteady and stall-aware aerodynamics (``aero.<name>``; numbers in ``p``,
see docs/model_unsteady.md)."""

SIX_DOF_UNSUPPORTED: tuple = ()
"""Planar terms not yet written in three dimensions, as (key, what) pairs: with model.degrees_of_freedom
= 6 each of these keys must be 0 (none left: the tail, the wing masses with symmetric and asymmetric
gaits, the optional drag terms and the unsteady and stall-aware sections are written in 3-D)."""

def get_value(cfg: Any, key: str) -> Any:
    """The value of a dotted key (``"gait.shoulder_flap.amplitude_deg"``, ``"wing.feather_lengths_m.3"``).

    Parameters
    ----------
    cfg : Config or section
        Configuration.
    key : str
        Dotted key.

    Returns
    -------
    Any
    """
    obj = cfg
    for part in key.split("."):
        if isinstance(obj, tuple):
            obj = obj[int(part)]
        else:
            obj = getattr(obj, part)
    return obj

def flat_keys(obj: Any, prefix: str = "") -> list[str]:
    """The dotted keys of every leaf value of a configuration or section (``prefix`` prepended).

    Parameters
    ----------
    obj : Config or section
        Configuration.
    prefix : str
        Text prepended to each key.

    Returns
    -------
    list of str
    """
    keys = []
    for f in fields(obj):
        v = getattr(obj, f.name)
        k = f"{prefix}{f.name}"
        if is_dataclass(v):
            keys += flat_keys(v, k + ".")
        else:
            keys.append(k)
    return keys

def suggest(key: str, candidates) -> str:
    """``"; did you mean 'X'?"`` for the closest of ``candidates``, else ``""``.

    Parameters
    ----------
    key : str
        The unknown name.
    candidates : iterable of str
        Known names.

    Returns
    -------
    str
    """
    match = difflib.get_close_matches(key, list(candidates), n=1, cutoff=0.6)
    return f"; did you mean '{match[0]}'?" if match else ""


def coerce(key: str, default: Any, value: Any) -> Any:
    """Check ``value`` against the type of ``default``; return the converted value.

    Parameters
    ----------
    key : str
        Dotted key, named by the error.
    default : Any
        Default value (its type is the one wanted).
    value : Any
        Value given.

    Returns
    -------
    Any
    """
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(key, f"expected true or false, got {value!r}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                return int(value)
            raise ConfigError(key, f"expected an integer, got {value!r}")
        return value
    if isinstance(default, float):
        return check_number(key, value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(key, f"expected a string, got {value!r}")
        return value
    if isinstance(default, tuple):
        if not isinstance(value, (list, tuple)):
            raise ConfigError(key, f"expected a list of numbers, got {value!r}")
        return tuple(check_number(f"{key}.{i}", v) for i, v in enumerate(value))
    raise ConfigError(key, f"unsupported value {value!r}")


def parse_scalar(text: str) -> Any:
    """Parse a ``--set`` value as a TOML value; bare words are strings.

    Parameters
    ----------
    text : str
        The value's text.

    Returns
    -------
    Any
    """
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text
    except RecursionError:
        raise ConfigError("--set", f"the value '{text[:40]}...' is nested too deeply") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise ConfigError("--set", f"the value '{text[:40]}...' cannot be read: {exc}") from None


# (lower, upper, inclusive-lower) physical ranges; angles in a documented range.
_POSITIVE = {
    "body.mass_kg", "body.pitch_inertia_kgm2", "body.reference_chord_m",
    "wing.arm_length_m", "wing.forearm_length_m", "wing.hand_length_m",
    "wing.shoulder_half_separation_m", "wing.section_half_thickness_m", "wing.smoothing_radius_m",
    "gait.frequency_hz", "aero.air_density_kgm3", "aero.lift_slope_per_rad", "aero.backward_step_s",
    "tail.root_behind_m", "tail.length_m", "tail.kinematic_viscosity_m2ps", "tail.reynolds_speed_mps",
    "drag.body_frontal_area_m2", "body.gravity_mps2",
}
ANGLE_LIMIT_DEG = 180.0
MAX_POINTS = 500
"""Upper bound of solve.points (shooting points per period)."""
MAX_STEPS_PER_PERIOD = 10000
"""Upper bound of solve.steps_per_period: the RK4 graphs and the data grid grow with it (the
reference case uses 148)."""
"""Joint offsets and amplitudes must lie in [-180, 180] deg, phases in [-360, 360] deg."""


_UPPER = {
    "body.mass_kg": (1.0e4, "kg"), "body.pitch_inertia_kgm2": (1.0e4, "kg m^2"),
    "body.gravity_mps2": (100.0, "m/s^2 (10 g)"), "body.reference_chord_m": (100.0, "m"),
    "wing.arm_length_m": (100.0, "m"), "wing.forearm_length_m": (100.0, "m"), "wing.hand_length_m": (100.0, "m"),
    "wing.shoulder_half_separation_m": (100.0, "m"), "wing.section_half_thickness_m": (100.0, "m"),
    "wing.smoothing_radius_m": (100.0, "m"), "wing.mass_kg": (1.0e4, "kg"),
    "gait.frequency_hz": (1000.0, "Hz"), "aero.air_density_kgm3": (100.0, "kg/m^3 (the air at the surface of "
                                                                          "Venus is 65)"),
    "aero.lift_slope_per_rad": (100.0, "per rad (thin-airfoil theory gives 2 pi)"),
    "aero.backward_step_s": (1.0, "s"), "tail.root_behind_m": (100.0, "m"), "tail.length_m": (100.0, "m"),
    "tail.kinematic_viscosity_m2ps": (1.0, "m^2/s (air 1.5e-5)"),
    "tail.reynolds_speed_mps": (340.0, "m/s (the speed of sound: the air of the model is incompressible)"),
    "drag.body_frontal_area_m2": (100.0, "m^2"), "drag.body_drag_coefficient": (100.0, ""),
    "drag.profile_drag_coefficient": (100.0, ""),
}
"""Largest physical value of a configuration number (with its unit and, where useful, why): beyond
it the model's numbers overflow or stop meaning anything, so it is bad input before any work."""
MAX_SOLVE_ITERATIONS = 100000
"""Upper bound of solve.max_iter."""
MAX_GUESS_SPEED_MPS = 340.0
"""Largest |u|, |w| of ``solve.initial_guess`` (the speed of sound)."""


def check_number(key: str, value: Any) -> float:
    """``value`` as a finite float, else a ConfigError on ``key``.

    Parameters
    ----------
    key : str
        Dotted key, named by the error.
    value : Any
        Value given.

    Returns
    -------
    float
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(key, f"expected a number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits
        raise ConfigError(key, f"an integer of {len(str(abs(value)))} digits is too large for a number; "
                               "give a value in the key's physical range") from None
    if not math.isfinite(number):
        raise ConfigError(key, f"must be finite, got {value!r}")
    return number


def _check_range(key: str, value: float) -> None:
    """The physical range of a positive quantity (:data:`_POSITIVE`) or one with an upper bound (:data:`_UPPER`)."""
    if key in _POSITIVE and value <= 0:
        why = " (without weight there is no flight to trim: lift, power and cost of transport are per weight)" \
            if key == "body.gravity_mps2" else ""
        raise ConfigError(key, f"must be > 0, got {value!r}{why}")
    if key in _UPPER and value > _UPPER[key][0]:
        hi, unit = _UPPER[key]
        raise ConfigError(key, f"must be at most {hi:g} {unit}".rstrip() + f", got {value!r}")


SOLVE_SOLVERS = ("auto", "ipopt", "lm", "newton-picard")
"""The values of ``solve.solver``."""


def _validate_solve(cfg: Any) -> None:
    """The checks of ``[solve]`` (part of :func:`validate`)."""
    s = cfg.solve
    if s.points < 2:
        raise ConfigError("solve.points", f"must be >= 2 (the closing point included), got {s.points!r}")
    if s.points > MAX_POINTS:
        raise ConfigError("solve.points", f"must be <= {MAX_POINTS}, got {s.points!r}")
    if s.steps_per_period > MAX_STEPS_PER_PERIOD:
        raise ConfigError("solve.steps_per_period",
                          f"must be <= {MAX_STEPS_PER_PERIOD} (the reference uses 148), got {s.steps_per_period!r}")
    if s.steps_per_period < 1 or s.steps_per_period % (s.points - 1):
        raise ConfigError("solve.steps_per_period",
                          f"must be a positive multiple of points - 1 = {s.points - 1}, got {s.steps_per_period!r}")
    if s.solver not in SOLVE_SOLVERS:
        raise ConfigError("solve.solver", f"must be one of {', '.join(SOLVE_SOLVERS)}, got {s.solver!r}")
    if s.derivatives not in ("exact", "fd"):
        raise ConfigError("solve.derivatives", f"must be 'exact' or 'fd', got {s.derivatives!r}")
    if s.derivatives == "fd" and s.solver != "lm":
        raise ConfigError("solve.derivatives", "'fd' (finite-difference Jacobians) needs solve.solver = 'lm' "
                                               "(--solver lm); IPOPT runs on exact derivatives")
    if isinstance(s.max_iter, bool) or not 1 <= s.max_iter <= MAX_SOLVE_ITERATIONS:
        raise ConfigError("solve.max_iter", f"must be an integer in [1, {MAX_SOLVE_ITERATIONS}], got {s.max_iter!r}")
    if not 0.0 <= s.tol < 1.0:
        raise ConfigError("solve.tol", f"must lie in [0, 1) (0: the solver's default, 1e-10 for ipopt, 1e-5 for "
                                       f"lm), got {s.tol!r}")
    if s.solver == "newton-picard" and not has_aero_states(cfg):
        raise ConfigError("solve.solver", "'newton-picard' needs aerodynamic states to iterate by Picard "
                                          "(aero.unsteady = 'wagner' or aero.section = 'dynamic-stall'); use 'auto', "
                                          "'ipopt' or 'lm'")
    if len(s.initial_guess) != 4:
        raise ConfigError("solve.initial_guess", f"needs 4 numbers (u, w, q, theta), got {len(s.initial_guess)}")
    for i, v in enumerate(s.initial_guess):
        v = check_number(f"solve.initial_guess.{i}", v)
        if i < 2 and abs(v) > MAX_GUESS_SPEED_MPS:
            raise ConfigError(f"solve.initial_guess.{i}", f"must lie within +-{MAX_GUESS_SPEED_MPS:g} m/s (the speed "
                                                          f"of sound: the model's air is incompressible), got {v!r}")


def _validate_span(cfg: Any) -> None:
    """``aero.span_direction``, ``aero.span_subdivisions`` (1..8, > 1 with the linear section only) and
    ``aero.collocation`` (``three_quarter`` with the linear section only) and ``aero.normalwash``
    (``tangency`` with the linear section only)."""
    if cfg.aero.span_direction not in SPAN_DIRECTIONS:
        raise ConfigError("aero.span_direction",
                          f"must be one of {', '.join(SPAN_DIRECTIONS)}; got {cfg.aero.span_direction!r}")
    k = cfg.aero.span_subdivisions
    if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= MAX_SUBDIVISIONS:
        raise ConfigError("aero.span_subdivisions", f"must be an integer in [1, {MAX_SUBDIVISIONS}], got {k!r}")
    if k > 1 and (cfg.aero.unsteady != "none" or cfg.aero.section != "linear"):
        raise ConfigError("aero.span_subdivisions", "> 1 needs the quasi-steady linear section "
                          "(aero.unsteady = 'none', aero.section = 'linear'); set it to 1")
    c = cfg.aero.collocation
    if c not in COLLOCATIONS:
        raise ConfigError("aero.collocation", f"must be one of {', '.join(COLLOCATIONS)}; got {c!r}")
    if c != "quarter" and (cfg.aero.unsteady != "none" or cfg.aero.section != "linear"):
        raise ConfigError("aero.collocation", f"{c!r} needs the quasi-steady linear section "
                          "(aero.unsteady = 'none', aero.section = 'linear'); set it to 'quarter'")
    law = cfg.aero.normalwash
    if law not in NORMALWASHES:
        raise ConfigError("aero.normalwash", f"must be one of {', '.join(NORMALWASHES)}; got {law!r}")
    if law != "angle" and (cfg.aero.unsteady != "none" or cfg.aero.section != "linear"):
        raise ConfigError("aero.normalwash", f"{law!r} needs the quasi-steady linear section "
                          "(aero.unsteady = 'none', aero.section = 'linear'); set it to 'angle'")


def validate(cfg: Any) -> None:
    """Raise :class:`ConfigError` on the first non-physical value.

    Parameters
    ----------
    cfg : Config
        Configuration.
    """
    for key in flat_keys(cfg):
        value = get_value(cfg, key)
        if isinstance(value, (str, tuple, bool)):
            continue
        if isinstance(value, int) and not isinstance(value, bool) and key.startswith(
                ("solve.", "aero.relaxed", "aero.newton", "model.degrees")):
            continue
        _check_range(key, check_number(key, value))
    for i, L in enumerate(cfg.wing.feather_lengths_m):
        check_number(f"wing.feather_lengths_m.{i}", L)
        if not 0 < L <= 100.0:
            raise ConfigError(f"wing.feather_lengths_m.{i}", f"must lie in (0, 100] m, got {L!r}")
    if len(cfg.wing.feather_lengths_m) != 7:
        raise ConfigError("wing.feather_lengths_m", f"needs 7 lengths, got {len(cfg.wing.feather_lengths_m)}")
    _validate_wing_mass(cfg)
    if not (-0.5 <= cfg.wing.root_ahead_m <= 0.5):
        raise ConfigError("wing.root_ahead_m", f"must lie in [-0.5, 0.5] m, got {cfg.wing.root_ahead_m!r}")
    for j in JOINT_NAMES:
        joint = getattr(cfg.gait, j)
        for name, lim in (("offset_deg", ANGLE_LIMIT_DEG), ("amplitude_deg", ANGLE_LIMIT_DEG),
                          ("phase_deg", 2 * ANGLE_LIMIT_DEG)):
            v = getattr(joint, name)
            if not -lim <= v <= lim:
                raise ConfigError(f"gait.{j}.{name}", f"must lie in [{-lim:g}, {lim:g}] deg, got {v!r}")
    _validate_sides(cfg)
    for key in ("drag.body_drag_coefficient", "drag.profile_drag_coefficient"):
        if get_value(cfg, key) < 0:
            raise ConfigError(key, f"must be >= 0 (0 = off), got {get_value(cfg, key)!r}")
    if not 0.0 <= cfg.tail.opening_angle_deg < 180.0:
        raise ConfigError("tail.opening_angle_deg", f"must lie in [0, 180) deg, got {cfg.tail.opening_angle_deg!r}")
    if not -90.0 < cfg.tail.incidence_deg < 90.0:
        raise ConfigError("tail.incidence_deg", f"must lie in (-90, 90) deg, got {cfg.tail.incidence_deg!r}")
    if cfg.aero.circulation not in CIRCULATION_MODES:
        raise ConfigError("aero.circulation", f"must be one of {', '.join(CIRCULATION_MODES)}; got {cfg.aero.circulation!r}")
    _validate_span(cfg)
    if cfg.aero.kinematic_velocity not in KINEMATIC_VELOCITY_MODES:
        raise ConfigError("aero.kinematic_velocity",
                          f"must be one of {', '.join(KINEMATIC_VELOCITY_MODES)}; got {cfg.aero.kinematic_velocity!r}")
    if not 1 <= cfg.aero.relaxed_evaluations <= 1000:
        raise ConfigError("aero.relaxed_evaluations", f"must be an integer in [1, 1000], got {cfg.aero.relaxed_evaluations!r}")
    _validate_unsteady(cfg)
    v = cfg.validity
    for name, lo, hi in (("stall_angle_deg", 0.0, 90.0), ("max_stalled_fraction", 0.0, 1.0),
                         ("max_abs_pitch_deg", 0.0, 180.0), ("max_airflow_body_angle_deg", 0.0, 180.0)):
        val = getattr(v, name)
        if not lo < val <= hi if name != "max_stalled_fraction" else not lo <= val <= hi:
            raise ConfigError(f"validity.{name}", f"must lie in ({lo:g}, {hi:g}], got {val!r}")
    _validate_solve(cfg)
    _validate_model(cfg)


SIDE_KEYS = tuple(f"gait.{side}.{j}.{field}" for side in ("right_offset", "left_offset") for j in JOINT_NAMES
                  for field in ("offset_deg", "amplitude_deg", "phase_deg"))
"""The per-side offset keys of an asymmetric gait (right wing's 21, then the left wing's)."""


def asymmetric(cfg: Any) -> bool:
    """True when a per-side offset (:data:`SIDE_KEYS`) is not zero.

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    bool
    """
    return any(get_value(cfg, k) != 0 for k in SIDE_KEYS)


def _validate_sides(cfg: Any) -> None:
    for key in SIDE_KEYS:
        base = get_value(cfg, key.replace(".right_offset", "").replace(".left_offset", ""))
        v = get_value(cfg, key) + base
        lim = 2 * ANGLE_LIMIT_DEG if key.endswith("phase_deg") else ANGLE_LIMIT_DEG
        if not -lim <= v <= lim:
            raise ConfigError(key, f"the wing's law (joint value + offset) must lie in [{-lim:g}, {lim:g}] deg, "
                                   f"got {v!r}")
    if asymmetric(cfg) and cfg.model.degrees_of_freedom != 6:
        key = next(k for k in SIDE_KEYS if get_value(cfg, k) != 0)
        raise ConfigError(key, "an asymmetric gait (per-side offset) needs model.degrees_of_freedom = 6; "
                               "set it or the offset to 0")


def _validate_model(cfg: Any) -> None:
    m = cfg.model
    if isinstance(m.degrees_of_freedom, bool) or m.degrees_of_freedom not in (4, 6):
        raise ConfigError("model.degrees_of_freedom", f"must be 4 or 6, got {m.degrees_of_freedom!r}")
    ixx, izz, ixz = m.roll_inertia_kgm2, m.yaw_inertia_kgm2, m.product_inertia_xz_kgm2
    for key, val in (("model.roll_inertia_kgm2", ixx), ("model.yaw_inertia_kgm2", izz)):
        if val <= 0:
            raise ConfigError(key, f"must be > 0 kg m^2, got {val!r}")
    if ixx * izz <= ixz ** 2:
        raise ConfigError("model.product_inertia_xz_kgm2", f"|I_xz| must be below sqrt(I_xx I_zz) = "
                                                           f"{math.sqrt(ixx * izz):.4g} kg m^2, got {ixz!r}")
    if m.degrees_of_freedom != 6:
        return
    for key, what in SIX_DOF_UNSUPPORTED:
        if get_value(cfg, key) != 0:
            raise ConfigError(key, f"{what}: not yet written in six degrees of freedom; set {key} = 0 "
                                   "or model.degrees_of_freedom = 4")


def has_aero_states(cfg: Any) -> bool:
    """Whether ``cfg``'s model has aerodynamic states (``aero.unsteady = "wagner"`` or
    ``aero.section = "dynamic-stall"``) besides the 4 body states.

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    bool
    """
    return cfg.aero.unsteady != "none" or cfg.aero.section == "dynamic-stall"


def require_body_states(cfg: Any, what: str, other: str = "") -> None:
    """Raise :class:`ConfigError` when ``cfg``'s model has aerodynamic states (``aero.unsteady =
    "wagner"`` or ``aero.section = "dynamic-stall"``) and ``what`` (a study) works on the 4 body
    states only; ``other``: the alternative that does work with them (named in the message).

    Parameters
    ----------
    cfg : Config
        Configuration.
    what : str
        The study, named by the error.
    other : str
        The alternative that works with aerodynamic states ("" for none).
    """
    if has_aero_states(cfg):
        raise ConfigError("aero.unsteady" if cfg.aero.unsteady != "none" else "aero.section",
                          f"{what} works on the 4 body states only (no lag or separation states yet): "
                          + (f"{other}, or " if other else "use ")
                          + "aero.unsteady = 'none' with aero.section = 'linear' or 'stall'")


def _validate_unsteady(cfg: Any) -> None:
    a = cfg.aero
    if a.unsteady not in UNSTEADY_MODES:
        raise ConfigError("aero.unsteady", f"must be one of {', '.join(UNSTEADY_MODES)}; got {a.unsteady!r}")
    if a.section not in SECTION_MODES:
        raise ConfigError("aero.section", f"must be one of {', '.join(SECTION_MODES)}; got {a.section!r}")
    if not 1 <= a.newton_steps <= 50:
        raise ConfigError("aero.newton_steps", f"must be an integer in [1, 50], got {a.newton_steps!r}")
    if a.circulation == "relaxed" and (a.unsteady != "none" or a.section != "linear"):
        raise ConfigError("aero.circulation", "'relaxed' works only with aero.unsteady = 'none' and aero.section = "
                                              "'linear'; use aero.circulation = 'exact'")
    if a.unsteady != "none" and (cfg.wing.mass_kg > 0 or cfg.wing.inertial_terms):
        raise ConfigError("aero.unsteady", "'wagner' with wing masses (wing.mass_kg > 0) is not supported yet; "
                                           "set wing.mass_kg = 0 or aero.unsteady = 'none'")
    for k in ("wagner_weight", "pitch_rate_weight", "added_mass_weight"):
        if not 0.0 <= getattr(a, k) <= 1.0:
            raise ConfigError(f"aero.{k}", f"must lie in [0, 1], got {getattr(a, k)!r}")
    for k in ("wagner_time_scale", "separation_angle_deg", "flat_plate_cd90", "separation_lag_semichords"):
        if not getattr(a, k) > 0:
            raise ConfigError(f"aero.{k}", f"must be > 0, got {getattr(a, k)!r}")
    if a.separation_angle_deg >= 90:
        raise ConfigError("aero.separation_angle_deg", f"must lie in (0, 90) deg, got {a.separation_angle_deg!r}")
    if a.separation_delay_semichords < 0:
        raise ConfigError("aero.separation_delay_semichords", f"must be >= 0, got {a.separation_delay_semichords!r}")


WING_MASS_SHARES = ("mass_share_arm", "mass_share_forearm", "mass_share_hand", "mass_share_primaries",
                    "mass_share_secondaries")
"""The keys of the wing-mass distribution (shares of ``wing.mass_kg``, summing to 1)."""


def _validate_wing_mass(cfg: Any) -> None:
    w = cfg.wing
    if w.mass_kg < 0:
        raise ConfigError("wing.mass_kg", f"must be >= 0 kg (0 = massless wings), got {w.mass_kg!r}")
    if 2 * w.mass_kg >= cfg.body.mass_kg:
        raise ConfigError("wing.mass_kg", f"both wings (2 x {w.mass_kg!r} kg) must weigh less than the whole "
                                          f"bird, body.mass_kg = {cfg.body.mass_kg!r} kg")
    for k in WING_MASS_SHARES:
        v = getattr(w, k)
        if not 0.0 <= v <= 1.0:
            raise ConfigError(f"wing.{k}", f"must lie in [0, 1], got {v!r}")
    total = sum(getattr(w, k) for k in WING_MASS_SHARES)
    if abs(total - 1.0) > 1e-9:
        raise ConfigError("wing." + WING_MASS_SHARES[0],
                          f"the wing mass shares ({', '.join(WING_MASS_SHARES)}) must sum to 1, got {total!r}")
