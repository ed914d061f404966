"""The most stable level-flight gait within bounds: minimise the largest Floquet multiplier modulus.

The spectral radius of the monodromy is not smooth (it jumps between eigenvalues, and a complex pair
has a kink). birdocp poses it smoothly: minimise ``r`` subject to all eigenvalues of ``Mon / r``
lying inside the unit circle, written as the Jury (Schur-Cohn) conditions on the characteristic
polynomial ``z^4 + a3 z^3 + a2 z^2 + a1 z + a0`` of ``Mon / r`` (coefficients from traces, all CasADi
expressions of the cycle and the gait):

    p(1) >= 0,  p(-1) >= 0,  1 - a0^2 >= 0,  b0^2 - b3^2 >= 0,  c0^2 - c2^2 >= 0,

with the Jury rows ``b_k = a0 a_k - a_{4-k}`` and ``c_k = b0 b_k - b3 b_{3-k}`` (each bounded below by a
small margin, :data:`JURY_MARGIN`, so that only strictly Jury-stable points are feasible). At the
optimum one of them is active and ``r`` equals the spectral radius up to the margin.

Two formulations. By default (``method="reduced"``) the NLP is the reduced-space one of
:mod:`birdocp.studies.gait` (the same code as ``optimize-gait``): IPOPT's unknowns are the free gait
parameters and ``r``; the level cycle is solved by Newton at every iterate and the Jury conditions'
gradients are exact (implicit function theorem, second-order variational equations). With
``method="full"`` the state at t = 0, the free gait parameters, the flapping amplitude (level
flight: mean vertical speed = climb rate) and ``r`` are all unknowns, single shooting over one period
(exact first derivatives, the monodromy's derivatives by forward-over-forward AD). The answer is
verified independently: numpy eigenvalues of the monodromy, and trims at the optimal gait.

Free keys must leave the wing's arm-frame shape unchanged (shoulder joints, wing root position,
shoulder separation, body and aerodynamic numbers, tail), so the expensive geometry stays numeric.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import require_body_states, PARAM_NAMES, Config, ConfigError, with_values
from birdocp.bird.config_checks import has_aero_states
from birdocp.bird.validity import invalid, periodic_validity
from birdocp.engine import interrupts
from birdocp.engine.floquet import matched_distances, sort_multipliers
from birdocp.engine.oracle import ConstraintOracle, active_bounds, ipopt_options
from birdocp.engine.results import result_dict, serial
from birdocp.io.progress import text_reporter
from birdocp.studies.gait_cycle import jury_conditions, jury_function, jury_values  # noqa: F401
from birdocp.studies.gait_types import check_free_keys
from birdocp.studies.gait_validity import WARM_IPOPT
from birdocp.studies.turn_cycle import turn_stages

__all__ = ["DEFAULT_FREE", "METHODS", "check_free_keys", "optimize_stability", "StabilityOptimum", "jury_conditions"]

from birdocp.bird.keys import AMPLITUDE_BOUNDS_DEG, AMPLITUDE_KEY, JURY_MARGIN  # noqa: E402

DEFAULT_FREE = {
    # key: (lower, upper) around the paper's gait; a biologically plausible range for the ibis
    "gait.shoulder_incidence.offset_deg": (5.0, 20.0),
    "gait.shoulder_incidence.amplitude_deg": (0.0, 10.0),
    "gait.shoulder_sweep.offset_deg": (-30.0, -5.0),
    "gait.shoulder_sweep.amplitude_deg": (10.0, 30.0),
}
"""Default free gait parameters and bounds: the shoulder incidence (offset 5-20 deg, amplitude up to
10 deg) and sweep (offset -30..-5 deg, amplitude 10-30 deg); the flapping amplitude is solved for
level flight within 20-70 deg. Phases and other shoulder keys can be freed with their own bounds."""


@dataclass
class StabilityOptimum:
    success: bool
    status: str
    message: str
    iterations: int
    free: dict                     # key -> optimal value
    bounds: dict
    amplitude_deg: float
    radius: float                  # optimal r
    multipliers: np.ndarray = field(metadata=serial(complex=True))  # eigenvalues of the optimal monodromy
    start_multipliers: np.ndarray = field(metadata=serial(complex=True))  # at the level-flight start
    x0: np.ndarray
    verification: dict = field(default_factory=dict)
    wall_s: dict = field(default_factory=dict)
    cfg: Config | None = None
    validity: dict | None = None
    """Where the model holds on the optimal cycle (:func:`birdocp.bird.validity.periodic_validity`)."""
    method: str = "reduced"
    kkt_residual: float | None = None
    """Largest entry of the Lagrangian's gradient at the optimum, per unit of each free parameter
    (reduced method; None for the full-space method)."""
    constraint_violation: float | None = None
    evaluations: dict = field(default_factory=dict)
    valid_constrained: bool = False
    """Whether the limits of ``[validity]`` were constraints (``valid=True``)."""
    validity_constraints: dict | None = None
    """With ``valid=True``: per limit its smooth value, exact value, bound, bound used, whether it is
    active (:func:`birdocp.studies.gait_validity.constraint_report`)."""
    validity_rounds: list | None = None
    """With ``valid=True``: the solves of the last stage (bounds used, exact verdict)."""
    six_dof: dict | None = None
    """With ``model.degrees_of_freedom = 6``: ``multipliers`` are the longitudinal and the lateral ones
    (the heading's 1 left out), split here with their radii (top-level JSON keys,
    :func:`birdocp.studies.lateral_optimize.multiplier_split`)."""

    @property
    def stable(self) -> bool:
        return bool(np.max(np.abs(self.multipliers)) < 1.0)

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, exclude=("cfg", "six_dof"), derived=("stable",), extra=dict(self.six_dof or {}) | {
            "moduli": np.abs(self.multipliers),
            "validity": self.validity or invalid(self.cfg, "not checked (no optimal cycle)"),
            "active_bounds": active_bounds(self.free, self.bounds)})


class _Evaluator:
    """Constraints ``g(z) = [x(T) - x0; mean W - climb; Jury(Mon / r)]`` and their Jacobian, with
    ``z = (x0, free parameters, r)``. The wing's arm-frame shape is numeric (no free key touches it);
    the assembly ``post`` is evaluated at the stage times for the current parameters, and the
    monodromy's derivatives come from forward-over-forward AD along each direction of z
    (:class:`birdocp.studies.sensitivity.SecondOrderMaps`), all directions in one mapped call."""

    def __init__(self, model, steps: int, p0, idx, climb_rate_mps: float):
        from birdocp.studies.sensitivity import SecondOrderMaps

        self.so = so = SecondOrderMaps.get(model, steps)
        self.grid = grid = so.grid
        self.K = K = so.n_times
        self.T = model.period_s
        self.times = ca.DM(grid.times(0.0)).reshape((1, -1))
        self.local = grid.pre_numeric(0.0, p0)
        self.p0 = np.asarray(p0, float)
        self.idx = list(idx)
        self.nf = len(idx)
        self.nz = 4 + self.nf + 1
        self.ng = 4 + 1 + 5
        self.jac_sparsity = ca.Sparsity.dense(self.ng, self.nz)
        self.climb = climb_rate_mps
        np_ = len(p0)
        L, t, p, dp = ca.SX.sym("local", model.pre.size1_out(0)), ca.SX.sym("t"), ca.SX.sym("p", np_), ca.SX.sym("dp", np_)
        d = model.post(L, t, p)
        self.post_map = grid.post_grid
        self.post_dir = ca.Function("post_dir", [L, t, p, dp], [ca.jtimes(d, p, dp)]).map(K * self.nf)
        ndir = 4 + self.nf
        self.dirs = so.directional.map(ndir, "thread", 2)
        Ms, rs = ca.SX.sym("M", 4, 4), ca.SX.sym("r")
        jur = jury_conditions(Ms / rs)
        self._jury = ca.Function("jury", [Ms, rs], [jur, ca.jacobian(jur, ca.vertcat(ca.vec(Ms), rs))])
        self._cache = {}
        self.n_g = self.n_jac = 0
        self.progress = False

    def jury(self, M, r):
        return np.asarray(self._jury(ca.DM(M), r)[0]).ravel()

    def _pfull(self, z):
        p = self.p0.copy()
        p[self.idx] = z[4:4 + self.nf]
        return p

    def base(self, z):
        z = np.asarray(z, float).ravel()
        key = z.tobytes()
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        p = self._pfull(z)
        Dg = self.post_map(self.local, self.times, ca.DM(p))
        D = Dg[:, self.grid.block_index]
        xT, q, M = self.so.base(ca.DM(z[:4]), D, ca.DM(p))
        out = (np.asarray(xT).ravel(), float(q), np.asarray(M), Dg, D, p)
        self._cache = {key: out}
        return out

    def g(self, z):
        self.n_g += 1
        xT, q, M, *_ = self.base(z)
        r = float(np.asarray(z).ravel()[-1])
        return np.concatenate([xT - z[:4], [q / self.T - self.climb], self.jury(M, r)])

    def jacobian(self, z):
        self.n_jac += 1
        z = np.asarray(z, float).ravel()
        xT, q, M, Dg, D, p = self.base(z)
        nf, K = self.nf, self.K
        seeds = np.zeros((len(p), nf))
        for k, j in enumerate(self.idx):
            seeds[j, k] = 1.0
        dDg = self.post_dir(ca.repmat(self.local, 1, nf), ca.repmat(self.times, 1, nf), ca.DM(p),
                            ca.DM(np.repeat(seeds, K, axis=1)))
        blk = self.grid.block_index
        ndir = 4 + nf
        dX = np.hstack([np.eye(4), np.zeros((4, nf))])
        dD = ca.horzcat(ca.DM.zeros(D.shape[0], D.shape[1] * 4),
                        *[dDg[:, k * K:(k + 1) * K][:, blk] for k in range(nf)])
        dP = np.hstack([np.zeros((len(p), 4)), seeds])
        out = np.asarray(self.dirs(ca.DM(z[:4]), D, ca.DM(p), ca.DM(dX), dD, ca.DM(dP)))  # (4+1+16) x ndir
        dxT, dq, dM = out[:4], out[4], out[5:]
        r = z[-1]
        jv, jj = self._jury(ca.DM(M), r)
        jj = np.asarray(jj)  # 5 x 17: d jury / d (vec(M), r)
        J = np.zeros((self.ng, self.nz))
        J[:4, :ndir] = dxT
        J[:4, :4] -= np.eye(4)
        J[4, :ndir] = dq / self.T
        J[5:, :ndir] = jj[:, :16] @ dM
        J[5:, -1] = jj[:, 16]
        if self.progress:
            text = (f"Jacobian {self.n_jac}: r = {r:.6f}, largest |multiplier| = "
                    f"{np.max(np.abs(np.linalg.eigvals(M))):.6f}, periodicity {np.max(np.abs(xT - z[:4])):.1e}")
            text_reporter(self.progress, "optimize-stability")(text)
        return J


METHODS = ("reduced", "full")
COARSE_TOL = 1e-5
"""IPOPT's tolerance in the coarse stage of the reduced method (the fine stage refines anyway)."""
COARSE_STEPS = {"reduced": 32, "full": 48}
"""RK4 steps per period of the coarse stage, per method (``coarse_steps="auto"``). Reduced method on the
reference problem: 32 steps, then 6 fine iterations (in development runs 24 and 48 coarse steps reached
the same optimum with 7 and 6 fine iterations, 16 steps needed 10: a coarser grid's optimum lies
farther from the fine one)."""


