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
  (:class:`birdocp.engine.shooting._Builder`, the continuation parameter one more free parameter):
  ``dG/dX`` by forward AD of the RK4 segments, the parameter columns by forward AD through the
  per-time data (of ``post`` only when no unknown enters the wing's arm-frame shape; from a constant
  column when the parameter enters the data affinely, like the wing-root position). The corrector
  starts from the Jacobian of the point it steps from, evaluates only residuals and updates the
  Jacobian by Broyden's formula, re-evaluating it where a step reduces the residual by less than
  ``chord_contraction``; the Jacobian at the converged point (tangent, monodromy) is always exact.
  Measured on the bird (5 points, 148 steps): a residual costs 9 ms (root position continued at
  fixed amplitude) / 29 ms (level flight, amplitude free), residual and Jacobian 81 / 200 ms; a
  point takes ~1.2 Jacobians and ~7 residuals.
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
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from birdocp.engine.floquet import monodromy_of, multipliers_info
from birdocp.engine.problem import LimitCycleProblem
from birdocp.engine.shooting import MultipleShooting, _get_builder, _initial_points, solve

__all__ = ["Branch", "BranchPoint", "SpecialPoint", "continuation", "Continuation"]


def _pairs(z) -> list:
    return [[float(np.real(v)), float(np.imag(v))] for v in np.asarray(z).ravel()]


def _fl(v):
    v = float(v)
    return v if math.isfinite(v) else None


@dataclass
class BranchPoint:
    parameter: float
    x0: list
    shooting_points: list
    free_values: dict
    multipliers: list          # [[re, im], ...], largest modulus first
    moduli: list
    stable: bool
    means: dict
    arclength: float           # scaled arclength from the first point
    tangent_parameter: float   # d lam / ds (scaled): its sign is the direction along the parameter
    iterations: int
    max_residual: float
    step: float                # the ds that produced this point (0 for the first)
    tests: dict                # test functions: fold, branch_point, period_doubling, neimark_sacker
    success: bool = True
    p: list = field(default_factory=list)

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["tests"] = {k: _fl(v) for k, v in self.tests.items()}
        d["max_residual"] = _fl(self.max_residual)
        return d


@dataclass
class SpecialPoint:
    kind: str                  # fold | branch_point | period_doubling | neimark_sacker
    parameter: float
    multipliers: list
    moduli: list
    free_values: dict
    x0: list
    arclength: float
    between: tuple             # indices of the branch points around it
    located: bool              # the location converged (else: the best bracket midpoint)
    evaluations: int
    test_value: float
    message: str = ""

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["between"] = list(self.between)
        d["test_value"] = _fl(self.test_value)
        return d


@dataclass
class Branch:
    parameter_name: str
    points: list
    special_points: list
    end_reason: str
    end_message: str
    settings: dict
    wall_s: float = 0.0
    free_names: list = field(default_factory=list)

    @property
    def parameters(self) -> np.ndarray:
        return np.array([pt.parameter for pt in self.points])

    def multipliers(self) -> np.ndarray:
        return np.array([[complex(a, b) for a, b in pt.multipliers] for pt in self.points])

    def to_dict(self) -> dict:
        return {"parameter_name": self.parameter_name, "free_names": list(self.free_names),
                "end_reason": self.end_reason, "end_message": self.end_message,
                "settings": self.settings, "wall_s": self.wall_s,
                "special_points": [s.to_dict() for s in self.special_points],
                "points": [p.to_dict() for p in self.points]}

    @staticmethod
    def from_dict(d: dict) -> "Branch":
        pts = [BranchPoint(**p) for p in d["points"]]
        sps = []
        for s in d.get("special_points", []):
            s = dict(s)
            s["between"] = tuple(s["between"])
            sps.append(SpecialPoint(**s))
        return Branch(d["parameter_name"], pts, sps, d["end_reason"], d["end_message"], d.get("settings", {}),
                      d.get("wall_s", 0.0), d.get("free_names", []))


