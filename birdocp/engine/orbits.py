"""The ODE formulation of :func:`birdocp.engine.orbit_front.solve`: periodic orbits of any
:class:`~birdocp.engine.ode.ODE` by multiple shooting, autonomous (unknown period) or forced.

Formulation
-----------
Time is scaled to ``tau = (t - t0) / T`` in [0, 1], so the period T is an ordinary unknown:
``dx/dtau = T f(x, t0 + T tau, p)``. M shooting points X_0 .. X_{M-1} (M counts the closing point;
M-1 segments of N/(M-1) steps of size 1/N in tau) and, for an autonomous system, T are the unknowns of

* continuity   Phi(X_i; T, p) - X_{i+1} = 0,  i = 0 .. M-2
* periodicity  X_{M-1} - X_0 = 0
* phase        (X_0 - x_a) . f(x_a, p) = 0                   (autonomous only)
* extra linear rows ``a . z = b`` (e.g. the amplitude condition of a Hopf start)

**Phase condition: a Poincare section re-anchored at the current iterate** (``OrbitMethod.phase =
"moving"``, the default). Before every Newton step the anchor x_a is the iterate's own X_0: the phase
row reads 0 there and its linearisation asks the step of X_0 to be orthogonal to the flow. That
equation always has a solution (a fixed section through the user's guess point may never meet the
orbit, and then no solution exists at all), it removes exactly the phase shift that makes the
shooting matrix singular, and it needs no reference orbit (the integral phase condition of AUTO
does). With ``phase="fixed"`` (or an explicit ``phase_point``) one section holds for the whole solve:
continuation uses it with the previous orbit's x0.

**Globalisation.** Levenberg-Marquardt (:mod:`birdocp.engine.lm`) keeps a step only if it lowers the
residual; far from the orbit its steps are short and gradient-like, near it they are Newton steps.
From a single guess point the start period is improved first: among the trajectory's crossings of the
section through the guess point between 1/1.6 and 1.6 times the period guess, the closest return
replaces the guess when it closes better (``period_search``) -- a 30 % period error then costs
nothing. A failure is declared early and says why: LM stops when its residual falls by less than
10x in 30 iterations; with ``steps_per_period=None`` a failed solve is retried on at most
``max_refinements_after_failure`` finer grids; ``time_limit_s`` bounds the wall time.

**Minimal period.** A guess near k times the period converges to the k-fold cover of the orbit. The
converged orbit is tested for ``x(t + T/k) = x(t)`` (:func:`birdocp.engine.orbit_checks.cover_multiple`)
and reduced to the minimal period (``covers = k``, ``reduced_from_period``, said in the message), or,
if the reduced solve fails, reported with status ``"multiple_cover"`` and ``success=False``.

Derivatives are exact: each segment's Jacobians with respect to its start point and to
``q = (p, T, t0)`` are the discrete variational equation stepped with the states
(:func:`birdocp.engine.steppers.make_variational_step`: RK4 by forward AD, the implicit integrators'
stages by the implicit function theorem), the same evaluation giving the trajectory; the shooting
matrix is assembled around them in numpy. IPOPT sees the constraints through
:class:`~birdocp.engine.oracle.ConstraintOracle`. The steps are built once per ODE and integrator
and shared by every grid; a grid started from the converged orbit of a coarser one (the refinement)
starts Levenberg-Marquardt undamped, a Newton step from a point O(h^p) away.

Success means ``max_residual <= tol`` (all equations, absolute), whatever the solver's status, plus
a non-degenerate orbit: an equilibrium satisfies every equation for any T (a constant trajectory),
so a result whose amplitude ``max_t |x(t) - x0|`` is below ``min_amplitude (1 + |x0|)`` has status
``"equilibrium"`` and ``success=False``.

Accuracy: by default every successful result is re-solved with twice the steps from its own
solution (on the section through its x0, at least one Newton step) and the differences, scaled
Richardson-style by ``2^p / (2^p - 1)`` (p = order of the integrator), plus the solver-tolerance
error ``|g| / sigma_min(J)``, are the error estimates of the period, x0 and the multipliers
(``error_estimate``; :func:`birdocp.engine.orbit_checks.attach_error`). ``accurate`` is False (and
the message says so) when a relative estimate exceeds ``OrbitMethod.accuracy``.
``steps_per_period=None`` refines the grid until the estimate is below ``accuracy`` (doubling, or at
once to the steps the estimate predicts, error ~ N^-p with a 1.3x margin, at most 4x).
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from birdocp.engine.floquet import monodromy_of, sort_multipliers
from birdocp.engine.lm import levenberg_marquardt
from birdocp.engine.nlp import run_ipopt
from birdocp.engine.orbit_checks import attach_error, cover_multiple, failure_reason, solver_error
from birdocp.engine.orbit_system import (OrbitGraphs, OrbitSystem, first_return_period, forward_points,
                                         initial_points, orbit_graphs, orbit_residual_system, orbit_system)
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.steppers import METHOD_ORDER

__all__ = ["solve_ode", "solve_orbit_system", "orbit_residual_system"]


def solve_ode(problem: OrbitProblem, method: OrbitMethod, warm_start: OrbitResult | None = None) -> OrbitResult:
    """The ODE formulation of :func:`birdocp.engine.orbit_front.solve` (use that front).

    Parameters
    ----------
    problem : OrbitProblem
        A problem of an :class:`~birdocp.engine.ode.ODE`: parameters, a guess point (or shooting
        points) and a period guess.
    method : OrbitMethod
        Grid, integrator, solver, tolerances (``None`` settings resolved for an ODE). With
        ``steps_per_period=None`` the steps are doubled from ``min_steps`` until the error estimate
        is below ``accuracy`` (a failed solve is retried on at most
        ``max_refinements_after_failure`` finer grids).
    warm_start : OrbitResult, optional
        A previous orbit (its period and shooting points are the start).

    Returns
    -------
    OrbitResult
        ``formulation="time_scaled"``; ``success`` means the residual is below ``method.tol``, the orbit is
        not an equilibrium and its period is minimal (or was reduced to it).
    """
    method = method.resolved(False)
    deadline = None if method.time_limit_s is None else time.perf_counter() + method.time_limit_s
    if method.steps_per_period is None:
        return _solve_refining(problem, method, warm_start, deadline)
    return solve_orbit_system(problem, method, warm_start, deadline=deadline)


def _solve_refining(problem, method, warm_start, deadline):
    """Double the steps from ``min_steps`` until the error estimate is below ``accuracy``."""
    S = method.points - 1
    N = S * max(1, int(np.ceil(method.min_steps / S)))
    good, failures = None, 0
    t_start = time.perf_counter()
    while True:
        m = replace(method, steps_per_period=N, error_estimate=True)
        res = solve_orbit_system(problem, m, good if good is not None else warm_start, deadline=deadline)
        res.wall_s["all_grids"] = time.perf_counter() - t_start
        if good is not None and good.covers > 1 and res.covers == 1:  # the reduction made on a coarser grid
            res.covers, res.reduced_from_period = good.covers, good.reduced_from_period
            res.message = good.message.split("; ")[0] + "; " + res.message
        if res.success and res.accurate:
            return res
        if res.success and res.error_estimate.get("relative_solver", 0.0) > method.accuracy:
            res.message += "; the solver tolerance limits the accuracy (lower OrbitMethod.tol): not refined further"
            return res
        if res.success:
            good = res
        elif good is not None:  # a finer grid failed where a coarser one converged: keep the latter
            good.message += f"; accuracy not reached: the solve on {N} steps failed ({res.status})"
            good.wall_s["all_grids"] = res.wall_s["all_grids"]
            return good
        else:
            failures += 1
        if deadline is not None and time.perf_counter() > deadline:
            res.message += f"; time limit {method.time_limit_s:g} s reached"
            return res
        if 2 * N > method.max_steps_per_period:
            if res.success:
                res.message += f"; accuracy not reached with max_steps_per_period={method.max_steps_per_period}"
            return res
        if failures > method.max_refinements_after_failure:
            res.message += f"; not retried on finer grids ({failures} grids up to {N} steps failed)"
            return res
        N = _next_steps(N, S, res, method)


def _next_steps(N: int, S: int, res, method) -> int:
    """The next grid: twice the steps, or at once the steps the error estimate predicts for the
    accuracy (error ~ N^-p, 1.3 x margin) up to four times the steps (an estimate dominated by
    ill-conditioned multipliers, e.g. the torus example's pair on the unit circle, does not fall as
    N^-p), a multiple of S, at most max_steps_per_period."""
    rel = res.error_estimate.get("relative", float("nan")) if res.success else float("nan")
    if not (np.isfinite(rel) and rel > method.accuracy):
        return 2 * N
    p = METHOD_ORDER[method.integrator]
    want = 1.3 * N * (rel / method.accuracy) ** (1.0 / p)
    n = min(max(2 * N, S * int(np.ceil(want / S))), 4 * N)
    return min(n, S * (method.max_steps_per_period // S))


def solve_orbit_system(problem: OrbitProblem, method: OrbitMethod, warm_start=None, *, free_idx=(), lin=None,
                       z_start=None, x_ref=None, estimate=True, deadline=None) -> OrbitResult:
    """:func:`solve_ode` at a fixed number of steps, with extra unknowns and rows (Hopf starts,
    continuation).

    Parameters
    ----------
    problem, method, warm_start
        As :func:`solve_ode` (``method.steps_per_period`` a number).
    free_idx : tuple of int
        Parameters that become unknowns (after T).
    lin : (A, b), optional
        Rows ``A z - b`` appended after the phase row.
    z_start : array, optional
        The full initial unknown vector.
    x_ref : array, optional
        A fixed Poincare section's point (default: the problem's phase point; else the section
        moves with the iterate when ``method.phase == "moving"``).
    estimate : bool
        Compute the error estimate (if ``method.error_estimate``).
    deadline : float, optional
        ``time.perf_counter()`` value after which the solver stops.

    Returns
    -------
    OrbitResult
    """
    t_all = time.perf_counter()
    method = method.resolved(False)
    setup = _setup(problem, method, warm_start, tuple(free_idx), lin, x_ref)
    if isinstance(setup, OrbitResult):
        return setup
    G, ev, p, T, x_ref, moving = setup
    build_s = time.perf_counter() - t_all
    z0, lo, hi, note = _start(problem, method, warm_start, G, ev, p, T, tuple(free_idx), z_start, moving)
    if moving:
        ev.anchor_phase(z0)
    ts = time.perf_counter()
    lam0 = 1e-8 if _on_another_grid(warm_start, problem, G, z_start, free_idx) else 1.0
    z, sstat, message, iters, hist = _run_solver(ev, z0, method, lo, hi, moving, deadline, lam0)
    solve_s = time.perf_counter() - ts
    x_ref = z[:problem.ode.nx].copy() if moving and np.all(np.isfinite(z)) else x_ref
    res = _assemble(problem, method, ev, G, z, sstat, note + message, iters, hist, x_ref)
    res.wall_s = {"build": build_s, "solve": solve_s}
    if free_idx:
        ode = problem.ode
        res.free_values = {ode.param_names[i] if ode.param_names else f"p{i}": float(res.p[i]) for i in free_idx}
    if not res.success:
        _explain(res, method, ev, z, lo, hi, moving)
    elif problem.ode.autonomous and method.min_period_check and not free_idx and lin is None:
        res = _minimal_period(res, problem, method, G, deadline)
    if res.success and method.error_estimate and estimate and res.covers == 1:
        te = time.perf_counter()
        _estimate_error(res, problem, method, ev, z, lo, hi, tuple(free_idx))
        res.wall_s["error_estimate"] = time.perf_counter() - te
    res.wall_s["total"] = time.perf_counter() - t_all
    return res


def _setup(problem, method, warm_start, free_idx, lin, x_ref):
    """Graphs, system and linear rows of a solve; a failed OrbitResult if the phase point is bad."""
    ode = problem.ode
    nx, S, N = ode.nx, method.points - 1, int(method.steps_per_period)
    auto = ode.autonomous
    G = orbit_graphs(ode, N, S, method.integrator)
    p = problem.p.copy()
    T = float(problem.period_guess)
    if warm_start is not None and np.isfinite(warm_start.period):
        T = float(warm_start.period) if auto else T
        p = np.asarray(warm_start.p, float).copy() if free_idx else p
    if x_ref is None and problem.phase_point is not None:
        x_ref = np.asarray(problem.phase_point, float).ravel()
    moving = auto and x_ref is None and method.phase == "moving"
    if auto and x_ref is None and not moving:
        if warm_start is not None and warm_start.phase_point is not None:
            x_ref = np.asarray(warm_start.phase_point, float)
        else:
            x_ref = problem.x_guess if problem.x_guess.ndim == 1 else problem.x_guess[0]
    n_lin_user = 0 if lin is None else len(lin[1])
    n_lin = n_lin_user + (1 if auto else 0)
    ev = orbit_system(G, auto, free_idx, n_lin)
    A, b = np.zeros((n_lin, ev.nz)), np.zeros(n_lin)
    if auto and not moving:  # fixed phase row: (X_0 - x_ref) . n = 0, n = f(x_ref)/|f(x_ref)|
        fr = ode.evaluate(x_ref, 0.0, p)
        nrm = np.linalg.norm(fr)
        if not np.isfinite(nrm) or nrm == 0:
            return _failed(problem, method, "bad_phase_point", "f is zero or non-finite at the phase point", x_ref, p, T)
        A[0, :nx] = fr / nrm
        b[0] = float(fr @ x_ref) / nrm
    if lin is not None:
        A[n_lin - n_lin_user:] = lin[0]
        b[n_lin - n_lin_user:] = lin[1]
    ev.set_context(p, T, problem.t0, A, b)
    return G, ev, p, T, x_ref, moving


def _start(problem, method, warm_start, G, ev, p, T, free_idx, z_start, moving):
    """The initial unknowns, their bounds and a note for the message (period from the first return)."""
    auto, nx, S = problem.ode.autonomous, problem.ode.nx, G.S
    note = ""
    if z_start is not None:
        z0 = np.asarray(z_start, float).copy()
    else:
        if warm_start is not None and warm_start.shooting_points.shape == (S + 1, nx):
            X0 = warm_start.shooting_points.T.copy()
        elif warm_start is not None:
            X0 = forward_points(G, warm_start.x0, p, T, problem.t0)
        else:
            X0 = initial_points(G, problem.x_guess, p, T, problem.t0)
            if auto and method.period_search and problem.x_guess.ndim == 1:
                X0, T, note = _search_period(G, problem, p, T, X0)
        z0 = np.concatenate([X0.T.ravel(), [T] if auto else [], p[list(free_idx)]])
    lo, hi = np.full(ev.nz, -np.inf), np.full(ev.nz, np.inf)
    if auto:
        lo[ev.nX] = method.period_bounds[0] * problem.period_guess
        hi[ev.nX] = method.period_bounds[1] * problem.period_guess
        z0[ev.nX] = np.clip(z0[ev.nX], lo[ev.nX], hi[ev.nX])
    return z0, lo, hi, note


def _search_period(G, problem, p, T, X0):
    """Replace the period guess by the trajectory's closest return to the guess point's section when
    that closes the orbit better (see the module docstring)."""
    x = problem.x_guess
    d_guess = float(np.linalg.norm(X0[:, -1] - X0[:, 0])) if np.all(np.isfinite(X0)) else float("inf")
    T_ret, d_ret = first_return_period(G, x, p, T, problem.t0)
    if T_ret is None or not d_ret < d_guess:
        return X0, T, ""
    return (forward_points(G, x, p, T_ret, problem.t0), T_ret,
            f"start period {T_ret:.6g} from the closest return (guess {T:.6g}); ")


def _on_another_grid(warm_start, problem, G, z_start, free_idx) -> bool:
    """The start is a converged orbit of the same problem on another grid (the refinement's previous
    grid): it is O(h^p) from the solution, inside Newton's basin, so LM starts undamped."""
    return (z_start is None and not free_idx and isinstance(warm_start, OrbitResult) and warm_start.success
            and warm_start.formulation == "ode" and warm_start.method.get("steps_per_period") != G.N
            and warm_start.method.get("integrator") == G.integrator and np.array_equal(warm_start.p, problem.p))