def optimize_stability(cfg: Config | None = None, free: dict | None = None, *, climb_rate_mps: float = 0.0,
                       amplitude_bounds=AMPLITUDE_BOUNDS_DEG, steps_per_period: int | None = None,
                       max_iter: int = 400, tol: float = 1e-7, verify: bool = True,
                       progress=False, coarse_steps: int | None | str = "auto", method: str = "reduced",
                       threads: int = 2, valid: bool = False, turn_deg_per_beat: float | None = None,
                       turn_steps: int = 0) -> StabilityOptimum:
    """Minimise the largest multiplier modulus of a level-flight cycle over the gait parameters
    ``free`` (key -> (lower, upper); default :data:`DEFAULT_FREE`): minimise r subject to the Jury
    conditions of ``Mon / r`` (each >= :data:`JURY_MARGIN`), level flight held by the flapping
    amplitude within ``amplitude_bounds`` [deg] (mean vertical speed = ``climb_rate_mps``).

    ``method="reduced"`` (default): the reduced-space NLP of :func:`birdocp.studies.gait.optimize_gait`
    (``objective="stability"``, free speed): IPOPT's unknowns are the free parameters and r only; the
    level cycle is solved by Newton at every iterate, the Jury conditions' gradients are exact (implicit
    function theorem, second-order variational equations). In the coarse stage the Hessian of the
    Lagrangian is the forward difference of those exact gradients (exact-Hessian IPOPT; the perturbed
    points evaluated ``threads`` at a time, each by Newton from the iterate's cycle, so the result does
    not depend on the number of threads); the fine stage holds the coarse stage's last second
    derivatives fixed (one fine gradient per iteration). ``method="full"``: the full-space
    single-shooting NLP (state, parameters, amplitude and r as unknowns; quasi-Newton).

    With ``coarse_steps`` (default ``"auto"``: 32 RK4 steps per period for the reduced method, 48 for
    the full one, none with aerodynamic states) the optimum is first found on that coarse grid, then
    refined on the full grid (``steps_per_period``) from it; ``max_iter`` counts per stage.

    Aerodynamic states (reduced method): r bounds the full monodromy's spectral radius (its dominant block).
    ``valid``: :func:`birdocp.studies.gait.optimize_gait`'s ``valid`` in every stage; the exact
    ``validity`` of the result is ``valid`` unless the rounds ran out.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case).
    free : dict, optional
        Gait key -> (lower, upper) bounds (default :data:`DEFAULT_FREE`).
    climb_rate_mps : float
        The mean vertical speed held [m/s].
    amplitude_bounds : (float, float)
        Bounds of the flapping amplitude [deg].
    steps_per_period : int, optional
        RK4 steps per period of the fine stage (default ``cfg.solve.steps_per_period``).
    max_iter : int
        IPOPT iterations per stage.
    tol : float
        IPOPT's tolerance.
    verify : bool
        Verify the optimum independently (numpy eigenvalues, trims from the optimum's state and from scratch).
    progress : bool or callable
        False (silent), True (one line per evaluation on stderr) or a callable taking that line's
        text (e.g. from :func:`birdocp.io.progress.progress_callback`).
    coarse_steps : int, None or "auto"
        RK4 steps per period of the coarse stage, whose optimum starts the fine one; "auto":
        :data:`COARSE_STEPS` of the method (none with aerodynamic states); None: no coarse stage.
    method : {"reduced", "full"}
        "reduced": the reduced-space NLP of :func:`birdocp.studies.gait.optimize_gait`; "full": the
        full-space single-shooting NLP (state, parameters, amplitude and r; quasi-Newton).
    threads : int
        Perturbed points evaluated at a time (reduced method).
    valid : bool
        The limits of ``cfg.validity`` as smooth constraints in every stage (reduced method only).
    turn_deg_per_beat : float, optional
        6 DOF: heading change per wingbeat held [deg] (a turn, :mod:`birdocp.studies.turn_cycle`).
    turn_steps : int
        Steps of a continuation in the turn rate (0: none; :func:`birdocp.studies.turn_cycle.turn_stages`).

    Returns
    -------
    StabilityOptimum
        The optimal gait, amplitude, cycle, multipliers, ``radius``, IPOPT's status and iterations, the
        verification, the optimum's validity and, with ``valid``, ``validity_constraints``.
    """
    _check_options(method, threads, valid, cfg)
    if coarse_steps == "auto":  # none with aerodynamic states: their lag diverges on RK4 grids of 32 steps
        coarse_steps = None if has_aero_states(cfg or Config()) else COARSE_STEPS[method]
    if method == "full":
        return _optimize_full(cfg, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                              steps_per_period=steps_per_period, max_iter=max_iter, tol=tol, verify=verify,
                              progress=progress, coarse_steps=coarse_steps)
    return _optimize_reduced(cfg, free, climb_rate_mps, amplitude_bounds, steps_per_period, coarse_steps,
                             max_iter, tol, verify, progress, threads, valid, turn_deg_per_beat, turn_steps)


