"""The process's in-memory caches: what an object builds is kept by that object.

A CasADi graph built from an object (an ODE's integrator grids and shooting graphs, a model's
validity angles, power functions or six-degree-of-freedom variant) is kept in that object's own
cache, :func:`owned_cache`: it lives and dies with its owner, and no key needs the owner's ``id()``. A few
caches keyed by *values* (the bird model of a structure, the compiled ODEs, the stage data of a
gait) are module-level, registered here by name with :func:`bounded_cache` or
:func:`register_cache` (the allowed places are listed in ``tests/test_architecture.py``).

Every cache is bounded, evicts the least recently used entry first, and is cleared with all the
others by :func:`clear_caches` (the owned caches of the objects still alive included).
"""
from __future__ import annotations

import weakref
from collections import OrderedDict
from typing import Any, Callable, Hashable

__all__ = ["BoundedCache", "bounded_cache", "register_cache", "owned_cache", "clear_caches", "cache_sizes"]

_REGISTRY: dict[str, Any] = {}
_MISSING = object()  # a cached value may be None
_OWNED: "weakref.WeakSet[BoundedCache]" = weakref.WeakSet()  # the owned caches of live objects
_OWNED_ATTRIBUTE = "_owned_caches"


class BoundedCache:
    """A mapping with at most ``maxsize`` entries, least recently used evicted first.

    Parameters
    ----------
    name : str
        Its name in :func:`cache_sizes`.
    maxsize : int
        Entries at most.
    """

    def __init__(self, name: str, maxsize: int):
        self.name = name
        self.maxsize = int(maxsize)
        self._data: OrderedDict = OrderedDict()

    def get(self, key: Hashable, default=None):
        """The entry of ``key`` (now the most recently used), else ``default``.

        Parameters
        ----------
        key : hashable
            Key of the entry.
        default : Any
            Returned when there is no entry.

        Returns
        -------
        Any
        """
        try:
            self._data.move_to_end(key)
        except KeyError:
            return default
        return self._data[key]

    def put(self, key: Hashable, value) -> None:
        """Store ``value`` under ``key``, evicting the least recently used entries beyond ``maxsize``.

        Parameters
        ----------
        key : hashable
            Key of the entry.
        value : Any
            Value stored.
        """
        self._data[key] = value
        self._data.move_to_end(key)
        while len(self._data) > self.maxsize:
            self._data.popitem(last=False)

    def build(self, key: Hashable, make: Callable[[], Any]):
        """The entry of ``key``; built by ``make()`` and stored when there is none.

        Parameters
        ----------
        key : hashable
            Key of the entry.
        make : callable
            ``make() -> value``, called on a miss only.

        Returns
        -------
        Any
        """
        value = self.get(key, _MISSING)
        if value is _MISSING:
            value = make()
            self.put(key, value)
        return value

    def clear(self) -> None:
        """Drop every entry."""
        self._data.clear()

    def __len__(self) -> int:
        return len(self._data)

    def __reduce__(self):
        # a copy of an owner (pickled to a worker process) gets an empty cache: graphs are rebuilt
        # there, never pickled with their owner
        return _empty_owned_cache, (self.name, self.maxsize)


def _empty_owned_cache(name: str, maxsize: int) -> BoundedCache:
    cache = BoundedCache(name, maxsize)
    _OWNED.add(cache)
    return cache


def bounded_cache(name: str, maxsize: int) -> BoundedCache:
    """A new :class:`BoundedCache`, registered under ``name`` (one name, one cache).

    Parameters
    ----------
    name : str
        Registry name (unique).
    maxsize : int
        Largest number of entries.

    Returns
    -------
    BoundedCache
    """
    if name in _REGISTRY:
        raise ValueError(f"a cache named {name!r} is registered already")
    cache = BoundedCache(name, maxsize)
    _REGISTRY[name] = cache
    return cache


def register_cache(name: str, fn: Callable) -> Callable:
    """Register a ``functools.lru_cache``-wrapped function (anything with ``cache_clear``); returns it.

    Parameters
    ----------
    name : str
        Registry name (unique).
    fn : callable
        The cached function.

    Returns
    -------
    callable
        ``fn``.
    """
    if not hasattr(fn, "cache_clear"):
        raise TypeError(f"{name}: not a cached function (no cache_clear)")
    _REGISTRY[name] = fn
    return fn


def owned_cache(owner, name: str = "graphs", maxsize: int = 64) -> BoundedCache:
    """The cache ``name`` that ``owner`` keeps of what is built from it (made on first use, stored on
    the object itself): its entries live as long as ``owner`` and need no ``id()`` in their keys.

    Parameters
    ----------
    owner : object
        Any object with a ``__dict__`` (frozen dataclasses included).
    name : str
        Which of the owner's caches (a large kind of entry gets its own, smaller bound).
    maxsize : int
        Largest number of entries (used when the cache is made).

    Returns
    -------
    BoundedCache
    """
    caches = owner.__dict__.get(_OWNED_ATTRIBUTE)
    if caches is None:
        caches = owner.__dict__[_OWNED_ATTRIBUTE] = {}  # __dict__: frozen dataclasses too
    cache = caches.get(name)
    if cache is None:
        cache = caches[name] = BoundedCache(f"owned: {type(owner).__name__}.{name}", maxsize)
        _OWNED.add(cache)
    return cache


def clear_caches() -> None:
    """Clear every registered cache and the owned caches of the objects alive (graphs are rebuilt on
    next use)."""
    for cache in _REGISTRY.values():
        if hasattr(cache, "cache_clear"):
            cache.cache_clear()
        else:
            cache.clear()
    for cache in list(_OWNED):
        cache.clear()


def cache_sizes() -> dict:
    """Entries held by each registered cache, by name, and by the owned caches of the objects alive,
    summed by owner type and cache name (``"owned: <type>.<name>"``).

    Returns
    -------
    dict of str to int
    """
    out = {}
    for name, cache in _REGISTRY.items():
        out[name] = cache.cache_info().currsize if hasattr(cache, "cache_info") else len(cache)
    for cache in list(_OWNED):
        out[cache.name] = out.get(cache.name, 0) + len(cache)
    return out
