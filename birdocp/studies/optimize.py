"""The most stable level-flight gait within bounds: minimise the largest Floquet multiplier modulus.

The spectral radius of the monodromy is not smooth (it jumps between eigenvalues, and a complex pair
has a kink). birdocp poses it smoothly: minimise ``r`` subject to all eigenvalues of ``Mon / r``
lying inside the unit circle, written as the Jury (Schur-Cohn) conditions on the characteristic
polynomial ``z^4 + a3 z^3 + a2 z^2 + a1 z + a0`` of ``Mon / r`` (coefficients from traces, all CasADi
expressions of the cycle and the gait):

    p(1) >= 0,  p(-1) >= 0,  1 - a0^2 >= 0,  b0^2 - b3^2 >= 0,  c0^2 - c2^2 >= 0,

with the Jury rows ``b_k = a0 a_k - a_{4-k}`` and ``c_k = b0 b_k - b3 b_{3-k}`` (each bounded below by a
small margin, :data:`JURY_MARGIN`, so that only strictly Jury-stable points are feasible). At the
optimum one of them is active and ``r`` equals the spectral radius up to the margin. The NLP (IPOPT, exact first derivatives, the
monodromy's derivatives by forward-over-forward AD) has the state at t = 0, the free gait
parameters, the flapping amplitude (level flight: mean vertical speed = climb rate) and ``r`` as
unknowns, single shooting over one period. The answer is verified independently: numpy
eigenvalues of the monodromy, and a trim from scratch at the optimal gait.

Free keys must leave the wing's arm-frame shape unchanged (shoulder joints, wing root position,
shoulder separation, body and aerodynamic numbers, tail), so the expensive geometry stays numeric.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, get_value, suggest, with_values
from birdocp.bird.validity import invalid, periodic_validity
from birdocp.engine import interrupts
from birdocp.engine.floquet import matched_distances, sort_multipliers
from birdocp.engine.oracle import ConstraintOracle, ipopt_options
from birdocp.engine.results import result_dict, serial

__all__ = ["DEFAULT_FREE", "check_free_keys", "optimize_stability", "StabilityOptimum", "jury_conditions"]

AMPLITUDE_KEY = "gait.shoulder_flap.amplitude_deg"
JURY_MARGIN = 1e-6
"""The Jury quantities are bounded below by this margin, not 0: the criterion needs the strict
inequalities, and with ``>= 0`` an optimiser finds degenerate points of the Jury table (an equality in
an intermediate row) where multipliers lie outside the circle (seen: r = 0.944 with a multiplier of
modulus 1.034). With the margin every feasible point has all multipliers strictly inside the circle
of radius r, at the cost of r exceeding the spectral radius by about the margin."""

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

    @property
    def stable(self) -> bool:
        return bool(np.max(np.abs(self.multipliers)) < 1.0)

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`)."""
        return result_dict(self, exclude=("cfg",), derived=("stable",), extra={
            "moduli": np.abs(self.multipliers),
            "validity": self.validity or invalid(self.cfg, "not checked (no optimal cycle)"),
            "active_bounds": [k for k, v in self.free.items()
                              if min(abs(v - self.bounds[k][0]), abs(v - self.bounds[k][1])) < 1e-6]})


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
            if callable(self.progress):
                self.progress(text)
            else:
                import sys
                print(f"optimize-stability: {text}", file=sys.stderr, flush=True)
        return J


def check_free_keys(m, cfg, free: dict) -> None:
    """ConfigError unless every free key can be a reduced variable (known, not the amplitude, not
    reshaping the wing in the arm frame, finite bounds around the configured value)."""
    for k, (lo, hi) in free.items():
        if k not in PARAM_NAMES:
            raise ConfigError(k, "unknown parameter for --free" + suggest(k, PARAM_NAMES))
        if k == AMPLITUDE_KEY:
            raise ConfigError(k, "the flapping amplitude is solved for level flight; free other keys")
        if PARAM_NAMES.index(k) in m.pre_params:
            raise ConfigError(k, "changes the wing's shape in the arm frame (elbow, wrist, morphology): "
                                 "free shoulder joints, wing.root_ahead_m or body/aero/drag keys")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ConfigError(k, f"bounds must be finite with lower < upper, got ({lo}, {hi})")
        v = float(get_value(cfg, k))
        if not lo <= v <= hi:
            raise ConfigError(k, f"configured value {v:g} lies outside its bounds ({lo:g}, {hi:g}); "
                                 f"widen --bounds {k}=LO:HI")


