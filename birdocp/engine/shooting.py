"""The data-split formulation of :func:`birdocp.engine.orbit_front.solve`: multiple shooting for the
periodic orbits of a forced :class:`~birdocp.engine.ode.ODE` with a data function (IPOPT or
Levenberg-Marquardt), with free parameters held by period-mean conditions.

Unknowns: the shooting points X_0 .. X_{M-1} at t0 + i T/(M-1) (M counts the closing point, as in
the paper, so there are M-1 segments) and the free parameters.  Equations:

* continuity   Phi_seg(X_i) - X_{i+1} = 0,  i = 0 .. M-2  (Phi_seg: n = N/(M-1) RK4 steps)
* periodicity  X_{M-1} - X_0 = 0
* mean conditions  (1/T) integral over the period of output_k  - target_k = 0

The solver table :data:`SOLVERS`: ``"ipopt"``, a pure feasibility NLP (objective 0; the system is
square when there is one mean condition per free parameter), limited-memory Hessian, MUMPS;
``"lm"``, the paper's Algorithm 1 (Levenberg-Marquardt on the shooting matrix, every step accepted,
lambda /10 or x10); ``"newton-picard"``, Newton on the method's ``newton_states`` and Picard on the
strongly contracting rest (:mod:`birdocp.engine.newton_picard`, with free parameters
:mod:`birdocp.engine.newton_picard_free`; the full blocks are formed once, at
the converged cycle, for the multipliers).

The problem, method and result types are the engine's one of each
(:class:`~birdocp.engine.problem.OrbitProblem`, :class:`~birdocp.engine.method.OrbitMethod`,
:class:`~birdocp.engine.orbit_result.OrbitResult`), the graphs live in
:mod:`birdocp.engine.shooting_graphs`. CasADi graphs are built once per (ode, steps_per_period, points, solver, derivatives, free set,
mean/extra output Functions) and cached in this module (:mod:`birdocp.engine.cache` registry); a sweep that
re-solves with new parameter values, targets, t0 or guesses reuses them (only numbers change: the
data grid and the parameter vector are NLP parameters, not constants baked into the graph).
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np

from birdocp.engine import interrupts
from birdocp.engine.cache import clear_caches
from birdocp.engine.floquet import FloquetResult, floquet_from_jacobians
from birdocp.engine.lm import levenberg_marquardt
from birdocp.engine.newton_picard import newton_picard
from birdocp.engine.newton_picard_chord import monodromy_chord_available, newton_picard_monodromy
from birdocp.engine.newton_picard_free import newton_picard_free
from birdocp.engine.step_jacobians import batched_segment_jacobians
from birdocp.engine.nlp import run_ipopt
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.problem import OrbitProblem, finite_vector
from birdocp.engine.ode import ODE
from birdocp.engine.shooting_graphs import ShootingGraphs, initial_points, rk4_grid, shooting_graphs

__all__ = ["solve_data_split", "SOLVERS", "estimate_error", "clear_cache", "floquet", "ShootingGraphs",
           "shooting_graphs", "initial_points", "rk4_grid"]

def clear_cache() -> None:
    """Clear every in-memory cache of the process (:func:`birdocp.engine.cache.clear_caches`)."""
    clear_caches()


def _lm(b: ShootingGraphs, method, problem, z, lo, hi, fd):
    """The paper's Algorithm 1: :func:`birdocp.engine.lm.levenberg_marquardt` with every step accepted
    (``accept="always"``, lam from 1). Returns (z, status, message, iterations, history).

    Exact derivatives: the shooting matrix from :meth:`ShootingGraphs.evaluate` (segment blocks by forward
    AD, assembled in numpy; residual and Jacobian in one evaluation per iterate); ``fd``: forward
    differences (:func:`_fd_jacobian`)."""
    nf = b.nf
    nzx = b.nz - nf
    lo_z = np.concatenate([np.full(nzx, -np.inf), lo]) if nf else None
    hi_z = np.concatenate([np.full(nzx, np.inf), hi]) if nf else None
    jac = (lambda zz, r: _fd_jacobian(b, problem, zz, r, method.fd_floor)) if fd else None
    out = levenberg_marquardt(b, z, tol=method.tol, max_iter=method.max_iter, lo=lo_z, hi=hi_z,
                              accept="always", lam0=1.0, stall_window=0, jacobian=jac, symbol="E")
    return out.z, out.status, out.message, out.iterations, out.history


def _fd_jacobian(b: ShootingGraphs, problem, z, r0, floor):
    """Forward differences as in the paper: segment Jacobians column by column (all segments in one
    mapped call per state), the shooting matrix assembled around them; free-parameter columns by
    forward differences of the whole residual."""
    nx, S, nf, nm = problem.ode.nx, b.S, b.nf, b.nm
    T = problem.ode.forcing_period
    X = z[: nx * (S + 1)].reshape(S + 1, nx).T
    pfull = problem.p.copy()
    if nf:
        pfull[list(b.free_idx)] = z[-nf:]
    Dn = b.grid.blocks_numeric(problem.t0, pfull)
    J = np.zeros((b.ng, b.nz))
    I = np.eye(nx)
    Js, dQ = b.grid.fd_segment_jacobians(X[:, :S], Dn, pfull, floor)
    dM = dQ[:nm] / T
    for i in range(S):
        J[i * nx:(i + 1) * nx, i * nx:(i + 1) * nx] = Js[i]
        J[i * nx:(i + 1) * nx, (i + 1) * nx:(i + 2) * nx] = -I
        for k in range(nm):
            J[(S + 1) * nx + k, i * nx:(i + 1) * nx] = dM[k, i]
    J[S * nx:(S + 1) * nx, 0:nx] = -I
    J[S * nx:(S + 1) * nx, S * nx:(S + 1) * nx] = I
    for k in range(nf):
        col = b.nz - nf + k
        zp = z.copy()
        hk = 1e-3 * z[col] if abs(z[col]) >= floor else 1e-3 * floor
        zp[col] += hk
        rp = b.resid(zp)
        J[:, col] = (rp - r0) / hk
    return J


def _run_ipopt(solver, z0, method, lbx, ubx):
    """One IPOPT attempt through the engine's one front (:func:`birdocp.engine.nlp.run_ipopt`)."""
    out = run_ipopt(solver, z0, lbx=lbx, ubx=ubx, p=np.concatenate([z0, [method.regularization]]))
    return out.z, out.status, out.success, out.iterations, out.history, out.message


