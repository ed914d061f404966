"""Special points: sign changes of the test functions between two points, located on the arclength.

* ``fold``: the parameter component of the tangent changes sign (the branch turns back; for a forced
  system one multiplier crosses +1 there);
* ``branch_point``: ``det(I - Mon)`` changes sign without a fold (a multiplier crosses +1 while the
  parameter keeps its direction: transcritical/pitchfork of cycles);
* ``period_doubling``: ``det(I + Mon)`` changes sign (a real multiplier crosses -1);
* ``neimark_sacker``: ``prod_{i<j} (L_i L_j - 1)`` changes sign and a complex pair is on the unit
  circle at the located point (a sign change from a real pair with ``L_i L_j = 1`` is a neutral
  saddle, not a bifurcation, and is not reported).

User test functions (:class:`BranchEvents`): named functions of a :class:`BranchPoint` (e.g. the
margin of a model's validity limit, positive where it holds), evaluated at every point and located
like the special points where one changes side (a value ``>= 0`` on one side, ``< 0`` on the other);
the special point's ``kind`` is the events' ``kind`` and its ``event`` the function's name. With
``stop`` the branch ends at the first located crossing from ``>= 0`` to ``< 0``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from birdocp.engine.continuation.branch import BranchPoint, SpecialPoint
from birdocp.engine.continuation.corrector import Corrector
from birdocp.engine.continuation.system import ContinuationState

__all__ = ["sign_changes", "locate", "BranchEvents", "event_crossings", "locate_event"]


@dataclass
class BranchEvents:
    """User test functions of the points of a branch, located like the special points.

    Attributes
    ----------
    evaluate : callable
        ``evaluate(point) -> {name: value}`` with a :class:`BranchPoint` (its ``x0``, ``p``,
        ``parameter``, ``free_values``, ...): one float per named test function, continuous along the
        branch where possible (a crossing of a piecewise-constant function is located at its jump).
        The values of every point are kept in its ``event_values``; NaN values are not compared.
    kind : str
        The ``kind`` of the special points located (default ``"event"``).
    stop : bool
        End the branch at the first located crossing from ``>= 0`` to ``< 0`` (that point is the
        branch's last; ``end_reason`` ``"stopped_at_event"``), or at the start when a value is
        already negative there.
    tol : float or None
        Location tolerance in scaled arclength (default: the options' ``locate_tol``).
    describe : callable or None
        ``describe(name, direction, point) -> str``: the special point's message (direction -1: the
        value falls below 0 along the branch, +1: it rises to 0 or above).
    """

    evaluate: Callable[[BranchPoint], Mapping[str, float]]
    kind: str = "event"
    stop: bool = False
    tol: float | None = None
    describe: Callable[[str, int, BranchPoint], str] | None = None

    def values(self, point: BranchPoint) -> dict:
        """The test functions at ``point`` (floats), also stored in ``point.event_values``.

        Parameters
        ----------
        point : BranchPoint
            Point, changed in place.

        Returns
        -------
        dict of str to float
        """
        vals = {str(k): float(v) for k, v in dict(self.evaluate(point)).items()}
        point.event_values = vals
        return vals

    def message(self, name: str, direction: int, point: BranchPoint) -> str:
        """The special point's message.

        Parameters
        ----------
        name : str
            Test function.
        direction : int
            Sign of the crossing (< 0: falls below 0).
        point : BranchPoint
            Point of the crossing.

        Returns
        -------
        str
        """
        if self.describe is not None:
            return self.describe(name, direction, point)
        return f"{name} {'falls below 0' if direction < 0 else 'rises to 0'} along the branch"


def _side(v: float) -> bool:
    return v >= 0


def event_crossings(va: Mapping[str, float], vb: Mapping[str, float]) -> list:
    """The names whose value changes side (``>= 0`` / ``< 0``) from ``va`` to ``vb`` (NaN skipped).

    Parameters
    ----------
    va, vb : mapping of str to float
        Test-function values at two consecutive points.

    Returns
    -------
    list of str
    """
    return [k for k in va if k in vb and np.isfinite(va[k]) and np.isfinite(vb[k])
            and _side(va[k]) != _side(vb[k])]


def locate_event(events: BranchEvents, name: str, corrector: Corrector, base: ContinuationState, ds: float,
                 va: float, vb: float, index: int, arclength: float, make_point: Callable[..., BranchPoint],
                 tol: float):
    """Locate where the test function ``name`` of ``events`` crosses zero between ``base`` (branch point
    ``index``, value ``va``) and the point ``ds`` further (value ``vb``): (SpecialPoint, the
    BranchPoint there with its ``event_values``, its corrected state), or ``None`` when no corrector
    solve succeeded.

    Parameters
    ----------
    events : BranchEvents
        The test functions.
    name : str
        The one that changed sign.
    corrector : Corrector
        Corrector of the continuation.
    base : ContinuationState
        State at the last point.
    ds : float
        Arclength to the next point.
    va, vb : float
        Values at both points.
    index : int
        Index of the last branch point.
    arclength : float
        Arclength at the last point.
    make_point : callable
        Builds a BranchPoint from a corrected state.
    tol : float
        Tolerance of the location.

    Returns
    -------
    tuple or None
    """
    seen: dict = {}

    def test(st: ContinuationState, c: float) -> float:
        pt = make_point(st, arclength + c, c)
        v = events.values(pt)[name]
        seen[id(st)] = pt
        # the boundary value 0 belongs to the side >= 0: the bracket keeps the sides of _side
        return v if v != 0 else math.ulp(0.0)

    c, st, ok, nev = _bisect(test, corrector, base, ds, va if va != 0 else math.ulp(0.0), vb, tol)
    if st is None:
        return None
    pt = seen[id(st)]
    direction = -1 if _side(va) else 1
    sp = SpecialPoint(kind=events.kind, parameter=pt.parameter, multipliers=pt.multipliers, moduli=pt.moduli,
                      free_values=pt.free_values, x0=pt.x0, arclength=pt.arclength, between=(index, index + 1),
                      located=ok, evaluations=nev, test_value=float(pt.event_values[name]),
                      message=events.message(name, direction, pt), event=name, direction=direction)
    return sp, pt, st


def sign_changes(cur: ContinuationState, nxt: ContinuationState, detect) -> list:
    """The kinds in ``detect`` whose test function changes sign from ``cur`` to ``nxt``.

    ``det(I - Mon)`` changes sign at a fold too: a branch point is not reported where the fold's
    test changes sign as well.

    Parameters
    ----------
    cur, nxt : ContinuationState
        Two consecutive states.
    detect : iterable of str
        Kinds to test.

    Returns
    -------
    list of str
    """
    kinds = []
    for kind in detect:
        if kind == "branch_point" and np.sign(cur.tests["fold"]) != np.sign(nxt.tests["fold"]):
            continue
        fa, fb = cur.tests[kind], nxt.tests[kind]
        if np.sign(fa) != np.sign(fb) and fa != 0:
            kinds.append(kind)
    return kinds


def _bisect(test: Callable[[ContinuationState, float], float], corrector: Corrector, base: ContinuationState,
            ds_b: float, fa: float, fb: float, tol: float):
    """Illinois regula falsi on the arclength in (0, ds_b) for the zero of ``test(state, ds)``: (best
    ds, its state, located, evaluations)."""
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
        fc = test(st, c)
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
    or no corrector solve succeeded.

    Parameters
    ----------
    kind : str
        Kind of special point.
    corrector : Corrector
        Corrector of the continuation.
    base, nxt : ContinuationState
        Two consecutive states.
    ds : float
        Arclength between them.
    index : int
        Index of the branch point of ``base``.
    arclength : float
        Arclength at ``base``.
    make_point : callable
        Builds a BranchPoint from a corrected state.
    name : str
        Name of the special point.
    tol : float
        Tolerance of the location.

    Returns
    -------
    SpecialPoint or None
    """
    c, st, ok, nev = _bisect(lambda state, _c: state.tests[kind], corrector, base, ds, base.tests[kind],
                             nxt.tests[kind], tol)
    if st is None:
        return None
    pt = make_point(st, arclength + c, c)
    msg = _message(kind, np.array([complex(x, y) for x, y in pt.multipliers]), name)
    if msg is None:
        return None
    return SpecialPoint(kind=kind, parameter=pt.parameter, multipliers=pt.multipliers, moduli=pt.moduli,
                        free_values=pt.free_values, x0=pt.x0, arclength=pt.arclength, between=(index, index + 1),
                        located=ok, evaluations=nev, test_value=float(st.tests[kind]), message=msg)