def _run_solver(ev, z0, method, lo, hi, moving, deadline, lam0=1.0):
    """(z, solver status, message, iterations, history) of the method's solver (:data:`SOLVERS`);
    ``lam0`` the initial damping of LM."""
    return SOLVERS[method.solver](ev, z0, method, lo, hi, moving, deadline, lam0)


def _run_ipopt_then_lm(ev, z0, method, lo, hi, moving, deadline, lam0=1.0):
    """IPOPT, then an LM polish (or LM from the start when IPOPT fails)."""
    prepare = ev.anchor_phase if moving else None
    z, sstat, iters, hist = _run_ipopt(ev, z0, method, lo, hi)
    g = ev.g(z) if np.all(np.isfinite(z)) else np.full(ev.ng, np.nan)
    r = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
    if np.isfinite(r) and method.tol < r < 1e-3:
        # polish: IPOPT stops on scaled criteria; a few exact Newton steps reach the tolerance
        out = levenberg_marquardt(ev, z, tol=method.tol, max_iter=5, lo=lo, hi=hi, prepare=prepare,
                                  deadline=deadline)
        z, iters, hist, r = out.z, iters + out.iterations, hist + out.history[1:], out.history[-1]
    if np.isfinite(r) and r <= method.tol:
        return z, sstat, f"IPOPT: {sstat}", iters, hist
    if moving:
        ev.anchor_phase(z0)
    z, status, message, its, hist_lm = _run_lm(ev, z0, method, lo, hi, moving, deadline, lam0)
    return (z, status, f"IPOPT: {sstat} (max|g| {r:.1e}); retried with LM: " + message, iters + its,
            hist + hist_lm)


