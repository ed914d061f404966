"""The continuation of periodic orbits as an iterator (cf. BifurcationKit's ``ContIterable``).

:class:`OrbitBranchIterator` follows a branch one point at a time and yields a
:class:`~birdocp.engine.continuation.step.ContinuationStep` for every accepted point (with the special
points located since the previous one); :func:`birdocp.engine.continuation.continuation` is the
collector over it that returns the whole :class:`~birdocp.engine.continuation.branch.Branch`. The
algorithm (predictor, corrector, step control, special points, end conditions) is described in
:mod:`birdocp.engine.continuation`.
"""
from __future__ import annotations

import time
from dataclasses import fields
from typing import Callable, Iterator

import numpy as np

from birdocp.engine.continuation.accuracy import PointError
from birdocp.engine.continuation.branch import Branch, BranchPoint
from birdocp.engine.continuation.corrector import Corrector
from birdocp.engine.continuation.events import BranchEvents, event_crossings, locate, locate_event, sign_changes
from birdocp.engine.continuation.options import ContinuationOptions
from birdocp.engine.continuation.step import ContinuationStep, RunOnce
from birdocp.engine.continuation.steps import StepController
from birdocp.engine.continuation.system import Continuation, ContinuationState
from birdocp.engine.floquet import complex_pairs, multipliers_info
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_front import solve
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.shooting import initial_points

__all__ = ["OrbitBranchIterator", "resolve_options"]


def resolve_options(options: ContinuationOptions | None, settings: dict) -> ContinuationOptions:
    """``options`` (default :class:`ContinuationOptions`) with the keyword ``settings`` named like its
    fields replacing them; a TypeError names unknown settings.

    Parameters
    ----------
    options : ContinuationOptions or None
        Base options.
    settings : dict
        Field name to value.

    Returns
    -------
    ContinuationOptions
    """
    opts = options or ContinuationOptions()
    unknown = set(settings) - {f.name for f in fields(ContinuationOptions)}
    if unknown:
        raise TypeError(f"unknown continuation setting(s): {sorted(unknown)}")
    return ContinuationOptions(**{**opts.__dict__, **settings}) if settings else opts


