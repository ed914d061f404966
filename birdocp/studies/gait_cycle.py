"""The level-flight cycle as a function of a few gait parameters (reduced space), with exact gradients.

Formulation (the reduced-space choice of issue 19): the decision variables are a few gait
parameters theta (shoulder joints' offsets, amplitudes, phases; wing root; any key that leaves the
wing's arm-frame shape numeric). For every theta the level cycle is eliminated: the state x0 at t = 0
and the flapping amplitude A solve ``Phi(x0; theta, A) = x0`` and ``mean W = climb rate`` (Newton,
warm-started by the first-order prediction of the previous point), and every output's gradient is
exact by the implicit function theorem::

    R(y, theta) = 0,  y = (x0, A)   =>   dy/dtheta = -R_y^-1 R_theta,   do/dtheta = o_theta + o_y dy/dtheta

with the partial derivatives (and, for stability, the monodromy's) from the variational equations of
:class:`birdocp.engine.variational.PeriodSensitivities` and the data's forward derivative along the
free parameters. IPOPT (limited-memory Hessian on the few reduced variables) then sees a small, dense
NLP: objective mean power, cost of transport or the stability radius r; constraints mean forward speed
= U (optional), the amplitude within its limits (the free keys' own limits are variable bounds), and
optionally all multipliers inside the circle of radius R (Jury conditions on Mon / R, as
:mod:`birdocp.studies.optimize`).
"""

from __future__ import annotations

import math
import threading

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.studies.gait_graphs import DOMINANT_COLUMNS, POSITIVE_EPS_W, level_cycle_graphs
from birdocp.studies.gait_types import Evaluation, WarmStart
from birdocp.studies.jury import dominant_block, jury_conditions, jury_function, jury_values  # noqa: F401

__all__ = ["ReducedLevelCycle", "jury_conditions", "dominant_block", "jury_values", "AMPLITUDE_KEY", "JURY_MARGIN",
           "POSITIVE_EPS_W", "NEWTON_RESCUE_STEPS", "DOMINANT_COLUMNS"]

from birdocp.bird.keys import AMPLITUDE_KEY, JURY_MARGIN  # noqa: E402 (one definition of each)
NEWTON_RESCUE_STEPS = 4
"""Level-cycle Newton: steps with a fresh Jacobian each after the chord steps ran out with the residual
still falling (``ReducedLevelCycle._newton``)."""


