"""The one-period map's Jacobian of a Floquet consistency check, from the first segment a solver has.

The check of a forced orbit (:func:`birdocp.engine.shooting.floquet`, every trim) compares the
monodromy -- the product of the segment Jacobians at the shooting points -- with the Jacobian of the
one-period map integrated in one go from x0 (:attr:`birdocp.engine.integrate.RK4Grid.period_jacobian`).
Its first segment starts at x0, the first shooting point: its end and Jacobian are the solver's.
:class:`PeriodJacobianFromFirst` takes them and integrates the other S-1 segments along the trajectory
from that end, chaining their Jacobians onto the first (``RK4Grid.period_jacobian_after_first``): the same operations on the same numbers as
``period_jacobian``, so the same result bit for bit, for one segment less. The outputs' integrals
(the period means) are not needed there: from the fifth call on one grid (sweeps, continuations) the
segments are those of the same grid without outputs, whose state and state Jacobian are the same
expressions (the same numbers), cheaper to evaluate (measured on the bird, 148 steps, two mean outputs:
25 ms a check against 42 ms) but ~70 ms to build, which four calls have then paid.
"""
from __future__ import annotations

import casadi as ca

__all__ = ["PeriodJacobianFromFirst", "STATE_ONLY_AFTER_CALLS"]

STATE_ONLY_AFTER_CALLS = 4
"""Calls on a grid after which the state-only grid is built and used."""


class PeriodJacobianFromFirst:
    """``(x1, J0, D, p) -> (x_T, dx_T/dx0)`` of one :class:`~birdocp.engine.integrate.RK4Grid` (see the
    module docstring).

    Parameters
    ----------
    grid : RK4Grid
        The grid (its ODE, steps, segments and outputs).
    """

    def __init__(self, grid):
        self.grid = grid
        self.calls = 0
        self._functions = {}

    def __call__(self, x1, J0, D, p):
        """The state after the period and the one-period map's Jacobian.

        Parameters
        ----------
        x1 : casadi.DM
            The first segment's end (nx).
        J0 : casadi.DM
            Its state Jacobian (nx x nx).
        D : casadi.DM
            The stage data of the period (nd x 3N).
        p : casadi.DM
            Parameters.

        Returns
        -------
        x_T, J_T : casadi.DM
        """
        self.calls += 1
        return self._function(self.calls > STATE_ONLY_AFTER_CALLS)(x1, J0, D, p)

    def _function(self, states_only: bool) -> ca.Function:
        """``period_jacobian_after_first`` of the grid itself or of its state-only twin (a compiled ODE
        keeps its own grid: a state-only variational step would be a second C library)."""
        grid = self.grid
        states_only = states_only and grid.nq > 0 and getattr(grid.ode.numeric, "source", None) is None
        if states_only not in self._functions:
            g = type(grid)(grid.ode, grid.N, grid.S, ()) if states_only else grid
            self._functions[states_only] = g.period_jacobian_after_first
        return self._functions[states_only]