def solve_data_split(problem: OrbitProblem, method: OrbitMethod,
                       warm_start: OrbitResult | None = None) -> OrbitResult:
    """The data-split formulation of :func:`birdocp.engine.orbit_front.solve` (use that front).

    ``success`` means converged: the max residual of all equations at the result is finite and at
    most the method's tolerance (10 x tol for IPOPT), whatever the solver's status says (IPOPT's
    ``Feasible_Point_Found`` or ``Solved_To_Acceptable_Level`` with a larger residual is a failure;
    a ``Solve_Succeeded`` with a larger residual becomes status ``residual_above_tol``). A Ctrl-C
    during the solve raises ``KeyboardInterrupt`` (never a status, never a retry), also when CasADi
    caught it inside IPOPT.

    Parameters
    ----------
    problem : OrbitProblem
        A problem of an :class:`~birdocp.engine.ode.ODE` with a data function.
    method : OrbitMethod
        Shooting points, RK4 steps per period, solver, derivatives, tolerances (``None`` settings
        resolved for an ODE with data: :meth:`~birdocp.engine.method.OrbitMethod.resolved`).
    warm_start : OrbitResult, optional
        A previous result on the same grid whose shooting points (and free values) start the solve.

    Returns
    -------
    OrbitResult
        ``formulation="data_split"``: ``success``, ``status``, ``x0``, ``shooting_points``, the
        trajectory, ``monodromy``, ``multipliers`` (largest modulus first), ``eigenvectors``,
        ``floquet_exponents``, ``stable``, ``means`` and ``free_values``.
    """
    with interrupts.interruptible():
        return _solve(problem, method.resolved(True), warm_start)