class ReducedLevelCycle:
    """The level-flight cycle as a function of the free gait parameters (see module docstring).

    cfg: configuration (every other value); keys: the free parameters theta; steps_per_period: RK4
    grid; climb_rate_mps: the mean vertical speed held by the amplitude; second_order: also the
    monodromy's derivatives (for stability constraints); amplitude_range_deg: Newton solutions with
    the flapping amplitude outside it are failures [deg]. The warm start of the Newton solves is
    :attr:`warm_start` (a :class:`WarmStart`), replaced only through :meth:`restart_from`.
    """

    def __init__(self, cfg: Config, keys, steps_per_period: int | None = None, climb_rate_mps: float = 0.0,
                 second_order: bool = False, amplitude_start_deg: float | None = None, valid: bool = False,
                 amplitude_range_deg: tuple[float, float] = (0.0, 90.0)):
        from birdocp.bird.model import get_model

        self.cfg = cfg
        self.m = m = get_model(cfg)
        self.keys = list(keys)
        self.N = N = int(steps_per_period or cfg.solve.steps_per_period)
        self.climb = float(climb_rate_mps)
        self.idx = [PARAM_NAMES.index(k) for k in self.keys]
        self.ia = PARAM_NAMES.index(AMPLITUDE_KEY)
        self.vidx = self.idx + [self.ia]
        self.nt = len(self.idx)
        self.p0 = np.asarray(m.p0, float).copy()
        self.T = m.period_s
        self.valid = bool(valid)
        self.second = bool(second_order)
        self.K = 2 * N + 1
        self.nx = m.ode.nx  # the full state: body (4) and aerodynamic states, if any
        g = level_cycle_graphs(m, cfg, N, tuple(self.vidx), self.nt, self.second, self.valid)
        self.out_names, self.outputs, self.grid, self.sens = g["out_names"], g["outputs"], g["grid"], g["sens"]
        self.sens2, self.sens_mono, self._data = g["sens2"], g["sens_mono"], g["data"]
        self.times, self.local, self._seeds = g["times"], g["local"], g["seeds"]
        self._y = np.concatenate([m.complete_state(cfg.solve.initial_guess, self.p0),
                                  [float(amplitude_start_deg if amplitude_start_deg is not None
                                         else self.p0[self.ia])]])
        self._theta = None
        self._started = False
        self._dy = None
        self._Ry = None
        self._cache: dict = {}
        self._anchor = None
        self.amplitude_range_deg = tuple(map(float, amplitude_range_deg))
        """Newton solutions with the flapping amplitude outside this range are failures [deg]."""
        self.n_full = self.n_resid = 0
        self._count_lock = threading.Lock()  # the counters (evaluate_near runs in threads)

    n_blocks = 1
    """Number of 4 x 4 monodromy blocks whose multipliers count (:meth:`stability_blocks`)."""

    def stability_blocks(self, ev: Evaluation) -> list:
        """``[(M, dM)]``: the 4 x 4 monodromy blocks whose eigenvalues are the multipliers that count,
        with their derivatives (16 x n_theta, column-major vec; None without the second order): the
        planar monodromy, and the further :attr:`Evaluation.blocks` (the lateral block of a
        six-degree-of-freedom cycle, :class:`birdocp.studies.lateral_optimize.LateralLevelCycle`).

        Parameters
        ----------
        ev : Evaluation
            A cycle (its monodromy and, second order, its derivatives).

        Returns
        -------
        list of (ndarray, ndarray or None)
        """
        return [(ev.monodromy, ev.d_monodromy)] + list(ev.blocks or [])

    def exact_validity(self, cfg_best: Config, x0) -> dict:
        """The exact validity (:func:`birdocp.bird.validity.periodic_validity`, on this cycle's grid) of
        the cycle through ``x0`` at the gait ``cfg_best``.

        Parameters
        ----------
        cfg_best : Config
            Configuration of the gait (free values and amplitude in it).
        x0 : array_like
            State at t = 0.

        Returns
        -------
        dict
        """
        from birdocp.bird.config import param_vector
        from birdocp.bird.validity import periodic_validity
        return periodic_validity(cfg_best, x0, param_vector(cfg_best), steps_per_period=self.N).to_dict()

    def multiplier_split(self, ev: Evaluation) -> dict | None:
        """The multipliers of ``ev`` split by block for the JSON (None: one block, nothing to split;
        six degrees of freedom: :func:`birdocp.studies.lateral_optimize.multiplier_split`).

        Parameters
        ----------
        ev : Evaluation
            A cycle.

        Returns
        -------
        dict or None
        """
        return None

    # -- pieces ----------------------------------------------------------------------------------
    def pfull(self, theta, A):
        """The full parameter vector: the configured values with theta and the amplitude put in.

        Parameters
        ----------
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.
        A : float
            Flapping amplitude [deg].

        Returns
        -------
        ndarray
            (len(PARAM_NAMES),).
        """
        p = self.p0.copy()
        p[self.idx] = theta
        p[self.ia] = A
        return p

    def _D(self, p):
        return self.grid.blocks_numeric(0.0, p)  # one Function (the slicing of a DM in Python cost a third)

    def residual(self, y, theta):
        """(R, means): the level-cycle residual (x_T - x0, mean W - climb) and the period means.

        Parameters
        ----------
        y : ndarray
            The unknowns (x0, A): state at t = 0 (state units) and flapping amplitude [deg].
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.

        Returns
        -------
        R : ndarray
            (nx + 1,): x_T - x0 (state units), mean vertical speed - climb rate [m/s].
        means : ndarray
            Period mean of each quadrature output (``out_names``, their units).
        """
        p = self.pfull(theta, y[self.nx])
        nx = self.nx
        xT, _, q = self.grid.period_map(ca.DM(y[:nx]), self._D(p), ca.DM(p))
        with self._count_lock:
            self.n_resid += 1
        means = np.asarray(q).ravel() / self.T
        return np.concatenate([np.asarray(xT).ravel() - y[:nx], [means[0] - self.climb]]), means

    def _full(self, y, theta):
        """First-order sensitivities at (y, theta): R, R_y, R_theta, the means' partials, and the
        data (D, directions, p) for a second-order pass."""
        with self._count_lock:
            self.n_full += 1
        nx = self.nx
        p = self.pfull(theta, y[nx])
        D, cols = self._data(ca.DM(p))
        s = self.sens(y[:nx], D, p, dp=self._seeds, columns=cols)
        T, nt = self.T, self.nt
        cy = list(range(nx)) + [nx + nt]        # columns of y = (x0, A)
        ct = list(range(nx, nx + nt))           # columns of theta
        J, Jq = s["J"], s["Jq"] / T
        R = np.concatenate([s["x_T"] - y[:nx], [s["q"][0] / T - self.climb]])
        Ry = np.vstack([J[:, cy] - np.eye(nx + 1)[:nx], Jq[0, cy]])
        Rt = np.vstack([J[:, ct], Jq[0, ct]])
        return s, R, Ry, Rt, Jq, cy, ct, (D, cols, p)

    # -- the reduced map -------------------------------------------------------------------------
    @property
    def warm_start(self) -> WarmStart:
        """Where the next Newton solve starts (copies: changing them changes nothing here)."""
        return WarmStart(self._y.copy(), None if self._theta is None else self._theta.copy(),
                         None if self._dy is None else self._dy.copy())

    @property
    def last_jacobian(self) -> np.ndarray | None:
        """dR/d(x0, A) of the last gradient evaluation (5 x 5), which chord Newton steps reuse; a copy,
        None before the first."""
        return None if self._Ry is None else self._Ry.copy()

    def sensitivity_inputs(self, p) -> tuple:
        """``(D, seeds, columns)``: the stage data at the parameters ``p``, the parameter directions and
        the data's columns along them -- the inputs of a
        :class:`~birdocp.engine.variational.PeriodSensitivities` pass on this cycle's grid
        (``sens(x0, D, p, dp=seeds, columns=columns)``).

        Parameters
        ----------
        p : array_like
            Full parameter vector (len(PARAM_NAMES),).

        Returns
        -------
        tuple
            ``(D, seeds, columns)``.
        """
        D, cols = self._data(ca.DM(np.asarray(p, float)))
        return D, self._seeds, cols

    def restart_from(self, start: WarmStart) -> None:
        """Start the next Newton solves from ``start`` (the only writer of the warm start besides
        :meth:`evaluate` and :meth:`set_guess`); the cached evaluations, the last Jacobian and the
        accepted point (:meth:`accept`) are kept.

        Parameters
        ----------
        start : WarmStart
            The unknowns (x0, A), and optionally the theta they were solved at and dy/dtheta there.

        Returns
        -------
        None
        """
        self._y = np.array(start.y, float)
        self._theta = None if start.theta is None else np.array(start.theta, float)
        self._dy = None if start.dy is None else np.array(start.dy, float)

    def set_guess(self, x0) -> None:
        """Start the first Newton solve from the state ``x0`` (at the configured amplitude; a body
        state of 4 numbers gets its aerodynamic states on the quasi-steady manifold).

        Parameters
        ----------
        x0 : array_like
            State at t = 0 (body: u, w [m/s], q [rad/s], theta [rad]; then the aerodynamic states).

        Returns
        -------
        None
        """
        self._y[:self.nx] = self.m.complete_state(x0, self.p0)
        self._started = True

    def _first_guess(self, theta):
        """x0 from a trim (multiple shooting) of the gait theta at the configured amplitude."""
        from birdocp.studies.trim import trim

        y = self._y.copy()
        tr = trim(with_values(self.cfg, dict(zip(self.keys, map(float, theta)))), steps_per_period=self.N)
        if tr.success:
            y[:self.nx] = tr.x0
        return y

    def evaluate(self, theta, grads: bool = True, tol: float = 1e-10, max_newton: int = 12) -> Evaluation:
        """The level cycle at theta (Newton on (x0, A), chord steps with the last Jacobian) and, with
        ``grads``, its exact gradients and monodromy; raises RuntimeError if Newton fails.

        Newton starts from the first-order prediction off the last point with gradients; if that
        fails (near a fold of cycles the prediction ``dy/dtheta`` is large and can throw Newton onto
        another cycle), from the last solved point, then from the last accepted point
        (:meth:`accept`). A non-finite residual, a growing one, or an amplitude outside
        ``amplitude_range_deg`` is a failure: the optimiser sees an evaluation error and cuts its step.

        Parameters
        ----------
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.
        grads : bool
            Also the exact gradients and the monodromy.
        tol : float
            Newton tolerance on the max abs residual (state units, m/s).
        max_newton : int
            Newton steps per start.

        Returns
        -------
        Evaluation
        """
        theta = np.asarray(theta, float).ravel()
        key = theta.tobytes()
        ev = self._cache.get(key)
        if ev is None:
            if self._theta is None and not self._started:
                self._started = True
                starts = [self._first_guess(theta)]
            else:
                starts = []
                if self._theta is not None and self._dy is not None:
                    starts.append(self._y + self._dy @ (theta - self._theta))  # first-order prediction
                starts.append(self._y.copy())
                if self._anchor is not None:
                    starts.append(self._anchor.copy())
            errors = []
            for y in starts:
                try:
                    ev = self._newton(y, theta, tol, max_newton)
                    break
                except RuntimeError as e:
                    errors.append(str(e))
            else:
                raise RuntimeError(f"level cycle not found at {dict(zip(self.keys, theta.tolist()))}: "
                                   + "; ".join(errors))
            self._cache[key] = ev
            while len(self._cache) > 8:  # the last few points (a finite-difference Hessian's stencil)
                self._cache.pop(next(iter(self._cache)))
        if grads and ev.grads is None:
            self._gradients(ev)
            self._theta, self._dy, self._Ry = theta.copy(), ev.dy, ev.Ry
        self._y = ev.y
        return ev

    def _gradients(self, ev: Evaluation) -> None:
        """Fill ``ev``'s exact gradients, monodromy (and its derivatives), ``dy`` and ``Ry``."""
        s, R, Ry, Rt, Jq, cy, ct, (D, cols, p) = self._full(ev.y, ev.theta)
        try:
            dy = -np.linalg.solve(Ry, Rt)           # 5 x nt
        except np.linalg.LinAlgError:
            raise RuntimeError("singular level-cycle Jacobian (a fold of cycles)") from None
        ev.grads = {n: Jq[i, ct] + Jq[i, cy] @ dy for i, n in enumerate(self.out_names)}
        nx = self.nx
        ev.grads["amplitude_deg"] = dy[nx]
        ev.monodromy = np.asarray(s["J"][:, :nx])
        if self.second:  # along theta_c with x0 and A following: dy[:nx, c], dy[nx, c]
            W = np.vstack([np.eye(self.nt), dy[nx]])
            if nx > DOMINANT_COLUMNS:  # d(M V), V the dominant subspace of this M (jury_values finds the same V)
                V = dominant_block(ev.monodromy, DOMINANT_COLUMNS)[2]
                s2 = self.sens2(ev.x0, D, p, dp=self._seeds, columns=cols, W=W, dx0=dy[:nx], S0=V)
                ev.d_monodromy = s2["dMon"]
            else:
                s2 = self.sens2(ev.x0, D, p, dp=self._seeds, columns=cols, W=W, dx0=dy[:nx])
                ev.d_monodromy, ev.monodromy = s2["dMon"], np.asarray(s2["Mon"])
        ev.dy, ev.Ry = dy, Ry

    def fill_monodromy(self, ev: Evaluation) -> None:
        """Set ``ev.monodromy`` if it has none (state directions only: no gradients, no second order).

        Parameters
        ----------
        ev : Evaluation
            A cycle, filled in place.

        Returns
        -------
        None
        """
        if ev.monodromy is None:
            p = self.pfull(ev.theta, ev.amplitude_deg)
            ev.monodromy = np.asarray(self.sens_mono(ev.x0, self._D(p), p)["J"])

    def evaluate_near(self, theta, base: Evaluation, tol: float = 1e-10, max_newton: int = 12) -> Evaluation:
        """The level cycle at theta, with its gradients, from the nearby ``base`` (an evaluation with
        gradients): Newton from base's first-order prediction with base's Jacobian as the chord.

        Side-effect-free (no warm-start state read or written, nothing cached; only the evaluation
        counters change, under a lock), so safe in threads and a pure function of (theta, base): the
        perturbed points of a finite-difference Hessian. Raises RuntimeError if Newton fails.

        Parameters
        ----------
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.
        base : Evaluation
            A nearby cycle with gradients (``dy`` and ``Ry`` set).
        tol : float
            Newton tolerance on the max abs residual.
        max_newton : int
            Newton steps.

        Returns
        -------
        Evaluation
            With its gradients.
        """
        theta = np.asarray(theta, float).ravel()
        y0 = base.y + base.dy @ (theta - base.theta)
        ev = self._newton(y0, theta, tol, max_newton, Ry=base.Ry, keep=False)
        self._gradients(ev)
        return ev

    def cached(self, theta) -> Evaluation | None:
        """The evaluation at exactly theta if it is among the last few, else None (no computation).

        Parameters
        ----------
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.

        Returns
        -------
        Evaluation or None
        """
        return self._cache.get(np.asarray(theta, float).ravel().tobytes())

    def accept(self, theta) -> None:
        """Mark the (already evaluated) cycle at theta as a good restart point for Newton.

        Parameters
        ----------
        theta : array_like
            Free parameters of a cycle among the last few evaluations (:meth:`cached`); any other
            theta changes nothing.

        Returns
        -------
        None
        """
        ev = self.cached(theta)
        if ev is not None:
            self._anchor = np.append(ev.x0, ev.amplitude_deg)

    def _newton(self, y, theta, tol, max_newton, Ry=None, keep: bool = True) -> Evaluation:
        """Newton on the level-cycle residual from y: chord steps with the last Jacobian (``keep``,
        which also remembers a fresh one for the next solve) or with ``Ry`` (``keep=False``: no
        state read or written), a fresh Jacobian when they stall. When the steps run out with the
        residual still below its start (a chord contracting by just under 0.3 a step: 12 steps reach
        only ~1e-8), up to :data:`NEWTON_RESCUE_STEPS` more with a fresh Jacobian each; a solve that
        converged within ``max_newton`` is unchanged."""
        y = np.asarray(y, float).copy()
        lo, hi = self.amplitude_range_deg
        it, rescue = 0, False
        Ry = self._Ry if keep else Ry
        R, means = self.residual(y, theta)
        last, first = np.inf, np.max(np.abs(R))
        while True:
            res = float(np.max(np.abs(R)))
            if not (math.isfinite(res) and np.all(np.isfinite(y))) or not lo <= y[self.nx] <= hi:
                raise RuntimeError(f"Newton left the level cycles (residual {res:.2e}, amplitude {y[self.nx]:.4g} deg)")
            if res <= tol:
                break
            if res > 1e3 * max(first, 1e-6) or it >= max_newton + (NEWTON_RESCUE_STEPS if rescue else 0):
                if rescue or it < max_newton or not res < first:
                    raise RuntimeError(f"residual {res:.2e} after {it} Newton steps")
                rescue = True
            if Ry is None or res > 0.3 * last or rescue:
                _, R, Ry, *_ = self._full(y, theta)  # fresh Jacobian (the chord stalled)
                if keep:
                    self._Ry = Ry
            last = res
            try:
                y = y - np.linalg.solve(Ry, R)
            except np.linalg.LinAlgError:
                raise RuntimeError("singular level-cycle Jacobian (a fold of cycles)") from None
            it += 1
            R, means = self.residual(y, theta)
        return Evaluation(theta.copy(), y[:self.nx].copy(), float(y[self.nx]), dict(zip(self.out_names, means.tolist())), None,
                          None, None, res, it)

    def solve_speed(self, speed_mps: float, theta, k: int = 0, bounds=None, tol: float = 1e-9,
                    max_iter: int = 30) -> Evaluation:
        """Level flight at mean forward speed ``speed_mps``: Newton on theta[k] (the others fixed),
        exact derivative dU/dtheta_k; damped (at most 3 units of the key per step), kept within
        ``bounds``. Raises RuntimeError when the speed is not reached; when dU/dtheta_k vanishes or
        changes sign between two iterates that both fall short on the same side, the speed lies beyond
        a local extremum of U(theta_k) and the message gives it.

        Parameters
        ----------
        speed_mps : float
            Target mean forward speed [m/s].
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.
        k : int
            Index of the free parameter that is varied.
        bounds : (float, float), optional
            Bounds of theta[k].
        tol : float
            Tolerance on the speed [m/s].
        max_iter : int
            Newton steps.

        Returns
        -------
        Evaluation
            The level cycle at the speed.
        """
        theta = np.asarray(theta, float).copy()
        prev = None
        for _ in range(max_iter):
            ev = self.evaluate(theta)
            r = ev.means["forward_speed_mps"] - speed_mps
            if abs(r) < tol:
                return ev
            g = ev.grads["forward_speed_mps"][k]
            if g == 0 or (prev is not None and prev[1] * r > 0 and prev[2] * g < 0):
                u, t = min([(r, theta[k])] + ([(prev[1], prev[0])] if prev else []), key=lambda a: abs(a[0]))
                raise RuntimeError(
                    f"speed {speed_mps} m/s not reachable by {self.keys[k]} here: the level speed has a local "
                    f"{'maximum' if r < 0 else 'minimum'} near {u + speed_mps:.6g} m/s ({self.keys[k]} about "
                    f"{t:.4g}; dU/d{self.keys[k].rsplit('.', 1)[-1]} changes sign)")
            prev = (float(theta[k]), r, g)
            step = -r / g
            step = float(np.clip(step, -3.0, 3.0))
            new = theta[k] + step
            if bounds is not None:
                new = float(np.clip(new, *bounds))
            if new == theta[k]:
                break  # at a bound
            theta[k] = new
        raise RuntimeError(f"speed {speed_mps} m/s not reached by {self.keys[k]} within its bounds (last U = "
                           f"{ev.means['forward_speed_mps']:.9g} m/s at {self.keys[k]} = {theta[k]:.6g})")