def _check_options(method: str, threads, valid: bool, cfg: Config | None = None) -> None:
    """ConfigError naming the option when ``method``, ``threads`` or ``valid`` is not allowed (for ``cfg``:
    the full-space method is planar)."""
    if method == "full" and cfg is not None and cfg.model.degrees_of_freedom == 6:
        raise ConfigError("--method", "the full-space method is planar; with model.degrees_of_freedom = 6 use "
                                      "--method reduced")
    if method not in METHODS:
        raise ConfigError("--method", f"must be one of {', '.join(METHODS)}, got {method!r}")
    if int(threads) < 1:
        raise ConfigError("--threads", f"must be a positive number of threads, got {threads!r}")
    if valid and method != "reduced":
        raise ConfigError("--valid", "validity constraints need the reduced method (drop --method full)")


def _optimize_reduced(cfg, free, climb_rate_mps, amplitude_bounds, steps_per_period, coarse_steps, max_iter,
                      tol, verify, progress, threads, valid, turn=None, turn_steps=0) -> StabilityOptimum:
    """The reduced-space formulation of :func:`optimize_stability` (the stages of :func:`turn_stages`)."""
    from birdocp.bird.model import get_model

    cfg = cfg or Config()
    free = dict(DEFAULT_FREE if free is None else free)
    check_free_keys(get_model(cfg), cfg, free)
    t_start = time.perf_counter()
    N = int(steps_per_period or cfg.solve.steps_per_period)
    stages = turn_stages([coarse_steps, N] if coarse_steps and coarse_steps < N else [N], free, turn, turn_steps)
    opt, first, iterations, wall, notes = _reduced_stages(cfg, stages, climb_rate_mps, amplitude_bounds,
                                                          max_iter, tol, progress, threads, valid)
    return _stability_result(cfg, free, opt, first, iterations, wall, notes, N, verify, valid, t_start)