def _run_lm(ev, z0, method, lo, hi, moving, deadline, lam0=1.0):
    """The engine's Levenberg-Marquardt (steps that do not lower the residual rejected), then a
    Newton polish."""
    prepare = ev.anchor_phase if moving else None
    out = levenberg_marquardt(ev, z0, tol=method.tol, max_iter=method.max_iter, lo=lo, hi=hi, prepare=prepare,
                              deadline=deadline, residual=ev.residual, lam0=lam0)
    z, hist = out.z, list(out.history)
    if out.status == "converged":
        z, hist = _polish(ev, z, hist, prepare)
    return z, out.status, out.message, out.iterations, hist


SOLVERS = {"ipopt": _run_ipopt_then_lm, "lm": _run_lm}
"""The solver table of the ODE formulation: name -> run(system, z0, method, lo, hi, moving, deadline)."""


def _polish(ev, z, hist, prepare, steps: int = 3):
    """Up to ``steps`` full Newton steps past the tolerance while each halves |g|_2: the solver error
    (part of the error estimate) then falls to round-off for the price of a few evaluations (a
    trial step costs a residual, the Jacobian is evaluated at accepted points only; no step once
    max|g| is at round-off, ``4 eps (1 + max|z|)``)."""
    g, J = ev.evaluate(z)
    for _ in range(steps):
        if np.max(np.abs(g)) <= 4 * np.finfo(float).eps * (1.0 + np.max(np.abs(z))):
            break
        zn = z - np.linalg.lstsq(J, g, rcond=None)[0]
        if prepare is not None:
            prepare(zn)
        gn = ev.residual(zn)
        if not (np.all(np.isfinite(gn)) and np.linalg.norm(gn) < 0.5 * np.linalg.norm(g)):
            if prepare is not None:
                prepare(z)
            break
        z = zn
        g, J = ev.evaluate(z)
        hist.append(float(np.max(np.abs(g))))
    return z, hist