# ----------------------------------------------------------------------------------------------
class Continuation:
    """The augmented system of one (problem, continuation parameter, grid). See the module docstring.

    The residual and its Jacobian are those of the multiple-shooting engine
    (:class:`birdocp.engine.shooting._Builder`, cached per configuration) with the continuation parameter
    as one more free parameter than there are mean conditions: the same graphs, the same pre/post
    data split (the wing shape in the arm frame is evaluated once when no unknown parameter enters
    it), the segment Jacobians by forward AD in nx directions and one forward direction per
    parameter unknown through the data."""

    def __init__(self, problem: LimitCycleProblem, param, points: int = 5, steps_per_period: int = 148):
        ode = problem.ode
        self.problem = problem
        self.ode = ode
        if isinstance(param, str):
            if param not in ode.param_names:
                raise ValueError(f"unknown continuation parameter {param!r}")
            self.j = ode.param_names.index(param)
        else:
            self.j = int(param)
            if not 0 <= self.j < ode.np:
                raise ValueError(f"continuation parameter index {self.j} out of range")
        self.free_idx = list(problem.free_indices())
        if self.j in self.free_idx:
            raise ValueError("the continuation parameter is one of the problem's free parameters")
        nm = len(problem.means)
        if nm != len(self.free_idx):
            raise ValueError(f"need one mean condition per free parameter ({len(self.free_idx)} free, {nm} means)")
        if steps_per_period % (points - 1):
            raise ValueError("steps_per_period must be a multiple of points - 1")
        self.lo, self.hi = problem.free_bounds() if self.free_idx else (np.zeros(0), np.zeros(0))
        self.mean_names = problem.mean_names()
        self.targets = np.array([m.target for m in problem.means], float)
        self.pidx = self.free_idx + [self.j]   # parameter unknowns, in the order of z
        method = MultipleShooting(points=points, steps_per_period=steps_per_period)
        self.builder, _ = _get_builder(problem, method, self.pidx)
        self.grid = self.builder.grid
        self.nx, self.S, self.nm = ode.nx, self.grid.S, nm
        b = self.builder
        b.set_context(b.symbolic_context(float(problem.t0), problem.p), problem.p, self.targets)
        self._ctx = b._ctx
        self.nz = self.nx * (self.S + 1) + len(self.pidx)
        self.evaluations = 0        # residual + Jacobian evaluations
        self.residual_evaluations = 0  # residual only (chord steps)

    # -- unknowns ------------------------------------------------------------------------------
    def p_of(self, z) -> np.ndarray:
        p = self.problem.p.copy()
        p[self.pidx] = z[self.nx * (self.S + 1):]
        return p

    def X_of(self, z) -> np.ndarray:
        return z[: self.nx * (self.S + 1)].reshape(self.S + 1, self.nx).T

    def z_of(self, shooting_points, p) -> np.ndarray:
        X = np.asarray(shooting_points, float).reshape(self.S + 1, self.nx)
        return np.concatenate([X.ravel(), np.asarray(p, float)[self.pidx]])

    def evaluate(self, z, jacobian: bool = True):
        """(G, J = dG/dz, means, monodromy) at z; with ``jacobian=False`` only G (the rest None)."""
        b = self.builder
        if b._ctx is not self._ctx:  # the cached builder served another solve in between
            b.set_context(*self._ctx)
            self._ctx = b._ctx
        if not jacobian:
            self.residual_evaluations += 1
            return b.resid(z), None, None, None
        self.evaluations += 1
        g, J = b.evaluate(z)
        return g, J, b.means_at(z), monodromy_of(b.blocks_at(z))


def _tangent(Ju, t_prev):
    """Unit null vector of Ju (n x n+1), oriented along t_prev (or by SVD when t_prev is None)."""
    if t_prev is None:
        _, _, Vt = np.linalg.svd(Ju)
        t = Vt[-1]
    else:
        A = np.vstack([Ju, t_prev[None, :]])
        b = np.zeros(A.shape[0])
        b[-1] = 1.0
        t = np.linalg.solve(A, b)
    t = t / np.linalg.norm(t)
    if t_prev is not None and t @ t_prev < 0:
        t = -t
    return t


def _tests(t, Mon, lam_index) -> dict:
    nx = Mon.shape[0]
    L = np.linalg.eigvals(Mon)
    ns = 1.0
    for i in range(nx):
        for k in range(i + 1, nx):
            ns *= (L[i] * L[k] - 1.0)
    return {"fold": float(t[lam_index]), "branch_point": float(np.linalg.det(np.eye(nx) - Mon)),
            "period_doubling": float(np.linalg.det(np.eye(nx) + Mon)), "neimark_sacker": float(np.real(ns))}


@dataclass
class _State:
    u: np.ndarray       # scaled unknowns
    t: np.ndarray       # unit tangent (scaled)
    g: np.ndarray
    means: np.ndarray
    Mon: np.ndarray
    iterations: int
    tests: dict
    J: np.ndarray       # dG/dz at the point (unscaled): the chord Jacobian of the next corrector