def _reduced_stages(cfg, stages, climb_rate_mps, amplitude_bounds, max_iter, tol, progress, threads, valid):
    """The reduced solves of ``stages`` (:func:`turn_stages`), each from the last one's optimum and, with
    the same keys, its second derivatives: (last optimum, first optimum, iterations, wall times, notes)."""
    wall, iterations, notes = {}, 0, []
    start, x_guess, first, opt = None, None, None, None
    cont = len({(t, tuple(f)) for _, t, f in stages}) > 1  # a continuation in the turn rate
    for k, (steps, turn, free) in enumerate(stages):
        last = k == len(stages) - 1  # a coarse stage only needs to find the basin: looser tolerance
        same = opt is not None and list(opt.free) == list(free)
        fd = cont and opt is not None and steps == stages[k - 1][0]  # a turn-rate step: fresh second derivatives
        opt = _reduced_stage(cfg, free, steps, climb_rate_mps, amplitude_bounds, max_iter,
                             tol if last else max(tol, COARSE_TOL), progress, start, x_guess,
                             opt.second_derivatives if same else None, threads, valid, last, turn,
                             hessian="fd" if fd else None)
        first = first or opt
        iterations += opt.iterations
        tag = "" if last else (f"stage{k}_" if cont else "coarse_")
        wall |= {tag + key: v for key, v in opt.wall_s.items() if key != "cpu_total"}
        if tag:
            notes.append(f"coarse stage ({steps} steps): {opt.status}, {opt.iterations} iterations" if not cont else
                         f"stage {k} ({steps} steps, turn {turn} deg/beat): {opt.status}, {opt.iterations} "
                         f"iterations, r {opt.objective_value:.6g}")
            if not opt.free or not np.all(np.isfinite(list(opt.free.values()))):
                break
            start = dict(opt.free) | {AMPLITUDE_KEY: opt.amplitude_deg}
            x_guess = opt.x0
    return opt, first, iterations, wall, notes


