"""Pseudo-arclength continuation of periodic orbits in one parameter, with special-point detection.

Works for any :class:`~birdocp.engine.problem.OrbitProblem` of a :class:`~birdocp.engine.ode.ODE`: the unknowns are the shooting points
``X_0 .. X_{M-1}``, the problem's free parameters (each held by one of its period-mean conditions,
e.g. the flapping amplitude held by mean W = 0 for level flight) and the continuation parameter
``lam``. The equations ``G = [continuity; periodicity; mean conditions]`` are one fewer than the
unknowns; the branch is the curve ``G(z) = 0``.

* **Scaling.** All geometry (tangent, arclength, step) is done in scaled unknowns ``u = z / s``:
  states and free parameters by ``scales`` (default 1), the continuation parameter by the length of
  the requested interval ``|to - from|`` (so the whole interval is one unit of arclength along lam).
* **Predictor.** ``u + ds t`` with ``t`` the unit tangent, the null vector of ``dG/du``, oriented by
  the previous tangent (first: by the direction from ``from`` to ``to``).
* **Corrector.** Quasi-Newton on the square system ``[G(u); t.(u - u_k) - ds] = 0``. The residual
  and its exact Jacobian come from the multiple-shooting engine's graphs
  (:func:`birdocp.engine.shooting.shooting_graphs`, the continuation parameter one more free parameter):
  ``dG/dX`` by forward AD of the RK4 segments, the parameter columns by forward AD through the
  per-time data (of ``post`` only when no unknown enters the wing's arm-frame shape; from a constant
  column when the parameter enters the data affinely, like the wing-root position). The corrector
  starts from the Jacobian of the point it steps from, evaluates only residuals and updates the
  Jacobian by Broyden's formula, re-evaluating it where a step reduces the residual by less than
  ``chord_contraction``; the Jacobian at the converged point (tangent, monodromy) is always exact.
* **Step control.** ds grows by 1.5 after a corrector converging in at most 5 steps, is kept after
  6-9, halves after more and after a failure (down to ``ds_min``: the branch is lost there). With
  ``max_dparam`` / ``max_dstate`` a step is first shortened so that it is expected to change the
  parameter / a shooting-point state by at most 0.85 of the limit (rate: the larger of the tangent's
  and the last step's), and a converged step beyond a limit is refused and shortened in proportion.
* **Special points** between consecutive points, from sign changes of test functions:

  - ``fold``: the parameter component of the tangent changes sign (the branch turns back; for a
    forced system one multiplier crosses +1 there);
  - ``branch_point``: ``det(I - Mon)`` changes sign without a fold (a multiplier crosses +1 while the
    parameter keeps its direction: transcritical/pitchfork of cycles);
  - ``period_doubling``: ``det(I + Mon)`` changes sign (a real multiplier crosses -1);
  - ``neimark_sacker``: ``prod_{i<j} (L_i L_j - 1)`` changes sign and a complex pair is on the unit
    circle at the located point (a sign change from a real pair with ``L_i L_j = 1`` is a neutral
    saddle, not a bifurcation, and is not reported).

  Each is located by Illinois regula falsi on the arclength from the point before the change (every
  evaluation a corrector solve) to ``locate_tol`` in scaled arclength and reported with the parameter
  value, the multipliers and the free parameters there.

  User test functions of a point (:class:`BranchEvents`, e.g. the margins of a model's validity
  limits) are evaluated at every point and located the same way where one changes side (``>= 0`` /
  ``< 0``): a special point of ``events.kind`` whose ``event`` names the function.

The continuation stops (``Branch.end_reason``) when the parameter leaves ``[min(from,to),
max(from,to)]`` (the last point is then re-solved exactly on the boundary: ``reached_to`` or, after a
fold, ``reached_from``), when the corrector fails at the minimum step (``corrector_failed``), when a
free parameter leaves its bounds (``free_parameter_bound``), when ``accept`` rejects a point
(``rejected``: e.g. a bird cycle with u <= 0), after ``max_points`` (``max_points``), or, with
``events.stop``, at the first located crossing of a user test function from ``>= 0`` to ``< 0`` (or at
the start when one is negative there: ``stopped_at_event``).

The pieces, one module each: ``options`` (:class:`ContinuationOptions`), ``system`` (the augmented
system, tangent, test functions), ``corrector`` (quasi-Newton), ``steps`` (step control), ``events``
(special points), ``branch`` (the result types), ``iterate`` (:class:`OrbitBranchIterator`, the branch
as an iterator of :class:`ContinuationStep`), ``front`` (:func:`birdocp.engine.iter_branch`, one front
for orbits and equilibria); :func:`continuation` collects the iterator's points into a :class:`Branch`.
"""
from __future__ import annotations