def _suggest(k):
    from birdocp.bird.config import suggest

    return suggest(k, PARAM_NAMES)


def optimize_stability(cfg: Config | None = None, free: dict | None = None, *, climb_rate_mps: float = 0.0,
                       amplitude_bounds=(20.0, 70.0), steps_per_period: int | None = None,
                       max_iter: int = 400, tol: float = 1e-7, verify: bool = True,
                       progress=False, coarse_steps: int | None = 48) -> StabilityOptimum:
    """Minimise the largest multiplier modulus of a level-flight cycle over the gait parameters
    ``free`` (key -> (lower, upper); default :data:`DEFAULT_FREE`).

    With ``coarse_steps`` (default 48 RK4 steps per period) the optimum is first found on that coarse
    grid (IPOPT's quasi-Newton iterations are ~3x cheaper there) and then refined on the full grid
    (``steps_per_period``, default ``cfg.solve.steps_per_period``) from the coarse optimum; the
    multipliers of the two grids differ by ~1e-4.

    ``progress``: False (silent), True (one line per Jacobian on stderr) or a callable taking that
    line's text (e.g. from :func:`birdocp.io.progress.progress_callback`)."""
    N_full = int(steps_per_period or (cfg or Config()).solve.steps_per_period)
    if coarse_steps and coarse_steps < N_full:
        coarse = optimize_stability(cfg, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                                    steps_per_period=coarse_steps, max_iter=max_iter, tol=tol, verify=False,
                                    progress=progress, coarse_steps=None)
        if np.all(np.isfinite(list(coarse.free.values()))) and coarse.free:
            start = with_values(cfg or Config(), coarse.free)
            fine = optimize_stability(start, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                                      steps_per_period=N_full, max_iter=max_iter, tol=tol, verify=verify,
                                      progress=progress, coarse_steps=None)
            fine.iterations += coarse.iterations
            fine.start_multipliers = coarse.start_multipliers
            fine.wall_s = {"coarse_" + k: v for k, v in coarse.wall_s.items()} | fine.wall_s
            fine.wall_s["total"] = coarse.wall_s.get("total", 0.0) + fine.wall_s.get("total", 0.0)
            fine.message += f"; coarse stage ({coarse_steps} steps): {coarse.status}, {coarse.iterations} iterations"
            return fine
        return coarse
    from birdocp.studies.level import level
    from birdocp.bird.model import get_model
    from birdocp.studies.trim import trim

    cfg = cfg or Config()
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

    if verify and np.all(np.isfinite(zs)):
        t0 = time.perf_counter()
        vals = dict(best)
        vals[AMPLITUDE_KEY] = float(ps[-1])
        cfg_best = with_values(cfg, vals)
        # independent checks: multiple shooting (5 points) from the optimum's state, and from scratch
        check = trim(cfg_best, x_guess=xs, points=5, steps_per_period=N)
        scratch = trim(cfg_best, points=5, steps_per_period=N)
        out.cfg = cfg_best
        pairs = lambda lam_: [[float(v.real), float(v.imag)] for v in lam_]
        dist = lambda a, b: float(np.max(matched_distances(a, b)))
        out.verification = {
            "trim_success": bool(check.success),
            "trim_multipliers": pairs(check.multipliers) if check.success else None,
            "max_multiplier_difference": dist(check.multipliers, lam) if check.success else None,
            "trim_mean_vertical_speed_mps": float(check.mean_vertical_speed_mps) if check.success else None,
            "trim_x0_difference": float(np.max(np.abs(check.x0 - xs))) if check.success else None,
            "scratch_trim_success": bool(scratch.success),
            "scratch_trim_x0": scratch.x0.tolist(),
            "scratch_trim_multipliers": pairs(scratch.multipliers) if scratch.success else None,
            "scratch_finds_another_cycle": bool(scratch.success and np.max(np.abs(scratch.x0 - xs)) > 1e-6),
            "radius_minus_spectral_radius": rs - float(np.max(np.abs(lam))),
            "jury_at_optimum": ev.jury(Mnum, rs).tolist(),
            "evaluations": {"constraints": ev.n_g, "jacobians": ev.n_jac},
        }
        wall["verify"] = time.perf_counter() - t0
    if np.all(np.isfinite(zs)):
        vals = dict(best)
        vals[AMPLITUDE_KEY] = float(ps[-1])
        out.validity = periodic_validity(with_values(cfg, vals), xs, pbest, steps_per_period=N).to_dict()
    wall["total"] = time.perf_counter() - t_start
    out.wall_s = wall
    return out