def _stability_result(cfg, free, opt, first, iterations, wall, notes, N, verify, valid, t_start) -> StabilityOptimum:
    """The :class:`StabilityOptimum` of the last stage's optimum ``opt`` (verified, exact validity)."""
    nan4 = np.full(4, np.nan)
    if not opt.free:
        out = StabilityOptimum(False, opt.status, opt.message, iterations, {}, free, float("nan"), float("nan"),
                               nan4.astype(complex), nan4.astype(complex), nan4, cfg=cfg)
        out.method, out.wall_s = "reduced", wall | {"total": time.perf_counter() - t_start}
        return out
    lam = np.asarray(opt.multipliers)
    finite = bool(np.all(np.isfinite(lam)) and np.isfinite(opt.objective_value))
    out = StabilityOptimum(bool(opt.success and finite), opt.status if finite else "nan",
                           "; ".join([opt.message] + notes), iterations, dict(opt.free), free, opt.amplitude_deg,
                           float(opt.objective_value), lam, np.asarray(first.start_multipliers), np.asarray(opt.x0),
                           cfg=cfg)
    out.method, out.kkt_residual = "reduced", opt.kkt_residual
    out.constraint_violation, out.evaluations = opt.constraint_violation, dict(opt.evaluations)
    out.valid_constrained, out.validity_constraints, out.validity_rounds = bool(valid), opt.validity_constraints, \
        opt.validity_rounds
    out.six_dof = opt.six_dof
    cfg_best = with_values(cfg, dict(opt.free) | {AMPLITUDE_KEY: opt.amplitude_deg})
    if verify and finite and out.six_dof and out.six_dof.get("symmetric") is False:  # a turn: a 6-DOF trim
        from birdocp.studies.turn_cycle import turn_check

        opt.start_x0 = opt.start_x0 if opt.start_x0 is not None else first.start_x0
        out.verification = turn_check(opt, cfg, N)
        out.cfg = out.verification.pop("cfg")
    elif verify and finite:
        t0 = time.perf_counter()
        _verify(out, cfg, N)
        wall["verify"] = time.perf_counter() - t0
    if finite:  # the exact verdict on the fine grid (the optimiser's own, when it measured one)
        from birdocp.bird.config import param_vector

        out.validity = opt.validity or periodic_validity(cfg_best, out.x0, param_vector(cfg_best),
                                                         steps_per_period=N).to_dict()
    wall["total"] = time.perf_counter() - t_start
    out.wall_s = wall
    return out