def _run_ipopt(ev: OrbitSystem, z0, method, lo, hi):
    """(z, status, iterations, history) of IPOPT through the engine's one front."""
    out = run_ipopt(ev.ipopt(method), z0, lbx=lo, ubx=hi)
    return out.z, out.status, out.iterations, list(out.history)


def _explain(res, method, ev, z, lo, hi, moving):
    """Append to a failure's message why it failed, when that is known."""
    if res.status not in ("not_converged", "nan") or not np.all(np.isfinite(z)):
        return
    A = ev.context[3] if ev.n_lin else None
    normal = None if (moving or A is None or not res.autonomous) else A[0, :ev.nx]
    traj = res.trajectory_x if np.all(np.isfinite(res.trajectory_x)) else None
    X = ev.points(z)
    amp0 = float(np.max(np.abs(X - X[:, :1])))
    k = ev.nX
    why = failure_reason(traj, res.phase_point, normal, res.period if res.autonomous else float("nan"),
                         lo[k] if res.autonomous else 0.0, hi[k] if res.autonomous else np.inf, max(amp0, res.amplitude))
    if why:
        res.message += f"; why: {why}"


def _minimal_period(res, problem, method, G, deadline):
    """Reduce a k-fold cover to the minimal period (or report it); see the module docstring."""
    if not np.all(np.isfinite(res.trajectory_x)):
        return res
    F = np.asarray(G.ode.rhs.map(res.trajectory_x.shape[0])(res.trajectory_x.T, 0.0, res.p)).T
    k, mis = cover_multiple(res.trajectory_x, F, res.period)
    if k == 1:
        return res
    S = method.points - 1
    N = S * max(2, int(round(G.N / (k * S))))
    sub = OrbitProblem(problem.ode, res.p, res.x0, period_guess=res.period / k, t0=problem.t0)
    m = replace(method, steps_per_period=N, period_search=False, min_period_check=False)
    red = solve_orbit_system(sub, m, deadline=deadline)
    if red.success and abs(k * red.period - res.period) <= 1e-6 * res.period + 1e3 * method.tol:
        red.covers, red.reduced_from_period = k, float(res.period)
        red.message = (f"the solve converged on {k} loops of the orbit (period {res.period:.10g}) and was reduced to "
                       f"the minimal period (covers = {k}); " + red.message)
        red.iterations += res.iterations
        red.residual_history = np.concatenate([res.residual_history, red.residual_history])
        return red
    res.success, res.status, res.covers = False, "multiple_cover", k
    res.message += (f"; the orbit is {k} loops of a shorter one (x(t + T/{k}) = x(t) to {mis:.1e} of its amplitude) "
                    f"and the solve at the period T/{k} failed ({red.status})")
    return res


