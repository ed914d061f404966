"""Validity as a constraint of the reduced-space gait optimisers: the exact verdict of an optimum, the
report of its smooth constraints, and the rounds that tighten a smooth bound until the exact
verdict is ``valid``.

The smooth measures (:mod:`birdocp.bird.validity_smooth`) approximate the exact ones; at an optimum
where a smooth limit is active the exact measure may still lie just beyond the limit (the integral KS
aggregate sits below the true maximum by a few tenths of a degree). :func:`solve_valid` then moves
that smooth bound inward by the difference (times :data:`TIGHTEN_FACTOR`) and solves again from the
optimum, at most :data:`VALID_ROUNDS` solves in all. Every round is listed in the result's
``validity_rounds``.
"""

from __future__ import annotations

import numpy as np

from birdocp.bird.config import Config, with_values

__all__ = ["VALID_ROUNDS", "TIGHTEN_FACTOR", "solve_valid", "attach_validity", "constraint_report"]

VALID_ROUNDS = 4
"""Solves at most (the first with the configured bounds, then tightened ones)."""
TIGHTEN_FACTOR = 1.25
"""A crossed limit's smooth bound moves inward by this factor times the exact measure's excess."""
_MIN_STEP = {"stalled_fraction": 1e-3, "min_forward_speed_mps": 0.01, "max_abs_pitch_deg": 0.01,
             "max_airflow_body_angle_deg": 0.01}
from birdocp.bird.keys import AMPLITUDE_KEY  # noqa: E402
WARM_IPOPT = {"ipopt.mu_init": 1e-6, "ipopt.mu_strategy": "monotone", "ipopt.bound_push": 1e-8,
              "ipopt.bound_frac": 1e-8}
"""IPOPT options of a re-solve from the previous round's optimum (no push away from active constraints)."""


def attach_validity(out, prob, ev, lam_g, cfg: Config) -> None:
    """Set ``out.validity`` (exact verdict of the optimal cycle, on the solver's grid) and, when the
    problem had smooth validity constraints, ``out.validity_constraints``.

    Parameters
    ----------
    out : GaitOptimum
        Result, changed in place.
    prob : object
        The optimisation problem solved.
    ev : object
        The problem evaluated at the optimum.
    lam_g : array_like
        Constraint multipliers at the optimum.
    cfg : Config
        Configuration.
    """
    if not out.free or not np.all(np.isfinite(out.x0)):
        return
    cfg_best = with_values(cfg, dict(out.free) | {AMPLITUDE_KEY: float(out.amplitude_deg)})
    out.validity = prob.rc.exact_validity(cfg_best, out.x0)
    if prob.valid_bounds:
        smooth = prob.smooth_validity(ev, grads=False)[0]
        first = prob.ng - 1 - len(prob.valid_bounds)  # rows of lam_g (no objective row)
        lam = {k: float(lam_g[first + i]) for i, k in enumerate(prob.valid_bounds)}
        out.validity_constraints = constraint_report(cfg, smooth, out.validity, prob.valid_bounds, lam)


def constraint_report(cfg: Config, smooth: dict, exact: dict, used: dict, lam: dict | None = None) -> dict:
    """Per validity limit, the smooth constraint at the optimum against the exact measure.

    Parameters
    ----------
    cfg : Config
        Configuration (the configured bounds).
    smooth : dict
        Limit to its smooth value at the optimum.
    exact : dict
        The exact validity (a validity dict).
    used : dict
        Limit to the (possibly tightened) bound the optimiser held.
    lam : dict, optional
        Limit to IPOPT's multiplier (None: no optimiser held it).

    Returns
    -------
    dict
        Limit to ``{"smooth", "exact", "bound", "bound_used", "kind" ('max' or 'min'), "active" (within
        1e-5 of its bound relative to max(1, |bound|)), "exact_within_bound", "multiplier", "smoothing"}``.
    """
    from birdocp.bird.validity_smooth import KS_RHO, STALL_WIDTH_DEG, limit_bounds

    out = {}
    for k, (bound, kind) in limit_bounds(cfg).items():
        b_used = used.get(k, (bound, kind))[0]
        s = smooth.get(k)
        active = s is not None and abs(s - b_used) <= 1e-5 * max(1.0, abs(b_used))
        how = (f"logistic step of width {STALL_WIDTH_DEG:g} deg, span-time mean over the RK4 stages"
               if k == "stalled_fraction" else f"Kreisselmeier-Steinhauser, integral form, rho {KS_RHO[k]:g}")
        e = (exact or {}).get(k)
        ok = None if e is None else bool(e <= bound if kind == "max" else e >= bound)
        out[k] = {"smooth": s, "exact": e, "bound": bound, "bound_used": b_used, "kind": kind,
                  "active": bool(active), "exact_within_bound": ok,
                  "multiplier": None if lam is None else lam.get(k), "smoothing": how}
    return out


