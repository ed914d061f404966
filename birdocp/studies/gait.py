"""The energy-optimal (and the most stable) level-flight gait, in reduced space.

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
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import require_body_states, PARAM_NAMES, Config, ConfigError, get_value, suggest, with_values
from birdocp.bird.validity import periodic_validity
from birdocp.engine.cache import bounded_cache
from birdocp.engine.floquet import sort_multipliers
from birdocp.engine.results import result_dict, serial

__all__ = ["ReducedLevelCycle", "ReducedProblem", "GaitOptimum", "optimize_gait", "OBJECTIVES", "DEFAULT_GAIT_FREE",
           "level_at_speed", "power_curve", "SPEED_KEY", "stability_pareto", "jury_conditions", "valid_power_curve",
           "curve_optima",
           "check_free_keys"]

AMPLITUDE_KEY = "gait.shoulder_flap.amplitude_deg"
SPEED_KEY = "gait.shoulder_incidence.offset_deg"
"""The gait parameter that holds the forward speed in the power curve (with the amplitude holding
level flight): the wing's mean incidence."""
OBJECTIVES = ("power", "cost-of-transport", "positive-power")
JURY_MARGIN = 1e-6
POSITIVE_EPS_W = 0.05
"""Smoothing of max(P, 0) in the positive-power objective, 1/2 (P + sqrt(P^2 + eps^2)), error <= eps/2."""

DEFAULT_GAIT_FREE = {
    "gait.shoulder_incidence.offset_deg": (0.0, 25.0),
    "gait.shoulder_incidence.amplitude_deg": (0.0, 10.0),
    "gait.shoulder_sweep.offset_deg": (-30.0, -5.0),
    "gait.shoulder_sweep.amplitude_deg": (10.0, 30.0),
}
"""Default free gait parameters of ``optimize-gait`` (the flapping amplitude is solved for level flight
within 20-70 deg): the shoulder incidence and sweep, as in ``optimize-stability``, with the incidence
offset's range widened to hold speeds from about 13 to 24 m/s."""

# rows of the quadrature output vector
_OUT = ("vertical_speed_mps", "forward_speed_mps", "flapping_power_W", "aerodynamic_power_W",
        "positive_power_smooth_W")


def jury_conditions(A):
    """The five Jury quantities (each >= 0 <=> all eigenvalues of the 4 x 4 A in the closed unit
    disc, strict > 0 for the open disc)."""
    t1 = ca.trace(A)
    A2 = A @ A
    t2 = ca.trace(A2)
    t3 = ca.trace(A2 @ A)
    a3 = -t1
    a2 = 0.5 * (t1 ** 2 - t2)
    a1 = -(t1 ** 3 - 3 * t1 * t2 + 2 * t3) / 6
    a0 = ca.det(A)
    a = [a0, a1, a2, a3, 1.0]
    p1 = sum(a)
    pm1 = a0 - a1 + a2 - a3 + 1.0
    b = [a[0] * a[k] - a[4] * a[4 - k] for k in range(4)]
    c = [b[0] * b[k] - b[3] * b[3 - k] for k in range(3)]
    return ca.vertcat(p1, pm1, 1 - a0 ** 2, b[0] ** 2 - b[3] ** 2, c[0] ** 2 - c[2] ** 2)


def check_free_bounds(cfg, free: dict) -> None:
    """ConfigError unless every free key is a known parameter other than the amplitude, with finite
    bounds lower < upper that hold the configured value and lie in the key's physical range (each
    bound is a valid configuration value). Needs no model: callers check this before building one."""
    for k, (lo, hi) in free.items():
        if k not in PARAM_NAMES:
            raise ConfigError(k, "unknown parameter for --free" + suggest(k, PARAM_NAMES))
        if k == AMPLITUDE_KEY:
            raise ConfigError(k, "the flapping amplitude is solved for level flight; free other keys")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ConfigError(k, f"bounds must be finite with lower < upper, got ({lo}, {hi})")
        v = float(get_value(cfg, k))
        if not lo <= v <= hi:
            raise ConfigError(k, f"configured value {v:g} lies outside its bounds ({lo:g}, {hi:g}); "
                                 f"widen --bounds {k}=LO:HI")
        for end, value in (("lower", lo), ("upper", hi)):
            try:
                with_values(cfg, {k: float(value)})
            except ConfigError as exc:
                raise ConfigError(k, f"the {end} bound {value:g} is not a valid value ({exc}); "
                                     f"narrow --bounds {k}=LO:HI") from None


def check_free_keys(m, cfg, free: dict) -> None:
    """ConfigError unless every free key can be a reduced variable (:func:`check_free_bounds`, and
    not reshaping the wing in the arm frame, which the model ``m`` tells)."""
    check_free_bounds(cfg, free)
    for k in free:
        if PARAM_NAMES.index(k) in m.pre_params:
            raise ConfigError(k, "changes the wing's shape in the arm frame (elbow, wrist, morphology): "
                                 "free shoulder joints, wing.root_ahead_m or body/aero/drag keys")


def _jury_function():
    M, r = ca.SX.sym("M", 4, 4), ca.SX.sym("r")
    j = jury_conditions(M / r)
    return ca.Function("jury", [M, r], [j, ca.jacobian(j, ca.vertcat(ca.vec(M), r))])


@dataclass
class Evaluation:
    """The level cycle at one theta and its exact gradients (per unit of each free key)."""

    theta: np.ndarray
    x0: np.ndarray
    amplitude_deg: float
    means: dict            # _OUT name -> period mean
    grads: dict            # name -> d mean / d theta; also "amplitude_deg"
    monodromy: np.ndarray
    d_monodromy: np.ndarray | None  # 16 x n_theta (column-major vec), second order only
    residual: float
    newton_iterations: int
    dy: np.ndarray | None = None    # d(x0, A)/d theta (5 x n_theta), with the gradients
    Ry: np.ndarray | None = None    # the level-cycle residual's Jacobian in (x0, A), with the gradients

    @property
    def y(self) -> np.ndarray:
        """The level cycle's unknowns (x0, A)."""
        return np.append(self.x0, self.amplitude_deg)

    @property
    def multipliers(self) -> np.ndarray:
        if self.monodromy is None or not np.all(np.isfinite(self.monodromy)):
            return np.full(4, np.nan, complex)
        return sort_multipliers(np.linalg.eigvals(self.monodromy))


_GRAPHS = bounded_cache("studies.gait_graphs", 4)


def _graphs(m, cfg: Config, N: int, vidx: tuple, nt: int, second: bool, valid: bool) -> dict:
    """The CasADi Functions of a :class:`ReducedLevelCycle` (outputs, RK4 grid, first- and
    second-order sensitivities, the monodromy alone, the data and its directions), built once per
    (model, steps, free parameters, order, validity thresholds, the wing's arm-frame shape) and reused
    by every later cycle of the same problem in this process (e.g. every point of a Pareto front a
    worker solves): a build costs seconds, a point's solve tens of them."""
    from birdocp.bird.energetics import power_functions
    from birdocp.engine.integrate import RK4Grid
    from birdocp.engine.variational import PeriodSensitivities

    p0 = np.asarray(m.p0, float)
    thresholds = None
    if valid:
        v = cfg.validity
        thresholds = (v.stall_angle_deg, v.min_forward_speed_mps, v.max_abs_pitch_deg, v.max_airflow_body_angle_deg)
    key = (id(m.model), N, vidx, second, thresholds, p0[list(m.ode.pre_params)].tobytes())
    hit = _GRAPHS.get(key)
    if hit is not None and hit["model"] is m.model:
        return hit
    nv = len(vidx)
    pf = power_functions(m)
    x, d, p = ca.SX.sym("x", 4), ca.SX.sym("d", m.ode.nd), ca.SX.sym("p", len(PARAM_NAMES))
    pw = pf.power(x, d, p)
    Pf = pw[1]  # the shoulder power: flapping (aerodynamic) + the wings' inertial part if any
    if "shoulder_inertial_power_W" in pf.names:
        Pf = Pf + pw[pf.names.index("shoulder_inertial_power_W")]
    out = ca.vertcat(pw[8], pw[7], Pf, pw[0], 0.5 * (Pf + ca.sqrt(Pf ** 2 + POSITIVE_EPS_W ** 2)))
    out_names = _OUT
    if valid:  # the smooth validity integrands, on the same RK4 stages (bird.validity_smooth)
        from birdocp.bird.validity_smooth import integrand_names, smooth_integrands

        out = ca.vertcat(out, smooth_integrands(cfg, m.ode.nd)(x, d, p))
        out_names = _OUT + integrand_names()
    outputs = ca.Function("gait_outputs", [x, d, p], [out])
    grid = RK4Grid(m.ode, N, 1, outputs=(outputs,))
    sens = PeriodSensitivities(m.ode, N, (outputs,), nv)
    g = {"model": m.model, "out_names": out_names, "outputs": outputs, "grid": grid, "sens": sens,
         # second order only along the nt total directions (x0 and A moving with theta), known once
         # the first-order pass gave dy/dtheta: about half the cost of all 4 + nt + 1 directions
         "sens2": (PeriodSensitivities(m.ode, N, (outputs,), nt, True, combined=True, n_data=nv) if second else None),
         # the monodromy alone (the 4 state directions): what a line-search trial point's stability
         # constraint needs, at a fraction of a gradient evaluation's cost
         "sens_mono": PeriodSensitivities(m.ode, N, (), 0) if second else None,
         "times": ca.DM(grid.times(0.0)).reshape((1, -1)), "local": grid.pre_numeric(0.0, p0)}
    L, t, ps = ca.SX.sym("local", m.pre.size1_out(0)), ca.SX.sym("t"), ca.SX.sym("p", len(PARAM_NAMES))
    dd = m.post(L, t, ps)
    # the data and its Jacobian along the free parameters (forward mode, shared nominal values)
    post_jac = ca.Function("post_jac", [L, t, ps], [dd, ca.jacobian(dd, ca.vertcat(*[ps[j] for j in vidx]))])
    seeds = np.zeros((len(PARAM_NAMES), nv))
    for k, j in enumerate(vidx):
        seeds[j, k] = 1.0
    # data and its directions in the variational layout, as one MX Function (the reordering of
    # ~10^6 numbers stays in CasADi: through numpy it cost more than the sensitivities)
    pm = ca.MX.sym("p", len(PARAM_NAMES))
    blk = grid.block_index
    Dg, Jg = post_jac.map(2 * N + 1)(g["local"], g["times"], pm)  # Jg: nv columns per time
    cols = sens.direction_columns([Jg[:, [tk * nv + k for tk in blk]] for k in range(nv)])
    g |= {"seeds": seeds, "data": ca.Function("gait_data", [pm], [Dg[:, blk], cols])}
    _GRAPHS.put(key, g)
    return g


class ReducedLevelCycle:
    """The level-flight cycle as a function of the free gait parameters (see module docstring).

    cfg: configuration (every other value); keys: the free parameters theta; steps_per_period: RK4
    grid; climb_rate_mps: the mean vertical speed held by the amplitude; second_order: also the
    monodromy's derivatives (for stability constraints).
    """

    def __init__(self, cfg: Config, keys, steps_per_period: int | None = None, climb_rate_mps: float = 0.0,
                 second_order: bool = False, amplitude_start_deg: float | None = None, valid: bool = False):
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
        g = _graphs(m, cfg, N, tuple(self.vidx), self.nt, self.second, self.valid)
        self.out_names, self.outputs, self.grid, self.sens = g["out_names"], g["outputs"], g["grid"], g["sens"]
        self.sens2, self.sens_mono, self._data = g["sens2"], g["sens_mono"], g["data"]
        self.times, self.local, self._seeds = g["times"], g["local"], g["seeds"]
        self._y = np.concatenate([np.asarray(cfg.solve.initial_guess, float),
                                  [float(amplitude_start_deg if amplitude_start_deg is not None
                                         else self.p0[self.ia])]])
        self._theta = None
        self._started = False
        self._dy = None
        self._Ry = None
        self._cache: dict = {}
        self._anchor = None
        self.amplitude_range_deg = (0.0, 90.0)
        """Newton solutions with the flapping amplitude outside this range are failures [deg]."""
        self.n_full = self.n_resid = 0
        self._count_lock = threading.Lock()  # the counters (evaluate_near runs in threads)

    # -- pieces ----------------------------------------------------------------------------------
    def pfull(self, theta, A):
        p = self.p0.copy()
        p[self.idx] = theta
        p[self.ia] = A
        return p

    def _D(self, p):
        return self.grid.blocks_numeric(0.0, p)  # one Function (the slicing of a DM in Python cost a third)

    def residual(self, y, theta):
        """(R, means): the level-cycle residual (x_T - x0, mean W - climb) and the period means."""
        p = self.pfull(theta, y[4])
        xT, _, q = self.grid.period_map(ca.DM(y[:4]), self._D(p), ca.DM(p))
        with self._count_lock:
            self.n_resid += 1
        means = np.asarray(q).ravel() / self.T
        return np.concatenate([np.asarray(xT).ravel() - y[:4], [means[0] - self.climb]]), means

    def _full(self, y, theta):
        """First-order sensitivities at (y, theta): R, R_y, R_theta, the means' partials, and the
        data (D, directions, p) for a second-order pass."""
        with self._count_lock:
            self.n_full += 1
        p = self.pfull(theta, y[4])
        D, cols = self._data(ca.DM(p))
        s = self.sens(y[:4], D, p, dp=self._seeds, columns=cols)
        T, nt = self.T, self.nt
        cy = list(range(4)) + [4 + nt]          # columns of y = (x0, A)
        ct = list(range(4, 4 + nt))             # columns of theta
        J, Jq = s["J"], s["Jq"] / T
        R = np.concatenate([s["x_T"] - y[:4], [s["q"][0] / T - self.climb]])
        Ry = np.vstack([J[:, cy] - np.eye(5)[:4], Jq[0, cy]])
        Rt = np.vstack([J[:, ct], Jq[0, ct]])
        return s, R, Ry, Rt, Jq, cy, ct, (D, cols, p)

    # -- the reduced map -------------------------------------------------------------------------
    def set_guess(self, x0) -> None:
        """Start the first Newton solve from the state ``x0`` (at the configured amplitude)."""
        self._y[:4] = np.asarray(x0, float)
        self._started = True

    def _first_guess(self, theta):
        """x0 from a trim (multiple shooting) of the gait theta at the configured amplitude."""
        from birdocp.studies.trim import trim

        y = self._y.copy()
        tr = trim(with_values(self.cfg, dict(zip(self.keys, map(float, theta)))), steps_per_period=self.N)
        if tr.success:
            y[:4] = tr.x0
        return y

    def evaluate(self, theta, grads: bool = True, tol: float = 1e-10, max_newton: int = 12) -> Evaluation:
        """The level cycle at theta (Newton on (x0, A), chord steps with the last Jacobian) and, with
        ``grads``, its exact gradients and monodromy; raises RuntimeError if Newton fails.

        Newton starts from the first-order prediction off the last point with gradients; if that
        fails (near a fold of cycles the prediction ``dy/dtheta`` is large and can throw Newton onto
        another cycle), from the last solved point, then from the last accepted point
        (:meth:`accept`). A non-finite residual, a growing one, or an amplitude outside
        ``amplitude_range_deg`` is a failure: the optimiser sees an evaluation error and cuts its step."""
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
        ev.grads["amplitude_deg"] = dy[4]
        ev.monodromy = np.asarray(s["J"][:, :4])
        if self.second:  # along theta_c with x0 and A following: dy[:4, c], dy[4, c]
            W = np.vstack([np.eye(self.nt), dy[4]])
            s2 = self.sens2(ev.x0, D, p, dp=self._seeds, columns=cols, W=W, dx0=dy[:4])
            ev.d_monodromy, ev.monodromy = s2["dMon"], np.asarray(s2["Mon"])
        ev.dy, ev.Ry = dy, Ry

    def fill_monodromy(self, ev: Evaluation) -> None:
        """Set ``ev.monodromy`` if it has none (state directions only: no gradients, no second order)."""
        if ev.monodromy is None:
            p = self.pfull(ev.theta, ev.amplitude_deg)
            ev.monodromy = np.asarray(self.sens_mono(ev.x0, self._D(p), p)["J"])

    def evaluate_near(self, theta, base: Evaluation, tol: float = 1e-10, max_newton: int = 12) -> Evaluation:
        """The level cycle at theta, with its gradients, from the nearby ``base`` (an evaluation with
        gradients): Newton from base's first-order prediction with base's Jacobian as the chord.

        Side-effect-free (no warm-start state read or written, nothing cached; only the evaluation
        counters change, under a lock), so safe in threads and a pure function of (theta, base): the
        perturbed points of a finite-difference Hessian. Raises RuntimeError if Newton fails."""
        theta = np.asarray(theta, float).ravel()
        y0 = base.y + base.dy @ (theta - base.theta)
        ev = self._newton(y0, theta, tol, max_newton, Ry=base.Ry, keep=False)
        self._gradients(ev)
        return ev

    def cached(self, theta) -> Evaluation | None:
        """The evaluation at exactly theta if it is among the last few, else None (no computation)."""
        return self._cache.get(np.asarray(theta, float).ravel().tobytes())

    def accept(self, theta) -> None:
        """Mark the (already evaluated) cycle at theta as a good restart point for Newton."""
        ev = self._cache.get(np.asarray(theta, float).ravel().tobytes())
        if ev is not None:
            self._anchor = np.append(ev.x0, ev.amplitude_deg)

    def _newton(self, y, theta, tol, max_newton, Ry=None, keep: bool = True) -> Evaluation:
        """Newton on the level-cycle residual from y: chord steps with the last Jacobian (``keep``,
        which also remembers a fresh one for the next solve) or with ``Ry`` (``keep=False``: no
        state read or written), a fresh Jacobian when they stall."""
        y = np.asarray(y, float).copy()
        lo, hi = self.amplitude_range_deg
        it = 0
        Ry = self._Ry if keep else Ry
        R, means = self.residual(y, theta)
        last, first = np.inf, np.max(np.abs(R))
        while True:
            res = float(np.max(np.abs(R)))
            if not (math.isfinite(res) and np.all(np.isfinite(y))) or not lo <= y[4] <= hi:
                raise RuntimeError(f"Newton left the level cycles (residual {res:.2e}, amplitude {y[4]:.4g} deg)")
            if res <= tol:
                break
            if it >= max_newton or res > 1e3 * max(first, 1e-6):
                raise RuntimeError(f"residual {res:.2e} after {it} Newton steps")
            if Ry is None or res > 0.3 * last:
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
        return Evaluation(theta.copy(), y[:4].copy(), float(y[4]), dict(zip(self.out_names, means.tolist())), None,
                          None, None, res, it)

    def solve_speed(self, speed_mps: float, theta, k: int = 0, bounds=None, tol: float = 1e-9,
                    max_iter: int = 30) -> Evaluation:
        """Level flight at mean forward speed ``speed_mps``: Newton on theta[k] (the others fixed),
        exact derivative dU/dtheta_k; damped, kept within ``bounds``."""
        theta = np.asarray(theta, float).copy()
        for _ in range(max_iter):
            ev = self.evaluate(theta)
            r = ev.means["forward_speed_mps"] - speed_mps
            if abs(r) < tol:
                return ev
            g = ev.grads["forward_speed_mps"][k]
            step = -r / g if g != 0 else 0.0
            step = float(np.clip(step, -3.0, 3.0))
            new = theta[k] + step
            if bounds is not None:
                new = float(np.clip(new, *bounds))
            if new == theta[k]:
                break  # at a bound
            theta[k] = new
        raise RuntimeError(f"speed {speed_mps} m/s not reached by {self.keys[k]} within its bounds (last U = "
                           f"{ev.means['forward_speed_mps']:.9g} m/s at {self.keys[k]} = {theta[k]:.6g})")