def _estimate_error(res, problem, method, ev, z, lo, hi, free_idx):
    """The error estimate (Richardson from 2N steps + solver error) of a converged orbit."""
    ode, S, N = problem.ode, method.points - 1, int(method.steps_per_period)
    e_solver = solver_error(*reversed(ev.evaluate(z)))
    fine_m = replace(method, steps_per_period=2 * N, solver="lm", max_iter=20)
    Gf = orbit_graphs(ode, 2 * N, S, method.integrator)
    evf = orbit_system(Gf, ode.autonomous, free_idx, ev.n_lin)
    p, T, _, A, b = ev.context
    evf.set_context(p, T, problem.t0, A, b)  # the section through x0
    # the start is the coarse solution, O(h^p) away: undamped from the first step (lam0 1e-8), then Newton
    # steps while they halve the residual -- a damped step that merely gets inside the tolerance would
    # leave the fine orbit part of the way and understate the difference (measured: 200x on Goodwin)
    out = levenberg_marquardt(evf, z, tol=method.tol, max_iter=20, lo=lo, hi=hi, residual=evf.residual, lam0=1e-8)
    zf, its = out.z, out.iterations
    zf, hist_f = _polish(evf, zf, list(out.history), None)
    fine = _assemble(problem, fine_m, evf, Gf, zf, out.status, out.message, its, hist_f, res.phase_point)
    attach_error(res, fine, METHOD_ORDER[method.integrator], method.accuracy, e_solver)


