"""Configuration: frozen dataclasses whose defaults are the paper's reference case.

Every number carries its unit in its name. Angles are in degrees in the configuration and are
converted to radians inside the model graphs. The defaults are the reference implementation's values
(``docs/model.md``), with the paper's reference flapping amplitude of 42 deg.

A configuration is read from / written to TOML with sections ``[body]``, ``[wing]``, ``[gait]`` (with
one sub-table per joint), ``[aero]`` and ``[solve]``. Any bad key or value raises :class:`ConfigError`
whose one-line message names the dotted key, the value and what is allowed.

The allowed values, the physical limits and :func:`validate` live in :mod:`birdocp.bird.config_checks`
(re-exported here); the amplitude key and its default bounds in :mod:`birdocp.bird.keys`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Any

from birdocp.bird.config_checks import (CIRCULATION_MODES, JOINT_NAMES, KINEMATIC_VELOCITY_MODES,  # noqa: F401
                                        SECTION_MODES, SIX_DOF_UNSUPPORTED, UNSTEADY_MODES, UNSTEADY_PARAMS,
                                        WING_MASS_SHARES, coerce, flat_keys, get_value, parse_scalar,
                                        require_body_states, suggest, validate, SIDE_KEYS, asymmetric)
from birdocp.bird.config_sections import (Aero, Body, Drag, Gait, Joint, Model, SideOffsets, Solve, Tail,  # noqa: F401
                                         Validity, Wing)
from birdocp.io.errors import ConfigError
from birdocp.io.files import dataclass_to_dict

__all__ = [
    "ConfigError", "Joint", "SideOffsets", "Body", "Wing", "Gait", "Aero", "Tail", "Drag", "Solve", "Validity", "Config",
    "JOINT_NAMES", "PARAM_NAMES", "param_vector", "load", "dump", "loads", "dumps",
    "from_dict", "to_dict", "set_value", "with_values", "WING_MASS_SHARES", "body_alone_mass_kg", "require_body_states",
]


@dataclass(frozen=True)
class Config:
    """The whole configuration, one frozen section per concern; the defaults are the paper's
    reference case (``birdocp config`` prints it as TOML, every key with its unit in the name).

    Attributes
    ----------
    body
        mass, pitch inertia, gravity, reference chord (:class:`Body`).
    wing
        bones, feathers, wing-root position, wing mass (:class:`Wing`).
    gait
        flapping frequency and the seven joint laws (:class:`Gait`).
    aero
        air density, lift slope, circulation solve, kinematic velocity (:class:`Aero`).
    tail
        the optional tail, off by default (:class:`Tail`).
    drag
        the optional body and profile drag, off by default (:class:`Drag`).
    solve
        shooting points, RK4 steps, solver, initial guess (:class:`Solve`).
    validity
        the thresholds of where the model holds (:class:`Validity`).
    model
        4 or 6 degrees of freedom and the lateral inertias used with 6 (:class:`Model`).

    Examples
    --------
    >>> from birdocp.bird.config import Config
    >>> cfg = Config()
    >>> cfg.gait.shoulder_flap.amplitude_deg, cfg.wing.root_ahead_m
    (42.0, 0.05)
    """

    body: Body = field(default_factory=Body)
    wing: Wing = field(default_factory=Wing)
    gait: Gait = field(default_factory=Gait)
    aero: Aero = field(default_factory=Aero)
    tail: Tail = field(default_factory=Tail)
    drag: Drag = field(default_factory=Drag)
    solve: Solve = field(default_factory=Solve)
    validity: Validity = field(default_factory=Validity)
    model: Model = field(default_factory=Model)

    def __post_init__(self):
        validate(self)


# ---------------------------------------------------------------------------------------------
# Parameter vector: every float of body, wing (feathers included) and gait except the frequency,
# plus the aerodynamic constants. These are symbolic inputs of the model graphs, so any of them can
# become a decision variable of a study. The frequency sets the period and stays structural.

def _param_names() -> tuple[str, ...]:
    names = []
    for f in fields(Body):
        names.append(f"body.{f.name}")
    for f in fields(Wing):
        if f.name == "feather_lengths_m":
            names += [f"wing.feather_lengths_m.{i}" for i in range(7)]
        elif f.type in ("float", float):
            names.append(f"wing.{f.name}")
    for j in JOINT_NAMES:
        for f in fields(Joint):
            names.append(f"gait.{j}.{f.name}")
    names += ["aero.air_density_kgm3", "aero.lift_slope_per_rad"]
    names += [f"tail.{f.name}" for f in fields(Tail) if f.type in ("float", float)]
    names += [f"drag.{f.name}" for f in fields(Drag) if f.type in ("float", float)]
    names += [f"aero.{k}" for k in UNSTEADY_PARAMS]
    return tuple(names)


PARAM_NAMES: tuple[str, ...] = _param_names()
"""Names of the entries of the model parameter vector ``p``, in order."""



def param_vector(cfg: Config):
    """The numeric parameter vector ``p`` (numpy array ordered as :data:`PARAM_NAMES`).

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    ndarray
    """
    import numpy as np

    return np.array([float(get_value(cfg, k)) for k in PARAM_NAMES])


def body_alone_mass_kg(cfg: Config) -> float:
    """Mass of the body without the wings [kg]: ``body.mass_kg - 2 wing.mass_kg``.

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    float
    """
    return cfg.body.mass_kg - 2.0 * cfg.wing.mass_kg


# ---------------------------------------------------------------------------------------------
# Dict / TOML conversion


def to_dict(cfg: Any) -> dict:
    """Nested plain dict (tuples as lists) of a config or section.

    Parameters
    ----------
    cfg : Config or section
        Dataclass to convert.

    Returns
    -------
    dict
    """
    return dataclass_to_dict(cfg)


def _unknown_key(key: str, candidates=None) -> str:
    """The message of an unknown configuration key: a did-you-mean suggestion, else where the keys are."""
    return "unknown key" + (suggest(key, _ALL_KEYS if candidates is None else candidates)
                            or "; 'birdocp config' prints every key")


def _build(cls: type, data: Any, prefix: str, base: Any = None) -> Any:
    """``cls`` from a table; missing keys keep ``base``'s values (default ``cls()``), so a partial
    ``[gait.shoulder_flap]`` table keeps the reference joint's other values, not ``Joint()``'s zeros."""
    if not isinstance(data, dict):
        raise ConfigError(prefix.rstrip("."), f"expected a table, got {data!r}")
    default = (cls() if base is None else base) if cls is not Config else None
    names = {f.name: f for f in fields(cls)}
    kwargs = {}
    for k, v in data.items():
        key = f"{prefix}{k}"
        if k not in names:
            raise ConfigError(key, _unknown_key(key, [f"{prefix}{n}" for n in names] + list(_ALL_KEYS)))
        f = names[k]
        sub = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if is_dataclass(sub):
            kwargs[k] = _build(type(sub), v, key + ".", sub)
        else:
            kwargs[k] = coerce(key, getattr(default, k) if default is not None else sub, v)
    try:
        return replace(default, **kwargs) if cls is not Config else cls(**kwargs)
    except ConfigError:
        raise
    except TypeError as exc:  # pragma: no cover - defensive
        raise ConfigError(prefix.rstrip("."), str(exc)) from None


def from_dict(data: dict) -> Config:
    """Build a validated :class:`Config` from a nested dict (missing keys take the defaults).

    Parameters
    ----------
    data : dict
        Nested dict of sections and keys.

    Returns
    -------
    Config
    """
    return _build(Config, data, "")


def loads(text: str) -> Config:
    """The configuration in TOML text (defaults for missing keys; ConfigError for a bad key or value).

    Parameters
    ----------
    text : str
        TOML text.

    Returns
    -------
    Config
    """
    from birdocp.io.inputs import parse_toml

    return from_dict(parse_toml(text, "", "config"))


def load(path: str | Path) -> Config:
    """The configuration in a TOML file (see :func:`loads`).

    Parameters
    ----------
    path : str or Path
        A TOML file as ``birdocp config`` prints it (missing keys take the defaults); read through
        :func:`birdocp.io.inputs.read_input_text` (a regular file of bounded size, never a FIFO).

    Returns
    -------
    Config
        The validated configuration.
    """
    from birdocp.io.inputs import read_input_text

    return loads(read_input_text(path, "", what=f"config file '{path}'"))


def dumps(cfg: Config) -> str:
    """The configuration as TOML text (every key, units in the key names).

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    str
    """
    import tomli_w

    return tomli_w.dumps(to_dict(cfg))


def dump(cfg: Config, path: str | Path) -> None:
    """Write the configuration as a TOML file, atomically.

    Parameters
    ----------
    cfg : Config
        The configuration (every key is written, units in the key names).
    path : str or Path
        The file to write.
    """
    from birdocp.io.files import atomic_write_text

    atomic_write_text(path, dumps(cfg))


def with_values(cfg: Config, values: dict[str, Any]) -> Config:
    """A copy of ``cfg`` with dotted keys replaced (values already typed).

    Parameters
    ----------
    cfg : Config
        The configuration to start from (not modified: configurations are frozen).
    values : dict of str to object
        Dotted key (``"gait.shoulder_flap.amplitude_deg"``) to its new value.

    Returns
    -------
    Config
        The new, validated configuration.

    Raises
    ------
    ConfigError
        An unknown key or a bad value (the message names the key and the fix).

    Examples
    --------
    >>> from birdocp.bird.config import Config, with_values
    >>> with_values(Config(), {"wing.root_ahead_m": 0.04}).wing.root_ahead_m
    0.04
    """
    data = to_dict(cfg)
    for key, value in values.items():
        parts = key.split(".")
        node = data
        for i, part in enumerate(parts[:-1]):
            if isinstance(node, list):
                raise ConfigError(key, _unknown_key(key))
            if part not in node or not isinstance(node[part], (dict, list)):
                raise ConfigError(key, _unknown_key(key))
            node = node[part]
        last = parts[-1]
        if isinstance(node, list):
            try:
                idx = int(last)
                if idx < 0:  # not Python's count from the end: wing.feather_lengths_m.-1 is no feather
                    raise IndexError(idx)
                node[idx] = value
            except (ValueError, IndexError):
                raise ConfigError(key, f"index must be 0..{len(node) - 1}") from None
        else:
            if last not in node:
                raise ConfigError(key, _unknown_key(key))
            if isinstance(node[last], dict):
                raise ConfigError(key, "is a table; set one of its keys, e.g. " + f"{key}.{next(iter(node[last]))}")
            node[last] = value
    return from_dict(data)


def set_value(cfg: Config, assignment: str) -> Config:
    """Apply one ``KEY=VALUE`` string (the CLI's ``--set``); the value is parsed as TOML.

    Parameters
    ----------
    cfg : Config
        The configuration to start from.
    assignment : str
        ``"KEY=VALUE"``, e.g. ``"aero.circulation=relaxed"``.

    Returns
    -------
    Config
        The new, validated configuration.

    Examples
    --------
    >>> from birdocp.bird.config import Config, set_value
    >>> set_value(Config(), "aero.circulation=relaxed").aero.circulation
    'relaxed'
    """
    if "=" not in assignment:
        raise ConfigError(assignment, "expected KEY=VALUE, e.g. aero.circulation=relaxed")
    key, text = assignment.split("=", 1)
    return with_values(cfg, {key.strip(): parse_scalar(text.strip())})


def _all_keys() -> tuple[str, ...]:
    keys = []
    for f in fields(Config):
        sub = f.default_factory()
        keys += flat_keys(sub, f.name + ".")
    return tuple(keys)


_ALL_KEYS = _all_keys()
ALL_KEYS = _ALL_KEYS