def continuation(problem: LimitCycleProblem, param, start_value: float, stop_value: float, *,
                 points: int = 5, steps_per_period: int = 148, start=None, step: float | None = None,
                 ds_min: float | None = None, ds_max: float | None = None, max_points: int = 200,
                 scales=None, tol: float = 1e-10, max_newton: int = 12, chord_contraction: float = 0.3,
                 locate_tol: float = 1e-10,
                 detect=("fold", "branch_point", "period_doubling", "neimark_sacker"),
                 accept: Callable | None = None, progress: Callable | None = None,
                 max_dparam: float | None = None, max_dstate: float | None = None,
                 system: Continuation | None = None) -> Branch:
    """Follow the periodic orbits of ``problem`` as ``param`` goes from ``start_value`` to ``stop_value``.

    problem:   the limit-cycle problem; its ``free`` parameters (held by its ``means``) are unknowns too.
    param:     the continuation parameter (name in ``ode.param_names`` or index).
    start:     a converged cycle at ``start_value`` (anything with ``shooting_points`` on the same grid,
               and ``p``); default: solved by :func:`birdocp.engine.shooting.solve` (IPOPT) from the problem.
    step:      the first step, in parameter units (default ``|stop - start| / 10``); ``ds_max`` /
               ``ds_min`` default to 4x / 1/256x the first scaled arclength step.
    scales:    scale of each unknown: dict with ``"states"`` (one number or nx), ``"free"`` (nf) and
               ``"parameter"`` (default ``|stop - start|``).
    accept:    optional ``accept(Xtraj_initial_point_dict) -> str | None``: called with the point's
               dict fields (parameter, x0, p, shooting_points); a returned string rejects the point and
               ends the branch (``rejected``).
    progress:  optional callback ``progress(text)``.
    tol:       the corrector's tolerance on max |G| (absolute, like the engine's).
    max_newton, chord_contraction: corrector steps allowed per point; a step reducing the residual by
               less than ``chord_contraction`` gets a freshly evaluated Jacobian.
    max_dparam, max_dstate: a corrected step changing the parameter by more than ``max_dparam`` (its
               units) or a shooting-point state by more than ``max_dstate`` is refused and ds shortened
               in proportion; steps aim at 0.85 of these limits (guards against jumping across to
               another branch with a large step).
    """
    t_all = time.perf_counter()
    sysm = system or Continuation(problem, param, points, steps_per_period)
    nx, S = sysm.nx, sysm.S
    nX = nx * (S + 1)
    nf = len(sysm.free_idx)
    span = abs(stop_value - start_value)
    if not span > 0:
        raise ValueError("start_value and stop_value must differ")
    direction = 1.0 if stop_value > start_value else -1.0
    rlo, rhi = min(start_value, stop_value), max(start_value, stop_value)
    sc = dict(scales or {})
    s_states = np.broadcast_to(np.asarray(sc.get("states", 1.0), float), (nx,))
    s_free = np.broadcast_to(np.asarray(sc.get("free", 1.0), float), (nf,))
    s_lam = float(sc.get("parameter", span))
    s = np.concatenate([np.tile(s_states, S + 1), s_free, [s_lam]])
    li = sysm.nz - 1   # index of lam in z
    say = progress or (lambda text: None)

    # --- first point: Newton at fixed lam from the given cycle, or from the problem's guess
    # integrated forward; if that fails, the engine (IPOPT, birdocp.engine.shooting.solve)
    p_start = np.asarray(start.p if start is not None else problem.p, float).copy()
    p_start[sysm.j] = start_value
    if start is not None:
        z0 = sysm.z_of(start.shooting_points, p_start)
    else:
        D0 = sysm.grid.blocks_numeric(float(problem.t0), p_start)
        z0 = sysm.z_of(_initial_points(sysm.builder, problem.x_guess, D0, p_start).T, p_start)
    def Ju_of(J):
        return J * s[None, :]

    def newton(u_pred, row, rhs_fn, J0=None, reach=None):
        """Quasi-Newton on [G(s u); row.u - rhs] = 0 from u_pred, starting with the Jacobian J0 (that
        of the point the prediction starts from) or, without J0, one evaluated at u_pred. Steps
        evaluate only the residual and update the Jacobian by Broyden's rank-one formula; the
        Jacobian is evaluated afresh where a step reduces the residual by less than
        ``chord_contraction`` or where a step from a non-exact Jacobian would move u by more than
        ``reach`` / 2 (scaled norm; ``reach`` = the predictor's step: a stale Jacobian that proposes
        a correction as large as the step itself is not trusted, e.g. where dG/dlam vanishes at the
        base point). The converged point's Jacobian (tangent, monodromy) is always evaluated at it.
        Returns (u, g, J, means, Mon, steps) or None."""
        u = u_pred.copy()
        A, full, prev, du = None, None, None, None
        try:
            for it in range(max_newton + 1):
                z = s * u
                if A is None and J0 is None:
                    full = sysm.evaluate(z)
                    g = full[0]
                else:
                    g = sysm.evaluate(z, jacobian=False)[0]
                    full = None
                r = np.concatenate([g, [row @ u - rhs_fn]])
                if not np.all(np.isfinite(r)):
                    return None
                nr = float(np.max(np.abs(r)))
                if nr < tol:
                    break
                if it == max_newton:
                    return None
                if full is None and prev is not None and nr > chord_contraction * prev:
                    full = sysm.evaluate(z)
                if full is None:
                    if A is None:
                        A = np.vstack([Ju_of(J0), row[None, :]])
                    else:  # Broyden: A du = -r_prev, so the secant correction is r (the new residual)
                        A = A + np.outer(r, du) / (du @ du)
                    du = np.linalg.solve(A, -r)
                    if reach is not None and not np.linalg.norm(du) <= 0.5 * reach:
                        full = sysm.evaluate(z)
                if full is not None:
                    if not np.all(np.isfinite(full[1])):
                        return None
                    A = np.vstack([Ju_of(full[1]), row[None, :]])
                    du = np.linalg.solve(A, -r)
                prev = nr
                if not np.all(np.isfinite(du)):
                    return None
                u = u + du
            if full is None:
                full = sysm.evaluate(s * u)
        except (np.linalg.LinAlgError, RuntimeError):
            return None
        g, J, means, Mon = full
        if not (np.all(np.isfinite(J)) and np.max(np.abs(g)) < tol):
            return None
        return u, g, J, means, Mon, it

    # polish the start at fixed lam
    e_l = np.zeros(sysm.nz)
    e_l[li] = 1.0
    out = newton(z0 / s, e_l, start_value / s_lam)
    if out is None and start is None:
        prob0 = LimitCycleProblem(problem.ode, p_start, problem.x_guess, problem.free, problem.means,
                                  problem.t0, problem.outputs)
        eng = solve(prob0, MultipleShooting(points=points, steps_per_period=steps_per_period))
        if eng.success:
            out = newton(sysm.z_of(eng.shooting_points, p_start) / s, e_l, start_value / s_lam)
    if out is None:
        return Branch(sysm.ode.param_names[sysm.j], [], [], "start_failed",
                      "Newton did not converge at the start value from the given cycle", {},
                      time.perf_counter() - t_all)
    u, g, J, means, Mon, it = out
    t = _tangent(Ju_of(J), None)
    if t[li] * direction < 0:
        t = -t
    cur = _State(u, t, g, means, Mon, it, _tests(t, Mon, li), J)

    # steps
    dlam0 = float(step) if step else span / 10.0
    ds0 = abs(dlam0 / s_lam) / max(abs(t[li]), 1e-3)
    ds_min = ds_min or ds0 / 256
    ds_max = ds_max or 4 * ds0
    ds = ds0
    name = sysm.ode.param_names[sysm.j] if sysm.ode.param_names else f"p{sysm.j}"
    free_names = [sysm.ode.param_names[i] if sysm.ode.param_names else f"p{i}" for i in sysm.free_idx]
    settings = {"parameter": name, "from": start_value, "to": stop_value, "points": points,
                "steps_per_period": steps_per_period, "first_step": dlam0, "ds_first": ds0, "ds_min": ds_min,
                "ds_max": ds_max, "scales": s.tolist(), "tol": tol, "max_points": max_points,
                "free": free_names, "mean_conditions": sysm.mean_names[:sysm.nm], "max_dparam": max_dparam,
                "max_dstate": max_dstate}

    def make_point(st: _State, arclen: float, ds_used: float) -> BranchPoint:
        z = s * st.u
        lam_m, _, _, _, stable = multipliers_info(st.Mon, sysm.ode.period_s)
        p = sysm.p_of(z)
        X = sysm.X_of(z)
        return BranchPoint(
            parameter=float(z[li]), x0=X[:, 0].tolist(), shooting_points=X.T.tolist(),
            free_values={n: float(p[i]) for n, i in zip(free_names, sysm.free_idx)},
            multipliers=_pairs(lam_m), moduli=[float(abs(v)) for v in lam_m], stable=bool(stable),
            means={n: float(v) for n, v in zip(sysm.mean_names, st.means)}, arclength=float(arclen),
            tangent_parameter=float(st.t[li]), iterations=int(st.iterations),
            max_residual=float(np.max(np.abs(st.g))) if st.g.size else 0.0, step=float(ds_used),
            tests=dict(st.tests), p=p.tolist())

    def check(pt: BranchPoint) -> str | None:
        if nf:
            fv = np.array([pt.p[i] for i in sysm.free_idx])
            if np.any(fv < sysm.lo) or np.any(fv > sysm.hi):
                return "free_parameter_bound"
        if accept is not None:
            msg = accept(pt)
            if msg:
                return "rejected: " + msg
        return None

    def corrected(base: _State, dsv: float):
        """Point at scaled arclength dsv from base along base's tangent, or None."""
        pred = base.u + dsv * base.t
        res = newton(pred, base.t, base.t @ base.u + dsv, base.J, abs(dsv))
        if res is None:  # again from a Jacobian evaluated at the predictor
            res = newton(pred, base.t, base.t @ base.u + dsv, None, abs(dsv))
        if res is None:
            return None
        u2, g2, J2, m2, Mon2, it2 = res
        t2 = _tangent(Ju_of(J2), base.t)
        return _State(u2, t2, g2, m2, Mon2, it2, _tests(t2, Mon2, li), J2)

    def at_lambda(a: _State, b: _State, lam_target: float):
        """Re-solve the point with lam fixed (between a and b, linear predictor)."""
        la, lb = s_lam * a.u[li], s_lam * b.u[li]
        w = (lam_target - la) / (lb - la) if lb != la else 1.0
        res = newton(a.u + w * (b.u - a.u), e_l, lam_target / s_lam, a.J if abs(w) < 0.5 else b.J,
                     float(np.linalg.norm(b.u - a.u)))
        if res is None:
            return None
        u2, g2, J2, m2, Mon2, it2 = res
        t2 = _tangent(Ju_of(J2), b.t)
        return _State(u2, t2, g2, m2, Mon2, it2, _tests(t2, Mon2, li), J2)

    pts = [make_point(cur, 0.0, 0.0)]
    states = [cur]
    specials: list[SpecialPoint] = []
    arclen = 0.0
    end_reason, end_message = "max_points", f"max_points={max_points} reached"
    say(f"{name} = {pts[0].parameter:.6g}: start, |L|max {max(pts[0].moduli):.4f}")

    def locate(kind: str, base: _State, ds_b: float, fa: float, fb: float, k: int):
        """Illinois regula falsi on the arclength in (0, ds_b) for the sign change of tests[kind]."""
        a, b = 0.0, ds_b
        best, nev, side = None, 0, 0
        ok = False
        for _ in range(60):
            if abs(b - a) < locate_tol:
                ok = True
                break
            c = (a * fb - b * fa) / (fb - fa) if fb != fa else 0.5 * (a + b)
            if not (min(a, b) < c < max(a, b)):
                c = 0.5 * (a + b)
            st = corrected(base, c)
            nev += 1
            if st is None:
                c = 0.5 * (a + b)
                st = corrected(base, c)
                nev += 1
                if st is None:
                    break
            fc = st.tests[kind]
            best = (c, st)
            if fc == 0:
                ok = True
                break
            if np.sign(fc) == np.sign(fa):
                a, fa = c, fc
                if side == -1:
                    fb *= 0.5
                side = -1
            else:
                b, fb = c, fc
                if side == 1:
                    fa *= 0.5
                side = 1
            if abs(fc) < 1e-14:
                ok = True
                break
        if best is None:
            return None
        c, st = best
        pt = make_point(st, arclen + c, c)
        lam_m = np.array([complex(x, y) for x, y in pt.multipliers])
        msg = ""
        if kind == "neimark_sacker":
            cplx = [v for v in lam_m if abs(v.imag) > 1e-8 and abs(abs(v) - 1) < 1e-4]
            if not cplx:
                return None  # a neutral saddle (real pair with L_i L_j = 1), not a bifurcation
            msg = f"complex pair on the unit circle, angle {math.degrees(abs(np.angle(cplx[0]))):.4g} deg"
        elif kind == "fold":
            near = lam_m[np.argmin(np.abs(lam_m - 1))]
            msg = f"turning point in {name}; multiplier nearest +1: {near.real:.6g}{near.imag:+.2g}j"
        elif kind == "branch_point":
            msg = "a multiplier crosses +1 without a turning point"
        elif kind == "period_doubling":
            near = lam_m[np.argmin(np.abs(lam_m + 1))]
            msg = f"multiplier nearest -1: {near.real:.6g}{near.imag:+.2g}j"
        return SpecialPoint(kind=kind, parameter=pt.parameter, multipliers=pt.multipliers, moduli=pt.moduli,
                            free_values=pt.free_values, x0=pt.x0, arclength=pt.arclength, between=(k, k + 1),
                            located=ok, evaluations=nev, test_value=float(st.tests[kind]), message=msg)

    observed = [0.0, 0.0]   # |d lam| / ds and max |d X| / ds of the last corrected step
    aim = 0.85              # steps aim at this fraction of max_dparam / max_dstate

    def capped(st: _State, dsv: float) -> float:
        """dsv shortened so that the step is expected to move the parameter by at most 0.85 max_dparam
        and a shooting-point state by at most 0.85 max_dstate (a corrected step beyond them is refused:
        predicting the limits saves the corrector solves a refused step costs). The expected change
        per unit ds is the larger of the tangent's and the last corrected step's."""
        if max_dparam:
            rate = max(abs(s_lam * st.t[li]), observed[0])
            if rate * dsv > aim * max_dparam:
                dsv = max(aim * max_dparam / rate, ds_min)
        if max_dstate:
            rate = max(float(np.max(np.abs(s[:nX] * st.t[:nX]))), observed[1])
            if rate * dsv > aim * max_dstate:
                dsv = max(aim * max_dstate / rate, ds_min)
        return dsv

    n_failed = n_refused = 0
    while len(pts) < max_points:
        ds = capped(cur, ds)
        nxt = corrected(cur, ds)
        if nxt is None:
            if ds / 2 < ds_min:
                end_reason = "corrector_failed"
                end_message = (f"the corrector failed at the minimum step ds={ds:.3g} after {name} = "
                               f"{pts[-1].parameter:.8g}: no nearby continuation of the branch")
                break
            ds /= 2
            n_failed += 1
            continue
        lam_new = s_lam * nxt.u[li]
        dX = np.max(np.abs(s[:nX] * (nxt.u[:nX] - cur.u[:nX])))
        dlam = abs(lam_new - s_lam * cur.u[li])
        observed[:] = [dlam / ds, dX / ds]
        over = max(dlam / max_dparam if max_dparam else 0.0, dX / max_dstate if max_dstate else 0.0)
        if over > 1 and ds / 2 >= ds_min:  # refused: shorten in proportion (at least halve at 2x over)
            ds *= max(min(0.9 / over, 0.9), 0.25)
            n_refused += 1
            continue
        boundary = None
        if lam_new > rhi or lam_new < rlo:
            boundary = rhi if lam_new > rhi else rlo
        # special points between cur and nxt (located on the arc, before cutting at a boundary)
        k = len(pts) - 1
        found = []
        for kind in detect:
            if kind == "branch_point" and np.sign(cur.tests["fold"]) != np.sign(nxt.tests["fold"]):
                continue  # det(I - Mon) changes sign at a fold too: reported as the fold
            fa, fb = cur.tests[kind], nxt.tests[kind]
            if np.sign(fa) != np.sign(fb) and fa != 0:
                sp = locate(kind, cur, ds, fa, fb, k)
                if sp is not None and rlo - 1e-12 <= sp.parameter <= rhi + 1e-12:
                    found.append(sp)
                    say(f"  {kind} at {name} = {sp.parameter:.9g} ({sp.message})")
        specials.extend(sorted(found, key=lambda q: q.arclength))
        if boundary is not None:
            last = at_lambda(cur, nxt, boundary)
            if last is not None:
                arclen += float(np.linalg.norm(last.u - cur.u))
                pt = make_point(last, arclen, ds)
                why = check(pt)
                if why is None:
                    pts.append(pt)
                    states.append(last)
            folded = any(q.kind == "fold" for q in specials)
            end_reason = "reached_to" if boundary == (rhi if direction > 0 else rlo) else "reached_from"
            end_message = (f"{name} reached {boundary:g}" + (" after turning back at a fold" if folded
                                                              and end_reason == "reached_from" else ""))
            break
        arclen += ds
        pt = make_point(nxt, arclen, ds)
        why = check(pt)
        if why is not None:
            end_reason = why.split(":")[0]
            end_message = f"point at {name} = {pt.parameter:.8g} not accepted: {why}"
            if why == "free_parameter_bound":
                end_message += f" (free values {pt.free_values}, bounds {sysm.lo.tolist()}..{sysm.hi.tolist()})"
            break
        pts.append(pt)
        states.append(nxt)
        say(f"{name} = {pt.parameter:.6g}: {nxt.iterations} it, ds {ds:.3g}, |L|max {max(pt.moduli):.4f}"
            + (f", free {pt.free_values}" if nf else ""))
        cur = nxt
        if nxt.iterations <= 5:
            ds = min(ds * 1.5, ds_max)
        elif nxt.iterations > 9:
            ds = max(ds / 2, ds_min)
    settings["evaluations"] = sysm.evaluations
    settings["residual_evaluations"] = sysm.residual_evaluations
    settings["corrector_failures"] = n_failed   # steps halved because the corrector did not converge
    settings["refused_steps"] = n_refused       # converged steps beyond max_dparam / max_dstate
    return Branch(name, pts, specials, end_reason, end_message, settings, time.perf_counter() - t_all, free_names)