class OrbitBranchIterator(RunOnce):
    """A branch of periodic orbits, followed as it is iterated.

    Iterating it (once) runs the continuation and yields a :class:`ContinuationStep` per accepted
    point, and a last step without a point when special points were located after the last accepted
    one. After (or during) the iteration ``points``, ``special_points``, ``end_reason`` and
    ``end_message`` hold what was found so far, and :meth:`branch` returns it as a :class:`Branch`
    (also after an interruption: the points accepted until then). The arguments are those of
    :func:`birdocp.engine.continuation.continuation` (without its callbacks).
    """

    def __init__(self, problem: OrbitProblem, param, start_value: float, stop_value: float, *,
                 options: ContinuationOptions | None = None, start=None, accept: Callable | None = None,
                 progress: Callable | None = None, system: Continuation | None = None,
                 orient: float | None = None, events: BranchEvents | None = None, **settings):
        self.opts = opts = resolve_options(options, settings)
        self.t_all = time.perf_counter()
        self.problem, self.start, self.accept, self.orient, self.events = problem, start, accept, orient, events
        self.say = progress or (lambda text: None)
        self.sysm = sysm = system or Continuation(problem, param, opts.points, opts.steps_per_period)
        if not (np.isfinite(start_value) and np.isfinite(stop_value)):
            raise ValueError(f"start_value and stop_value must be finite, got {start_value!r}, {stop_value!r}")
        self.span = span = abs(stop_value - start_value)
        if not span > 0:
            raise ValueError("start_value and stop_value must differ")
        self.start_value, self.stop_value = start_value, stop_value
        self.direction = 1.0 if stop_value > start_value else -1.0
        self.rlo, self.rhi = min(start_value, stop_value), max(start_value, stop_value)
        self.nX, self.nf = sysm.nx * (sysm.S + 1), len(sysm.free_idx)
        sc = dict(opts.scales or {})
        s_states = np.broadcast_to(np.asarray(sc.get("states", 1.0), float), (sysm.nx,))
        s_free = np.broadcast_to(np.asarray(sc.get("free", 1.0), float), (self.nf,))
        self.s_lam = float(sc.get("parameter", span))
        self.s = np.concatenate([np.tile(s_states, sysm.S + 1), s_free, [self.s_lam]])
        self.li = sysm.nz - 1   # index of lam in z
        self.corr = Corrector(sysm, self.s, opts.tol, opts.max_newton, opts.chord_contraction)
        self.name, self.free_names = sysm.name, sysm.free_names
        self.points: list = []
        self.special_points: list = []
        self.end_reason = "incomplete"
        self.end_message = "the iteration was left before the branch ended"
        self.settings: dict = {}
        self.steps: StepController | None = None
        self._started = False
        self._errors: PointError | None = None   # built at the first point with error_estimate

    # --- the points -----------------------------------------------------------------------------
    def make_point(self, st: ContinuationState, arclen: float, ds_used: float) -> BranchPoint:
        """The :class:`BranchPoint` of a corrected state.

        Parameters
        ----------
        st : ContinuationState
            Corrected state.
        arclen : float
            Arclength at the point.
        ds_used : float
            Step that reached it.

        Returns
        -------
        BranchPoint
        """
        sysm, li = self.sysm, self.li
        z = self.s * st.u
        lam_m, _, _, _, stable = multipliers_info(st.Mon, sysm.period_of(z))
        p = sysm.p_of(z)
        X = sysm.X_of(z)
        return BranchPoint(
            parameter=float(z[li]), x0=X[:, 0].tolist(), shooting_points=X.T.tolist(),
            free_values={n: float(p[i]) for n, i in zip(self.free_names, sysm.free_idx)},
            multipliers=complex_pairs(lam_m), moduli=[float(abs(v)) for v in lam_m], stable=bool(stable),
            means={n: float(v) for n, v in zip(sysm.mean_names, st.means)}, arclength=float(arclen),
            tangent_parameter=float(st.t[li]), iterations=int(st.iterations),
            max_residual=float(np.max(np.abs(st.g))) if st.g.size else 0.0, step=float(ds_used),
            tests=dict(st.tests), p=p.tolist(), period=sysm.period_of(z))

    def rejection(self, pt: BranchPoint) -> str | None:
        """Why ``pt`` is not accepted (a free parameter out of its bounds, ``accept``), or None.

        Parameters
        ----------
        pt : BranchPoint
            Point.

        Returns
        -------
        str or None
        """
        sysm = self.sysm
        if self.nf:
            fv = np.array([pt.p[i] for i in sysm.free_idx])
            if np.any(fv < sysm.lo) or np.any(fv > sysm.hi):
                return "free_parameter_bound"
        if self.accept is not None:
            msg = self.accept(pt)
            if msg:
                return "rejected: " + msg
        return None

    def _emit(self, pt: BranchPoint | None, found: list, st: ContinuationState | None = None) -> ContinuationStep:
        """Record the special points ``found`` and the accepted point ``pt`` (of the corrected state
        ``st``: its error estimate with ``error_estimate``); the step to yield."""
        self.special_points.extend(found)
        if pt is not None:
            if self.opts.error_estimate and st is not None:
                if self._errors is None:
                    self._errors = PointError(self.sysm, self.s, self.opts.tol, self.opts.max_newton)
                pt.error_estimate = self._errors.point_error(st)
            self.points.append(pt)
        return ContinuationStep(len(self.points) - 1 if pt is not None else None, pt, list(found))

    # --- the first point --------------------------------------------------------------------------
    def _first_state(self) -> ContinuationState | None:
        """Newton at fixed lam from the given cycle, or from the problem's guess integrated forward; if
        that fails, the engine (IPOPT). None when no start is found."""
        sysm, s, problem, start, opts = self.sysm, self.s, self.problem, self.start, self.opts
        p_start = np.asarray(start.p if start is not None else problem.p, float).copy()
        p_start[sysm.j] = self.start_value
        if start is not None:
            z0 = sysm.z_of(start.shooting_points, p_start)
        else:
            D0 = sysm.grid.blocks_numeric(float(problem.t0), p_start)
            z0 = sysm.z_of(initial_points(sysm.builder, problem.x_guess, D0, p_start).T, p_start)
        e_l = np.zeros(sysm.nz)
        e_l[self.li] = 1.0
        out = self.corr.newton(z0 / s, e_l, self.start_value / self.s_lam)
        if out is None and start is None:
            prob0 = OrbitProblem(problem.ode, p_start, problem.x_guess, t0=problem.t0, free=problem.free,
                                 means=problem.means, outputs=problem.outputs)
            eng = solve(prob0, OrbitMethod(points=opts.points, steps_per_period=opts.steps_per_period))
            if eng.success:
                out = self.corr.newton(sysm.z_of(eng.shooting_points, p_start) / s, e_l, self.start_value / self.s_lam)
        if out is None:
            return None
        cur = self.corr.state(out, None)
        if cur.t[self.li] * (self.direction if self.orient is None else np.sign(self.orient) or self.direction) < 0:
            cur.t = -cur.t
            cur.tests = dict(cur.tests, fold=float(cur.t[self.li]))
        return cur

    def _setup_steps(self, cur: ContinuationState) -> None:
        """The step controller and the run's settings (``Branch.settings``)."""
        opts, s, li = self.opts, self.s, self.li
        dlam0 = float(opts.step) if opts.step else self.span / 10.0
        ds0 = abs(dlam0 / self.s_lam) / max(abs(cur.t[li]), 1e-3)
        self.steps = StepController(ds0, opts.ds_min or ds0 / 256, opts.ds_max or 4 * ds0, s, li, self.nX,
                                    opts.max_dparam, opts.max_dstate)
        self.settings = {"parameter": self.name, "from": self.start_value, "to": self.stop_value,
                         "points": opts.points, "steps_per_period": opts.steps_per_period, "first_step": dlam0,
                         "ds_first": ds0, "ds_min": self.steps.ds_min, "ds_max": self.steps.ds_max,
                         "scales": s.tolist(), "tol": opts.tol, "max_points": opts.max_points,
                         "free": self.free_names, "mean_conditions": self.sysm.mean_names[:self.sysm.nm],
                         "max_dparam": opts.max_dparam, "max_dstate": opts.max_dstate}
        if opts.error_estimate:  # the key only when asked for (branch files written without it stay as they were)
            self.settings["error_estimate"] = True

    # --- the iteration ----------------------------------------------------------------------------
    def _run(self) -> Iterator[ContinuationStep]:
        cur = self._first_state()
        if cur is None:
            self.end_reason = "start_failed"
            self.end_message = "Newton did not converge at the start value from the given cycle"
            return
        self._setup_steps(cur)
        pt0 = self.make_point(cur, 0.0, 0.0)
        cur_ev = self.events.values(pt0) if self.events is not None else {}
        yield self._emit(pt0, [], cur)
        self.say(f"{self.name} = {pt0.parameter:.6g}: start, |L|max {max(pt0.moduli):.4f}")
        below = [k for k, v in cur_ev.items() if v < 0]
        if self.events is not None and self.events.stop and below:
            self.end_reason = "stopped_at_event"
            self.end_message = (f"{self.events.kind} at the start ({self.name} = {pt0.parameter:.8g}): "
                                f"{', '.join(below)} < 0")
            return
        arclen = 0.0
        while len(self.points) < self.opts.max_points:
            nxt, ds = self._advance(cur)
            if nxt is None:
                return
            step = self._check(cur, nxt, ds, cur_ev, arclen)
            if step is not None:
                yield step
                return
            arclen += ds
            pt, nxt_ev, found = self._pending
            why = self.rejection(pt)
            if why is not None:
                self._end_rejected(pt, why)
                if found:
                    yield self._emit(None, found)
                return
            yield self._emit(pt, found, nxt)
            self.say(f"{self.name} = {pt.parameter:.6g}: {nxt.iterations} it, ds {ds:.3g}, |L|max "
                     f"{max(pt.moduli):.4f}" + (f", free {pt.free_values}" if self.nf else ""))
            cur, cur_ev = nxt, nxt_ev
            self.steps.converged(nxt.iterations)
        self.end_reason, self.end_message = "max_points", f"max_points={self.opts.max_points} reached"

    def _advance(self, cur: ContinuationState) -> tuple:
        """The next corrected state and its step ``(nxt, ds)``, retrying with shorter steps; ``(None,
        ds)`` (and ``end_reason`` ``corrector_failed``) when the corrector fails at the minimum step."""
        steps = self.steps
        while True:
            ds = steps.capped(cur)
            nxt = self.corr.along(cur, ds)
            if nxt is None:
                if not steps.failed():
                    self.end_reason = "corrector_failed"
                    self.end_message = (f"the corrector failed at the minimum step ds={ds:.3g} after {self.name} = "
                                        f"{self.points[-1].parameter:.8g}: no nearby continuation of the branch")
                    return None, ds
                continue
            if steps.refuse(cur, nxt):
                continue
            return nxt, ds

    def _locate_specials(self, cur, nxt, ds, arclen) -> list:
        """The special points (fold, branch point, ...) located between ``cur`` and ``nxt`` within the
        parameter interval."""
        found = []
        for kind in sign_changes(cur, nxt, self.opts.detect):
            sp = locate(kind, self.corr, cur, nxt, ds, len(self.points) - 1, arclen, self.make_point, self.name,
                        self.opts.locate_tol)
            if sp is not None and self.rlo - 1e-12 <= sp.parameter <= self.rhi + 1e-12:
                found.append(sp)
                self.say(f"  {kind} at {self.name} = {sp.parameter:.9g} ({sp.message})")
        return found

    def _locate_events(self, cur, ds, cur_ev, nxt_ev, arclen, found) -> tuple | None:
        """Locate the user test functions' crossings (appended to ``found``); the first located
        stopping crossing ``(special point, point, state)``, or None."""
        events, stop_at = self.events, None
        ev_tol = (events.tol or self.opts.locate_tol) if events is not None else None
        for ev_name in event_crossings(cur_ev, nxt_ev):
            hit = locate_event(events, ev_name, self.corr, cur, ds, cur_ev[ev_name], nxt_ev[ev_name],
                               len(self.points) - 1, arclen, self.make_point, ev_tol)
            if hit is not None and self.rlo - 1e-12 <= hit[0].parameter <= self.rhi + 1e-12:
                found.append(hit[0])
                self.say(f"  {hit[0].kind} at {self.name} = {hit[0].parameter:.9g} ({hit[0].message})")
                if events.stop and hit[0].direction < 0 and (stop_at is None
                                                             or hit[0].arclength < stop_at[0].arclength):
                    stop_at = hit
        return stop_at

    def _check(self, cur, nxt, ds, cur_ev, arclen) -> ContinuationStep | None:
        """Special points and events between ``cur`` and ``nxt``; the last step of the branch when it
        ends here (a stopping event, the parameter interval's end), else None (the point, its events
        and the special points are left in ``_pending``)."""
        lam_new = self.s_lam * nxt.u[self.li]
        boundary = None
        if lam_new > self.rhi or lam_new < self.rlo:
            boundary = self.rhi if lam_new > self.rhi else self.rlo
        found = self._locate_specials(cur, nxt, ds, arclen)
        pt = self.make_point(nxt, arclen + ds, ds)
        nxt_ev = self.events.values(pt) if self.events is not None else {}
        stop_at = self._locate_events(cur, ds, cur_ev, nxt_ev, arclen, found)
        if stop_at is not None:
            found = sorted((q for q in found if q.arclength <= stop_at[0].arclength), key=lambda q: q.arclength)
            self.end_reason = "stopped_at_event"
            self.end_message = (f"stopped at the {stop_at[0].kind} at {self.name} = {stop_at[0].parameter:.8g}: "
                                f"{stop_at[0].message}")
            return self._emit(stop_at[1], found, stop_at[2])
        found.sort(key=lambda q: q.arclength)
        if boundary is not None:
            return self._at_boundary(cur, nxt, ds, arclen, boundary, found)
        self._pending = (pt, nxt_ev, found)
        return None

    def _at_boundary(self, cur, nxt, ds, arclen, boundary, found) -> ContinuationStep:
        """The last point, re-solved exactly on the interval's end ``boundary``, and the end reason."""
        last = self.corr.at_parameter(cur, nxt, boundary, self.s_lam)
        pt = None
        if last is not None:
            arclen += float(np.linalg.norm(last.u - cur.u))
            pt = self.make_point(last, arclen, ds)
            if self.events is not None:
                self.events.values(pt)
            if self.rejection(pt) is not None:
                pt = None
        folded = any(q.kind == "fold" for q in self.special_points + found)
        self.end_reason = "reached_to" if boundary == (self.rhi if self.direction > 0 else self.rlo) else "reached_from"
        self.end_message = (f"{self.name} reached {boundary:g}" + (" after turning back at a fold" if folded
                                                                   and self.end_reason == "reached_from" else ""))
        return self._emit(pt, found, last)

    def _end_rejected(self, pt: BranchPoint, why: str) -> None:
        self.end_reason = why.split(":")[0]
        self.end_message = f"point at {self.name} = {pt.parameter:.8g} not accepted: {why}"
        if why == "free_parameter_bound":
            self.end_message += (f" (free values {pt.free_values}, bounds {self.sysm.lo.tolist()}.."
                                 f"{self.sysm.hi.tolist()})")

    # --- the result -------------------------------------------------------------------------------
    def branch(self) -> Branch:
        """The branch followed so far (all of it after the iteration ended).

        Returns
        -------
        Branch
        """
        settings = dict(self.settings)
        if self.steps is not None:
            settings.update(evaluations=self.sysm.evaluations, residual_evaluations=self.sysm.residual_evaluations,
                            corrector_failures=self.steps.failures, refused_steps=self.steps.refusals)
            return Branch(self.name, list(self.points), list(self.special_points), self.end_reason, self.end_message,
                          settings, time.perf_counter() - self.t_all, self.free_names)
        return Branch(self.name, list(self.points), list(self.special_points), self.end_reason, self.end_message,
                      {}, time.perf_counter() - self.t_all)