def _failed(problem, method, status, message, x_ref, p, T):
    nx = problem.ode.nx
    nan = np.full(nx, np.nan)
    return OrbitResult(success=False, status=status, message=message, solver_status=status, iterations=0,
                       residual_history=np.zeros(0), max_residual=float("nan"), period=float(T), x0=nan, p=p,
                       shooting_points=np.full((method.points, nx), np.nan), trajectory_t=np.zeros(0),
                       trajectory_x=np.zeros((0, nx)), autonomous=problem.ode.autonomous, error_estimate={},
                       phase_point=np.asarray(x_ref, float), formulation="time_scaled")


def _assemble(problem, method, ev: OrbitSystem, G: OrbitGraphs, z, sstat, message, iters, hist, x_ref) -> OrbitResult:
    """The OrbitResult at the solver's last iterate z: status from the residual, trajectory, multipliers."""
    ode = problem.ode
    nx = ode.nx
    z = np.asarray(z, float).ravel()
    finite = np.all(np.isfinite(z))
    q = ev.q_of(z) if finite else np.full(G.nq, np.nan)
    p, T = q[:ode.np], float(q[ode.np])
    X = ev.points(z)
    g = ev.g(z) if finite else np.full(ev.ng, np.nan)
    r = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
    traj = ev.trajectory(z) if finite and np.all(np.isfinite(g)) else None
    if traj is None:
        traj = np.full((G.N + 1, nx), np.nan)
    tt = problem.t0 + T * np.arange(G.N + 1) / G.N
    amp = float(np.max(np.abs(traj - traj[0]))) if np.all(np.isfinite(traj)) else float("nan")
    arc = float(np.sum(np.linalg.norm(np.diff(traj, axis=0), axis=1))) if np.all(np.isfinite(traj)) else float("nan")
    scale = 1.0 + float(np.max(np.abs(X[:, 0]))) if finite else 1.0
    if not (np.isfinite(r) and finite):
        status, success = "nan", False
    elif r > method.tol:
        status, success = "not_converged", False
        message += f"; max residual {r:.2e} > tol {method.tol:.1e}"
    elif ode.autonomous and not (amp > method.min_amplitude * scale):
        status, success = "equilibrium", False
        message += (f"; the solution is an equilibrium (amplitude {amp:.1e} <= {method.min_amplitude:.0e}"
                    f" x (1 + |x0|)), not a periodic orbit")
    elif ode.autonomous and not T > 0:
        status, success = "bad_period", False
    else:
        status, success = "converged", True
    res = OrbitResult(success=success, status=status, message=message, solver_status=str(sstat),
                      iterations=int(iters), residual_history=np.asarray(hist, float), max_residual=r, period=T,
                      x0=X[:, 0].copy(), p=p, shooting_points=X.T.copy(), trajectory_t=tt, trajectory_x=traj,
                      amplitude=amp, arc_length=arc, autonomous=ode.autonomous, error_estimate={}, formulation="time_scaled",
                      shooting_times=problem.t0 + T * np.arange(G.S + 1) / G.S,
                      method={"points": method.points, "steps_per_period": G.N, "integrator": method.integrator,
                              "solver": method.solver, "tol": method.tol, "accuracy": method.accuracy},
                      phase_point=np.asarray(x_ref, float).copy())
    if finite and np.all(np.isfinite(g)):
        try:
            Mo = monodromy_of(ev.blocks(z))
            lam = np.linalg.eigvals(Mo).astype(complex)
            lam = sort_multipliers(lam)
            res.monodromy, res.multipliers = Mo, lam
            if ode.autonomous:
                k = int(np.argmin(np.abs(lam - 1.0)))
                res.trivial_multiplier = complex(lam[k])
                res.trivial_multiplier_error = float(abs(lam[k] - 1.0))
                res.nontrivial_multipliers = np.delete(lam, k)
            else:
                res.nontrivial_multipliers = lam
            res.stable = bool(np.all(np.abs(res.nontrivial_multipliers) < 1.0))
        except np.linalg.LinAlgError as e:
            res.message += f"; Floquet analysis failed: {e}"
    return res