def _converged(max_res: float, tol: float) -> bool:
    return bool(np.isfinite(max_res) and max_res <= tol)


def _solve(problem, method, warm_start):
    t_total = time.perf_counter()
    b, build_s = shooting_graphs(problem, method)
    nf = len(b.free_idx)
    lo, hi = problem.free_bounds() if nf else (np.zeros(0), np.zeros(0))
    wall = {"build": build_s, "data": 0.0, "solve": 0.0, "floquet": 0.0}
    z0, p_init, D_init = _start(problem, b, warm_start, lo, hi, wall, method.solver == "newton-picard")
    ts = time.perf_counter()
    z, status, success, message, iters, hist = _run(problem, method, b, z0, lo, hi)
    wall["solve"] = time.perf_counter() - ts
    res, ev = _result(problem, method, b, z, p_init, D_init, (status, success, message, iters, hist), wall)
    if np.all(np.isfinite(z)) and np.all(np.isfinite(ev[0])):  # also after a failure: useful for diagnosis
        tf = time.perf_counter()
        # Newton-Picard never formed the full blocks: the stage Jacobians in batch give them
        # (engine.step_jacobians), without the second pass of the one-period Jacobian that only checks them (NaN)
        np_ = method.solver == "newton-picard"
        _attach_floquet(res, b, z, *ev[1:], check=not np_, batched=np_)
        wall["floquet"] = time.perf_counter() - tf
    wall["total"] = time.perf_counter() - t_total
    if method.error_estimate and res.success:
        res.error_estimate = estimate_error(problem, method, res, b, z)
    return res


def estimate_error(problem: OrbitProblem, method: OrbitMethod, result: OrbitResult, graphs=None,
                   z=None) -> dict:
    """Error estimate of a converged forced orbit: discretisation (Richardson) plus solver tolerance.

    The orbit is re-solved with 2N RK4 steps (the paper's LM from the result's shooting points, to
    max |residual| 1e-10 or the method's tolerance if smaller, so that the fine orbit is converged
    well past the difference it measures); the differences of the matched multipliers, of x0 and of the period means are
    scaled by ``2^4 / (2^4 - 1)``. The solver's part is ``|g|_2 / sigma_min(J)`` at the result (the
    distance to the exact solution of the N-step equations), added to the x0 estimate and, relative
    to the state's size, to the multipliers'. Every estimate is at least the round-off of its value.

    Parameters
    ----------
    problem, method, result
        The solved problem, its method and its (converged) result.
    graphs, z
        The N-step graphs and the unknowns at the result (default: rebuilt / from the result).

    Returns
    -------
    dict
        ``multipliers`` (absolute, max over the matched multipliers), ``multipliers_relative``,
        ``x0`` (state units), ``means`` (by name), ``solver``, ``steps_per_period_fine``, ``wall_s``,
        and ``fine_status`` (the 2N solve's status).
    """
    from dataclasses import replace

    from birdocp.engine.orbit_checks import richardson_errors, solver_error

    t = time.perf_counter()
    method = method.resolved(True)
    b = graphs if graphs is not None else shooting_graphs(problem, method)[0]
    if z is None:
        z = np.concatenate([np.asarray(result.shooting_points).ravel(), result.p[list(b.free_idx)]])
    g, J = b.evaluate(z)
    e_solver = solver_error(J, g)
    fine_m = replace(method, steps_per_period=2 * int(method.steps_per_period), solver="lm", error_estimate=False,
                     tol=min(method.tol, 1e-10), max_iter=20)
    fine = solve_data_split(problem, fine_m, result)
    lam = np.asarray(result.multipliers)
    out = {"solver": e_solver, "steps_per_period_fine": fine_m.steps_per_period, "fine_status": fine.status}
    if fine.success and fine.multipliers is not None:
        out.update(richardson_errors(lam, fine.multipliers, result.x0, fine.x0, result.means, fine.means, e_solver))
    else:
        out.update(multipliers=float("nan"), multipliers_relative=float("nan"), x0=float("nan"), means={})
    out["wall_s"] = time.perf_counter() - t
    return out