# ----------------------------------------------------------------------------------------------
# The bird

STABILITY_MARGIN = "stability_margin"
PARAM_ALIASES = ("root_ahead_m", "stability_margin", "amplitude_deg")


def resolve_parameter(key: str) -> tuple[str, str]:
    """(model key, display) for a continuation parameter: ``stability_margin`` (SM in percent, continued
    as the root position ``root_ahead_m = -SM/100 * body.reference_chord_m``), an alias or a dotted key."""
    from birdocp.studies.level import resolve_key

    k = str(key).strip()
    if k in (STABILITY_MARGIN, "SM", "sm"):
        return "wing.root_ahead_m", STABILITY_MARGIN
    rk = resolve_key(k, "PARAM")
    return rk, rk


def sm_percent(root_ahead_m: float, chord_m: float) -> float:
    """Stability margin SM = (G - O'w)/c = -root_ahead_m / c, in percent."""
    return -100.0 * float(root_ahead_m) / float(chord_m)


def root_of_sm(sm_pct: float, chord_m: float) -> float:
    return -float(sm_pct) / 100.0 * float(chord_m)


def bird_branch(cfg=None, key: str = "root_ahead_m", start_value: float = 0.05, stop_value: float = 0.035, *,
                level: bool = False, climb_rate_mps: float = 0.0, bounds=None, points: int | None = None,
                steps_per_period: int | None = None, start=None, progress=None, **options) -> Branch:
    """Continue the bird's periodic flight in one parameter (model units; for ``stability_margin`` the
    values are SM in percent). ``level=True`` holds level flight: the flapping amplitude is an unknown
    too, with the mean vertical speed held at ``climb_rate_mps`` (amplitude bounds: ``bounds`` or the
    level-flight defaults, 20..70 deg). The start is solved by Newton from ``cfg.solve.initial_guess``
    (``start``: a converged TrimResult/LimitCycleResult at the start value instead).

    The branch's ``parameter`` is the model parameter (``wing.root_ahead_m`` for SM); the SM of every
    point is added to ``settings['stability_margin_percent']`` when ``key`` is ``stability_margin``.
    A point whose shooting points have u <= 0 is rejected (not a forward flight)."""
    from birdocp.bird.config import Config
    from birdocp.studies.level import AMPLITUDE_KEY, default_bounds
    from birdocp.bird.model import get_model
    from birdocp.engine.problem import MeanCondition
    from birdocp.studies.trim import TrimResult, flight_outputs

    cfg = cfg or Config()
    model_key, display = resolve_parameter(key)
    chord = cfg.body.reference_chord_m
    a, b = float(start_value), float(stop_value)
    if display == STABILITY_MARGIN:
        a, b = root_of_sm(a, chord), root_of_sm(b, chord)
        if options.get("step"):
            options["step"] = abs(root_of_sm(options["step"], chord))  # SM percent -> metres
        if options.get("max_dparam"):
            options["max_dparam"] = abs(root_of_sm(options["max_dparam"], chord))
    m = get_model(cfg)
    _OUTPUTS = flight_outputs(m.ode.nd)
    points = int(points or cfg.solve.points)
    steps = int(steps_per_period or cfg.solve.steps_per_period)
    guess = np.asarray(cfg.solve.initial_guess, float)
    if level:
        if model_key == AMPLITUDE_KEY:
            raise ValueError("with level flight held the amplitude is solved for: continue another parameter")
        lo, hi = bounds if bounds is not None else default_bounds(cfg, AMPLITUDE_KEY)
        cond = MeanCondition(_OUTPUTS["vertical_speed_mps"], float(climb_rate_mps), "vertical_speed_mps")
        prob = LimitCycleProblem(m.ode, m.p0, guess, free={AMPLITUDE_KEY: (float(lo), float(hi))}, means=[cond],
                                 outputs={"forward_speed_mps": _OUTPUTS["forward_speed_mps"]})
    else:
        prob = LimitCycleProblem(m.ode, m.p0, guess, outputs=_OUTPUTS)
    ws = start.cycle if isinstance(start, TrimResult) else start
    options.setdefault("scales", {"states": 1.0, "free": 10.0})

    def accept(pt):
        u = np.asarray(pt.shooting_points)[:, 0]
        return None if np.all(u > 0) else f"u <= 0 at a shooting point (min {u.min():.3g} m/s)"

    br = continuation(prob, model_key, a, b, points=points, steps_per_period=steps, start=ws, accept=accept,
                      progress=progress, **options)
    br.settings.update({"key": key, "display": display, "level": bool(level), "climb_rate_mps": climb_rate_mps,
                        "reference_chord_m": chord, "config_amplitude_deg": cfg.gait.shoulder_flap.amplitude_deg})
    if display == STABILITY_MARGIN:
        br.settings["stability_margin_percent"] = [sm_percent(p.parameter, chord) for p in br.points]
    return br


