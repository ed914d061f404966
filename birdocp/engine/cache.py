"""One registry for the process's in-memory caches (built CasADi graphs, models, compiled ODEs).

Every cache is bounded, evicts the least recently used entry first, and is cleared with all the
others by :func:`clear_caches`. Keys hold object identities where a graph belongs to one object;
the entries keep those objects alive, so an identity is never reused while its entry exists.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import Any, Callable, Hashable

__all__ = ["BoundedCache", "bounded_cache", "register_cache", "clear_caches", "cache_sizes"]

_REGISTRY: dict[str, Any] = {}


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

    def clear(self) -> None:
        """Drop every entry."""
        self._data.clear()

    def __len__(self) -> int:
        return len(self._data)


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


def clear_caches() -> None:
    """Clear every registered cache (graphs are rebuilt on next use)."""
    for cache in _REGISTRY.values():
        if hasattr(cache, "cache_clear"):
            cache.cache_clear()
        else:
            cache.clear()


def cache_sizes() -> dict:
    """Entries held by each registered cache, by name.

    Returns
    -------
    dict of str to int
    """
    out = {}
    for name, cache in _REGISTRY.items():
        out[name] = cache.cache_info().currsize if hasattr(cache, "cache_info") else len(cache)
    return out
