"""Results as JSON: the one serialiser of every result type of birdocp.

Every result is a dataclass; its ``to_dict()`` is :func:`result_dict` of itself (plus, where the JSON
has keys that are derived from the fields, those keys by name). :func:`to_jsonable` turns any value
into plain JSON types with one convention:

* complex numbers are ``[re, im]`` pairs; a complex array is a (nested) list of pairs. Multipliers
  keep the order of the result (largest modulus first: :func:`birdocp.engine.floquet.sort_multipliers`
  builds them so; the serialiser never reorders);
* NaN and +-inf are ``null`` (JSON has no NaN; a reader never mistakes a missing number for a value);
* numpy arrays are (nested) lists, numpy scalars Python numbers, tuples lists, paths strings,
  dictionary keys strings;
* a dataclass is its ``to_dict()`` if it has one, else :func:`result_dict` (nested results too).

How a field is written is declared on the field, with :func:`serial` as the ``metadata`` of
:func:`dataclasses.field`: a JSON name other than the field name (``key``), no JSON at all (``skip``,
e.g. time histories that go to ``arrays.npz``), a 2-D array written one list per *column*
(``columns``, e.g. eigenvectors: entry k is the mode of multiplier k), complex numbers that must
stay pairs even when they happen to be real (``complex``) or a dict merged into the result
(``flatten``). Field names carry units (``period_s``, ``amplitude_deg``); so do JSON keys.

The module imports only the standard library (numpy objects are recognised when numpy is loaded), so
the engine, io and the command line's ``--help`` path can all use it.
"""
from __future__ import annotations

import dataclasses
import math
import os
import sys
from typing import Any, Iterable, Mapping

__all__ = ["to_jsonable", "result_dict", "serial", "finite_or_none", "complex_pairs", "SERIAL"]

SERIAL = "birdocp.serial"
"""The key of a field's ``metadata`` that holds its :func:`serial` declaration."""


def serial(*, key: str | None = None, skip: bool = False, complex: bool = False, columns: bool = False,
           flatten: bool = False) -> dict:
    """Field metadata that says how :func:`result_dict` writes the field.

    Parameters
    ----------
    key : str, optional
        The JSON name (default: the field name).
    skip : bool
        Leave the field out of the JSON (e.g. a time history saved to ``arrays.npz``).
    complex : bool
        The field holds complex numbers (multipliers, eigenvalues): written as ``[re, im]`` pairs even
        when every value happens to be real (numpy returns real eigenvalues as a float array).
    columns : bool
        A 2-D array is written one list per column (eigenvectors: entry k is the k-th mode).
    flatten : bool
        A dict field whose items become keys of the result itself.

    Returns
    -------
    dict
        ``{SERIAL: {...}}``, for ``dataclasses.field(metadata=...)``.
    """
    return {SERIAL: {"key": key, "skip": bool(skip), "complex": bool(complex), "columns": bool(columns),
                     "flatten": bool(flatten)}}


def finite_or_none(v) -> float | None:
    """``float(v)``, or ``None`` where ``v`` is None or not finite (JSON has no NaN).

    Parameters
    ----------
    v : Any
        Number or None.

    Returns
    -------
    float or None
    """
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def complex_pairs(values) -> list:
    """Complex numbers (any array shape, flattened) as ``[re, im]`` pairs of floats, in their order.

    For building result fields that hold pairs; NaN parts stay NaN here (:func:`to_jsonable` writes
    them as null).

    Parameters
    ----------
    values : array_like
        Complex numbers.

    Returns
    -------
    list of [float, float]
    """
    import numpy as np

    return [[float(np.real(v)), float(np.imag(v))] for v in np.asarray(values).ravel()]


def _columns(v):
    if v is None:
        return None
    np = sys.modules.get("numpy")
    if np is not None and isinstance(v, np.ndarray):
        return v.T
    return [list(col) for col in zip(*v)]


def result_dict(obj: Any, *, exclude: Iterable[str] = (), rename: Mapping[str, str] | None = None,
                derived: Iterable[str] = (), extra: Mapping[str, Any] | None = None) -> dict:
    """The JSON dict of the dataclass ``obj``: its fields in order, as their :func:`serial` metadata
    says, then the ``derived`` attributes and the ``extra`` items; every value through
    :func:`to_jsonable`.

    Parameters
    ----------
    obj : dataclass instance
    exclude : iterable of str
        Field names left out (in addition to those declared ``skip``).
    rename : mapping, optional
        Field name -> JSON key (overrides the declared ``key``), for results that wrap another
        result's fields (a trim writes the engine cycle's ``shooting_times`` as ``shooting_times_s``).
    derived : iterable of str
        Names of properties (or other attributes) of ``obj`` to include under their own names.
    extra : mapping, optional
        Further keys and values; a key that is already present is replaced in place.

    Returns
    -------
    dict
        Plain JSON types only (see the module for the conventions).
    """
    if not (dataclasses.is_dataclass(obj) and not isinstance(obj, type)):
        raise TypeError(f"result_dict needs a dataclass instance, got {type(obj).__name__}")
    exclude, rename = set(exclude), dict(rename or {})
    out = {}
    for f in dataclasses.fields(obj):
        how = f.metadata.get(SERIAL) or {}
        if how.get("skip") or f.name in exclude:
            continue
        v = getattr(obj, f.name)
        if how.get("complex") and v is not None:
            import numpy as np

            v = np.asarray(v, dtype=complex)
        if how.get("columns"):
            v = _columns(v)
        if how.get("flatten"):
            out.update(to_jsonable(dict(v or {})))
            continue
        out[rename.get(f.name) or how.get("key") or f.name] = to_jsonable(v)
    for name in derived:
        out[name] = to_jsonable(getattr(obj, name))
    for k, v in (extra or {}).items():
        out[str(k)] = to_jsonable(v)
    return out


def to_jsonable(obj: Any) -> Any:
    """Plain JSON types from any result value (the conventions are in the module docstring):
    complex to ``[re, im]``, NaN/inf to None, numpy to lists and Python numbers, dataclasses to
    their ``to_dict()`` (or :func:`result_dict`).

    Parameters
    ----------
    obj : Any
        Result value.

    Returns
    -------
    Any
    """
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        to_dict = getattr(obj, "to_dict", None)
        return to_jsonable(to_dict()) if callable(to_dict) else result_dict(obj)
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    np = sys.modules.get("numpy")  # no numpy object exists unless numpy was imported (kept off --help)
    if np is None:
        if isinstance(obj, complex):
            return [to_jsonable(obj.real), to_jsonable(obj.imag)]
        if isinstance(obj, float):
            return obj if math.isfinite(obj) else None
        return obj
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (complex, np.complexfloating)):
        return [to_jsonable(float(obj.real)), to_jsonable(float(obj.imag))]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj
