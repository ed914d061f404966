"""The energy-optimal (and the most stable) level-flight gait, in reduced space: IPOPT over a few
gait parameters with the level cycle eliminated (:mod:`birdocp.studies.gait_cycle`: the cycle and
its exact gradients; :mod:`birdocp.studies.gait_problem`: the NLP). The stability-power Pareto
front and the power curve over valid gaits (both: many :func:`optimize_gait` solves) are here; the
power curve of one gait lives in :mod:`birdocp.studies.power_curves` (its names importable from here
too), the parallel waves in :mod:`birdocp.studies.pareto`."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import Config, ConfigError, get_value, with_values
from birdocp.bird.keys import AMPLITUDE_BOUNDS_DEG
from birdocp.engine.oracle import active_bounds
from birdocp.engine.oracle import ipopt_options as one_ipopt_front  # the one set of IPOPT options
from birdocp.engine.results import result_dict, serial
from birdocp.studies.gait_cycle import (AMPLITUDE_KEY, JURY_MARGIN, POSITIVE_EPS_W,  # noqa: F401
                                        ReducedLevelCycle, jury_conditions)
from birdocp.studies.gait_types import Evaluation, check_free_bounds, check_free_keys  # noqa: F401
from birdocp.studies.gait_problem import ReducedProblem
from birdocp.studies.lateral_optimize import reduced_level_cycle
from birdocp.studies.turn_cycle import check_turn, is_turn, turn_check
from birdocp.studies.power_curves import SPEED_KEY, curve_optima, level_at_speed, power_curve  # noqa: F401

__all__ = ["ReducedLevelCycle", "ReducedProblem", "GaitOptimum", "GaitSolverOptions", "optimize_gait", "OBJECTIVES", "DEFAULT_GAIT_FREE",
           "level_at_speed", "power_curve", "SPEED_KEY", "jury_conditions",
           "curve_optima",
           "check_free_keys"]

OBJECTIVES = ("power", "cost-of-transport", "positive-power")
DEFAULT_GAIT_FREE = {
    "gait.shoulder_incidence.offset_deg": (0.0, 25.0),
    "gait.shoulder_incidence.amplitude_deg": (0.0, 10.0),
    "gait.shoulder_sweep.offset_deg": (-30.0, -5.0),
    "gait.shoulder_sweep.amplitude_deg": (10.0, 30.0),
}
"""Default free gait parameters of ``optimize-gait`` (the flapping amplitude is solved for level flight
within 20-70 deg): the shoulder incidence and sweep, as in ``optimize-stability``, with the incidence
offset's range widened to hold speeds from about 13 to 24 m/s."""


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
    six_dof: dict | None = None
    """With ``model.degrees_of_freedom = 6``: the multipliers split into longitudinal and lateral ones
    and their radii (:func:`birdocp.studies.lateral_optimize.multiplier_split`; top-level JSON keys)."""
    second_derivatives: np.ndarray | None = None
    """With ``hessian="fd"``: the last finite-difference second derivatives, ``[k, i, j] =
    d^2 G_i / dz_j dz_k`` (G = objective and constraints, z = free values and r, unscaled); what a
    warm-started ``hessian="fixed"`` solve (e.g. on a finer grid) takes as ``second_derivatives``."""
    ipopt_multipliers: dict | None = None
    """IPOPT's multipliers at the optimum: ``lam_g`` (one per constraint row, the objective row
    excluded) and ``lam_x`` (one per free value and r, per unit of each, unscaled); what a warm start
    of a nearby problem takes as ``warm_multipliers`` (:class:`GaitSolverOptions`)."""

    @property
    def largest_modulus(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): the documented keys.

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, exclude=("cfg", "start_x0", "means", "second_derivatives", "six_dof",
                                          "ipopt_multipliers"),
                           derived=("largest_modulus",), extra=dict(self.six_dof or {}) | {
            "active_bounds": active_bounds(self.free, self.bounds),
            "moduli": np.abs(self.multipliers), "stable": bool(self.largest_modulus < 1),
            "mean_shoulder_power_W": self.means.get("flapping_power_W"),
            "mean_aerodynamic_power_W": self.means.get("aerodynamic_power_W"),
            "mean_vertical_speed_mps": self.means.get("vertical_speed_mps")}
            | {f"mean_{k}": self.means[k] for k in ("right_shoulder_power_W", "left_shoulder_power_W")
               if k in self.means})


@dataclass
class GaitSolverOptions:
    """How :func:`optimize_gait` solves (the problem itself: objective, speed, bounds, start, are its
    own arguments). Every field can also be given to :func:`optimize_gait` by keyword.

    ``hessian``: "sr1" (limited-memory SR1 updates) or "fd" (IPOPT's exact-Hessian mode on the
    forward finite difference of the exact constraint gradients, four or five extra gradient
    evaluations per iteration; far fewer iterations with a stability constraint or objective: 21
    instead of 120 for the most stable gait of the reference problem on 48 steps; the perturbed
    points are evaluated ``threads`` at a time, each by Newton from the iterate's cycle, so the
    result does not depend on the number of threads), or "fixed" (exact-Hessian mode on the
    ``second_derivatives`` of a nearby solve held fixed, e.g. those of a coarser grid's optimum:
    one gradient evaluation per iteration).

    Parameters
    ----------
    max_iter : int
        IPOPT iterations.
    tol : float
        IPOPT's tolerance.
    verify : bool
        Verify the optimum by an independent trim.
    progress : bool or callable
        False (silent), True (one line per evaluation on stderr) or a callable taking that line.
    ipopt_options : dict, optional
        Extra IPOPT options.
    hessian : {"sr1", "fd", "fixed"}
        How IPOPT gets second derivatives: "sr1" limited-memory SR1 updates; "fd" exact-Hessian mode
        on the forward difference of the exact constraint gradients (perturbed points evaluated
        ``threads`` at a time); "fixed" exact-Hessian mode on ``second_derivatives`` held fixed.
    radius_start_factor : float
        With the stability objective, r starts at this factor times the start's spectral radius.
    threads : int
        Perturbed points evaluated at a time with ``hessian="fd"``.
    second_derivatives : numpy.ndarray, optional
        The fixed second derivatives for ``hessian="fixed"``.
    valid_rounds : int, optional
        With ``valid``: solves at most, tightening a bound the exact check finds crossed (default
        :data:`birdocp.studies.gait_validity.VALID_ROUNDS`).
    warm_multipliers : dict, optional
        A nearby optimum's :attr:`GaitOptimum.ipopt_multipliers`: IPOPT starts from them
        (``warm_start_init_point``; with a small ``mu_init`` in ``ipopt_options``, e.g.
        :data:`birdocp.studies.gait_validity.WARM_IPOPT`, a real warm start). Ignored when the
        constraint rows differ in number.
    """

    max_iter: int = 100
    tol: float = 1e-8
    verify: bool = True
    progress: object = False
    ipopt_options: dict | None = None
    hessian: str = "sr1"
    radius_start_factor: float = 1.05
    threads: int = 2
    second_derivatives: np.ndarray | None = None
    valid_rounds: int | None = None
    warm_multipliers: dict | None = None

    def check(self) -> None:
        """ValueError/ConfigError (naming the option) for an impossible choice, before any computation."""
        if self.hessian not in ("sr1", "fd", "fixed"):
            raise ValueError(f"hessian must be 'sr1', 'fd' or 'fixed', got {self.hessian!r}")
        if (self.hessian == "fixed") != (self.second_derivatives is not None):
            raise ValueError("hessian='fixed' needs second_derivatives (and only it takes them)")
        if int(self.threads) < 1:
            raise ConfigError("--threads", f"must be a positive number of threads, got {self.threads!r}")


def optimize_gait(cfg: Config | None = None, free: dict | None = None, *, objective: str = "power",
                  speed_mps: float | None = None, max_multiplier: float | None = None,
                  climb_rate_mps: float = 0.0, amplitude_bounds=AMPLITUDE_BOUNDS_DEG,
                  steps_per_period: int | None = None, start: dict | None = None, x_guess=None,
                  valid: bool = False, turn_deg_per_beat: float | None = None, solver: GaitSolverOptions | None = None,
                  **solver_options) -> GaitOptimum:
    """Minimise mean power (``objective="power"``), cost of transport, smoothed positive-work power,
    or the stability radius (``"stability"``) over the gait parameters ``free`` (key -> (lo, hi);
    default :data:`DEFAULT_GAIT_FREE`), in level flight (mean W = ``climb_rate_mps``, the amplitude
    solved within ``amplitude_bounds``) at mean forward speed ``speed_mps`` (None: free speed), with
    all multipliers inside the circle of radius ``max_multiplier`` (None: no stability constraint).

    The start is the configured gait (``start`` overrides values), brought to ``speed_mps`` by the
    first free key (Newton, exact derivative); its objective is ``start_objective_value``. The
    optimum is verified by a trim (5-point multiple shooting) at the optimal gait. How IPOPT solves:
    :class:`GaitSolverOptions` (``solver``, or its fields by keyword, e.g. ``max_iter=60``).

    ``valid``: every limit of ``cfg.validity`` is a smooth constraint
    (:mod:`birdocp.bird.validity_smooth`; exact gradients from the same RK4 stages). The exact
    validity of the optimum is checked; a limit still crossed (a smooth measure is not a bound of the
    exact one) has its smooth bound tightened by the difference and the problem is solved again from
    the optimum, at most ``valid_rounds`` solves in all. The result always carries the exact
    ``validity``; with ``valid`` also ``validity_constraints``.

    6 DOF, per-side offsets or ``turn_deg_per_beat``: a turn (:mod:`birdocp.studies.turn_cycle`).

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    free : dict, optional
        Gait key -> (lo, hi) (default :data:`DEFAULT_GAIT_FREE`; 6 DOF: also per-side offsets).
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
    start : dict, optional
        Gait values overriding the configured start.
    x_guess : array_like (4,), optional
        State at t = 0 of the start's level cycle, if known (default: a trim of the start gait).
    valid : bool
        Every limit of ``cfg.validity`` a smooth constraint (:mod:`birdocp.bird.validity_smooth`); a
        limit the optimum still crosses exactly is tightened by the difference and the problem solved
        again, at most ``valid_rounds`` solves.
    turn_deg_per_beat : float, optional
        6 DOF: heading change per wingbeat held [deg] (positive to the right; None: free).
    solver : GaitSolverOptions, optional
        How IPOPT solves (default :class:`GaitSolverOptions`).
    **solver_options
        Fields of :class:`GaitSolverOptions` overriding ``solver``'s (``max_iter``, ``tol``,
        ``verify``, ``progress``, ``ipopt_options``, ``hessian``, ``radius_start_factor``,
        ``threads``, ``second_derivatives``, ``valid_rounds``, ``warm_multipliers``).

    Returns
    -------
    GaitOptimum
        The optimal gait, amplitude, cycle, objective value, multipliers, IPOPT's status, KKT residual
        and the verification; its exact ``validity`` always, with ``valid`` also
        ``validity_constraints``.
    """
    from dataclasses import asdict, replace

    from birdocp.studies.gait_validity import VALID_ROUNDS, solve_valid

    opts = replace(solver or GaitSolverOptions(), **solver_options)
    cfg = cfg or Config()
    options = {k: v for k, v in asdict(opts).items() if k != "valid_rounds"} | dict(
        objective=objective, speed_mps=speed_mps, max_multiplier=max_multiplier, climb_rate_mps=climb_rate_mps,
        amplitude_bounds=amplitude_bounds, steps_per_period=steps_per_period, start=start, x_guess=x_guess,
        turn_deg_per_beat=turn_deg_per_beat)
    return solve_valid(_solve_gait, cfg, free, valid, options,
                       VALID_ROUNDS if opts.valid_rounds is None else opts.valid_rounds)


def _checked_free(objective, free, speed_mps, max_multiplier) -> dict:
    """The free keys (default :data:`DEFAULT_GAIT_FREE`), after the problem's own checks (ConfigError)."""
    if objective not in OBJECTIVES + ("stability",):
        raise ConfigError("--objective", f"must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    free = dict(DEFAULT_GAIT_FREE if free is None else free)
    if not free:
        raise ConfigError("--free", "give at least one free gait parameter")
    if speed_mps is not None and not (math.isfinite(speed_mps) and speed_mps > 0):
        raise ConfigError("--speed", f"must be a positive finite speed in m/s, got {speed_mps!r}")
    if max_multiplier is not None and not (math.isfinite(max_multiplier) and max_multiplier > 0):
        raise ConfigError("--max-multiplier", f"must be a positive number, got {max_multiplier!r}")
    return free


def _start_cycle(rc: ReducedLevelCycle, theta0, lo, hi, speed_mps):
    """The start's level cycle (brought to ``speed_mps`` by the first free key when it can be) and a
    note when it could not; RuntimeError when there is no level cycle at the start."""
    ev0 = rc.evaluate(theta0)
    if speed_mps is None:
        return ev0, ""
    try:
        return rc.solve_speed(speed_mps, theta0, 0, (lo[0], hi[0])), ""
    except RuntimeError as e:  # the first key cannot reach the speed: IPOPT starts infeasible
        last = rc.warm_start.theta
        return rc.evaluate(last if last is not None else theta0), f"; start not at the speed ({e})"


def _nlp_solver(prob: ReducedProblem, opts: GaitSolverOptions, warm: bool = False):
    """(IPOPT solver, the oracle to keep alive, the Hessian object, the sigma_k sigma_j scale) of
    ``prob``; ``warm``: IPOPT starts from the multipliers given to the call."""
    from birdocp.engine.oracle import ConstraintOracle, FixedHessian, StencilHessian

    zs = ca.MX.sym("z", prob.nz)
    scale2 = np.multiply.outer(prob.sigma, prob.sigma)[:, None, :]  # [k, ., j]: sigma_k sigma_j
    fd = {"fd": lambda: StencilHessian(h=1e-6, threads=int(opts.threads)),
          "fixed": lambda: FixedHessian(np.asarray(opts.second_derivatives, float) / scale2),
          "sr1": lambda: None}[opts.hessian]()
    oracle = ConstraintOracle(prob, "gait", fd_hessian=fd)  # keep a reference: IPOPT calls it during the solve
    G = oracle(zs)
    # SR1 limited-memory updates (BFGS crept along the speed constraint in 0.015-deg steps, and did not
    # converge on the stability radius); r is bounded by twice its start (SR1 took wild steps in r)
    ipopt = one_ipopt_front(**{
        "ipopt.hessian_approximation": "limited-memory" if opts.hessian == "sr1" else "exact",
        "ipopt.limited_memory_update_type": "sr1", "ipopt.sb": "yes",
        "ipopt.print_level": 5 if opts.progress is True else 0, "print_time": False,
        "ipopt.max_iter": int(opts.max_iter), "ipopt.tol": opts.tol, "ipopt.constr_viol_tol": 1e-8,
        "ipopt.acceptable_tol": 1e-6, "ipopt.acceptable_iter": 5, "ipopt.mu_strategy": "adaptive",
        "ipopt.nlp_scaling_method": "gradient-based", **({"ipopt.warm_start_init_point": "yes"} if warm else {}),
        **(opts.ipopt_options or {})})
    return ca.nlpsol("gait", "ipopt", {"x": zs, "f": G[0], "g": G[1:]}, ipopt), oracle, fd, scale2


def _solve_gait(cfg: Config, free: dict | None, *, objective: str, speed_mps, max_multiplier, climb_rate_mps,
                amplitude_bounds, steps_per_period, start, x_guess, valid_bounds: dict | None = None,
                turn_deg_per_beat: float | None = None, **solver_options) -> GaitOptimum:
    """One reduced-space solve (:func:`optimize_gait`; ``solver_options``: the fields of
    :class:`GaitSolverOptions`); ``valid_bounds``: limit -> (bound, 'max' or 'min') of the smooth
    validity constraints (None: none). Sets the optimum's exact ``validity``."""
    opts = GaitSolverOptions(**solver_options)
    opts.check()
    free = _checked_free(objective, free, speed_mps, max_multiplier)
    from birdocp.bird.model import get_model

    if start:  # a previous optimum may sit on a bound to within IPOPT's tolerance
        start = {k: float(np.clip(v, *free[k])) if k in free else v for k, v in start.items()}
    cfg_start = with_values(cfg, start) if start else cfg
    check_free_keys(get_model(cfg), cfg_start, free)
    turn = is_turn(cfg_start, free, turn_deg_per_beat)
    check_turn(cfg_start, objective, turn_deg_per_beat, turn)
    t_all, cpu_all = time.perf_counter(), time.process_time()
    keys = list(free)
    t0 = time.perf_counter()
    rc = reduced_level_cycle(cfg_start, keys, turn=turn, steps_per_period=steps_per_period, climb_rate_mps=climb_rate_mps,
                             second_order=objective == "stability" or max_multiplier is not None,
                             valid=bool(valid_bounds),
                             amplitude_range_deg=(amplitude_bounds[0] - 10.0, amplitude_bounds[1] + 10.0),
                             **({"power": True} if turn and objective != "stability" else {}))
    wall = {"build": time.perf_counter() - t0}
    if x_guess is not None:
        rc.set_guess(x_guess)
    lo, hi = np.array([free[k][0] for k in keys]), np.array([free[k][1] for k in keys])
    t0 = time.perf_counter()
    fail = lambda m: _failed(objective, free, m, cfg, speed_mps, max_multiplier)  # noqa: E731
    try:
        ev0, note = _start_cycle(rc, np.array([float(get_value(cfg_start, k)) for k in keys]), lo, hi, speed_mps)
    except RuntimeError as e:
        return fail(f"start: {e}")
    wall["start"] = time.perf_counter() - t0
    prob = ReducedProblem(rc, objective, speed_mps, max_multiplier, amplitude_bounds, valid_bounds, turn_deg_per_beat)
    prob.progress = opts.progress
    z0, lbx, ubx = _scaled_start(prob, ev0, lo, hi, opts.radius_start_factor)
    start_value = float(prob.both(z0)[0][0]) if not prob.with_r else float(np.max(np.abs(ev0.multipliers)))
    if note and not prob.with_r:
        start_value = float("nan")  # the configured gait does not fly level at this speed
    duals = _warm_duals(prob, opts.warm_multipliers)
    solver, oracle, fd, scale2 = _nlp_solver(prob, opts, warm=bool(duals))
    glo, ghi = prob.bounds_g()
    t0 = time.perf_counter()
    try:
        from birdocp.engine import interrupts

        with interrupts.interruptible():  # Ctrl-C inside IPOPT: KeyboardInterrupt, not a status
            sol = solver(x0=z0, lbx=lbx, ubx=ubx, lbg=glo, ubg=ghi, **duals)
    except RuntimeError as e:  # the reduced map failed (no level cycle) and IPOPT could not recover
        return fail(f"IPOPT stopped: {e}")
    wall["solve"] = time.perf_counter() - t0
    st = solver.stats()
    msg = f"IPOPT: {st['return_status']}{note}"
    out = _optimum(prob, sol, st, msg, (glo, ghi), ev0, start_value, free, cfg, speed_mps, max_multiplier)
    if out is None:
        return fail(f"{msg}; no level cycle at IPOPT's last point")
    if getattr(fd, "last", None) is not None:  # a StencilHessian's last second derivatives, unscaled
        out.second_derivatives = fd.last[1] * scale2
    if opts.verify:
        t0 = time.perf_counter()
        out.verification = turn_check(out, cfg, rc.N) if turn else _verify_gait(out, cfg, rc.N)
        out.cfg = out.verification.pop("cfg")
        wall["verify"] = time.perf_counter() - t0
    wall["total"] = time.perf_counter() - t_all
    wall["cpu_total"] = time.process_time() - cpu_all  # this process's CPU time (the machine is shared)
    out.wall_s = wall
    return out


def _warm_duals(prob: ReducedProblem, warm: dict | None) -> dict:
    """``lam_x0``/``lam_g0`` of the solver call from a nearby optimum's multipliers (in this problem's
    scaled variables: lam_x per unit of z = lam_x per unit of theta / sigma); empty when there are none
    or the rows differ in number."""
    if not warm or len(warm.get("lam_g", ())) != prob.ng - 1 or len(warm.get("lam_x", ())) != prob.nz:
        return {}
    return {"lam_x0": np.asarray(warm["lam_x"], float) / prob.sigma, "lam_g0": np.asarray(warm["lam_g"], float)}


def _scaled_start(prob: ReducedProblem, ev0: Evaluation, lo, hi, radius_start_factor: float):
    """(z0, lbx, ubx) in IPOPT's scaled variables (r appended for the stability objective, bounded by
    twice its start: SR1 took wild steps in r)."""
    z0, lbx, ubx = ev0.theta.copy(), np.asarray(lo, float).copy(), np.asarray(hi, float).copy()
    if prob.with_r:
        r0 = radius_start_factor * float(np.max(np.abs(ev0.multipliers)))
        z0, lbx, ubx = np.append(z0, r0), np.append(lbx, 0.02), np.append(ubx, 2.0 * r0)
    prob.set_scale(ev0)
    return z0 * prob.sigma, lbx * prob.sigma, ubx * prob.sigma


def _optimum(prob: ReducedProblem, sol, st, msg, gbounds, ev0, start_value, free, cfg, speed_mps,
             max_multiplier) -> GaitOptimum | None:
    """The :class:`GaitOptimum` at IPOPT's last point (KKT residual, violation, exact validity), or
    None when there is no level cycle there."""
    rc, (glo, ghi) = prob.rc, gbounds
    z = np.asarray(sol["x"]).ravel() / prob.sigma
    lam_g, lam_x = np.asarray(sol["lam_g"]).ravel(), np.asarray(sol["lam_x"]).ravel()
    Gz, Jz = prob.both(z * prob.sigma)
    if Jz is None or not np.all(np.isfinite(Jz)):
        return None
    ev = rc.evaluate(z[:rc.nt])
    # KKT: gradient of the Lagrangian in the scaled variables (IPOPT's sign convention:
    # grad f + J^T lam_g + lam_x = 0); per unit of each parameter: times sigma
    kkt = (Jz[0] + Jz[1:].T @ lam_g + lam_x) * prob.sigma
    viol = float(np.max(np.concatenate([np.maximum(glo - Gz[1:], 0), np.maximum(Gz[1:] - ghi, 0)])))
    best = {k: float(v) for k, v in zip(rc.keys, z[:rc.nt])}
    out = GaitOptimum(bool(st["success"]) and viol < 1e-6, str(st["return_status"]), msg, prob.objective,
                      int(st["iter_count"]), float(Gz[0]), start_value, best, free,
                      dict(zip(rc.keys, ev0.theta.tolist())), ev.amplitude_deg, ev.x0, ev.multipliers,
                      ev0.multipliers, ev.means["forward_speed_mps"], speed_mps, max_multiplier, dict(ev.means),
                      float(np.max(np.abs(kkt))), viol, cfg=cfg)
    out.evaluations = {"full": rc.n_full, "residual": rc.n_resid, "no_level_cycle": len(prob.failures)}
    out.six_dof = rc.multiplier_split(ev)
    if "right_shoulder_power_W" in ev.means:  # a turn's power objective: each wing's exact positive work
        from birdocp.bird.sixdof_power import sampled_wing_powers

        w = sampled_wing_powers(rc.six, ev.x0, rc.pfull(ev.theta, ev.amplitude_deg), rc.N)
        out.six_dof = dict(out.six_dof or {}) | {k: w.pop(k) for k in list(w) if k.startswith("mean_")} \
            | {"wing_power_samples": w}
    out.ipopt_multipliers = {"lam_g": lam_g.tolist(), "lam_x": (lam_x * prob.sigma).tolist()}
    from birdocp.studies.gait_validity import attach_validity

    attach_validity(out, prob, ev, lam_g, cfg)
    out.start_x0 = ev0.x0
    return out


def _verify_gait(opt: GaitOptimum, cfg: Config, steps: int) -> dict:
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
                                                             - np.sort_complex(opt.multipliers))))
            if len(tr.multipliers) == len(opt.multipliers) else None,
            "trim_mean_positive_power_W": e["mean_positive_power_W"],
            "trim_cost_of_transport": e["cost_of_transport"],
            "trim_strouhal_number": e["strouhal_number"],
        })
        if cfg.model.degrees_of_freedom == 6:  # all eight multipliers from a 6-DOF trim
            from birdocp.studies.lateral_optimize import lateral_check

            out.update(lateral_check(cfg_best, tr.x0, opt.multipliers, steps))
    return out


def _failed(objective, free, message, cfg, speed, R) -> GaitOptimum:
    nan4 = np.full(4, np.nan)
    return GaitOptimum(False, "start_failed" if message.startswith("start") else "error", message, objective, 0,
                       float("nan"), float("nan"), {}, free, {}, float("nan"), nan4, nan4.astype(complex),
                       nan4.astype(complex), float("nan"), speed, R, {}, float("nan"), float("nan"), cfg=cfg)


# ------------------------------------------------------------------------------------------------

