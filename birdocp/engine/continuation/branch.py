"""What a continuation returns: the branch, its points and its special points (typed, serialisable)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from birdocp.engine.results import finite_or_none, result_dict

__all__ = ["BranchPoint", "SpecialPoint", "Branch", "finite_or_none"]


def _total_s(wall) -> float:
    """The total of a ``wall_s`` entry: a dict with ``total`` (every result's convention) or, in
    branch files written before it, a number."""
    return float(wall.get("total", 0.0)) if isinstance(wall, dict) else float(wall)


@dataclass
class BranchPoint:
    """One converged cycle of a branch.

    ``multipliers`` are ``[re, im]`` pairs, largest modulus first; ``arclength`` is the scaled
    arclength from the first point; ``tangent_parameter`` is d(parameter)/ds in scaled units (its
    sign is the direction of travel along the parameter); ``tests`` holds the values of the
    special-point test functions (fold, branch_point, period_doubling, neimark_sacker);
    ``validity`` is filled by the application (for the bird: where the model holds on the cycle,
    :func:`birdocp.bird.validity.periodic_validity`; ``None`` when not checked); ``event_values``
    holds the user test functions at the point (:class:`~birdocp.engine.continuation.events.BranchEvents`;
    ``None`` without them); ``error_estimate`` the point's estimated errors with
    ``ContinuationOptions(error_estimate=True)`` (:func:`~birdocp.engine.continuation.accuracy.point_error`;
    ``None``, and no JSON key, without it)."""

    parameter: float
    x0: list
    shooting_points: list
    free_values: dict
    multipliers: list
    moduli: list
    stable: bool
    means: dict
    arclength: float
    tangent_parameter: float
    iterations: int
    max_residual: float
    step: float                # the scaled arclength step that produced this point (0 for the first)
    tests: dict
    success: bool = True
    p: list = field(default_factory=list)
    validity: dict | None = None
    period: float | None = None   # the orbit's period (varies along a branch of autonomous orbits)
    event_values: dict | None = None  # the user test functions at the point (BranchEvents), else None
    error_estimate: dict | None = None  # ContinuationOptions(error_estimate=True), else None

    @property
    def state(self) -> list:
        """The state at the start of the period (``x0``)."""
        return self.x0

    @property
    def spectrum(self) -> np.ndarray:
        """The Floquet multipliers as complex numbers (largest modulus first)."""
        return np.array([complex(a, b) for a, b in self.multipliers])

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`; NaN test values as null; the
        ``error_estimate`` key only where the point has one).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, exclude=() if self.error_estimate is not None else ("error_estimate",))


@dataclass
class SpecialPoint:
    """A located bifurcation between the branch points ``between`` (indices).

    ``kind`` is one of ``fold``, ``branch_point``, ``period_doubling``, ``neimark_sacker``, or the
    ``kind`` of user test functions (:class:`~birdocp.engine.continuation.events.BranchEvents`, e.g.
    ``validity_boundary``), whose ``event`` is then the name of the function that crosses zero and
    ``direction`` -1 (it falls below 0 along the branch) or +1 (it rises to 0); ``located`` says
    whether the location converged to the requested tolerance (else the best bracket point is
    reported)."""

    kind: str
    parameter: float
    multipliers: list
    moduli: list
    free_values: dict
    x0: list
    arclength: float
    between: tuple
    located: bool
    evaluations: int
    test_value: float
    message: str = ""
    event: str | None = None
    direction: int | None = None

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


@dataclass
class Branch:
    """A branch of periodic orbits: its points in order of arclength, the special points found
    between them, why it ended (``end_reason``: reached_to, reached_from, corrector_failed,
    free_parameter_bound, rejected, max_points, start_failed, stopped_at_event; ``incomplete`` when
    collected from an iterator that was left early) and the settings used."""

    parameter_name: str
    points: list
    special_points: list
    end_reason: str
    end_message: str
    settings: dict
    wall_s: float = 0.0
    free_names: list = field(default_factory=list)

    @property
    def parameters(self) -> np.ndarray:
        """The continuation parameter at every point."""
        return np.array([pt.parameter for pt in self.points])

    def multipliers(self) -> np.ndarray:
        """Complex multipliers, one row per point (largest modulus first).

        Returns
        -------
        ndarray of complex, shape (n_points, nx)
        """
        return np.array([[complex(a, b) for a, b in pt.multipliers] for pt in self.points])

    def to_dict(self) -> dict:
        """JSON-ready dict (``from_dict`` reads it back).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, extra={"wall_s": {"total": self.wall_s}})

    @staticmethod
    def from_dict(d: dict) -> "Branch":
        """The branch written by :meth:`to_dict`.

        Parameters
        ----------
        d : dict
            The dict of :meth:`to_dict` (e.g. a branch.json read back).

        Returns
        -------
        Branch
        """
        pts = [BranchPoint(**p) for p in d["points"]]
        sps = []
        for s in d.get("special_points", []):
            s = dict(s)
            s["between"] = tuple(s["between"])
            sps.append(SpecialPoint(**s))
        return Branch(d["parameter_name"], pts, sps, d["end_reason"], d["end_message"], d.get("settings", {}),
                      _total_s(d.get("wall_s", 0.0)), d.get("free_names", []))

