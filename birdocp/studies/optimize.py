"""The most stable level-flight gait within bounds: minimise the largest Floquet multiplier modulus.

The spectral radius of the monodromy is not smooth (it jumps between eigenvalues, and a complex pair
has a kink). birdocp poses it smoothly: minimise ``r`` subject to all eigenvalues of ``Mon / r``
lying inside the unit circle, written as the Jury (Schur-Cohn) conditions on the characteristic
polynomial ``z^4 + a3 z^3 + a2 z^2 + a1 z + a0`` of ``Mon / r`` (coefficients from traces, all CasADi
expressions of the cycle and the gait):

    p(1) >= 0,  p(-1) >= 0,  1 - a0^2 >= 0,  b0^2 - b3^2 >= 0,  c0^2 - c2^2 >= 0,

with the Jury rows ``b_k = a0 a_k - a_{4-k}`` and ``c_k = b0 b_k - b3 b_{3-k}`` (each bounded below by a
small margin, :data:`JURY_MARGIN`, so that only strictly Jury-stable points are feasible). At the
optimum one of them is active and ``r`` equals the spectral radius up to the margin. The NLP is posed in reduced space
(:mod:`birdocp.studies.gait`): IPOPT's unknowns are the free gait parameters and ``r``; for every
iterate the level cycle (the state at t = 0 and the flapping amplitude, mean vertical speed = climb
rate) is solved by Newton, and the exact gradients of the Jury quantities follow from the
implicit-function theorem with the monodromy's derivatives from second-order variational equations
(:mod:`birdocp.engine.variational`). Measured on the reference problem (4 free keys, 148 steps): see
the README (the full-space shooting NLP took 356 IPOPT iterations, about 6.5 min). The answer is
verified independently: numpy eigenvalues of the monodromy, and trims at the optimal gait.

Free keys must leave the wing's arm-frame shape unchanged (shoulder joints, wing root position,
shoulder separation, body and aerodynamic numbers, tail), so the expensive geometry stays numeric.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.bird.validity import invalid, periodic_validity
from birdocp.engine.floquet import matched_distances
from birdocp.studies.gait import jury_conditions

__all__ = ["DEFAULT_FREE", "optimize_stability", "StabilityOptimum", "jury_conditions"]

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
    multipliers: np.ndarray        # numpy eigenvalues of the optimal monodromy
    start_multipliers: np.ndarray  # at the level-flight start
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
        pair = lambda z: [[float(v.real), float(v.imag)] for v in np.asarray(z)]
        return {"success": self.success, "status": self.status, "message": self.message,
                "iterations": self.iterations, "free": self.free,
                "bounds": {k: list(v) for k, v in self.bounds.items()},
                "amplitude_deg": self.amplitude_deg, "radius": self.radius,
                "multipliers": pair(self.multipliers), "moduli": np.abs(self.multipliers).tolist(),
                "start_multipliers": pair(self.start_multipliers), "x0": self.x0.tolist(),
                "stable": self.stable, "verification": self.verification, "wall_s": self.wall_s,
                "validity": self.validity or invalid(self.cfg, "not checked (no optimal cycle)").to_dict(),
                "active_bounds": [k for k, v in self.free.items()
                                  if min(abs(v - self.bounds[k][0]), abs(v - self.bounds[k][1])) < 1e-6]}


def optimize_stability(cfg: Config | None = None, free: dict | None = None, *, climb_rate_mps: float = 0.0,
                       amplitude_bounds=(20.0, 70.0), steps_per_period: int | None = None,
                       max_iter: int = 400, tol: float = 1e-7, verify: bool = True,
                       progress=False, coarse_steps: int | None = None) -> StabilityOptimum:
    """Minimise the largest multiplier modulus of a level-flight cycle over the gait parameters
    ``free`` (key -> (lower, upper); default :data:`DEFAULT_FREE`).

    Reduced space (:mod:`birdocp.studies.gait`): the NLP's unknowns are the free parameters and r
    only; the level cycle (state and flapping amplitude) is solved for every iterate and its
    monodromy's exact derivatives follow from the implicit function theorem. ``progress``: False,
    True (one line per gradient evaluation on stderr) or a callable taking that line. ``coarse_steps``
    (default None: off) first solves on that coarse grid and refines on the full one
    (``steps_per_period``, default ``cfg.solve.steps_per_period``)."""
    cfg = cfg or Config()
    N_full = int(steps_per_period or cfg.solve.steps_per_period)
    if coarse_steps and coarse_steps < N_full:
        coarse = optimize_stability(cfg, free, climb_rate_mps=climb_rate_mps, amplitude_bounds=amplitude_bounds,
                                    steps_per_period=coarse_steps, max_iter=max_iter, tol=tol, verify=False,
                                    progress=progress, coarse_steps=None)
        if coarse.free and np.all(np.isfinite(list(coarse.free.values()))):
            fine = optimize_stability(with_values(cfg, coarse.free), free, climb_rate_mps=climb_rate_mps,
                                      amplitude_bounds=amplitude_bounds, steps_per_period=N_full,
                                      max_iter=max_iter, tol=tol, verify=verify, progress=progress,
                                      coarse_steps=None)
            fine.iterations += coarse.iterations
            fine.start_multipliers = coarse.start_multipliers
            fine.wall_s = {"coarse_" + k: v for k, v in coarse.wall_s.items()} | fine.wall_s
            fine.wall_s["total"] = coarse.wall_s.get("total", 0.0) + fine.wall_s.get("total", 0.0)
            fine.message += f"; coarse stage ({coarse_steps} steps): {coarse.status}, {coarse.iterations} iterations"
            return fine
        return coarse
    from birdocp.studies.gait import optimize_gait
    from birdocp.studies.trim import trim

    free = dict(DEFAULT_FREE if free is None else free)
    t_start = time.perf_counter()
    g = optimize_gait(cfg, free, objective="stability", climb_rate_mps=climb_rate_mps,
                      amplitude_bounds=amplitude_bounds, steps_per_period=N_full, max_iter=max_iter, tol=tol,
                      verify=False, progress=progress)
    nan4 = np.full(4, np.nan)
    if not g.free:
        return StabilityOptimum(False, g.status, g.message, 0, {}, free, float("nan"), float("nan"),
                                nan4.astype(complex), nan4.astype(complex), nan4, cfg=cfg)
    lam = g.multipliers
    out = StabilityOptimum(g.success, g.status, g.message, g.iterations, dict(g.free), free, g.amplitude_deg,
                           float(g.objective_value), lam, g.start_multipliers, np.asarray(g.x0), cfg=cfg)
    wall = dict(g.wall_s)
    if verify:
        t0 = time.perf_counter()
        vals = dict(g.free)
        vals[AMPLITUDE_KEY] = g.amplitude_deg
        cfg_best = with_values(cfg, vals)
        xs = np.asarray(g.x0)
        # independent checks: multiple shooting (5 points) from the optimum's state, and from scratch
        check = trim(cfg_best, x_guess=xs, points=5, steps_per_period=N_full)
        scratch = trim(cfg_best, points=5, steps_per_period=N_full)
        out.cfg = cfg_best
        pairs = lambda lam_: [[float(v.real), float(v.imag)] for v in lam_]
        dist = lambda a, b: float(np.max(matched_distances(a, b)))
        Mnum = check.monodromy if check.success else None
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
            "radius_minus_spectral_radius": out.radius - float(np.max(np.abs(lam))),
            "jury_at_optimum": (np.asarray(ca.DM(jury_conditions(ca.DM(Mnum) / out.radius))).ravel().tolist()
                                if Mnum is not None else None),
            "kkt_residual": g.kkt_residual,
            "evaluations": dict(g.evaluations),
        }
        wall["verify"] = time.perf_counter() - t0
    if np.all(np.isfinite(np.asarray(g.x0))):
        vals = dict(g.free)
        vals[AMPLITUDE_KEY] = g.amplitude_deg
        cfg_v = with_values(cfg, vals)
        from birdocp.bird.config import param_vector

        out.validity = periodic_validity(cfg_v, np.asarray(g.x0), param_vector(cfg_v),
                                         steps_per_period=N_full).to_dict()
    wall["total"] = time.perf_counter() - t_start
    out.wall_s = wall
    return out
