"""The reduced NLP of the gait optimisers (objective and constraints of a
:class:`birdocp.studies.gait_cycle.ReducedLevelCycle`, for IPOPT through
:class:`birdocp.engine.oracle.ConstraintOracle`)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import get_value
from birdocp.io.progress import text_reporter
from birdocp.studies.gait_cycle import JURY_MARGIN, ReducedLevelCycle, jury_function, jury_values
from birdocp.studies.gait_types import Evaluation

__all__ = ["ReducedProblem"]


class ReducedProblem:
    """The reduced NLP for IPOPT (the evaluator of :class:`birdocp.engine.oracle.ConstraintOracle`):
    G(z) = [objective; constraints] and dG/dz, z = the scaled free values theta (and r for the
    stability objective); :meth:`jacobian_near` gives a finite-difference Hessian's perturbed points."""

    def __init__(self, rc: ReducedLevelCycle, objective: str, speed, max_multiplier, amplitude_bounds,
                 valid_bounds: dict | None = None, turn_deg_per_beat: float | None = None):
        self.rc, self.objective, self.speed, self.R = rc, objective, speed, max_multiplier
        self.turn = turn_deg_per_beat
        """Heading change per wingbeat held [deg] (a turn, :class:`birdocp.studies.turn_cycle.TurnLevelCycle`), or None."""
        self.amp = amplitude_bounds
        self.with_r = objective == "stability"
        self.jury = jury_function() if (max_multiplier is not None or self.with_r) else None
        nt = rc.nt
        self.nz = nt + (1 if self.with_r else 0)
        self.valid_bounds = dict(valid_bounds or {})
        """limit -> (bound used, 'max' or 'min') of the smooth validity constraints (empty: none)."""
        self.names = ["amplitude_deg"] + (["forward_speed_mps"] if speed is not None else []) \
            + (["heading_change_deg"] if turn_deg_per_beat is not None else []) \
            + ([f"jury{i}" + (f"_block{b}" if b else "") for b in range(rc.n_blocks) for i in range(5)]
               if self.jury is not None else []) \
            + ["valid_" + k for k in self.valid_bounds]
        self.ng = 1 + len(self.names)
        self.jac_sparsity = ca.Sparsity.dense(self.ng, self.nz)
        self.sigma = np.ones(self.nz)
        self.failures: list = []
        self.progress = None
        self._reported = None
        mg = float(get_value(rc.cfg, "body.mass_kg") * get_value(rc.cfg, "body.gravity_mps2"))
        self.mg = mg

    def bounds_g(self):
        """Lower and upper bounds of the constraint rows: the amplitude [deg], the speed condition [m/s] when
        set, the Jury rows (>= ``JURY_MARGIN``) with a stability bound, the validity limits held.

        Returns
        -------
        lo, hi : ndarray
        """
        lo, hi = [self.amp[0]], [self.amp[1]]
        if self.speed is not None:
            lo.append(self.speed)
            hi.append(self.speed)
        if self.turn is not None:
            lo.append(self.turn)
            hi.append(self.turn)
        if self.jury is not None:
            lo += [JURY_MARGIN] * 5 * self.rc.n_blocks
            hi += [np.inf] * 5 * self.rc.n_blocks
        for b, kind in self.valid_bounds.values():
            lo.append(b if kind == "min" else -np.inf)
            hi.append(b if kind == "max" else np.inf)
        return np.array(lo), np.array(hi)

    def smooth_validity(self, ev: Evaluation, grads: bool = True):
        """({limit: smooth value}, {limit: gradient in theta}) of the constrained validity limits.

        Parameters
        ----------
        ev : Evaluation
            Evaluation of the level cycle.
        grads : bool
            Also the gradients.

        Returns
        -------
        values, gradients : dict
        """
        from birdocp.bird.validity_smooth import integrand_names, smooth_measures

        names = integrand_names()
        g = [ev.grads[n] for n in names] if grads and ev.grads is not None else None
        vals, der = smooth_measures(self.rc.cfg, [ev.means[n] for n in names], g)
        return vals, der

    def _obj(self, ev: Evaluation, z):
        if self.objective == "power":
            return ev.means["flapping_power_W"], ev.grads["flapping_power_W"]
        if self.objective == "positive-power":
            return ev.means["positive_power_smooth_W"], ev.grads["positive_power_smooth_W"]
        if self.objective == "cost-of-transport":
            P, U = ev.means["flapping_power_W"], ev.means["forward_speed_mps"]
            gP, gU = ev.grads["flapping_power_W"], ev.grads["forward_speed_mps"]
            return P / (self.mg * U), (gP * U - P * gU) / (self.mg * U ** 2)
        raise ValueError(self.objective)

    def set_scale(self, ev: "Evaluation"):
        """Variable scaling z_k = sigma_k theta_k so that a unit step of z_k changes the speed by at most
        1 m/s, the power by 10 % and the amplitude by 1 deg (measured: the sweep offset moves the speed
        by 6.6 m/s per degree, the incidence by 0.24: unscaled, IPOPT's quasi-Newton crept along the
        constraint in 0.015-deg steps).

        Parameters
        ----------
        ev : Evaluation
            Evaluation with gradients at the start point.

        Returns
        -------
        None
        """
        g = ev.grads
        rows = [np.abs(g["forward_speed_mps"]), np.abs(g["amplitude_deg"]), np.full(self.rc.nt, 1e-2)]
        if "flapping_power_W" in g:  # a turn has no power output
            rows.append(np.abs(g["flapping_power_W"]) / (0.1 * max(abs(ev.means["flapping_power_W"]), 1e-3)))
        if "turn_rate_degps" in g:  # a turn: 1 deg of heading change per beat
            rows.append(np.abs(g["turn_rate_degps"]) * self.rc.T)
        sig = np.maximum.reduce(rows)
        self.sigma = np.concatenate([sig, [1.0] if self.with_r else []])

    def both(self, z, grads: bool = True):
        """The constraints G and their Jacobian dG/dz at the scaled unknowns ``z``.

        Parameters
        ----------
        z : array_like
            Scaled unknowns.
        grads : bool
            Also the Jacobian.

        Returns
        -------
        G, J : ndarray
        """
        z = np.asarray(z, float).ravel() / self.sigma
        nt = self.rc.nt
        try:
            ev = self.rc.evaluate(z[:nt], grads=grads)
        except RuntimeError as e:  # no level cycle here: NaN makes IPOPT cut its step back
            self.failures.append(str(e))
            return np.full(self.ng, np.nan), np.full((self.ng, self.nz), np.nan)
        if ev.grads is None:  # values only (a line-search trial point)
            G = np.array([z[-1] if self.with_r else self._value(ev)] + [ev.amplitude_deg]
                         + ([ev.means["forward_speed_mps"]] if self.speed is not None else [])
                         + ([ev.means["turn_rate_degps"] * self.rc.T] if self.turn is not None else []))
            if self.jury is not None:  # the monodromy alone: no gradients at a trial point
                self.rc.fill_monodromy(ev)
                r = z[-1] if self.with_r else self.R
                G = np.concatenate([G] + [self._jury_or_nan(M, r)[0] for M, _ in self.rc.stability_blocks(ev)])
            if self.valid_bounds:
                vals = self.smooth_validity(ev, grads=False)[0]
                G = np.concatenate([G, [vals[k] for k in self.valid_bounds]])
            return G, None
        return self._assemble(ev, z)

    def _assemble(self, ev: Evaluation, z):
        """(G, dG/dz) from an evaluation with gradients; z unscaled (theta, r)."""
        nt = self.rc.nt
        G = np.zeros(self.ng)
        J = np.zeros((self.ng, self.nz))
        if self.with_r:
            G[0], J[0, -1] = z[-1], 1.0
        else:
            G[0], J[0, :nt] = self._obj(ev, z)
        G[1], J[1, :nt] = ev.amplitude_deg, ev.grads["amplitude_deg"]
        i = 2
        if self.speed is not None:
            G[i], J[i, :nt] = ev.means["forward_speed_mps"], ev.grads["forward_speed_mps"]
            i += 1
        if self.turn is not None:  # the heading change per beat [deg]
            G[i], J[i, :nt] = ev.means["turn_rate_degps"] * self.rc.T, ev.grads["turn_rate_degps"] * self.rc.T
            i += 1
        if self.jury is not None:
            r = z[-1] if self.with_r else self.R
            for M, dM in self.rc.stability_blocks(ev):  # the (dominant) planar monodromy, and the lateral block
                G[i:i + 5], J[i:i + 5, :nt], jr = self._jury_or_nan(M, r, dM)
                if self.with_r:
                    J[i:i + 5, -1] = jr
                i += 5
        if self.valid_bounds:
            vals, der = self.smooth_validity(ev)
            for k in self.valid_bounds:
                G[i], J[i, :nt] = vals[k], der[k]
                i += 1
        return G, J / self.sigma

    def _jury_or_nan(self, M, r, d_monodromy=None):
        """:func:`birdocp.studies.gait_cycle.jury_values`, NaN (IPOPT cuts its step) where the
        monodromy has no dominant 4-dimensional subspace."""
        try:
            return jury_values(self.jury, M, r, d_monodromy)
        except RuntimeError as e:
            self.failures.append(str(e))
            nt = 0 if d_monodromy is None else np.shape(d_monodromy)[1]
            return np.full(5, np.nan), np.full((5, nt), np.nan), np.full(5, np.nan)

    def _value(self, ev):
        P, U = ev.means["flapping_power_W"], ev.means["forward_speed_mps"]
        return {"power": P, "positive-power": ev.means["positive_power_smooth_W"],
                "cost-of-transport": P / (self.mg * U)}[self.objective]

    def g(self, z):
        """The constraints G at ``z``.

        Parameters
        ----------
        z : array_like
            Scaled unknowns.

        Returns
        -------
        ndarray
        """
        return self.both(z, grads=False)[0]

    def jacobian(self, z):
        """dG/dz at ``z``; a finite one marks the cycle as a restart point (:meth:`ReducedLevelCycle.accept`).

        Parameters
        ----------
        z : array_like
            Scaled unknowns.

        Returns
        -------
        ndarray
        """
        G, J = self.both(z)
        if J is not None and np.all(np.isfinite(J)):  # IPOPT asks for derivatives at accepted points
            theta = np.asarray(z, float).ravel()[:self.rc.nt] / self.sigma[:self.rc.nt]
            self.rc.accept(theta)
            self._report(np.asarray(z, float).ravel(), G[0], self.rc.cached(theta))
        return J

    def _report(self, z, value, ev) -> None:
        """One progress line per new point where IPOPT asks for derivatives (it asks several times at
        each iterate: objective gradient, constraint Jacobian, Hessian)."""
        say = text_reporter(self.progress, "optimize-stability" if self.with_r else "optimize-gait")
        if say is None or ev is None or (self._reported is not None and np.array_equal(self._reported, z)):
            return
        self._reported = z.copy()
        say(f"{self.objective} {value:.6g}, |L1| {np.max(np.abs(ev.multipliers)):.5f}, A {ev.amplitude_deg:.3f} deg"
            + (f", heading change {ev.means['turn_rate_degps'] * self.rc.T:.4f} deg/beat" if self.turn is not None else ""))

    def jacobian_near(self, zk, z):
        """dG/dz at ``zk`` next to ``z`` (where :meth:`jacobian` was just evaluated), side-effect-free
        and thread-safe (:meth:`ReducedLevelCycle.evaluate_near` from z's cycle): the perturbed points
        of :class:`birdocp.engine.oracle.StencilHessian`. NaN where no level cycle is found.

        Parameters
        ----------
        zk : array_like
            Scaled unknowns of the perturbed point.
        z : array_like
            Scaled unknowns of the last evaluated point.

        Returns
        -------
        ndarray
        """
        nt = self.rc.nt
        zk = np.asarray(zk, float).ravel() / self.sigma
        theta = np.asarray(z, float).ravel()[:nt] / self.sigma[:nt]
        base = self.rc.cached(theta)
        nan = np.full((self.ng, self.nz), np.nan)
        if base is None or base.grads is None:
            return nan
        try:
            ev = base if np.array_equal(zk[:nt], theta) else self.rc.evaluate_near(zk[:nt], base)
        except RuntimeError:
            return nan
        return self._assemble(ev, zk)[1]
