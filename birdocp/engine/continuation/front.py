"""One continuation front for periodic orbits and equilibria: :func:`iter_branch` yields the points."""
from __future__ import annotations

import numpy as np

from birdocp.engine.ode import ODE
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.problem import OrbitProblem

__all__ = ["iter_branch"]

EQUILIBRIUM_SETTINGS = ("p", "ds", "max_points", "tol", "locate")


def iter_branch(problem, param, start_value: float, stop_value: float, *, start=None, **settings):
    """Follow a branch in ``param`` from ``start_value`` to ``stop_value``, one point at a time.

    One front for the three kinds of branch; what is followed depends on ``problem`` and ``start``:

    * an :class:`~birdocp.engine.problem.OrbitProblem` of an ODE with data: its forced periodic orbits
      (:class:`~birdocp.engine.continuation.iterate.OrbitBranchIterator`; ``start`` an optional
      converged cycle);
    * an :class:`~birdocp.engine.ode.ODE` (without data) with ``start`` a converged
      :class:`~birdocp.engine.orbit_result.OrbitResult`: the autonomous orbits through it (the period
      varies; :func:`~birdocp.engine.continuation.autonomous.autonomous_branch_iterator`);
    * an :class:`~birdocp.engine.ode.ODE` (without data) with ``start`` an
      :class:`~birdocp.engine.equilibria.Equilibrium` or a state: its equilibria
      (:class:`~birdocp.engine.equilibria.EquilibriumBranchIterator`).

    Parameters
    ----------
    problem : OrbitProblem or ODE
        The system.
    param : str or int
        The continuation parameter (a name or an index of the parameters).
    start_value, stop_value : float
        The parameter interval: the branch starts at ``start_value`` (the start is corrected there)
        and ends at ``stop_value`` or earlier (the iterator's ``end_reason`` / ``status`` says why).
    start : object, optional
        What the branch starts from: for an ``OrbitProblem``, optionally a converged cycle of it
        (an ``OrbitResult``, e.g. ``TrimResult.cycle``); for an ``ODE``, a converged ``OrbitResult``
        of it (autonomous orbits), or an ``Equilibrium`` or a state near an equilibrium (equilibria).
    **settings
        For orbits: the fields of :class:`~birdocp.engine.continuation.options.ContinuationOptions`
        (``step``, ``max_points``, ``error_estimate``, ...; or ``options=``) and ``accept``,
        ``progress``, ``orient``, ``events``, ``system``, ``method`` (autonomous orbits); for
        equilibria: ``p`` (the parameters, default the Equilibrium's), ``ds``, ``max_points``, ``tol``,
        ``locate``.

    Returns
    -------
    OrbitBranchIterator or EquilibriumBranchIterator
        Iterate it (once) for a :class:`~birdocp.engine.continuation.step.ContinuationStep` per point
        (``point``, ``parameter``, ``state``, ``spectrum``, ``stable``, ``step``, ``error_estimate``,
        the ``special_points`` located since the previous point); its ``branch()`` returns the points
        so far as a ``Branch`` (orbits) or ``EquilibriumBranch``, also after the loop was left early.

    Examples
    --------
    The equilibrium ``x = 0`` of ``x' = mu x - x^3`` loses its stability at ``mu = 0``:

    >>> from birdocp.engine import ODE, iter_branch
    >>> ode = ODE.from_function(lambda x, t, p: p[0] * x[0] - x[0] ** 3, 1, ("mu",))
    >>> steps = list(iter_branch(ode, "mu", -1.0, 1.0, start=[0.0], p=[-1.0], ds=0.25))
    >>> [(round(s.parameter, 2), s.stable) for s in steps]
    [(-1.0, True), (-0.75, True), (-0.38, True), (0.19, False), (1.03, False)]
    """
    from birdocp.engine.continuation.iterate import OrbitBranchIterator

    if isinstance(problem, OrbitProblem) and problem.data_split:
        return OrbitBranchIterator(problem, param, start_value, stop_value, start=start, **settings)
    if not isinstance(problem, ODE):
        raise TypeError(f"iter_branch: problem must be an OrbitProblem of an ODE with data or an ODE, "
                        f"got {type(problem).__name__}")
    if start is None:
        raise ValueError("iter_branch: an ODE needs start= (an OrbitResult, an Equilibrium or a state)")
    if isinstance(start, OrbitResult):
        from birdocp.engine.continuation.autonomous import autonomous_branch_iterator

        return autonomous_branch_iterator(start, problem, param, start_value, stop_value, **settings)
    return _equilibria(problem, param, start_value, stop_value, start, settings)


def _equilibria(ode: ODE, param, start_value, stop_value, start, settings):
    from birdocp.engine.equilibria import EquilibriumBranchIterator

    unknown = set(settings) - set(EQUILIBRIUM_SETTINGS)
    if unknown:
        raise TypeError(f"unknown setting(s) for a branch of equilibria: {sorted(unknown)}; "
                        f"known: {list(EQUILIBRIUM_SETTINGS)}")
    settings = dict(settings)
    p = settings.pop("p", None)
    if p is None:
        p = getattr(start, "p", None)
    if p is None:
        raise ValueError("iter_branch: equilibria need the parameters: p=... or start=an Equilibrium")
    p = np.asarray(p, float).ravel().copy()
    if not np.isfinite(start_value):
        raise ValueError(f"iter_branch: start_value must be finite, got {start_value!r}")
    p[ode.param_index(param)] = float(start_value)
    x = getattr(start, "x", start)
    return EquilibriumBranchIterator(ode, p, param, x, stop_value, **settings)