def _reduced_stage(cfg, free, steps, climb_rate_mps, amplitude_bounds, max_iter, tol, progress, start, x_guess,
                   second=None, threads=2, valid=False, final=True, turn=None, hessian=None):
    """One reduced-space solve (:func:`birdocp.studies.gait.optimize_gait`, objective "stability") on
    ``steps`` RK4 steps per period.

    From the configured gait: exact-Hessian IPOPT on forward differences of the exact gradients, the
    perturbed points ``threads`` at a time (21 iterations on the reference problem; limited-memory SR1
    took 120 and wandered to another local minimum). From a previous stage's optimum (``start``,
    ``x_guess``): r starts just above that optimum's spectral radius, the barrier parameter small, and
    the Hessian is that stage's last finite-difference second derivatives (``second``) held fixed (6
    iterations, 10 gradient evaluations on the reference problem, against 11 and 27 with SR1 updates,
    the fallback when ``second`` is missing or not finite), or ``hessian`` (a turn-rate step: "fd", the
    cold barrier options, with which IPOPT does not creep). ``valid``: validity constraints."""
    from birdocp.studies.gait import optimize_gait

    warm = start is not None
    opts = dict(WARM_IPOPT) if warm and not hessian else None  # the one set of re-solve options (gait_validity)
    fixed = second is not None and bool(np.all(np.isfinite(second)))
    hessian = hessian or ("fd" if not warm else ("fixed" if fixed else "sr1"))
    return optimize_gait(cfg, free, objective="stability", climb_rate_mps=climb_rate_mps,
                         amplitude_bounds=amplitude_bounds, steps_per_period=steps, max_iter=max_iter,
                         tol=tol, verify=False, progress=progress, start=start, x_guess=x_guess,
                         hessian=hessian, radius_start_factor=1.001 if warm else 1.05,
                         ipopt_options=opts, threads=threads, second_derivatives=second if hessian == "fixed" else None,
                         valid=valid, valid_rounds=None if final else 1, turn_deg_per_beat=turn)


def _verify(out: StabilityOptimum, cfg: Config, N: int, jury=None) -> None:
    """Independent checks at the optimum ``out`` (sets ``out.verification`` and ``out.cfg``): a 5-point
    multiple-shooting trim from the optimum's state, and one from scratch (the configured initial
    guess); numpy eigenvalues; the Jury quantities of the trim's monodromy (or ``jury``) at r."""
    from birdocp.studies.trim import trim

    vals = dict(out.free)
    vals[AMPLITUDE_KEY] = float(out.amplitude_deg)
    cfg_best = with_values(cfg, vals)
    xs = np.asarray(out.x0, float)
    check = trim(cfg_best, x_guess=xs, points=5, steps_per_period=N)
    scratch = trim(cfg_best, points=5, steps_per_period=N)
    out.cfg = cfg_best
    pairs = lambda lam_: [[float(v.real), float(v.imag)] for v in lam_]
    dist = lambda a, b: float(np.max(matched_distances(a, b)))
    lam = np.asarray(out.multipliers)
    if jury is None and check.success and check.monodromy is not None:
        try:  # of the 4 dominant multipliers (the body modes; the aerodynamic ones lie far inside)
            jury = jury_values(jury_function(), np.asarray(check.monodromy), out.radius)[0]
        except RuntimeError:
            jury = None
    out.verification = {
        "trim_success": bool(check.success),
        "trim_multipliers": pairs(check.multipliers) if check.success else None,
        "max_multiplier_difference": dist(check.multipliers, lam) if check.success and len(lam) == len(check.multipliers) else None,
        "trim_mean_vertical_speed_mps": float(check.mean_vertical_speed_mps) if check.success else None,
        "trim_x0_difference": float(np.max(np.abs(check.x0 - xs))) if check.success else None,
        "scratch_trim_success": bool(scratch.success),
        "scratch_trim_x0": scratch.x0.tolist(),
        "scratch_trim_multipliers": pairs(scratch.multipliers) if scratch.success else None,
        "scratch_finds_another_cycle": bool(scratch.success and np.max(np.abs(scratch.x0 - xs)) > 1e-6),
        "radius_minus_spectral_radius": out.radius - float(np.max(np.abs(lam))),
        "jury_at_optimum": None if jury is None else np.asarray(jury).ravel().tolist(),
        "kkt_residual": out.kkt_residual,
        "evaluations": dict(out.evaluations),
    }
    if cfg.model.degrees_of_freedom == 6 and check.success:  # all eight multipliers from a 6-DOF trim
        from birdocp.studies.lateral_optimize import lateral_check

        out.verification.update(lateral_check(cfg_best, check.x0, lam, N))


