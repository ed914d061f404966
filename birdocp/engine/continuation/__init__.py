"""Pseudo-arclength continuation of periodic orbits in one parameter, with special-point detection.

Works for any :class:`~birdocp.engine.problem.LimitCycleProblem`: the unknowns are the shooting points
``X_0 .. X_{M-1}``, the problem's free parameters (each held by one of its period-mean conditions,
e.g. the flapping amplitude held by mean W = 0 for level flight) and the continuation parameter
``lam``. The equations ``G = [continuity; periodicity; mean conditions]`` are one fewer than the
unknowns; the branch is the curve ``G(z) = 0``.

* **Scaling.** All geometry (tangent, arclength, step) is done in scaled unknowns ``u = z / s``:
  states and free parameters by ``scales`` (default 1), the continuation parameter by the length of
  the requested interval ``|to - from|`` (so the whole interval is one unit of arclength along lam).
* **Predictor.** ``u + ds t`` with ``t`` the unit tangent, the null vector of ``dG/du``, oriented by
  the previous tangent (first: by the direction from ``from`` to ``to``).
* **Corrector.** Quasi-Newton on the square system ``[G(u); t.(u - u_k) - ds] = 0``. The residual
  and its exact Jacobian come from the multiple-shooting engine's graphs
  (:func:`birdocp.engine.shooting.shooting_graphs`, the continuation parameter one more free parameter):
  ``dG/dX`` by forward AD of the RK4 segments, the parameter columns by forward AD through the
  per-time data (of ``post`` only when no unknown enters the wing's arm-frame shape; from a constant
  column when the parameter enters the data affinely, like the wing-root position). The corrector
  starts from the Jacobian of the point it steps from, evaluates only residuals and updates the
  Jacobian by Broyden's formula, re-evaluating it where a step reduces the residual by less than
  ``chord_contraction``; the Jacobian at the converged point (tangent, monodromy) is always exact.
* **Step control.** ds grows by 1.5 after a corrector converging in at most 5 steps, is kept after
  6-9, halves after more and after a failure (down to ``ds_min``: the branch is lost there). With
  ``max_dparam`` / ``max_dstate`` a step is first shortened so that it is expected to change the
  parameter / a shooting-point state by at most 0.85 of the limit (rate: the larger of the tangent's
  and the last step's), and a converged step beyond a limit is refused and shortened in proportion.
* **Special points** between consecutive points, from sign changes of test functions:

  - ``fold``: the parameter component of the tangent changes sign (the branch turns back; for a
    forced system one multiplier crosses +1 there);
  - ``branch_point``: ``det(I - Mon)`` changes sign without a fold (a multiplier crosses +1 while the
    parameter keeps its direction: transcritical/pitchfork of cycles);
  - ``period_doubling``: ``det(I + Mon)`` changes sign (a real multiplier crosses -1);
  - ``neimark_sacker``: ``prod_{i<j} (L_i L_j - 1)`` changes sign and a complex pair is on the unit
    circle at the located point (a sign change from a real pair with ``L_i L_j = 1`` is a neutral
    saddle, not a bifurcation, and is not reported).

  Each is located by Illinois regula falsi on the arclength from the point before the change (every
  evaluation a corrector solve) to ``locate_tol`` in scaled arclength and reported with the parameter
  value, the multipliers and the free parameters there.

The continuation stops (``Branch.end_reason``) when the parameter leaves ``[min(from,to),
max(from,to)]`` (the last point is then re-solved exactly on the boundary: ``reached_to`` or, after a
fold, ``reached_from``), when the corrector fails at the minimum step (``corrector_failed``), when a
free parameter leaves its bounds (``free_parameter_bound``), when ``accept`` rejects a point
(``rejected``: e.g. a bird cycle with u <= 0) or after ``max_points`` (``max_points``).

The pieces, one module each: ``options`` (:class:`ContinuationOptions`), ``system`` (the augmented
system, tangent, test functions), ``corrector`` (quasi-Newton), ``steps`` (step control), ``events``
(special points), ``branch`` (the result types); :func:`continuation` puts them together.
"""
from __future__ import annotations

