"""Special points: sign changes of the test functions between two points, located on the arclength.

* ``fold``: the parameter component of the tangent changes sign (the branch turns back; for a forced
  system one multiplier crosses +1 there);
* ``branch_point``: ``det(I - Mon)`` changes sign without a fold (a multiplier crosses +1 while the
  parameter keeps its direction: transcritical/pitchfork of cycles);
* ``period_doubling``: ``det(I + Mon)`` changes sign (a real multiplier crosses -1);
* ``neimark_sacker``: ``prod_{i<j} (L_i L_j - 1)`` changes sign and a complex pair is on the unit
  circle at the located point (a sign change from a real pair with ``L_i L_j = 1`` is a neutral
  saddle, not a bifurcation, and is not reported).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from birdocp.engine.continuation.branch import BranchPoint, SpecialPoint
from birdocp.engine.continuation.corrector import Corrector
from birdocp.engine.continuation.system import ContinuationState

__all__ = ["sign_changes", "locate"]


def sign_changes(cur: ContinuationState, nxt: ContinuationState, detect) -> list:
    """The kinds in ``detect`` whose test function changes sign from ``cur`` to ``nxt``.

    ``det(I - Mon)`` changes sign at a fold too: a branch point is not reported where the fold's
    test changes sign as well."""
    kinds = []
    for kind in detect:
        if kind == "branch_point" and np.sign(cur.tests["fold"]) != np.sign(nxt.tests["fold"]):
            continue
        fa, fb = cur.tests[kind], nxt.tests[kind]
        if np.sign(fa) != np.sign(fb) and fa != 0:
            kinds.append(kind)
    return kinds


def _bisect(kind, corrector: Corrector, base: ContinuationState, ds_b: float, fa: float, fb: float,
            tol: float):
    """Illinois regula falsi on the arclength in (0, ds_b): (best ds, its state, located, evaluations)."""
    a, b = 0.0, ds_b
    best, nev, side = None, 0, 0
    ok = False
    for _ in range(60):
        if abs(b - a) < tol:
            ok = True
            break
        c = (a * fb - b * fa) / (fb - fa) if fb != fa else 0.5 * (a + b)
        if not (min(a, b) < c < max(a, b)):
            c = 0.5 * (a + b)
        st = corrector.along(base, c)
        nev += 1
        if st is None:
            c = 0.5 * (a + b)
            st = corrector.along(base, c)
            nev += 1
            if st is None:
                break
        fc = st.tests[kind]
        best = (c, st)
        if fc == 0:
            ok = True
            break
        if np.sign(fc) == np.sign(fa):
            a, fa = c, fc
            if side == -1:
                fb *= 0.5
            side = -1
        else:
            b, fb = c, fc
            if side == 1:
                fa *= 0.5
            side = 1
        if abs(fc) < 1e-14:
            ok = True
            break
    return (None, None, ok, nev) if best is None else (*best, ok, nev)


def _message(kind: str, multipliers: np.ndarray, name: str) -> str | None:
    """What the special point is, in words; ``None`` when it is not one (a neutral saddle)."""
    if kind == "neimark_sacker":
        cplx = [v for v in multipliers if abs(v.imag) > 1e-8 and abs(abs(v) - 1) < 1e-4]
        if not cplx:
            return None
        return f"complex pair on the unit circle, angle {math.degrees(abs(np.angle(cplx[0]))):.4g} deg"
    if kind == "fold":
        near = multipliers[np.argmin(np.abs(multipliers - 1))]
        return f"turning point in {name}; multiplier nearest +1: {near.real:.6g}{near.imag:+.2g}j"
    if kind == "branch_point":
        return "a multiplier crosses +1 without a turning point"
    if kind == "period_doubling":
        near = multipliers[np.argmin(np.abs(multipliers + 1))]
        return f"multiplier nearest -1: {near.real:.6g}{near.imag:+.2g}j"
    return ""


def locate(kind: str, corrector: Corrector, base: ContinuationState, nxt: ContinuationState, ds: float,
           index: int, arclength: float, make_point: Callable[..., BranchPoint], name: str,
           tol: float) -> SpecialPoint | None:
    """Locate the special point ``kind`` between ``base`` (branch point ``index``) and ``nxt``, the
    point ``ds`` further along the arclength; ``None`` where the sign change is not a bifurcation
    or no corrector solve succeeded."""
    c, st, ok, nev = _bisect(kind, corrector, base, ds, base.tests[kind], nxt.tests[kind], tol)
    if st is None:
        return None
    pt = make_point(st, arclength + c, c)
    msg = _message(kind, np.array([complex(x, y) for x, y in pt.multipliers]), name)
    if msg is None:
        return None
    return SpecialPoint(kind=kind, parameter=pt.parameter, multipliers=pt.multipliers, moduli=pt.moduli,
                        free_values=pt.free_values, x0=pt.x0, arclength=pt.arclength, between=(index, index + 1),
                        located=ok, evaluations=nev, test_value=float(st.tests[kind]), message=msg)