def _full_two_grids(cfg, free, climb_rate_mps, amplitude_bounds, coarse_steps, N_full, max_iter, tol, verify,
                    progress) -> StabilityOptimum:
    """:func:`_optimize_full` on the coarse grid, then on the full grid from the coarse optimum (the
    coarse result when it has no finite optimum)."""
    coarse = _optimize_full(cfg, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                                steps_per_period=coarse_steps, max_iter=max_iter, tol=tol, verify=False,
                            progress=progress, coarse_steps=None)
    if np.all(np.isfinite(list(coarse.free.values()))) and coarse.free:
        start = with_values(cfg or Config(), coarse.free)
        fine = _optimize_full(start, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                                  steps_per_period=N_full, max_iter=max_iter, tol=tol, verify=verify,
                              progress=progress, coarse_steps=None)
        fine.iterations += coarse.iterations
        fine.start_multipliers = coarse.start_multipliers
        fine.wall_s = {"coarse_" + k: v for k, v in coarse.wall_s.items()} | fine.wall_s
        fine.wall_s["total"] = coarse.wall_s.get("total", 0.0) + fine.wall_s.get("total", 0.0)
        fine.message += f"; coarse stage ({coarse_steps} steps): {coarse.status}, {coarse.iterations} iterations"
        return fine
    return coarse