from typing import Callable

from birdocp.engine.continuation.branch import Branch, BranchPoint, SpecialPoint
from birdocp.engine.continuation.events import BranchEvents
from birdocp.engine.continuation.iterate import OrbitBranchIterator
from birdocp.engine.continuation.options import SPECIAL_POINT_KINDS, ContinuationOptions
from birdocp.engine.continuation.step import ContinuationStep
from birdocp.engine.continuation.system import Continuation
from birdocp.engine.problem import OrbitProblem

__all__ = ["Branch", "BranchPoint", "SpecialPoint", "Continuation", "ContinuationOptions", "SPECIAL_POINT_KINDS",
           "BranchEvents", "ContinuationStep", "continuation", "collect"]


def collect(steps, on_point: Callable | None = None, on_special: Callable | None = None):
    """Run a branch iterator to its end, calling ``on_special`` with every special point and then
    ``on_point`` with the point of each step; returns the iterator's ``branch()``.

    Parameters
    ----------
    steps : iterator
        Branch iterator (:func:`iter_branch` and the like).
    on_point : callable, optional
        ``on_point(point)`` after each step.
    on_special : callable, optional
        ``on_special(special_point)`` for each special point.

    Returns
    -------
    Branch
    """
    for step in steps:
        for sp in step.special_points:
            if on_special is not None:
                on_special(sp)
        if step.point is not None and on_point is not None:
            on_point(step.point)
    return steps.branch()


def continuation(problem: OrbitProblem, param, start_value: float, stop_value: float, *,
                 options: ContinuationOptions | None = None, start=None, accept: Callable | None = None,
                 progress: Callable | None = None, system: Continuation | None = None,
                 on_point: Callable | None = None, on_special: Callable | None = None, orient: float | None = None,
                 events: BranchEvents | None = None, **settings) -> Branch:
    """Follow the periodic orbits of ``problem`` as ``param`` goes from ``start_value`` to ``stop_value``.

    The collector over :class:`~birdocp.engine.continuation.iterate.OrbitBranchIterator` (the
    iterator behind :func:`birdocp.engine.iter_branch`): it runs the branch to its end and returns it.

    Parameters
    ----------
    problem : OrbitProblem
        The limit-cycle problem; its ``free`` parameters (held by its ``means``) are unknowns too.
    param : str or int
        The continuation parameter (a name in ``ode.param_names`` or an index).
    start_value, stop_value : float
        The interval of the parameter (its units).
    options : ContinuationOptions, optional
        How the branch is followed; keyword arguments named like its fields (``points``, ``step``,
        ``max_dparam``, ...) override it.
    start : object, optional
        A converged cycle at ``start_value`` (anything with ``shooting_points`` on the same grid, and
        ``p``); default: Newton from the problem's guess integrated forward, else
        :func:`birdocp.engine.orbit_front.solve` (IPOPT).
    accept : callable, optional
        ``accept(point) -> str | None`` with the :class:`BranchPoint`; a returned string rejects the
        point and ends the branch (``rejected``).
    progress : callable, optional
        ``progress(text)``, one line per point.
    system : Continuation, optional
        A prebuilt augmented system (same problem, parameter and grid) to reuse.
    on_point : callable, optional
        ``on_point(point)`` with each accepted :class:`BranchPoint` as soon as it is accepted (e.g. to
        keep the points of a run that is interrupted before the branch is returned).
    on_special : callable, optional
        ``on_special(special_point)`` with each located :class:`SpecialPoint` as soon as it is located
        (before the point after it is accepted).
    orient : float, optional
        The sign of d(parameter)/ds at the first point: the direction of travel (a branch resumed from
        a point after a fold: the sign of that point's ``tangent_parameter``); default: towards
        ``stop_value``.
    events : BranchEvents, optional
        User test functions of a point (e.g. the margins of a model's validity limits), evaluated at
        every point (``event_values``) and located where one crosses zero, as special points of
        ``events.kind`` naming the function (``event``); with ``events.stop`` the branch ends at the
        first crossing from ``>= 0`` to ``< 0`` (``end_reason`` ``stopped_at_event``).
    **settings
        Fields of :class:`ContinuationOptions` replacing those of ``options``.

    Returns
    -------
    Branch
        The points, the special points and why the branch ended.
    """
    it = OrbitBranchIterator(problem, param, start_value, stop_value, options=options, start=start, accept=accept,
                             progress=progress, system=system, orient=orient, events=events, **settings)
    return collect(it, on_point, on_special)