def _start(problem, b, warm_start, lo, hi, wall, first_only=False):
    """The initial unknowns (shooting points, free parameters), the start parameters and their data;
    sets the graphs' context. ``first_only``: the solver reads only the first point (Newton-Picard
    integrates from it), so a start without a warm start repeats it instead of integrating the guess."""
    nx, S, t0, free_idx, nf = problem.ode.nx, b.S, float(problem.t0), b.free_idx, b.nf
    p_init = problem.p.copy()
    if warm_start is not None and np.shape(warm_start.p) == p_init.shape and nf:
        p_init[list(free_idx)] = np.asarray(warm_start.p)[list(free_idx)]
    if nf:
        p_init[list(free_idx)] = np.clip(p_init[list(free_idx)], lo, hi)
    td = time.perf_counter()
    D_init = b.grid.blocks_numeric(t0, p_init)
    wall["data"] += time.perf_counter() - td
    if warm_start is not None and np.shape(warm_start.shooting_points) == (S + 1, nx) \
            and np.all(np.isfinite(warm_start.shooting_points)):
        X0 = np.asarray(warm_start.shooting_points, float).T.copy()
    else:
        x_start = np.asarray(warm_start.x0, float) if warm_start is not None else problem.x_guess
        if not np.all(np.isfinite(x_start)):
            x_start = problem.x_guess
        X0 = (np.tile(np.asarray(x_start, float)[:, None], (1, S + 1)) if first_only
              else initial_points(b, x_start, D_init, p_init))
    z0 = np.concatenate([X0.T.ravel(), p_init[list(free_idx)]])
    targets = np.array([m.target for m in problem.means], float)
    if b.symbolic_data:
        b.set_context(b.symbolic_context(t0, problem.p), problem.p, targets)
    else:
        b.set_context(D_init, p_init, targets)
    return z0, p_init, D_init


def _run(problem, method, b, z0, lo, hi):
    """The method's solver from the table :data:`SOLVERS`. Returns (z, status, success, message,
    iterations, history)."""
    return SOLVERS[method.solver](problem, method, b, z0, lo, hi)


def _run_lm(problem, method, b, z0, lo, hi):
    """The paper's LM (:func:`_lm`)."""
    z, status, message, iters, hist = _lm(b, method, problem, z0.copy(), lo, hi, method.derivatives == "fd")
    return z, status, status == "converged", message, iters, np.asarray(hist, float)


def _run_ipopt_attempts(problem, method, b, z0, lo, hi):
    """IPOPT with full steps, then once with the filter line search if that fails."""
    nzx = problem.ode.nx * (b.S + 1)
    lbx = np.concatenate([np.full(nzx, -np.inf), lo])
    ubx = np.concatenate([np.full(nzx, np.inf), hi])
    attempts = [False, True] if method.ipopt_fallback and "ipopt.accept_every_trial_step" not in \
        method.ipopt_options else [False]
    iters, hists, msgs = 0, [], []
    for fallback in attempts:
        z, status, success, it, h, msg = _run_ipopt(b.ipopt(method, fallback), z0, method, lbx, ubx)
        if np.all(np.isfinite(z)):  # the status alone is not convergence: the residual decides
            r_try = b.evaluate(z)[0]  # IPOPT's last evaluation (kept), or one more
            success = _converged(float(np.max(np.abs(r_try))) if r_try.size else 0.0, 10 * method.tol)
        iters += it
        hists.append(h)
        msgs.append(("filter line search: " if fallback else "") + msg)
        if success:
            break
    return z, status, success, "; retried: ".join(msgs), iters, np.concatenate(hists)


