"""What a branch iterator yields: one step of a continuation (a point and the special points before it)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

__all__ = ["ContinuationStep", "RunOnce"]


@dataclass
class ContinuationStep:
    """One step of a continuation, as yielded by :func:`birdocp.engine.iter_branch`.

    The same for branches of periodic orbits (``point`` a
    :class:`~birdocp.engine.continuation.branch.BranchPoint`) and of equilibria (``point`` an
    :class:`~birdocp.engine.equilibria.EquilibriumPoint`); the properties read either.

    Attributes
    ----------
    index : int or None
        The point's index in the branch (0 for the start); None for a last step that carries only
        special points (located after the last accepted point, where the branch then ended).
    point : BranchPoint or EquilibriumPoint or None
        The accepted point.
    special_points : list
        The special points located between the previous point and this one, in order of arclength:
        :class:`~birdocp.engine.continuation.branch.SpecialPoint` on an orbit branch (fold,
        branch_point, period_doubling, neimark_sacker, user events), on an equilibrium branch
        :class:`~birdocp.engine.equilibria.HopfPoint` (``kind`` ``"hopf"``) and folds (a
        :class:`~birdocp.engine.equilibria.EquilibriumFold`).
    """

    index: int | None
    point: object | None
    special_points: list = field(default_factory=list)

    @property
    def parameter(self) -> float | None:
        """The continuation parameter at the point (its units)."""
        return None if self.point is None else float(self.point.parameter)

    @property
    def state(self) -> np.ndarray | None:
        """The state: an orbit's x0 (at t0), or the equilibrium."""
        return None if self.point is None else np.asarray(self.point.state, float)

    @property
    def stable(self) -> bool | None:
        """Whether the point is stable (multipliers inside the unit circle / eigenvalues left of the
        imaginary axis)."""
        return None if self.point is None else bool(self.point.stable)

    @property
    def spectrum(self) -> np.ndarray | None:
        """Complex Floquet multipliers (orbits) or eigenvalues (equilibria), in the point's order."""
        return None if self.point is None else np.asarray(self.point.spectrum, complex)

    @property
    def step(self) -> float | None:
        """The scaled arclength step that produced the point (0 for the first)."""
        return None if self.point is None else float(self.point.step)

    @property
    def error_estimate(self) -> dict | None:
        """The point's error estimate (``ContinuationOptions(error_estimate=True)``), else None."""
        return None if self.point is None else getattr(self.point, "error_estimate", None)

    @property
    def kinds(self) -> list:
        """The kinds of the special points of this step (e.g. ``["fold"]``)."""
        return [sp.kind for sp in self.special_points]


class RunOnce:
    """Base of the branch iterators: iterating runs ``_run()`` once (a second iteration is an
    error: the branch state lives in the iterator). Subclasses set ``self._started = False``."""

    _started = False

    def __iter__(self) -> Iterator[ContinuationStep]:
        if self._started:
            raise RuntimeError("a branch iterator runs once; make a new one to follow the branch again")
        self._started = True
        return self._run()

    def _run(self) -> Iterator[ContinuationStep]:
        raise NotImplementedError
