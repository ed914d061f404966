"""Settings of a continuation run, in one object (cf. BifurcationKit's ``ContParameters``)."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ContinuationOptions", "SPECIAL_POINT_KINDS"]

SPECIAL_POINT_KINDS = ("fold", "branch_point", "period_doubling", "neimark_sacker")


@dataclass
class ContinuationOptions:
    """How a branch is followed.

    Attributes
    ----------
    points, steps_per_period : int
        Shooting points per period (closing point included) and RK4 steps per period.
    step : float or None
        First step in parameter units (default ``|stop - start| / 10``).
    ds_min, ds_max : float or None
        Smallest and largest scaled arclength step (default 1/256 and 4 times the first).
    max_points : int
        Points at most, the first included.
    scales : dict or None
        Scale of each unknown: ``"states"`` (one number or nx), ``"free"`` (nf), ``"parameter"``
        (default ``|stop - start|``). All geometry is done in the scaled unknowns.
    tol : float
        Corrector tolerance on max |G| (absolute, like the shooting engine's).
    max_newton : int
        Corrector steps per point.
    chord_contraction : float
        A quasi-Newton step reducing the residual by less than this factor gets a fresh Jacobian.
    locate_tol : float
        Special points are located to this scaled arclength.
    detect : tuple of str
        Special points to detect (a subset of :data:`SPECIAL_POINT_KINDS`).
    max_dparam, max_dstate : float or None
        A corrected step changing the parameter (its units) or a shooting-point state by more than
        this is refused and shortened in proportion; steps aim at 0.85 of the limits (guards against
        jumping to another branch).
    error_estimate : bool
        Give every accepted point an ``error_estimate`` (a re-solve on twice the steps per period and
        the solver's tolerance: :mod:`birdocp.engine.continuation.accuracy`); costs about one more
        corrector solve on the 2N grid per point.
    """

    points: int = 5
    steps_per_period: int = 148
    step: float | None = None
    ds_min: float | None = None
    ds_max: float | None = None
    max_points: int = 200
    scales: dict | None = None
    tol: float = 1e-10
    max_newton: int = 12
    chord_contraction: float = 0.3
    locate_tol: float = 1e-10
    detect: tuple = SPECIAL_POINT_KINDS
    max_dparam: float | None = None
    max_dstate: float | None = None
    error_estimate: bool = False