def _optimize_full(cfg: Config | None = None, free: dict | None = None, *, climb_rate_mps: float = 0.0,
                   amplitude_bounds=AMPLITUDE_BOUNDS_DEG, steps_per_period: int | None = None,
                   max_iter: int = 400, tol: float = 1e-7, verify: bool = True,
                   progress=False, coarse_steps: int | None = 48) -> StabilityOptimum:
    """The full-space formulation (``method="full"``): single shooting with the state at t = 0, the
    free parameters, the amplitude and r as IPOPT's unknowns (limited-memory Hessian; 356 iterations
    and ~6 min on the reference problem).

    With ``coarse_steps`` (default 48 RK4 steps per period) the optimum is first found on that coarse
    grid (IPOPT's quasi-Newton iterations are ~3x cheaper there) and then refined on the full grid
    (``steps_per_period``, default ``cfg.solve.steps_per_period``) from the coarse optimum; the
    multipliers of the two grids differ by ~1e-4.

    ``progress``: False (silent), True (one line per Jacobian on stderr) or a callable taking that
    line's text (e.g. from :func:`birdocp.io.progress.progress_callback`)."""
    N_full = int(steps_per_period or (cfg or Config()).solve.steps_per_period)
    if coarse_steps and coarse_steps < N_full:
        return _full_two_grids(cfg, free, climb_rate_mps, amplitude_bounds, coarse_steps, N_full, max_iter, tol,
                               verify, progress)
    from birdocp.studies.level import level
    from birdocp.bird.model import get_model

    cfg = cfg or Config()
    require_body_states(cfg, "the full-space method", "use the reduced method (drop --method full)")
    free = dict(DEFAULT_FREE if free is None else free)
    t_start = time.perf_counter()
    m = get_model(cfg)
    check_free_keys(m, cfg, free)
    N = int(steps_per_period or cfg.solve.steps_per_period)

    # Start: the level-flight cycle of the configured gait.
    t0 = time.perf_counter()
    lv = level(cfg, bounds=amplitude_bounds, climb_rate_mps=climb_rate_mps, points=2, steps_per_period=N)
    if not lv.success:
        return StabilityOptimum(False, "start_failed", f"level flight at the start gait: {lv.message}", 0,
                                {}, free, float("nan"), float("nan"), np.full(4, np.nan), np.full(4, np.nan),
                                np.full(4, np.nan), cfg=cfg)
    wall = {"start_level": time.perf_counter() - t0}

    # NLP: z = (x0, free params, amplitude, r); constraints evaluated by a ConstraintOracle.
    t0 = time.perf_counter()
    keys = list(free) + [AMPLITUDE_KEY]
    idx = [PARAM_NAMES.index(k) for k in keys]
    p0 = np.asarray(lv.cycle.p, float)
    ev = _Evaluator(m, N, p0, idx, climb_rate_mps)
    ev.progress = progress
    z = ca.MX.sym("z", ev.nz)
    g_cb = ConstraintOracle(ev, "stability")
    nlp = {"x": z, "f": z[-1], "g": g_cb(z)}
    opts = ipopt_options(**{"ipopt.max_iter": int(max_iter), "ipopt.tol": tol, "ipopt.constr_viol_tol": 1e-9,
                            "ipopt.acceptable_tol": 1e-5, "ipopt.acceptable_iter": 5, "ipopt.mu_strategy": "adaptive"})
    solver = ca.nlpsol("stability", "ipopt", nlp, opts)
    wall["build"] = time.perf_counter() - t0

    lam0 = np.asarray(lv.multipliers)
    r0 = 1.05 * float(np.max(np.abs(lam0)))
    lo = [-np.inf, -np.inf, -np.inf, -np.inf] + [free[k][0] for k in free] + [amplitude_bounds[0], 0.02]
    hi = [np.inf] * 4 + [free[k][1] for k in free] + [amplitude_bounds[1], 50.0]
    lo[0] = 3.0  # forward flight: u >= 3 m/s at t = 0
    zinit = np.concatenate([lv.x0, p0[idx], [r0]])
    lbg = np.concatenate([np.zeros(5), np.full(5, JURY_MARGIN)])
    ubg = np.concatenate([np.zeros(5), np.full(5, np.inf)])
    t0 = time.perf_counter()
    with interrupts.interruptible():  # Ctrl-C inside IPOPT: KeyboardInterrupt, not a status
        sol = solver(x0=zinit, lbx=lo, ubx=hi, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    wall["solve"] = time.perf_counter() - t0
    return _full_result(sol, stats, ev, free, p0, idx, lam0, cfg, N, verify, wall, t_start)


def _full_result(sol, stats, ev, free, p0, idx, lam0, cfg, N, verify, wall, t_start) -> StabilityOptimum:
    """The :class:`StabilityOptimum` of the full-space solve ``sol`` (numpy eigenvalues of its
    monodromy, verification, exact validity)."""
    zs = np.asarray(sol["x"]).ravel()
    xs, ps, rs = zs[:4], zs[4:-1], float(zs[-1])
    pbest = p0.copy()
    pbest[idx] = ps
    Mnum = ev.base(np.concatenate([xs, ps, [rs]]))[2]
    lam = np.linalg.eigvals(Mnum)
    lam = sort_multipliers(lam)
    best = {k: float(v) for k, v in zip(free, ps)}
    finite = bool(np.all(np.isfinite(zs)) and np.all(np.isfinite(lam)))  # non-finite numbers are no success
    out = StabilityOptimum(bool(stats["success"]) and finite, str(stats["return_status"]) if finite else "nan",
                           f"IPOPT: {stats['return_status']}" + ("" if finite else " (non-finite result)"),
                           int(stats["iter_count"]), best, free, float(ps[-1]), rs, lam, lam0, xs, cfg=cfg)
    out.method = "full"
    out.evaluations = {"constraints": ev.n_g, "jacobians": ev.n_jac}
    if verify and np.all(np.isfinite(zs)):
        t0 = time.perf_counter()
        _verify(out, cfg, N, ev.jury(Mnum, rs))
        wall["verify"] = time.perf_counter() - t0
    if np.all(np.isfinite(zs)):
        vals = dict(best)
        vals[AMPLITUDE_KEY] = float(ps[-1])
        out.validity = periodic_validity(with_values(cfg, vals), xs, pbest, steps_per_period=N).to_dict()
    wall["total"] = time.perf_counter() - t_start
    out.wall_s = wall
    return out