def _run_newton_picard(problem, method, b, z0, lo, hi):
    """Newton-Picard (:func:`birdocp.engine.newton_picard.newton_picard`); when its complement is not
    contracting (or its reduced matrix singular), the paper's LM on the full state from its best
    iterate (histories concatenated). ``method.chord = "monodromy"``:
    :func:`birdocp.engine.newton_picard_chord.newton_picard_monodromy` (not with free parameters, nor
    without the SX state Jacobian it needs: the subspace chord then). With free parameters
    :func:`birdocp.engine.newton_picard_free.newton_picard_free` (they join the Newton subspace)."""
    if method.chord == "monodromy" and not b.nf and monodromy_chord_available(b.grid):
        out = newton_picard_monodromy(b, problem, z0, tol=method.tol, max_iter=method.max_iter,
                                      max_rate=method.picard_max_rate)
    elif b.nf:
        out = newton_picard_free(b, problem, z0, method.newton_states, lo, hi, tol=method.tol,
                                 max_iter=method.max_iter, max_rate=method.picard_max_rate)
    else:
        out = newton_picard(b, problem, z0, method.newton_states, tol=method.tol, max_iter=method.max_iter,
                            max_rate=method.picard_max_rate)
    if out.status not in ("not_contracting", "singular"):
        return out.z, out.status, out.status == "converged", out.message, out.iterations, np.asarray(out.history)
    start = out.z if np.all(np.isfinite(out.z)) else z0
    z, status, success, message, iters, hist = _run_lm(problem, method, b, start, lo, hi)
    return (z, status, success, f"{out.message}; full Newton (lm) from its best iterate: {message}",
            out.iterations + iters, np.concatenate([out.history, hist]))


SOLVERS = {"ipopt": _run_ipopt_attempts, "lm": _run_lm, "newton-picard": _run_newton_picard}
"""The solver table of the data-split formulation: name -> run(problem, method, graphs, z0, lo, hi)."""


def _residual_at(problem, b, z, pfull, Dn):
    """Residual g, trajectory Xt and means at z (numerically, from the data Dn; NaN without it)."""
    grid, nx, S, T = b.grid, problem.ode.nx, b.S, problem.ode.forcing_period
    targets = np.array([m.target for m in problem.means], float)
    if Dn is None:
        return np.full(b.ng, np.nan), np.full((nx, b.N), np.nan), np.full(grid.nq, np.nan)
    Xz = z[:nx * (S + 1)].reshape(S + 1, nx).T
    Xe, Xt, Qv = (np.asarray(v) for v in grid.segments(ca.DM(Xz[:, :S]), Dn, ca.DM(pfull)))
    means_v = np.sum(Qv, axis=1) / T if grid.nq else np.zeros(0)
    g = np.concatenate([(Xe - Xz[:, 1:]).T.ravel(), Xz[:, S] - Xz[:, 0], means_v[:b.nm] - targets])
    return g, Xt, means_v


