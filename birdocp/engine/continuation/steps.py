"""Step-length control of a continuation."""
from __future__ import annotations

import numpy as np

from birdocp.engine.continuation.system import ContinuationState

__all__ = ["StepController"]


class StepController:
    """Chooses the scaled arclength step ``ds``.

    ``ds`` grows by 1.5 after a corrector converging in at most 5 steps, is kept after 6-9, halves
    after more and after a failure (down to ``ds_min``: the branch is lost there). With
    ``max_dparam`` / ``max_dstate`` a step is first shortened so that it is expected to change the
    parameter / a shooting-point state by at most ``aim`` (0.85) of the limit (rate: the larger of
    the tangent's and the last step's), and a converged step beyond a limit is refused and
    shortened in proportion.
    """

    aim = 0.85

    def __init__(self, ds: float, ds_min: float, ds_max: float, scales: np.ndarray, lam_index: int,
                 n_states: int, max_dparam: float | None, max_dstate: float | None):
        self.ds, self.ds_min, self.ds_max = ds, ds_min, ds_max
        self.s = scales
        self.li = lam_index
        self.nX = n_states
        self.max_dparam, self.max_dstate = max_dparam, max_dstate
        self.observed = [0.0, 0.0]   # |d lam| / ds and max |d X| / ds of the last corrected step
        self.failures = 0            # steps halved because the corrector did not converge
        self.refusals = 0            # converged steps beyond max_dparam / max_dstate

    def capped(self, st: ContinuationState) -> float:
        """The current ``ds``, shortened so the step is expected to stay within the limits.

        Parameters
        ----------
        st : ContinuationState
            Current state.

        Returns
        -------
        float
        """
        s, li, nX = self.s, self.li, self.nX
        ds = self.ds
        if self.max_dparam:
            rate = max(abs(s[li] * st.t[li]), self.observed[0])
            if rate * ds > self.aim * self.max_dparam:
                ds = max(self.aim * self.max_dparam / rate, self.ds_min)
        if self.max_dstate:
            rate = max(float(np.max(np.abs(s[:nX] * st.t[:nX]))), self.observed[1])
            if rate * ds > self.aim * self.max_dstate:
                ds = max(self.aim * self.max_dstate / rate, self.ds_min)
        self.ds = ds
        return ds

    def failed(self) -> bool:
        """The corrector failed: halve ``ds``; ``False`` when that would go below ``ds_min``.

        Returns
        -------
        bool
        """
        if self.ds / 2 < self.ds_min:
            return False
        self.ds /= 2
        self.failures += 1
        return True

    def refuse(self, cur: ContinuationState, nxt: ContinuationState) -> bool:
        """Record the step ``cur -> nxt``; ``True`` (and ``ds`` shortened) when it exceeds a limit.

        Parameters
        ----------
        cur, nxt : ContinuationState
            The step's ends.

        Returns
        -------
        bool
        """
        s, li, nX, ds = self.s, self.li, self.nX, self.ds
        dX = np.max(np.abs(s[:nX] * (nxt.u[:nX] - cur.u[:nX])))
        dlam = abs(s[li] * nxt.u[li] - s[li] * cur.u[li])
        self.observed[:] = [dlam / ds, dX / ds]
        over = max(dlam / self.max_dparam if self.max_dparam else 0.0,
                   dX / self.max_dstate if self.max_dstate else 0.0)
        if over > 1 and ds / 2 >= self.ds_min:  # shorten in proportion (at least halve at 2x over)
            self.ds *= max(min(0.9 / over, 0.9), 0.25)
            self.refusals += 1
            return True
        return False

    def converged(self, iterations: int) -> None:
        """Adapt ``ds`` to the corrector's work on the accepted step.

        Parameters
        ----------
        iterations : int
            Corrector iterations of the step.
        """
        if iterations <= 5:
            self.ds = min(self.ds * 1.5, self.ds_max)
        elif iterations > 9:
            self.ds = max(self.ds / 2, self.ds_min)
