"""The one base of the engine's periodic-orbit results: forced (:class:`~birdocp.engine.shooting_types.LimitCycleResult`,
from :func:`~birdocp.engine.shooting.solve`) and any ODE (:class:`~birdocp.engine.orbit_types.PeriodicOrbit`,
from :func:`~birdocp.engine.orbits.solve_orbit`)."""
from __future__ import annotations

__all__ = ["OrbitResult", "ORBIT_RESULT_NAMES"]

ORBIT_RESULT_NAMES = ("success", "status", "message", "iterations", "residual_history", "max_residual", "period",
                      "autonomous", "x0", "p", "shooting_points", "trajectory_t", "trajectory_x", "monodromy",
                      "multipliers", "stable", "free_values", "means", "error_estimate", "method", "wall_s")
"""The names every orbit result has, with the same meaning (the attributes of :class:`OrbitResult`)."""


class OrbitResult:
    """What every periodic-orbit result of the engine has, under the same names.

    :class:`~birdocp.engine.shooting_types.LimitCycleResult` (forced orbits, multiple shooting with
    mean conditions) and :class:`~birdocp.engine.orbit_types.PeriodicOrbit` (orbits of any ODE,
    autonomous or forced) derive from it; each adds what only it has (e.g. ``floquet_exponents`` /
    ``covers``). A name one of them does not store is a read-only property there (``period`` and
    ``autonomous`` of a forced result, ``means`` of a ``PeriodicOrbit``); ``PeriodicOrbit.free_params``
    is the deprecated alias of ``free_values``. The JSON (``to_dict()``) of each is unchanged.

    Attributes
    ----------
    success : bool
        Converged: the residual is below the tolerance (plus each type's own checks).
    status, message : str
        What happened, in a word and in a sentence.
    iterations : int
        Solver iterations.
    residual_history : numpy.ndarray
        The max residual per iteration.
    max_residual : float
        The max residual at the result.
    period : float
        The period (time units of the system): solved for autonomous orbits, the forcing period
        otherwise.
    autonomous : bool
        Whether the period was an unknown.
    x0 : numpy.ndarray
        The state at the start of the period.
    p : numpy.ndarray
        The parameters (free ones at their solved values).
    shooting_points : numpy.ndarray
        The shooting points, one row per point (the closing point included).
    trajectory_t, trajectory_x : numpy.ndarray
        The orbit on the integration grid.
    monodromy : numpy.ndarray or None
        The monodromy matrix.
    multipliers : numpy.ndarray or None
        The Floquet multipliers, largest modulus first.
    stable : bool or None
        Whether the orbit is stable (an autonomous orbit's trivial multiplier left out).
    free_values : dict
        The solved free parameters by name.
    means : dict
        Period means of the problem's outputs by name (none for a ``PeriodicOrbit``).
    error_estimate : dict or None
        The estimated errors (``None`` or empty when not computed).
    method : dict
        The method's settings.
    wall_s : dict
        Seconds by phase, ``total`` among them.
    """

    __slots__ = ()