def _result(problem, method, b, z, p_init, D_init, outcome, wall):
    """The OrbitResult at z (status from the residual, whatever the solver said) and
    (g, X, Dn, pd) for the Floquet analysis."""
    status, success, message, iters, hist = outcome
    solver_status = status
    nx, S, N, T, t0, free_idx, nf = problem.ode.nx, b.S, b.N, problem.ode.forcing_period, float(problem.t0), b.free_idx, b.nf
    nzx = nx * (S + 1)
    pfull = problem.p.copy() if nf else p_init.copy()
    if nf:
        pfull[list(free_idx)] = z[nzx:]
    Dn = D_init
    if nf and np.all(np.isfinite(pfull)):
        td = time.perf_counter()
        Dn = b.grid.blocks_numeric(t0, pfull)
        wall["data"] += time.perf_counter() - td
    elif nf:
        Dn = None
    g, Xt, means_v = _residual_at(problem, b, z, pfull, Dn)
    max_res = float(np.max(np.abs(g))) if np.all(np.isfinite(g)) else float("nan")
    tol_ok = method.tol * (10 if method.solver == "ipopt" else 1)
    if not _converged(max_res, tol_ok):
        message += (f" (max residual {max_res:.2e} > tol {tol_ok:.1e}: not converged)"
                    if np.isfinite(max_res) else " (non-finite residual: not converged)")
        if status in ("converged", "Solve_Succeeded"):  # a status that claims the tolerance: replaced
            status = "residual_above_tol" if np.isfinite(max_res) else "nan"
        success = False
    elif not success and method.solver == "ipopt":
        # converged means the residual is below the tolerance, whatever IPOPT's status says
        message += f" (max residual {max_res:.2e}: converged)"
        success = True
    X = z[:nzx].reshape(S + 1, nx)
    means = {n: float(v) for n, v in zip(problem.mean_names(), means_v.ravel())}
    shooting_times = t0 + T / S * np.arange(S + 1)
    res = OrbitResult(
        success=bool(success), status=status, message=message, iterations=int(iters),
        residual_history=hist, wall_s=wall, formulation="data_split", autonomous=False,
        solver_status=solver_status,
        period=float(shooting_times[-1] - shooting_times[0]),
        shooting_times=shooting_times, shooting_points=X, x0=X[0].copy(), p=pfull,
        free_values={problem.free_name(i): float(pfull[i]) for i in free_idx},
        trajectory_t=t0 + b.grid.h * np.arange(N + 1), trajectory_x=np.vstack([X[0][None, :], Xt.T]),
        max_residual=max_res, means=means,
        method={"points": method.points, "steps_per_period": method.steps_per_period,
                "solver": method.solver, "derivatives": method.derivatives,
                "tol": method.tol, "max_iter": method.max_iter},
    )
    return res, (g, X, Dn, ca.DM(pfull))


def _batched_or_none(grid, points, trajectory, Dn, pd):
    """:func:`birdocp.engine.step_jacobians.batched_segment_jacobians`, or None when its graphs cannot
    be built or evaluated (e.g. a right-hand side without SX derivatives): the variational pass then."""
    try:
        return batched_segment_jacobians(grid, points, trajectory, Dn, pd)
    except Exception as e:  # noqa: BLE001 - any failure: the variational pass
        interrupts.check_from(e)
        return None


def _attach_floquet(res, b, z, X, Dn, pd, check=True, batched=False):
    """Multipliers, eigenvectors and exponents at z (the solver's last segment blocks when at z);
    ``check``: compare the monodromy with the one-period Jacobian (a second variational pass);
    ``batched``: without the solver's blocks, the segment Jacobians from the stage Jacobians in batch
    (:func:`birdocp.engine.step_jacobians.batched_segment_jacobians`) instead of the variational pass."""
    grid, nx, S = b.grid, b.nx, b.S
    try:
        Js = b.blocks_at(z)  # IPOPT's (or LM's) last Jacobian evaluation, when at z
        if Js is None and batched:  # the stage Jacobians in batch, chained in numpy
            Js = _batched_or_none(grid, X[:S].T, res.trajectory_x[1:].T, Dn, pd)
        if Js is None:
            Xe, Jcat = grid.segment_jacobians(ca.DM(X[:S].T), Dn, pd)
            Jcat = np.asarray(Jcat)
            Js = [Jcat[:, i * nx:(i + 1) * nx] for i in range(S)]
            x1 = np.asarray(Xe)[:, 0]
        else:  # the first segment's end on the residual's trajectory (the same integration, the same numbers)
            x1 = res.trajectory_x[grid.n]
        # the one-period map's Jacobian along the trajectory from x0: its first segment is the solver's
        Jfull = (np.asarray(grid.period_jacobian_from_first(ca.DM(x1), ca.DM(Js[0]), Dn, pd)[1]) if check
                 else None)
        fr = floquet_from_jacobians(Js, Jfull, b.ode.forcing_period)
        res.monodromy, res.multipliers, res.eigenvectors = fr.monodromy, fr.multipliers, fr.eigenvectors
        res.floquet_exponents, res.doubling_times_s = fr.floquet_exponents, fr.doubling_times_s
        res.stable = fr.stable
        res.monodromy_vs_full_period_jacobian = fr.monodromy_vs_full_period_jacobian
    except Exception as e:  # never raise from the analysis of a result
        interrupts.check_from(e)
        res.message += f"; Floquet analysis failed: {e}"
    if res.success and (res.multipliers is None or not np.all(np.isfinite(res.multipliers))):
        res.success, res.status = False, "nan"  # a cycle without finite multipliers is no success
        res.message += "; non-finite Floquet multipliers"


