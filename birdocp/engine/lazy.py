"""A CasADi Function read on first use: its signature is known before, its graph is loaded late.

Reading the bird's largest graph back from the cache (``pre``, the arm-frame wing shape: 183k SX
instructions) takes about 0.25 s, and a trim whose stage data are on disk
(:mod:`birdocp.engine.datastore`) never evaluates it. A :class:`LazyFunction` is a
``casadi.Function`` (``isinstance`` holds, it can be passed anywhere a Function goes) that answers
the signature queries (``n_in``, ``n_out``, ``size_in``, ``size_out``, ``size1_in``, ...,
``name``) from a stored signature and calls its loader the first time anything else is asked of it
(a call, ``map``, ``serialize``, being passed to CasADi); from then on it *is* the loaded Function.
"""
from __future__ import annotations

from typing import Callable

import casadi as ca

__all__ = ["LazyFunction", "signature"]

_SIGNATURE_QUERIES = ("n_in", "n_out", "size_in", "size_out", "size1_in", "size2_in", "size1_out", "size2_out",
                      "numel_in", "numel_out", "name")


def signature(f: ca.Function) -> dict:
    """``{"name", "size_in": [[rows, cols], ...], "size_out": [...]}`` of a Function (JSON-able).

    Parameters
    ----------
    f : casadi.Function
        Function.

    Returns
    -------
    dict
    """
    return {"name": f.name(), "size_in": [list(f.size_in(i)) for i in range(f.n_in())],
            "size_out": [list(f.size_out(i)) for i in range(f.n_out())]}


def _answer(sig: dict, query: str):
    ins, outs = sig["size_in"], sig["size_out"]
    table = {
        "n_in": lambda: len(ins), "n_out": lambda: len(outs), "name": lambda: sig["name"],
        "size_in": lambda i: tuple(ins[i]), "size_out": lambda i: tuple(outs[i]),
        "size1_in": lambda i: ins[i][0], "size2_in": lambda i: ins[i][1],
        "size1_out": lambda i: outs[i][0], "size2_out": lambda i: outs[i][1],
        "numel_in": lambda i: ins[i][0] * ins[i][1], "numel_out": lambda i: outs[i][0] * outs[i][1],
    }
    return table[query]


class LazyFunction(ca.Function):
    """A Function loaded by ``loader()`` on first use; ``sig`` (from :func:`signature`) answers the
    signature queries until then.

    Parameters
    ----------
    loader : callable
        Returns the Function (called once, on first use other than a signature query).
    sig : dict
        Its signature, as :func:`signature` gives it.
    """

    def __init__(self, loader: Callable[[], ca.Function], sig: dict):  # noqa: D107 - no C++ object yet
        object.__setattr__(self, "_lazy", (loader, sig))

    def __getattribute__(self, name):
        d = object.__getattribute__(self, "__dict__")
        lazy = d.get("_lazy")
        if lazy is not None:
            if name in _SIGNATURE_QUERIES:
                return _answer(lazy[1], name)
            if name in ("__dict__", "__class__", "_lazy", "loaded"):
                return object.__getattribute__(self, name)
            del d["_lazy"]
            ca.Function.__init__(self, lazy[0]())  # shares the loaded Function's internals
        return object.__getattribute__(self, name)

    @property
    def loaded(self) -> bool:
        """Whether the graph has been loaded."""
        return "_lazy" not in object.__getattribute__(self, "__dict__")