def _tightened(cfg: Config, used: dict, exact: dict, smooth: dict) -> dict | None:
    """The smooth bounds moved inward for every limit the exact verdict crosses (None: none crossed,
    or a crossed limit without a measure)."""
    from birdocp.bird.validity_smooth import limit_bounds

    new, moved = dict(used), False
    for k, (bound, kind) in limit_bounds(cfg).items():
        e = exact.get(k)
        if e is None:
            return None
        excess = (e - bound) if kind == "max" else (bound - e)
        if excess > 0:
            step = max(TIGHTEN_FACTOR * excess, _MIN_STEP[k])
            b, s = used[k][0], smooth.get(k)
            if kind == "max":  # by the excess, or to the bound less the exact-smooth gap if that is inward
                b = min(b - step, bound - TIGHTEN_FACTOR * (e - s)) if s is not None else b - step
            else:
                b = max(b + step, bound + TIGHTEN_FACTOR * (s - e)) if s is not None else b + step
            new[k] = (b, kind)
            moved = True
    return new if moved else None


def solve_valid(solve, cfg: Config, free, valid: bool, options: dict, rounds_max: int = VALID_ROUNDS):
    """``solve(cfg, free, valid_bounds=..., **options)`` once (``valid`` False: no smooth constraints),
    or in rounds until the optimum's exact validity is ``valid`` (see the module).

    Parameters
    ----------
    solve : callable
        ``solve(cfg, free, valid_bounds=..., **options)``.
    cfg : Config
        Configuration.
    free : dict
        Free keys and bounds.
    valid : bool
        Add the smooth validity constraints.
    options : dict
        Further keywords of ``solve``.
    rounds_max : int
        Largest number of rounds.

    Returns
    -------
    object
        The last result of ``solve``.
    """
    import time

    from birdocp.bird.validity_smooth import limit_bounds

    if not valid:
        return solve(cfg, free, **options)
    t0 = time.perf_counter()
    used = limit_bounds(cfg)
    rounds, iterations, out = [], 0, None
    for _ in range(max(1, int(rounds_max))):
        out = solve(cfg, free, valid_bounds=used, **options)
        iterations += out.iterations
        v = out.validity or {}
        rounds.append({"bounds_used": {k: b for k, (b, _) in used.items()}, "status": out.status,
                       "success": bool(out.success), "exact_valid": bool(v.get("valid")),
                       "iterations": out.iterations})
        if not out.free or v.get("valid") or not np.all(np.isfinite(list(out.free.values()))):
            break
        smooth = {k: c.get("smooth") for k, c in (out.validity_constraints or {}).items()}
        new = _tightened(cfg, used, v, smooth)
        if new is None:
            break
        used = new
        # warm: from this optimum (gait, amplitude, cycle); the stability radius restarts just above it
        options = dict(options, start=dict(out.free) | {AMPLITUDE_KEY: float(out.amplitude_deg)},
                       x_guess=np.asarray(out.x0, float), radius_start_factor=1.001,
                       ipopt_options=WARM_IPOPT | dict(options.get("ipopt_options") or {}))
    out.iterations = iterations
    out.validity_rounds = rounds
    if len(rounds) > 1:
        out.message += f"; {len(rounds)} validity rounds (smooth bounds tightened until the exact verdict holds)"
    if isinstance(out.wall_s, dict):
        out.wall_s = dict(out.wall_s, total_with_validity_rounds=time.perf_counter() - t0)
    return out