def floquet(ode: ODE, x0, p, method=None, *, t0: float = 0.0, points=None, grid=None, blocks=None) -> FloquetResult:
    """Floquet analysis at the periodic orbit through ``x0`` (at time ``t0``) for parameters ``p``.

    Parameters
    ----------
    ode : ODE
        The ODE.
    x0 : array_like (nx,)
        A state on the periodic orbit at ``t0``.
    p : array_like (np,)
        The parameters.
    method : OrbitMethod, optional
        Points and RK4 steps per period (default ``OrbitMethod()``: 5 points, 148 steps).
    t0 : float
        The time of ``x0``.
    points : array_like, optional
        The shooting points (M x nx or (M-1) x nx); by default obtained by integrating forward from
        ``x0`` (identical at a converged orbit).
    grid : RK4Grid, optional
        A prebuilt grid of the same ODE and method, to reuse.
    blocks : numpy.ndarray, optional
        The per-time data on the grid, if already evaluated.

    Returns
    -------
    FloquetResult
        ``monodromy``, ``multipliers`` (largest modulus first), ``eigenvectors``, ``floquet_exponents``,
        ``doubling_times_s``, ``stable`` and the check ``monodromy_vs_full_period_jacobian``.

    Examples
    --------
    The forced linear oscillator ``x'' + 0.5 x' + x = cos t`` has the orbit ``x = 2 sin t``; its
    monodromy is ``exp(2 pi A)``, whose determinant is ``exp(-0.5 * 2 pi)`` (Liouville's formula).

    >>> import casadi as ca, numpy as np
    >>> from birdocp.engine import OrbitMethod, ODE
    >>> from birdocp.engine.shooting import floquet
    >>> x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 1)
    >>> f = ca.Function("f", [x, t, p], [ca.vertcat(x[1], -p[0] * x[1] - x[0] + ca.cos(t))])
    >>> fl = floquet(ODE.from_rhs(f, 2 * np.pi), [0.0, 2.0], [0.5], OrbitMethod(points=3, steps_per_period=200))
    >>> bool(fl.stable), bool(np.isclose(np.linalg.det(fl.monodromy), np.exp(-np.pi), rtol=1e-8))
    (True, True)
    """
    method = (method or OrbitMethod()).resolved(True)
    grid = grid or rk4_grid(ode, method, ())
    x0 = finite_vector(x0, "floquet x0", ode.nx, f"the ODE has nx={ode.nx}")
    p = finite_vector(p, "floquet p", ode.np, f"the ODE has np={ode.np}")
    D = blocks if blocks is not None else grid.blocks_numeric(t0, p)
    pd = ca.DM(p)
    S, nx = grid.S, ode.nx
    if points is None:
        Xt = np.asarray(grid.period_map(ca.DM(x0), D, pd)[1])
        pts = np.column_stack([x0] + [Xt[:, grid.n * (i + 1) - 1] for i in range(S - 1)])
    else:
        pts = np.asarray(points, float)[:S].T
    Xe, Jcat = grid.segment_jacobians(ca.DM(pts), D, pd)
    Jcat = np.asarray(Jcat)
    Js = [Jcat[:, i * nx:(i + 1) * nx] for i in range(S)]
    _, Jfull = grid.period_jacobian_from_first(Xe[:, 0], ca.DM(Js[0]), D, pd)  # the one-period map's, from pts[:, 0]
    return floquet_from_jacobians(Js, np.asarray(Jfull), ode.forcing_period)