import time
from dataclasses import fields
from typing import Callable

import numpy as np

from birdocp.engine.continuation.branch import Branch, BranchPoint, SpecialPoint
from birdocp.engine.continuation.corrector import Corrector
from birdocp.engine.continuation.events import locate, sign_changes
from birdocp.engine.continuation.options import SPECIAL_POINT_KINDS, ContinuationOptions
from birdocp.engine.continuation.steps import StepController
from birdocp.engine.continuation.system import Continuation, ContinuationState
from birdocp.engine.floquet import complex_pairs, multipliers_info
from birdocp.engine.problem import LimitCycleProblem
from birdocp.engine.shooting import MultipleShooting, initial_points, solve

__all__ = ["Branch", "BranchPoint", "SpecialPoint", "Continuation", "ContinuationOptions", "SPECIAL_POINT_KINDS",
           "continuation"]


def continuation(problem: LimitCycleProblem, param, start_value: float, stop_value: float, *,
                 options: ContinuationOptions | None = None, start=None, accept: Callable | None = None,
                 progress: Callable | None = None, system: Continuation | None = None,
                 on_point: Callable | None = None, on_special: Callable | None = None, orient: float | None = None,
                 **settings) -> Branch:
    """Follow the periodic orbits of ``problem`` as ``param`` goes from ``start_value`` to ``stop_value``.

    Parameters
    ----------
    problem : LimitCycleProblem
        The limit-cycle problem; its ``free`` parameters (held by its ``means``) are unknowns too.
    param : str or int
        The continuation parameter (a name in ``ode.param_names`` or an index).
    start_value, stop_value : float
        The interval of the parameter (its units).
    options : ContinuationOptions, optional
        How the branch is followed; keyword arguments named like its fields (``points``, ``step``,
        ``max_dparam``, ...) override it.
    start : object, optional
        A converged cycle at ``start_value`` (anything with ``shooting_points`` on the same grid, and
        ``p``); default: Newton from the problem's guess integrated forward, else
        :func:`birdocp.engine.shooting.solve` (IPOPT).
    accept : callable, optional
        ``accept(point) -> str | None`` with the :class:`BranchPoint`; a returned string rejects the
        point and ends the branch (``rejected``).
    progress : callable, optional
        ``progress(text)``, one line per point.
    system : Continuation, optional
        A prebuilt augmented system (same problem, parameter and grid) to reuse.
    on_point : callable, optional
        ``on_point(point)`` with each accepted :class:`BranchPoint` as soon as it is accepted (e.g. to
        keep the points of a run that is interrupted before the branch is returned).
    on_special : callable, optional
        ``on_special(special_point)`` with each located :class:`SpecialPoint` as soon as it is located
        (before the point after it is accepted).
    orient : float, optional
        The sign of d(parameter)/ds at the first point: the direction of travel (a branch resumed from
        a point after a fold: the sign of that point's ``tangent_parameter``); default: towards
        ``stop_value``.

    Returns
    -------
    Branch
        The points, the special points and why the branch ended.
    """
    opts = options or ContinuationOptions()
    names = {f.name for f in fields(ContinuationOptions)}
    unknown = set(settings) - names
    if unknown:
        raise TypeError(f"unknown continuation setting(s): {sorted(unknown)}")
    if settings:
        opts = ContinuationOptions(**{**opts.__dict__, **settings})
    t_all = time.perf_counter()
    sysm = system or Continuation(problem, param, opts.points, opts.steps_per_period)
    nx, S = sysm.nx, sysm.S
    nX = nx * (S + 1)
    nf = len(sysm.free_idx)
    if not (np.isfinite(start_value) and np.isfinite(stop_value)):
        raise ValueError(f"start_value and stop_value must be finite, got {start_value!r}, {stop_value!r}")
    span = abs(stop_value - start_value)
    if not span > 0:
        raise ValueError("start_value and stop_value must differ")
    direction = 1.0 if stop_value > start_value else -1.0
    rlo, rhi = min(start_value, stop_value), max(start_value, stop_value)
    sc = dict(opts.scales or {})
    s_states = np.broadcast_to(np.asarray(sc.get("states", 1.0), float), (nx,))
    s_free = np.broadcast_to(np.asarray(sc.get("free", 1.0), float), (nf,))
    s_lam = float(sc.get("parameter", span))
    s = np.concatenate([np.tile(s_states, S + 1), s_free, [s_lam]])
    li = sysm.nz - 1   # index of lam in z
    say = progress or (lambda text: None)
    corr = Corrector(sysm, s, opts.tol, opts.max_newton, opts.chord_contraction)
    name, free_names = sysm.name, sysm.free_names

    # --- first point: Newton at fixed lam from the given cycle, or from the problem's guess integrated
    # forward; if that fails, the engine (IPOPT)
    p_start = np.asarray(start.p if start is not None else problem.p, float).copy()
    p_start[sysm.j] = start_value
    if start is not None:
        z0 = sysm.z_of(start.shooting_points, p_start)
    else:
        D0 = sysm.grid.blocks_numeric(float(problem.t0), p_start)
        z0 = sysm.z_of(initial_points(sysm.builder, problem.x_guess, D0, p_start).T, p_start)
    e_l = np.zeros(sysm.nz)
    e_l[li] = 1.0
    out = corr.newton(z0 / s, e_l, start_value / s_lam)
    if out is None and start is None:
        prob0 = LimitCycleProblem(problem.ode, p_start, problem.x_guess, problem.free, problem.means,
                                  problem.t0, problem.outputs)
        eng = solve(prob0, MultipleShooting(points=opts.points, steps_per_period=opts.steps_per_period))
        if eng.success:
            out = corr.newton(sysm.z_of(eng.shooting_points, p_start) / s, e_l, start_value / s_lam)
    if out is None:
        return Branch(name, [], [], "start_failed", "Newton did not converge at the start value from the given cycle",
                      {}, time.perf_counter() - t_all)
    cur = corr.state(out, None)
    if cur.t[li] * (direction if orient is None else np.sign(orient) or direction) < 0:
        cur.t = -cur.t
        cur.tests = dict(cur.tests, fold=float(cur.t[li]))

    dlam0 = float(opts.step) if opts.step else span / 10.0
    ds0 = abs(dlam0 / s_lam) / max(abs(cur.t[li]), 1e-3)
    steps = StepController(ds0, opts.ds_min or ds0 / 256, opts.ds_max or 4 * ds0, s, li, nX,
                           opts.max_dparam, opts.max_dstate)
    run_settings = {"parameter": name, "from": start_value, "to": stop_value, "points": opts.points,
                    "steps_per_period": opts.steps_per_period, "first_step": dlam0, "ds_first": ds0,
                    "ds_min": steps.ds_min, "ds_max": steps.ds_max, "scales": s.tolist(), "tol": opts.tol,
                    "max_points": opts.max_points, "free": free_names, "mean_conditions": sysm.mean_names[:sysm.nm],
                    "max_dparam": opts.max_dparam, "max_dstate": opts.max_dstate}

    def make_point(st: ContinuationState, arclen: float, ds_used: float) -> BranchPoint:
        z = s * st.u
        lam_m, _, _, _, stable = multipliers_info(st.Mon, sysm.period_of(z))
        p = sysm.p_of(z)
        X = sysm.X_of(z)
        return BranchPoint(
            parameter=float(z[li]), x0=X[:, 0].tolist(), shooting_points=X.T.tolist(),
            free_values={n: float(p[i]) for n, i in zip(free_names, sysm.free_idx)},
            multipliers=complex_pairs(lam_m), moduli=[float(abs(v)) for v in lam_m], stable=bool(stable),
            means={n: float(v) for n, v in zip(sysm.mean_names, st.means)}, arclength=float(arclen),
            tangent_parameter=float(st.t[li]), iterations=int(st.iterations),
            max_residual=float(np.max(np.abs(st.g))) if st.g.size else 0.0, step=float(ds_used),
            tests=dict(st.tests), p=p.tolist(), period=sysm.period_of(z))

    def rejection(pt: BranchPoint) -> str | None:
        if nf:
            fv = np.array([pt.p[i] for i in sysm.free_idx])
            if np.any(fv < sysm.lo) or np.any(fv > sysm.hi):
                return "free_parameter_bound"
        if accept is not None:
            msg = accept(pt)
            if msg:
                return "rejected: " + msg
        return None

    pts = [make_point(cur, 0.0, 0.0)]
    keep = on_point or (lambda point: None)
    keep(pts[0])
    specials: list[SpecialPoint] = []
    arclen = 0.0
    end_reason, end_message = "max_points", f"max_points={opts.max_points} reached"
    say(f"{name} = {pts[0].parameter:.6g}: start, |L|max {max(pts[0].moduli):.4f}")
    while len(pts) < opts.max_points:
        ds = steps.capped(cur)
        nxt = corr.along(cur, ds)
        if nxt is None:
            if not steps.failed():
                end_reason = "corrector_failed"
                end_message = (f"the corrector failed at the minimum step ds={ds:.3g} after {name} = "
                               f"{pts[-1].parameter:.8g}: no nearby continuation of the branch")
                break
            continue
        if steps.refuse(cur, nxt):
            continue
        lam_new = s_lam * nxt.u[li]
        boundary = None
        if lam_new > rhi or lam_new < rlo:
            boundary = rhi if lam_new > rhi else rlo
        # special points between cur and nxt (located on the arc, before cutting at a boundary)
        found = []
        for kind in sign_changes(cur, nxt, opts.detect):
            sp = locate(kind, corr, cur, nxt, ds, len(pts) - 1, arclen, make_point, name, opts.locate_tol)
            if sp is not None and rlo - 1e-12 <= sp.parameter <= rhi + 1e-12:
                found.append(sp)
                say(f"  {kind} at {name} = {sp.parameter:.9g} ({sp.message})")
        found.sort(key=lambda q: q.arclength)
        specials.extend(found)
        for sp in found:
            (on_special or (lambda q: None))(sp)
        if boundary is not None:
            last = corr.at_parameter(cur, nxt, boundary, s_lam)
            if last is not None:
                arclen += float(np.linalg.norm(last.u - cur.u))
                pt = make_point(last, arclen, ds)
                if rejection(pt) is None:
                    pts.append(pt)
                    keep(pt)
            folded = any(q.kind == "fold" for q in specials)
            end_reason = "reached_to" if boundary == (rhi if direction > 0 else rlo) else "reached_from"
            end_message = (f"{name} reached {boundary:g}" + (" after turning back at a fold" if folded
                                                              and end_reason == "reached_from" else ""))
            break
        arclen += ds
        pt = make_point(nxt, arclen, ds)
        why = rejection(pt)
        if why is not None:
            end_reason = why.split(":")[0]
            end_message = f"point at {name} = {pt.parameter:.8g} not accepted: {why}"
            if why == "free_parameter_bound":
                end_message += f" (free values {pt.free_values}, bounds {sysm.lo.tolist()}..{sysm.hi.tolist()})"
            break
        pts.append(pt)
        keep(pt)
        say(f"{name} = {pt.parameter:.6g}: {nxt.iterations} it, ds {ds:.3g}, |L|max {max(pt.moduli):.4f}"
            + (f", free {pt.free_values}" if nf else ""))
        cur = nxt
        steps.converged(nxt.iterations)
    run_settings["evaluations"] = sysm.evaluations
    run_settings["residual_evaluations"] = sysm.residual_evaluations
    run_settings["corrector_failures"] = steps.failures
    run_settings["refused_steps"] = steps.refusals
    return Branch(name, pts, specials, end_reason, end_message, run_settings, time.perf_counter() - t_all,
                  free_names)