# ------------------------------------------------------------------------------------------------
@dataclass
class GaitOptimum:
    """Result of :func:`optimize_gait` (to_dict: the documented JSON keys)."""

    success: bool
    status: str
    message: str
    objective: str
    iterations: int
    objective_value: float
    start_objective_value: float
    free: dict
    bounds: dict
    start_free: dict
    amplitude_deg: float
    x0: np.ndarray
    multipliers: np.ndarray = field(metadata=serial(complex=True))
    start_multipliers: np.ndarray = field(metadata=serial(complex=True))
    mean_forward_speed_mps: float
    speed_mps: float | None
    max_multiplier: float | None
    means: dict
    kkt_residual: float
    constraint_violation: float
    verification: dict = field(default_factory=dict)
    wall_s: dict = field(default_factory=dict)
    evaluations: dict = field(default_factory=dict)
    cfg: Config | None = None
    start_x0: np.ndarray | None = None
    validity: dict | None = None
    """Where the model holds on the optimal cycle (:meth:`birdocp.bird.validity.CycleValidity.to_dict`)."""
    validity_constraints: dict | None = None
    """With ``valid=True``: per limit of ``[validity]`` its smooth value, the exact one, the configured
    bound, the bound used, whether it is active, its multiplier and smoothing
    (:func:`birdocp.studies.gait_validity.constraint_report`)."""
    validity_rounds: list | None = None
    """With ``valid=True``: one entry per solve (bounds used, status, exact verdict, iterations)."""
    second_derivatives: np.ndarray | None = None
    """With ``hessian="fd"``: the last finite-difference second derivatives, ``[k, i, j] =
    d^2 G_i / dz_j dz_k`` (G = objective and constraints, z = free values and r, unscaled); what a
    warm-started ``hessian="fixed"`` solve (e.g. on a finer grid) takes as ``second_derivatives``."""

    @property
    def largest_modulus(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): the documented keys."""
        return result_dict(self, exclude=("cfg", "start_x0", "means", "second_derivatives"), derived=("largest_modulus",), extra={
            "active_bounds": [k for k, v in self.free.items()
                              if min(abs(v - self.bounds[k][0]), abs(v - self.bounds[k][1])) < 1e-6],
            "moduli": np.abs(self.multipliers), "stable": bool(self.largest_modulus < 1),
            "mean_shoulder_power_W": self.means.get("flapping_power_W"),
            "mean_aerodynamic_power_W": self.means.get("aerodynamic_power_W"),
            "mean_vertical_speed_mps": self.means.get("vertical_speed_mps")})


class ReducedProblem:
    """The reduced NLP for IPOPT (the evaluator of :class:`birdocp.engine.oracle.ConstraintOracle`):
    G(z) = [objective; constraints] and dG/dz, z = the scaled free values theta (and r for the
    stability objective); :meth:`jacobian_near` gives a finite-difference Hessian's perturbed points."""

    def __init__(self, rc: ReducedLevelCycle, objective: str, speed, max_multiplier, amplitude_bounds,
                 valid_bounds: dict | None = None):
        self.rc, self.objective, self.speed, self.R = rc, objective, speed, max_multiplier
        self.amp = amplitude_bounds
        self.with_r = objective == "stability"
        self.jury = _jury_function() if (max_multiplier is not None or self.with_r) else None
        nt = rc.nt
        self.nz = nt + (1 if self.with_r else 0)
        self.valid_bounds = dict(valid_bounds or {})
        """limit -> (bound used, 'max' or 'min') of the smooth validity constraints (empty: none)."""
        self.names = ["amplitude_deg"] + (["forward_speed_mps"] if speed is not None else []) \
            + ([f"jury{i}" for i in range(5)] if self.jury is not None else []) \
            + ["valid_" + k for k in self.valid_bounds]
        self.ng = 1 + len(self.names)
        self.jac_sparsity = ca.Sparsity.dense(self.ng, self.nz)
        self.sigma = np.ones(self.nz)
        self.failures: list = []
        self.progress = None
        mg = float(get_value(rc.cfg, "body.mass_kg") * get_value(rc.cfg, "body.gravity_mps2"))
        self.mg = mg

    def bounds_g(self):
        lo, hi = [self.amp[0]], [self.amp[1]]
        if self.speed is not None:
            lo.append(self.speed)
            hi.append(self.speed)
        if self.jury is not None:
            lo += [JURY_MARGIN] * 5
            hi += [np.inf] * 5
        for b, kind in self.valid_bounds.values():
            lo.append(b if kind == "min" else -np.inf)
            hi.append(b if kind == "max" else np.inf)
        return np.array(lo), np.array(hi)

    def smooth_validity(self, ev: Evaluation, grads: bool = True):
        """({limit: smooth value}, {limit: gradient in theta}) of the constrained validity limits."""
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
        constraint in 0.015-deg steps)."""
        g = ev.grads
        P = max(abs(ev.means["flapping_power_W"]), 1e-3)
        sig = np.maximum.reduce([np.abs(g["forward_speed_mps"]), np.abs(g["flapping_power_W"]) / (0.1 * P),
                                 np.abs(g["amplitude_deg"]), np.full(self.rc.nt, 1e-2)])
        self.sigma = np.concatenate([sig, [1.0] if self.with_r else []])

    def both(self, z, grads: bool = True):
        z = np.asarray(z, float).ravel() / self.sigma
        nt = self.rc.nt
        try:
            ev = self.rc.evaluate(z[:nt], grads=grads)
        except RuntimeError as e:  # no level cycle here: NaN makes IPOPT cut its step back
            self.failures.append(str(e))
            return np.full(self.ng, np.nan), np.full((self.ng, self.nz), np.nan)
        if ev.grads is None:  # values only (a line-search trial point)
            G = np.array([z[-1] if self.with_r else self._value(ev)] + [ev.amplitude_deg]
                         + ([ev.means["forward_speed_mps"]] if self.speed is not None else []))
            if self.jury is not None:  # the monodromy alone: no gradients at a trial point
                self.rc.fill_monodromy(ev)
                r = z[-1] if self.with_r else self.R
                G = np.concatenate([G, np.asarray(self.jury(ca.DM(ev.monodromy), r)[0]).ravel()])
            if self.valid_bounds:
                vals = self.smooth_validity(ev, grads=False)[0]
                G = np.concatenate([G, [vals[k] for k in self.valid_bounds]])
            return G, None
        return self._assemble(ev, z)

    def _assemble(self, ev: Evaluation, z, report: bool = True):
        """(G, dG/dz) from an evaluation with gradients; z unscaled (theta, r)."""
        nt = self.rc.nt
        G = np.zeros(self.ng)
        J = np.zeros((self.ng, self.nz))
        if self.with_r:
            G[0], J[0, -1] = z[-1], 1.0
        else:
            G[0], J[0, :nt] = self._obj(ev, z)
        if report and callable(self.progress):
            self.progress(f"{self.objective} {G[0]:.6g}, |L1| {np.max(np.abs(ev.multipliers)):.5f}, "
                          f"A {ev.amplitude_deg:.3f} deg")
        G[1], J[1, :nt] = ev.amplitude_deg, ev.grads["amplitude_deg"]
        i = 2
        if self.speed is not None:
            G[i], J[i, :nt] = ev.means["forward_speed_mps"], ev.grads["forward_speed_mps"]
            i += 1
        if self.jury is not None:
            r = z[-1] if self.with_r else self.R
            jv, jj = (np.asarray(v) for v in self.jury(ca.DM(ev.monodromy), r))
            G[i:i + 5] = jv.ravel()
            J[i:i + 5, :nt] = jj[:, :16] @ ev.d_monodromy
            if self.with_r:
                J[i:i + 5, -1] = jj[:, 16]
            i += 5
        if self.valid_bounds:
            vals, der = self.smooth_validity(ev)
            for k in self.valid_bounds:
                G[i], J[i, :nt] = vals[k], der[k]
                i += 1
        return G, J / self.sigma

    def _value(self, ev):
        P, U = ev.means["flapping_power_W"], ev.means["forward_speed_mps"]
        return {"power": P, "positive-power": ev.means["positive_power_smooth_W"],
                "cost-of-transport": P / (self.mg * U)}[self.objective]

    def g(self, z):
        return self.both(z, grads=False)[0]

    def jacobian(self, z):
        J = self.both(z)[1]
        if J is not None and np.all(np.isfinite(J)):  # IPOPT asks for derivatives at accepted points
            self.rc.accept(np.asarray(z, float).ravel()[:self.rc.nt] / self.sigma[:self.rc.nt])
        return J

    def jacobian_near(self, zk, z):
        """dG/dz at ``zk`` next to ``z`` (where :meth:`jacobian` was just evaluated), side-effect-free
        and thread-safe (:meth:`ReducedLevelCycle.evaluate_near` from z's cycle): the perturbed points
        of :class:`birdocp.engine.oracle.StencilHessian`. NaN where no level cycle is found."""
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
        return self._assemble(ev, zk, report=False)[1]


def optimize_gait(cfg: Config | None = None, free: dict | None = None, *, objective: str = "power",
                  speed_mps: float | None = None, max_multiplier: float | None = None,
                  climb_rate_mps: float = 0.0, amplitude_bounds=(20.0, 70.0),
                  steps_per_period: int | None = None, max_iter: int = 100, tol: float = 1e-8,
                  verify: bool = True, progress=False, start: dict | None = None, x_guess=None,
                  ipopt_options: dict | None = None, hessian: str = "sr1",
                  radius_start_factor: float = 1.05, threads: int = 2,
                  second_derivatives: np.ndarray | None = None, valid: bool = False,
                  valid_rounds: int | None = None) -> GaitOptimum:
    """Minimise mean power (``objective="power"``), cost of transport, smoothed positive-work power,
    or the stability radius (``"stability"``) over the gait parameters ``free`` (key -> (lo, hi);
    default :data:`DEFAULT_GAIT_FREE`), in level flight (mean W = ``climb_rate_mps``, the amplitude
    solved within ``amplitude_bounds``) at mean forward speed ``speed_mps`` (None: free speed), with
    all multipliers inside the circle of radius ``max_multiplier`` (None: no stability constraint).

    The start is the configured gait (``start`` overrides values), brought to ``speed_mps`` by the
    first free key (Newton, exact derivative); its objective is ``start_objective_value``. ``x_guess``:
    the state at t = 0 of the start's level cycle, if known (default: a trim of the start gait). The
    optimum is verified by a trim (5-point multiple shooting) at the optimal gait.

    ``hessian``: "sr1" (limited-memory SR1 updates) or "fd" (IPOPT's exact-Hessian mode on the
    forward finite difference of the exact constraint gradients, four or five extra gradient
    evaluations per iteration; far fewer iterations with a stability constraint or objective: 21
    instead of 120 for the most stable gait of the reference problem on 48 steps; the perturbed
    points are evaluated ``threads`` at a time, each by Newton from the iterate's cycle, so the
    result does not depend on the number of threads), or "fixed" (exact-Hessian mode on the
    ``second_derivatives`` of a nearby solve held fixed, e.g. those of a coarser grid's optimum:
    one gradient evaluation per iteration).
    ``radius_start_factor``: with the stability objective, r starts at this factor times the start's
    spectral radius.

    ``valid``: every limit of ``cfg.validity`` is a smooth constraint
    (:mod:`birdocp.bird.validity_smooth`; exact gradients from the same RK4 stages). The exact
    validity of the optimum is checked; a limit still crossed (a smooth measure is not a bound of the
    exact one) has its smooth bound tightened by the difference and the problem is solved again from
    the optimum, at most ``valid_rounds`` (default
    :data:`birdocp.studies.gait_validity.VALID_ROUNDS`) solves in all. The result
    always carries the exact ``validity``; with ``valid`` also ``validity_constraints``.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    free : dict, optional
        Gait key -> (lo, hi) (default :data:`DEFAULT_GAIT_FREE`).
    objective : {"power", "cost-of-transport", "positive-power", "stability"}
        What is minimised.
    speed_mps : float, optional
        Mean forward speed held [m/s] (None: free speed).
    max_multiplier : float, optional
        Bound on every multiplier's modulus (None: no stability constraint).
    climb_rate_mps : float
        Mean vertical speed held [m/s].
    amplitude_bounds : (float, float)
        Bounds of the flapping amplitude [deg].
    steps_per_period : int, optional
        RK4 steps per period (default ``cfg.solve.steps_per_period``).
    max_iter : int
        IPOPT iterations.
    tol : float
        IPOPT's tolerance.
    verify : bool
        Verify the optimum by an independent trim.
    progress : bool or callable
        False (silent), True (one line per evaluation on stderr) or a callable taking that line.
    start : dict, optional
        Gait values overriding the configured start.
    x_guess : array_like (4,), optional
        State at t = 0 of the start's level cycle, if known.
    ipopt_options : dict, optional
        Extra IPOPT options.
    hessian : {"sr1", "fd", "fixed"}
        How IPOPT gets second derivatives (see above).
    radius_start_factor : float
        Start of r with the stability objective (see above).
    threads : int
        Perturbed points evaluated at a time with ``hessian="fd"``.
    second_derivatives : numpy.ndarray, optional
        The fixed second derivatives for ``hessian="fixed"``.
    valid : bool
        Every limit of ``cfg.validity`` a smooth constraint (see above).
    valid_rounds : int, optional
        Solves at most, tightening a bound the exact check finds crossed (default
        :data:`birdocp.studies.gait_validity.VALID_ROUNDS`).

    Returns
    -------
    GaitOptimum
        The optimal gait, amplitude, cycle, objective value, multipliers, IPOPT's status, KKT residual
        and the verification; its exact ``validity`` always, with ``valid`` also
        ``validity_constraints``.
    """
    from birdocp.studies.gait_validity import VALID_ROUNDS, solve_valid

    cfg = cfg or Config()
    require_body_states(cfg, "this gait study")

    options = dict(objective=objective, speed_mps=speed_mps, max_multiplier=max_multiplier,
                   climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                   steps_per_period=steps_per_period, max_iter=max_iter, tol=tol, verify=verify,
                   progress=progress, start=start, x_guess=x_guess, ipopt_options=ipopt_options,
                   hessian=hessian, radius_start_factor=radius_start_factor, threads=threads,
                   second_derivatives=second_derivatives)
    return solve_valid(_solve_gait, cfg, free, valid, options,
                       VALID_ROUNDS if valid_rounds is None else valid_rounds)


def _solve_gait(cfg: Config, free: dict | None, *, objective: str, speed_mps, max_multiplier, climb_rate_mps,
                amplitude_bounds, steps_per_period, max_iter, tol, verify, progress, start, x_guess,
                ipopt_options, hessian, radius_start_factor, threads, second_derivatives,
                valid_bounds: dict | None = None) -> GaitOptimum:
    """One reduced-space solve (:func:`optimize_gait`); ``valid_bounds``: limit -> (bound, 'max' or
    'min') of the smooth validity constraints (None: none). Sets the optimum's exact ``validity``."""
    if hessian not in ("sr1", "fd", "fixed"):
        raise ValueError(f"hessian must be 'sr1', 'fd' or 'fixed', got {hessian!r}")
    if (hessian == "fixed") != (second_derivatives is not None):
        raise ValueError("hessian='fixed' needs second_derivatives (and only it takes them)")
    if int(threads) < 1:
        raise ConfigError("--threads", f"must be a positive number of threads, got {threads!r}")
    if objective not in OBJECTIVES + ("stability",):
        raise ConfigError("--objective", f"must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    free = dict(DEFAULT_GAIT_FREE if free is None else free)
    if not free:
        raise ConfigError("--free", "give at least one free gait parameter")
    if speed_mps is not None and not (math.isfinite(speed_mps) and speed_mps > 0):
        raise ConfigError("--speed", f"must be a positive finite speed in m/s, got {speed_mps!r}")
    if max_multiplier is not None and not (math.isfinite(max_multiplier) and max_multiplier > 0):
        raise ConfigError("--max-multiplier", f"must be a positive number, got {max_multiplier!r}")
    from birdocp.bird.model import get_model

    m = get_model(cfg)
    if start:  # a previous optimum may sit on a bound to within IPOPT's tolerance
        start = {k: float(np.clip(v, *free[k])) if k in free else v for k, v in start.items()}
    cfg_start = with_values(cfg, start) if start else cfg
    check_free_keys(m, cfg_start, free)
    t_all, cpu_all = time.perf_counter(), time.process_time()
    wall = {}
    keys = list(free)
    second = objective == "stability" or max_multiplier is not None
    t0 = time.perf_counter()
    rc = ReducedLevelCycle(cfg_start, keys, steps_per_period, climb_rate_mps, second_order=second,
                           valid=bool(valid_bounds))
    wall["build"] = time.perf_counter() - t0
    rc.amplitude_range_deg = (amplitude_bounds[0] - 10.0, amplitude_bounds[1] + 10.0)
    if x_guess is not None:
        rc.set_guess(x_guess)
    lo = np.array([free[k][0] for k in keys])
    hi = np.array([free[k][1] for k in keys])
    theta0 = np.array([float(get_value(cfg_start, k)) for k in keys])
    t0 = time.perf_counter()
    start_note = ""
    try:
        ev0 = rc.evaluate(theta0)
        if speed_mps is not None:
            try:
                ev0 = rc.solve_speed(speed_mps, theta0, 0, (lo[0], hi[0]))
            except RuntimeError as e:  # the first key cannot reach the speed: IPOPT starts infeasible
                ev0 = rc.evaluate(rc._theta if rc._theta is not None else theta0)
                start_note = f"; start not at the speed ({e})"
    except RuntimeError as e:
        return _failed(objective, free, f"start: {e}", cfg, speed_mps, max_multiplier)
    wall["start"] = time.perf_counter() - t0
    prob = ReducedProblem(rc, objective, speed_mps, max_multiplier, amplitude_bounds, valid_bounds)
    prob.progress = progress
    z0 = ev0.theta.copy()
    lbx, ubx = lo.copy(), hi.copy()
    if prob.with_r:
        r0 = radius_start_factor * float(np.max(np.abs(ev0.multipliers)))
        z0 = np.append(z0, r0)
        lbx, ubx = np.append(lbx, 0.02), np.append(ubx, 2.0 * r0)
    prob.set_scale(ev0)
    z0, lbx, ubx = z0 * prob.sigma, lbx * prob.sigma, ubx * prob.sigma
    start_value = float(prob.both(z0)[0][0]) if not prob.with_r else float(np.max(np.abs(ev0.multipliers)))
    if start_note and not prob.with_r:
        start_value = float("nan")  # the configured gait does not fly level at this speed
    start_mult = ev0.multipliers
    from birdocp.engine.oracle import ConstraintOracle, FixedHessian, StencilHessian

    zs = ca.MX.sym("z", prob.nz)
    scale2 = np.multiply.outer(prob.sigma, prob.sigma)[:, None, :]  # [k, ., j]: sigma_k sigma_j
    fd = {"fd": lambda: StencilHessian(h=1e-6, threads=int(threads)),
          "fixed": lambda: FixedHessian(np.asarray(second_derivatives, float) / scale2),
          "sr1": lambda: None}[hessian]()
    oracle = ConstraintOracle(prob, "gait", fd_hessian=fd)  # keep a reference: IPOPT calls it during the solve
    G = oracle(zs)
    nlp = {"x": zs, "f": G[0], "g": G[1:]}
    # SR1 limited-memory updates (BFGS crept along the speed constraint in 0.015-deg steps, and did not
    # converge on the stability radius); r is bounded by twice its start (SR1 took wild steps in r)
    opts = {"ipopt.hessian_approximation": "limited-memory" if hessian == "sr1" else "exact",
            "ipopt.limited_memory_update_type": "sr1",
            "ipopt.sb": "yes",
            "ipopt.print_level": 5 if progress is True else 0, "print_time": False, "ipopt.max_iter": int(max_iter),
            "ipopt.tol": tol, "ipopt.constr_viol_tol": 1e-8, "ipopt.acceptable_tol": 1e-6,
            "ipopt.acceptable_iter": 5, "ipopt.mu_strategy": "adaptive", "ipopt.nlp_scaling_method": "gradient-based", **(ipopt_options or {})}
    solver = ca.nlpsol("gait", "ipopt", nlp, opts)
    glo, ghi = prob.bounds_g()
    t0 = time.perf_counter()
    try:
        from birdocp.engine import interrupts

        with interrupts.interruptible():  # Ctrl-C inside IPOPT: KeyboardInterrupt, not a status
            sol = solver(x0=z0, lbx=lbx, ubx=ubx, lbg=glo, ubg=ghi)
        st = solver.stats()
        status, ok, iters = str(st["return_status"]), bool(st["success"]), int(st["iter_count"])
        z = np.asarray(sol["x"]).ravel() / prob.sigma
        lam_g, lam_x = np.asarray(sol["lam_g"]).ravel(), np.asarray(sol["lam_x"]).ravel()
        msg = f"IPOPT: {status}{start_note}"
    except RuntimeError as e:  # the reduced map failed (no level cycle) and IPOPT could not recover
        return _failed(objective, free, f"IPOPT stopped: {e}", cfg, speed_mps, max_multiplier)
    wall["solve"] = time.perf_counter() - t0
    Gz, Jz = prob.both(z * prob.sigma)
    if Jz is None or not np.all(np.isfinite(Jz)):
        return _failed(objective, free, f"{msg}; no level cycle at IPOPT's last point", cfg, speed_mps,
                       max_multiplier)
    ev = rc.evaluate(z[:rc.nt])
    # KKT: gradient of the Lagrangian in the scaled variables (IPOPT's sign convention:
    # grad f + J^T lam_g + lam_x = 0); per unit of each parameter: times sigma
    kkt = (Jz[0] + Jz[1:].T @ lam_g + lam_x) * prob.sigma
    viol = float(np.max(np.concatenate([np.maximum(glo - Gz[1:], 0), np.maximum(Gz[1:] - ghi, 0)])))
    best = {k: float(v) for k, v in zip(keys, z[:rc.nt])}
    out = GaitOptimum(ok and viol < 1e-6, status, msg, objective, iters, float(Gz[0]), start_value, best, free,
                      dict(zip(keys, ev0.theta.tolist())), ev.amplitude_deg, ev.x0, ev.multipliers,
                      start_mult, ev.means["forward_speed_mps"], speed_mps, max_multiplier, dict(ev.means),
                      float(np.max(np.abs(kkt))), viol, cfg=cfg)
    out.evaluations = {"full": rc.n_full, "residual": rc.n_resid, "no_level_cycle": len(prob.failures)}
    from birdocp.studies.gait_validity import attach_validity

    attach_validity(out, prob, ev, lam_g, cfg)
    out.start_x0 = ev0.x0
    if isinstance(fd, StencilHessian) and fd.last is not None:
        out.second_derivatives = fd.last[1] * scale2
    if verify:
        t0 = time.perf_counter()
        out.verification = verify_gait(out, cfg, rc.N)
        out.cfg = out.verification.pop("cfg")
        wall["verify"] = time.perf_counter() - t0
    wall["total"] = time.perf_counter() - t_all
    wall["cpu_total"] = time.process_time() - cpu_all  # this process's CPU time (the machine is shared)
    out.wall_s = wall
    return out


def verify_gait(opt: GaitOptimum, cfg: Config, steps: int) -> dict:
    """An independent trim from scratch at the optimal gait and amplitude: 5-point multiple shooting
    from the state of the start gait's cycle (nothing of the optimiser's cycle; the configured
    initial guess finds another, climbing cycle at some optima); its power, speeds and multipliers
    against the optimiser's."""
    from birdocp.studies.trim import trim

    vals = dict(opt.free)
    vals[AMPLITUDE_KEY] = opt.amplitude_deg
    cfg_best = with_values(cfg, vals)
    guess = [float(v) for v in (opt.start_x0 if opt.start_x0 is not None else cfg.solve.initial_guess)]
    tr = trim(cfg_best, x_guess=guess, points=5, steps_per_period=steps)
    out = {"cfg": cfg_best, "trim_success": bool(tr.success), "trim_guess": guess}
    if tr.success:
        e = tr.energetics
        out.update({
            "trim_x0_difference": float(np.max(np.abs(tr.x0 - opt.x0))),
            "trim_mean_shoulder_power_W": e["mean_shoulder_power_W"],
            "trim_mean_aerodynamic_power_W": e["mean_aerodynamic_power_W"],
            "power_difference_W": float(e["mean_shoulder_power_W"] - opt.means["flapping_power_W"]),
            "trim_mean_forward_speed_mps": float(tr.mean_forward_speed_mps),
            "trim_mean_vertical_speed_mps": float(tr.mean_vertical_speed_mps),
            "trim_multipliers": [[float(v.real), float(v.imag)] for v in tr.multipliers],
            "max_multiplier_difference": float(np.max(np.abs(np.sort_complex(tr.multipliers)
                                                             - np.sort_complex(opt.multipliers)))),
            "trim_mean_positive_power_W": e["mean_positive_power_W"],
            "trim_cost_of_transport": e["cost_of_transport"],
            "trim_strouhal_number": e["strouhal_number"],
        })
    return out


def _failed(objective, free, message, cfg, speed, R) -> GaitOptimum:
    nan4 = np.full(4, np.nan)
    return GaitOptimum(False, "start_failed" if message.startswith("start") else "error", message, objective, 0,
                       float("nan"), float("nan"), {}, free, {}, float("nan"), nan4, nan4.astype(complex),
                       nan4.astype(complex), float("nan"), speed, R, {}, float("nan"), float("nan"), cfg=cfg)


# ------------------------------------------------------------------------------------------------
def level_at_speed(cfg: Config, speed_mps: float, key: str = SPEED_KEY, bounds=(-10.0, 35.0),
                   steps_per_period: int | None = None, rc: ReducedLevelCycle | None = None) -> Evaluation:
    """Level flight at mean forward speed ``speed_mps``: the amplitude and ``key`` solved."""
    rc = rc or ReducedLevelCycle(cfg, [key], steps_per_period)
    theta = rc._theta if rc._theta is not None else np.array([float(get_value(cfg, key))])
    return rc.solve_speed(speed_mps, theta, 0, bounds)


def power_curve(cfg: Config | None = None, speeds=None, key: str = SPEED_KEY, bounds=(-10.0, 35.0),
                steps_per_period: int | None = None, progress: bool = False) -> dict:
    """Level flight over a range of forward speeds (the speed held by ``key``, level flight by the
    amplitude), with the power outputs and the multipliers of every point.

    The points are continued outward from the speed of the configured gait's level cycle. Returns
    ``{"rows": [...], "minimum_power": {...}, "maximum_range": {...}, "key": key}``; minimum-power and
    maximum-range (minimum P/U) speeds from a parabola through the three points around the discrete
    minimum, over the rows whose cycle is *valid* only (each row carries ``validity`` and ``valid``,
    and the cycle: ``x0``, the key's value and ``amplitude_deg``); ``"interior": False`` when the
    minimum lies at an end of the valid rows. ``minimum_power_all_rows`` and
    ``maximum_range_all_rows``: the same over every converged row, valid or not.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    speeds : sequence of float, optional
        Forward speeds [m/s] (default 12..24 m/s by 1 m/s).
    key : str
        The gait key that sets the speed.
    bounds : (float, float)
        Bounds of ``key`` (its units).
    steps_per_period : int, optional
        RK4 steps per period (default ``cfg.solve.steps_per_period``).
    progress : bool
        One line per point on stderr.

    Returns
    -------
    dict
        ``rows``, ``minimum_power``, ``maximum_range`` (over valid rows), their ``*_all_rows`` and ``key``.
    """
    from birdocp.bird.energetics import cycle_energetics

    cfg = cfg or Config()
    require_body_states(cfg, "this gait study")
    speeds = np.sort(np.asarray(speeds if speeds is not None else np.arange(12.0, 24.01, 1.0), float))
    rc = ReducedLevelCycle(cfg, [key], steps_per_period)
    ev0 = rc.evaluate(np.array([float(get_value(cfg, key))]))
    U0 = ev0.means["forward_speed_mps"]
    up = [s for s in speeds if s >= U0]
    down = [s for s in speeds[::-1] if s < U0]
    rows = []
    for branch in (up, down):
        rc._y, rc._theta, rc._dy = ev0.x0.tolist() + [ev0.amplitude_deg], ev0.theta.copy(), None
        rc._y = np.asarray(rc._y)
        rc._dy = None
        ev_prev = ev0
        for s in branch:
            row = {"speed_mps": float(s), "success": False}
            try:
                ev = rc.solve_speed(float(s), ev_prev.theta, 0, bounds)
            except RuntimeError as e:
                row["message"] = str(e)
                rows.append(row)
                if progress:
                    print(f"power curve: {s:.3g} m/s failed: {e}", flush=True)
                break
            ev_prev = ev
            p = rc.pfull(ev.theta, ev.amplitude_deg)
            e = cycle_energetics(rc.m, p, ev.x0, rc.N)
            v = periodic_validity(with_values(cfg, {key: float(ev.theta[0]), AMPLITUDE_KEY: ev.amplitude_deg}),
                                  ev.x0, p, steps_per_period=rc.N).to_dict()
            lam = ev.multipliers
            row.update({"success": True, key: float(ev.theta[0]), "amplitude_deg": ev.amplitude_deg,
                        "x0": ev.x0.tolist(), "mean_forward_speed_mps": ev.means["forward_speed_mps"],
                        "mean_vertical_speed_mps": ev.means["vertical_speed_mps"],
                        **{k: e[k] for k in ("mean_shoulder_power_W", "mean_aerodynamic_power_W",
                                             "mean_positive_power_W", "cost_of_transport",
                                             "strouhal_number", "reduced_frequency")},
                        "multipliers": [[float(v.real), float(v.imag)] for v in lam],
                        "largest_modulus": float(np.max(np.abs(lam))), "validity": v, "valid": bool(v["valid"])})
            rows.append(row)
            if progress:
                print(f"power curve: U {s:6.2f} m/s  {key} {ev.theta[0]:8.4f}  A {ev.amplitude_deg:8.4f} deg  "
                      f"P {e['mean_shoulder_power_W']:8.4f} W  |L1| {row['largest_modulus']:.4f}", flush=True)
    rows.sort(key=lambda r: r["speed_mps"])
    return {"key": key, "rows": rows} | curve_optima(rows)


def curve_optima(rows: list) -> dict:
    """``minimum_power`` and ``maximum_range`` over the valid converged rows (``mean_shoulder_power_W``
    against ``speed_mps``), and ``..._all_rows`` over every converged row."""
    out = {}
    for tag, keep in (("", lambda r: r.get("valid")), ("_all_rows", lambda r: True)):
        ok = [r for r in rows if r["success"] and keep(r)]
        U = np.array([r["speed_mps"] for r in ok])
        P = np.array([r["mean_shoulder_power_W"] for r in ok])
        out["minimum_power" + tag] = _vertex(U, P, "power_W")
        out["maximum_range" + tag] = _vertex(U, P / U if len(U) else P, "power_per_speed_J_per_m", P)
    return out


def _vertex(U, y, name, P=None) -> dict:
    """The minimum of y(U) from the parabola through the discrete minimum and its neighbours
    (at an end of the range: the end point, flagged)."""
    if len(U) < 3:
        return {"speed_mps": None, name: None, "interior": False}
    i = int(np.argmin(y))
    if i == 0 or i == len(U) - 1:
        out = {"speed_mps": float(U[i]), name: float(y[i]), "interior": False}
    else:
        c = np.polyfit(U[i - 1:i + 2], y[i - 1:i + 2], 2)
        us = float(-c[1] / (2 * c[0]))
        out = {"speed_mps": us, name: float(np.polyval(c, us)), "interior": True}
    if P is not None and out["speed_mps"] is not None:
        out["power_W"] = out[name] * out["speed_mps"]
    return out


# ------------------------------------------------------------------------------------------------
def stability_pareto(cfg: Config | None, speed_mps: float, bounds, *, free: dict | None = None,
                     start: dict | None = None, x_guess=None, objective: str = "power",
                     steps_per_period: int | None = None, max_halvings: int = 4, progress=None,
                     executor=None, anchors=(), start_bound: float | None = None, **options) -> list[dict]:
    """The Pareto front of minimum ``objective`` in level flight at ``speed_mps`` against the bound R
    on every multiplier's modulus: one :func:`optimize_gait` per R in ``bounds`` (in the given order,
    normally from loose to tight), each started from the previous optimum (gait, amplitude and cycle).

    A failed point is retried from the last optimum with a smaller step: the bound halfway between the
    last successful R and the failed one is inserted first (at most ``max_halvings`` times in a row).
    Returns one row per bound tried (inserted ones included, ``"inserted": True``), each with
    ``bound``, ``success``, ``status``, ``objective_value``, ``largest_modulus``, ``free``,
    ``amplitude_deg``, ``x0``, ``iterations``, ``kkt_residual``, ``wall_s`` and the verification's
    ``power_difference_W``, ``validity``, ``valid`` and ``validity_constraints``. ``options`` go to
    :func:`optimize_gait` (e.g. ``valid=True``: the front over valid cycles).

    With an ``executor`` (:mod:`birdocp.engine.executors`: processes or Dask) the points are solved in
    parallel waves, each from its nearest solved neighbour (:func:`birdocp.studies.pareto.pareto_parallel`;
    ``anchors``: known solutions such as the most stable gait, ``start_bound``: the start's largest
    modulus); no halving then, one row per bound.

    Parameters
    ----------
    cfg : Config or None
        The configuration (None: the paper's reference case).
    speed_mps : float
        Mean forward speed held [m/s].
    bounds : sequence of float
        The bounds R on every multiplier's modulus, in the order tried.
    free : dict, optional
        Gait key -> (lo, hi) (default :data:`DEFAULT_GAIT_FREE`).
    start : dict, optional
        Gait values of the first start.
    x_guess : array_like (4,), optional
        State at t = 0 of the start's level cycle, if known.
    objective : str
        The objective of :func:`optimize_gait`.
    steps_per_period : int, optional
        RK4 steps per period.
    max_halvings : int
        Inserted bounds in a row after failures.
    progress : callable, optional
        ``progress(text)``, one line per point.
    executor : Executor, optional
        Solve the points in parallel waves (see above).
    anchors : sequence
        Known solutions to start points from (with ``executor``).
    start_bound : float, optional
        The start's largest modulus (with ``executor``).
    **options
        Passed to :func:`optimize_gait`.

    Returns
    -------
    list of dict
        One row per bound tried (see above).
    """
    if executor is not None:
        from birdocp.studies.pareto import pareto_parallel

        return pareto_parallel(executor, optimize_gait, cfg, speed_mps, bounds, free=free, start=start, x_guess=x_guess,
                               start_bound=start_bound, anchors=anchors, objective=objective,
                               steps_per_period=steps_per_period, progress=progress, **options)
    from birdocp.studies.pareto import pareto_row

    queue = [(float(R), False) for R in bounds]
    rows, last_R, halvings = [], None, 0
    while queue:
        R, inserted = queue[0]
        opt = optimize_gait(cfg, free, objective=objective, speed_mps=speed_mps, max_multiplier=R, start=start,
                            x_guess=x_guess, steps_per_period=steps_per_period, **options)
        row = pareto_row(R, opt, inserted)
        if progress:
            progress(f"Pareto R = {R:.5f}: {opt.status}, P {opt.objective_value:.5f}, |L1| "
                     f"{opt.largest_modulus:.5f}, {opt.iterations} iterations, "
                     f"{opt.wall_s.get('total', float('nan')):.1f} s")
        if opt.success:
            rows.append(row)
            queue.pop(0)
            start = dict(opt.free) | {AMPLITUDE_KEY: opt.amplitude_deg}
            x_guess, last_R, halvings = opt.x0, R, 0
        elif last_R is not None and halvings < max_halvings:
            rows.append(row)
            queue.insert(0, (0.5 * (last_R + R), True))
            halvings += 1
        else:
            rows.append(row)
            queue.pop(0)
            halvings = 0
    return rows


def valid_power_curve(executor, cfg, speeds, *, free=None, start=None, x_guess=None, start_speed=None,
                      progress=None, wave: int | None = None, **options) -> dict:
    """The power curve over valid gaits: at each speed the least-power level gait over ``free``
    (default :data:`DEFAULT_GAIT_FREE`) with every limit of ``[validity]`` a constraint
    (``optimize_gait(objective="power", valid=True)``), the speeds solved in parallel waves through
    ``executor`` (:mod:`birdocp.engine.executors`), each from its nearest solved speed
    (:func:`birdocp.studies.pareto.waves`; ``start``/``x_guess`` at ``start_speed``: a known solution
    to begin from, default the configured gait). Returns ``{"rows", "minimum_power",
    "maximum_range", ...}`` as :func:`power_curve` (optima over the valid rows)."""
    from birdocp.studies.pareto import power_point, waves

    options = {k: v for k, v in options.items() if k != "progress"} | {"valid": True}
    s0 = float(np.median(speeds)) if start_speed is None else float(start_speed)

    def job(U, nb):
        return {"optimize": optimize_gait, "cfg": cfg, "free": free, "speed_mps": float(U),
                "start": nb["start"] or None, "x_guess": nb["x_guess"], "options": options,
                "started_from": nb["label"]}

    def say(U, row):
        if progress:
            progress(f"valid power curve U = {U:.2f}: {row['status']}, P {row['objective_value']:.5f} W, valid "
                     f"{row['valid']}, {row['iterations']} iterations, {row['wall_s'].get('total', math.nan):.1f} s")
    rows = waves(executor, [float(U) for U in speeds], [(s0, None, start, x_guess)], job, power_point, say, wave)
    return {"rows": rows, "free": free} | curve_optima(rows)