# ----------------------------------------------------------------------------------------------
# Figures

def _x_of(branch: Branch, pts=None):
    """(x values, axis label) of branch points: SM in percent for the root position, else the parameter."""
    s = branch.settings
    vals = np.array([p.parameter for p in (branch.points if pts is None else pts)], float)
    if branch.parameter_name == "wing.root_ahead_m" and s.get("display", STABILITY_MARGIN) == STABILITY_MARGIN:
        return -100.0 * vals / float(s.get("reference_chord_m", 0.2)), "stability margin SM [%]"
    return vals, branch.parameter_name


def plot_branches(branches: dict, out_dir, prefix: str = "") -> list:
    """Figures of one or more branches (label -> Branch): ``locus.png`` (multipliers in the complex plane,
    coloured by the parameter, unit circle), ``moduli.png`` (moduli against the parameter, special
    points and the branch ends marked; with a free parameter a second panel shows it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path

    from birdocp.plots.figures import save_figure

    out_dir = Path(out_dir)
    paths = []
    labels = [k for k, b in branches.items() if b.points]
    if not labels:
        return paths
    marks = {"fold": ("s", "tab:red"), "branch_point": ("D", "tab:orange"), "period_doubling": ("v", "tab:purple"),
             "neimark_sacker": ("*", "tab:green")}
    # locus
    fig, axes = plt.subplots(1, len(labels), figsize=(6.2 * len(labels), 5.8), squeeze=False)
    for ax, lab in zip(axes[0], labels):
        b = branches[lab]
        x, xl = _x_of(b)
        th = np.linspace(0, 2 * np.pi, 400)
        ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8, label="unit circle")
        L = b.multipliers()
        sc = None
        for k in range(L.shape[1]):
            sc = ax.scatter(L[:, k].real, L[:, k].imag, c=x, cmap="viridis", s=18, zorder=3)
            ax.plot(L[:, k].real, L[:, k].imag, "-", color="0.6", lw=0.6, zorder=2)
        for sp in b.special_points:
            m, c = marks.get(sp.kind, ("o", "k"))
            Ls = np.array([complex(*v) for v in sp.multipliers])
            ax.plot(Ls.real, Ls.imag, m, color=c, ms=9, mfc="none", mew=2, label=f"{sp.kind}", zorder=4)
        ax.axhline(0, color="0.85", lw=0.5, zorder=0)
        ax.axvline(0, color="0.85", lw=0.5, zorder=0)
        ax.set_aspect("equal")
        lim = max(1.15, float(np.max(np.abs(L))) * 1.08)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-min(lim, 1.2), min(lim, 1.2))
        ax.set_xlabel("Re Λ")
        ax.set_ylabel("Im Λ")
        ax.set_title(f"{lab}: multipliers along the branch")
        cb = fig.colorbar(sc, ax=ax, shrink=0.7)
        cb.set_label(xl)
        h, l_ = ax.get_legend_handles_labels()
        uniq = dict(zip(l_, h))
        ax.legend(uniq.values(), uniq.keys(), loc="upper left", fontsize=8)
    fig.tight_layout()
    paths.append(save_figure(fig, out_dir / f"{prefix}locus.png"))
    plt.close(fig)
    # moduli (+ free parameter)
    has_free = any(branches[lab].free_names for lab in labels)
    fig, axes = plt.subplots(2 if has_free else 1, 1, figsize=(8, 7.5 if has_free else 4.8), sharex=True,
                             squeeze=False)
    ax = axes[0, 0]
    styles = ["-", "--", ":", "-."]
    for i, lab in enumerate(labels):
        b = branches[lab]
        x, xl = _x_of(b)
        M = np.array([p.moduli for p in b.points])
        ax.plot(x, M[:, 0], styles[i % 4], color="tab:red", marker=".", label=f"{lab}: |Λ1| (expanding)")
        for k in range(1, M.shape[1]):
            ax.plot(x, M[:, k], styles[i % 4], color="tab:blue", lw=0.8, label=f"{lab}: |Λ2..4|" if k == 1 else None)
        ax.plot(x[-1:], M[-1:, 0], "kx", ms=10, mew=2, label="branch end" if i == 0 else None)
        for sp in b.special_points:
            m, c = marks.get(sp.kind, ("o", "k"))
            xs, _ = _x_of(b, [sp])
            ax.plot(xs, [max(sp.moduli)], m, color=c, ms=9, mfc="none", mew=2, label=sp.kind)
        if has_free and b.free_names:
            F = np.array([[p.free_values[n] for n in b.free_names] for p in b.points])
            axes[1, 0].plot(x, F[:, 0], styles[i % 4], marker=".", label=f"{lab}: {b.free_names[0]}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_ylabel("|Λ|")
    ax.set_title("Floquet multipliers' moduli along the branch (|Λ| > 1: unstable)")
    h, l_ = ax.get_legend_handles_labels()
    uniq = dict(zip(l_, h))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    if has_free:
        axes[1, 0].set_ylabel("solved free parameter")
        axes[1, 0].legend(fontsize=8)
        axes[1, 0].grid(alpha=0.3)
    axes[-1, 0].set_xlabel(xl)
    fig.tight_layout()
    paths.append(save_figure(fig, out_dir / f"{prefix}moduli.png"))
    plt.close(fig)
    return paths
