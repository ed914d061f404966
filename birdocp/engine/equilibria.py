"""Equilibria of ``x' = f(x, p)``, their continuation in one parameter, Hopf points, and the
periodic orbit born at a Hopf point.

* :func:`find_equilibrium`: damped Newton on f(x, p) = 0 with the exact Jacobian (CasADi AD).
* :class:`EquilibriumBranchIterator` (collected by :func:`continue_equilibria`): pseudo-arclength
  continuation of f(x, p) = 0 in one parameter
  (tangent predictor, Newton corrector on the bordered system), eigenvalues at every point;
  detects Hopf points (a complex pair crosses the imaginary axis) and folds (the parameter
  component of the tangent changes sign), and locates each Hopf point to round-off by a secant
  iteration on the real part of the critical pair.
* :func:`orbit_from_hopf`: the periodic orbit of amplitude ``eps`` born at a Hopf point. Its guess
  is ``x_H + eps Re(v e^{i theta})`` with v the critical eigenvector (omega the critical frequency,
  period guess 2 pi / omega); the shooting system has the parameter as an extra unknown and two
  linear rows: the section ``(X_0 - x_H) . Im v = 0`` (orthogonal to the orbit's velocity at
  theta = 0) and the amplitude ``(X_0 - x_H) . Re v / |Re v| = eps`` (v rotated so Re v _|_ Im v,
  Re v the major axis: eps is the distance of X_0 from the Hopf equilibrium along that axis).
  The parameter offset then comes out ~ eps^2 (the square-root law of a generic Hopf point; its sign
  tells super- from subcritical). :func:`hopf_branch` repeats this for a list of amplitudes, each
  warm-started from the previous orbit.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Iterator

import numpy as np

from birdocp.engine.continuation.step import ContinuationStep, RunOnce
from birdocp.engine.ode import ODE
from birdocp.engine.equilibria_linear import critical_pair, ode_jacobians, sorted_eig  # noqa: F401
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_result import OrbitResult
from birdocp.engine.orbits import solve_orbit_system
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.problem import finite_vector
from birdocp.engine.results import result_dict, serial

__all__ = ["Equilibrium", "EquilibriumBranch", "HopfPoint", "find_equilibrium", "continue_equilibria",
           "locate_hopf", "orbit_from_hopf", "hopf_branch",
           "ode_jacobians", "sorted_eig", "critical_pair",
           "EquilibriumPoint", "EquilibriumFold", "EquilibriumBranchIterator"]


@dataclass
class Equilibrium:
    """An equilibrium: x, p, residual max|f|, eigenvalues (largest real part first), stable."""

    success: bool
    status: str
    x: np.ndarray
    p: np.ndarray
    residual: float
    iterations: int
    eigenvalues: np.ndarray = field(metadata=serial(complex=True))
    eigenvectors: np.ndarray = field(metadata=serial(skip=True))
    stable: bool

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`; eigenvectors left out).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


@dataclass
class HopfPoint:
    """A Hopf point: parameter ``param`` (index) at value ``p[param]``, equilibrium x, critical
    frequency omega (rad per time unit), eigenvector v (complex, Re v _|_ Im v, |v| = 1)."""

    x: np.ndarray
    p: np.ndarray
    param: int
    omega: float
    eigenvector: np.ndarray = field(metadata=serial(skip=True))
    real_part: float  # residual of the location (real part of the critical pair)

    @property
    def period(self) -> float:
        """The period 2 pi / omega of the orbit born here (time units)."""
        return 2 * np.pi / self.omega

    @property
    def kind(self) -> str:
        """``"hopf"`` (a special point of an equilibrium branch)."""
        return "hopf"

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`, with the period).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, derived=("period",))


@dataclass
class EquilibriumBranch:
    """Points of a continued equilibrium branch: params (values of the continued parameter), x (K x nx),
    eigenvalues (K x nx), stable (K), hopf (located HopfPoints), folds (indices of fold brackets);
    ``status`` ``ok``, ``no_start``, ``corrector_failed`` or ``incomplete`` (collected from an
    iterator that was left early)."""

    param: int
    params: np.ndarray
    x: np.ndarray
    eigenvalues: np.ndarray = field(metadata=serial(complex=True))
    stable: np.ndarray
    hopf: list = field(default_factory=list)
    folds: list = field(default_factory=list)
    status: str = "ok"
    message: str = ""

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`; the Hopf points nested).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


def find_equilibrium(ode: ODE, p, x_guess, *, tol: float = 1e-12, max_iter: int = 50, t: float = 0.0) -> Equilibrium:
    """Damped Newton on f(x, p) = 0 (exact Jacobian); eigenvalues of df/dx at the result.

    Parameters
    ----------
    ode : ODE
        The system (autonomous, or forced at the frozen time ``t``).
    p : array_like
        Its parameters.
    x_guess : array_like
        The starting state.
    tol : float
        Convergence: max |f| at most ``tol``.
    max_iter : int
        Newton iterations.
    t : float
        The time at which a forced system is frozen.

    Returns
    -------
    Equilibrium
        ``success``, ``x``, ``eigenvalues`` of df/dx, ``stable`` and the residual.
    """
    p = finite_vector(p, "find_equilibrium p", ode.np, f"the ODE has np={ode.np}")
    x = finite_vector(x_guess, "find_equilibrium x_guess", ode.nx, f"the ODE has nx={ode.nx}").copy()
    f = ode.evaluate(x, t, p)
    it, status = 0, "max_iter"
    while it < max_iter:
        r = float(np.max(np.abs(f)))
        if not np.isfinite(r):
            status = "nan"
            break
        if r <= tol:
            status = "converged"
            break
        J, _ = ode_jacobians(ode, x, p, t)
        try:
            dx = np.linalg.solve(J, -f)
        except np.linalg.LinAlgError:
            status = "singular"
            break
        a = 1.0
        while a > 1e-4:
            fn = ode.evaluate(x + a * dx, t, p)
            if np.all(np.isfinite(fn)) and np.linalg.norm(fn) < np.linalg.norm(f) * (1 - 1e-4 * a) + 1e-300:
                break
            a /= 2
        x, f = x + a * dx, ode.evaluate(x + a * dx, t, p)
        it += 1
    r = float(np.max(np.abs(f)))
    if status == "max_iter" and r <= tol:
        status = "converged"
    J, _ = ode_jacobians(ode, x, p, t)
    lam, V = sorted_eig(J) if np.all(np.isfinite(J)) else (np.full(ode.nx, np.nan + 0j), np.eye(ode.nx, dtype=complex))
    return Equilibrium(status == "converged", status, x, p, r, it, lam, V, bool(np.all(lam.real < 0)))


def locate_hopf(ode: ODE, p, param, x_guess, bracket, *, tol: float = 1e-12, max_iter: int = 60) -> HopfPoint | None:
    """Hopf point in ``bracket = (a, b)`` of parameter ``param``: the real part of the critical complex
    pair changes sign in the bracket; secant steps safeguarded by bisection (Illinois), the
    equilibrium re-solved by Newton at each trial value.

    Parameters
    ----------
    ode : ODE
        System.
    p : array_like
        Parameters.
    param : int or str
        The parameter varied.
    x_guess : array_like
        Equilibrium guess.
    bracket : (float, float)
        Parameter interval.
    tol : float
        Tolerance on the parameter.
    max_iter : int
        Largest number of steps.

    Returns
    -------
    HopfPoint or None
    """
    j = ode.param_index(param)
    p = np.asarray(p, float).ravel().copy()
    xg = np.asarray(x_guess, float).ravel()

    def h(val, xg):
        pp = p.copy()
        pp[j] = val
        e = find_equilibrium(ode, pp, xg)
        k = critical_pair(e.eigenvalues)
        return (e.eigenvalues[k].real if k is not None and e.success else np.nan), e, k

    a, b = map(float, bracket)
    fa, ea, _ = h(a, xg)
    fb, eb, _ = h(b, ea.x)
    if not (np.isfinite(fa) and np.isfinite(fb)) or fa * fb > 0:
        return None
    side = 0
    e, k = ea, None
    for _ in range(max_iter):
        c = b - fb * (b - a) / (fb - fa)
        if not (min(a, b) < c < max(a, b)):
            c = 0.5 * (a + b)
        fc, e, k = h(c, ea.x if abs(c - a) < abs(c - b) else eb.x)
        if not np.isfinite(fc):
            return None
        if abs(fc) <= tol or abs(b - a) < 1e-15 * (1 + abs(c)):
            break
        if fc * fb < 0:
            a, fa, ea = b, fb, eb
            b, fb, eb = c, fc, e
            side = 0
        else:
            b, fb, eb = c, fc, e
            fa = fa / 2 if side == 1 else fa
            side = 1
    lam, V = e.eigenvalues, e.eigenvectors
    v = V[:, k]
    # rotate v so that Re v _|_ Im v (then x_H + eps Re(v e^{i theta}) is an ellipse with axes Re v, Im v)
    vr, vi = v.real, v.imag
    phi = 0.5 * np.arctan2(-2 * vr @ vi, vr @ vr - vi @ vi)
    v = v * np.exp(1j * phi)
    v = v / np.linalg.norm(v)
    if np.linalg.norm(v.real) < np.linalg.norm(v.imag):
        v = v * 1j  # Re v the major axis
    return HopfPoint(e.x.copy(), e.p.copy(), j, float(lam[k].imag), v, float(lam[k].real))


def continue_equilibria(ode: ODE, p, param, x_start, stop, *, ds: float = 0.05, max_points: int = 500,
                        tol: float = 1e-11, locate: bool = True) -> EquilibriumBranch:
    """Pseudo-arclength continuation of f(x, p) = 0 in ``param`` from ``(x_start, p[param])`` towards
    ``stop`` (a parameter value), with eigenvalues; Hopf points located to ``tol``.

    The collector over :class:`EquilibriumBranchIterator` (the iterator behind
    :func:`birdocp.engine.iter_branch` for equilibria).

    Parameters
    ----------
    ode : ODE
        The system.
    p : array_like
        Its parameters (the continued one's value is the start).
    param : str or int
        The continuation parameter.
    x_start : array_like
        An equilibrium (or a guess of one) at the start.
    stop : float
        The parameter value where the branch should end.
    ds : float
        Arclength step.
    max_points : int
        Largest number of points.
    tol : float
        Newton tolerance of each point and of the located Hopf points.
    locate : bool
        Locate Hopf points and folds between points.

    Returns
    -------
    EquilibriumBranch
        The points with their eigenvalues, the Hopf points and folds.
    """
    from birdocp.engine.continuation import collect

    return collect(EquilibriumBranchIterator(ode, p, param, x_start, stop, ds=ds, max_points=max_points, tol=tol,
                                             locate=locate))


@dataclass
class EquilibriumPoint:
    """One point of an equilibrium branch: the parameter value, the equilibrium ``x``, the eigenvalues
    of df/dx (largest real part first), ``stable``, the arclength ``step`` that produced it (0 for the
    first) and the parameter component of the unit tangent ``tangent_parameter``."""

    parameter: float
    x: np.ndarray
    eigenvalues: np.ndarray = field(metadata=serial(complex=True))
    stable: bool
    step: float
    tangent_parameter: float

    @property
    def state(self) -> np.ndarray:
        """The equilibrium."""
        return self.x

    @property
    def spectrum(self) -> np.ndarray:
        """The eigenvalues of df/dx."""
        return self.eigenvalues

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


@dataclass
class EquilibriumFold:
    """A fold of an equilibrium branch: the parameter component of the tangent changes sign between
    the points ``between`` (the parameter there is ``parameter_range``; not located further)."""

    index: int
    between: tuple
    parameter_range: tuple
    kind: str = "fold"

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self)


class EquilibriumBranchIterator(RunOnce):
    """A branch of equilibria of ``ode``, followed as it is iterated (once).

    The arguments are those of :func:`birdocp.engine.equilibria.continue_equilibria`. After (or
    during) the iteration ``points``, ``hopf``, ``folds``, ``status`` and ``message`` hold what was
    found so far and :meth:`branch` returns it as an :class:`~birdocp.engine.equilibria.EquilibriumBranch`.
    """

    def __init__(self, ode: ODE, p, param, x_start, stop: float, *, ds: float = 0.05, max_points: int = 500,
                 tol: float = 1e-11, locate: bool = True):
        self.ode, self.j = ode, ode.param_index(param)
        self.p = np.asarray(p, float).ravel().copy()
        if not np.isfinite(stop):
            raise ValueError(f"continue_equilibria: stop must be a finite parameter value, got {stop!r}")
        self.x_start, self.stop = x_start, float(stop)
        self.ds, self.max_points, self.tol, self.locate = ds, max_points, tol, locate
        self.direction = np.sign(stop - self.p[self.j]) or 1.0
        self.points: list = []
        self.hopf: list = []
        self.folds: list = []
        self.status, self.message = "incomplete", "the iteration was left before the branch ended"
        self._started = False

    def _pp(self, lam: float) -> np.ndarray:
        pp = self.p.copy()
        pp[self.j] = lam
        return pp

    def _F(self, u):
        return self.ode.evaluate(u[:self.ode.nx], 0.0, self._pp(u[-1]))

    def _DF(self, u):
        fx, fp = ode_jacobians(self.ode, u[:self.ode.nx], self._pp(u[-1]))
        return np.hstack([fx, fp[:, [self.j]]])

    def _tangent(self, u, prev=None):
        _, _, Vt = np.linalg.svd(self._DF(u))
        t = Vt[-1]
        if prev is None:
            t = t * np.sign(t[-1] * self.direction or 1.0)
        elif t @ prev < 0:
            t = -t
        return t / np.linalg.norm(t)

    def _correct(self, u, t, h):
        """Newton on the bordered system from the predictor ``u + h t``; None if it fails."""
        un = u + h * t
        for _ in range(20):
            r = np.concatenate([self._F(un), [t @ (un - u) - h]])
            if not np.all(np.isfinite(r)):
                return None
            if np.max(np.abs(r)) <= self.tol:
                return un
            try:
                un = un - np.linalg.solve(np.vstack([self._DF(un), t[None, :]]), r)
            except np.linalg.LinAlgError:
                return None
        return None

    def _emit(self, u, lam, t, h, found) -> ContinuationStep:
        nx = self.ode.nx
        pt = EquilibriumPoint(float(u[-1]), u[:nx].copy(), lam, bool(np.all(lam.real < 0)), float(h), float(t[-1]))
        self.points.append(pt)
        return ContinuationStep(len(self.points) - 1, pt, found)

    def _run(self) -> Iterator[ContinuationStep]:
        e0 = find_equilibrium(self.ode, self.p, self.x_start)
        if not e0.success:
            self.status, self.message = "no_start", f"no equilibrium at the start ({e0.status})"
            return
        u = np.concatenate([e0.x, [self.p[self.j]]])
        t = self._tangent(u)
        yield self._emit(u, e0.eigenvalues, t, 0.0, [])
        h = self.ds
        while len(self.points) < self.max_points:
            if (u[-1] - self.stop) * self.direction >= 0:
                break
            un = self._correct(u, t, h)
            if un is None:
                h /= 2
                if h < 1e-8 * self.ds:
                    self.status, self.message = "corrector_failed", f"corrector failed at param={u[-1]:.6g}"
                    break
                continue
            tn = self._tangent(un, t)
            lam, _ = sorted_eig(ode_jacobians(self.ode, un[:self.ode.nx], self._pp(un[-1]))[0])
            found = self._special(u, t, un, tn, lam)
            u, t = un, tn
            yield self._emit(u, lam, t, h, found)
            h = min(1.5 * h, 4 * self.ds)
        if self.status == "incomplete":
            self.status, self.message = "ok", ""

    def _special(self, u, t, un, tn, lam) -> list:
        """The fold and the Hopf point between ``u`` and ``un`` (recorded in ``folds`` / ``hopf``)."""
        found = []
        i = len(self.points)
        if tn[-1] * t[-1] < 0:
            self.folds.append(i)
            found.append(EquilibriumFold(i, (i - 1, i), (float(u[-1]), float(un[-1]))))
        prev = self.points[-1].eigenvalues
        kp, kn = critical_pair(prev), critical_pair(lam)
        if self.locate and kp is not None and kn is not None and prev[kp].real * lam[kn].real < 0:
            hp = locate_hopf(self.ode, self.p, self.j, u[:self.ode.nx], (u[-1], un[-1]))
            if hp is not None:
                self.hopf.append(hp)
                found.append(hp)
        return found

    def branch(self) -> EquilibriumBranch:
        """The branch followed so far (all of it after the iteration ended).

        Returns
        -------
        EquilibriumBranch
        """
        nx = self.ode.nx
        if not self.points:
            return EquilibriumBranch(self.j, np.zeros(0), np.zeros((0, nx)), np.zeros((0, nx)), np.zeros(0, bool),
                                     status=self.status, message=self.message)
        P = np.array([np.concatenate([pt.x, [pt.parameter]]) for pt in self.points])
        return EquilibriumBranch(self.j, P[:, -1], P[:, :nx], np.array([pt.eigenvalues for pt in self.points]),
                                 np.array([pt.stable for pt in self.points]), list(self.hopf), list(self.folds),
                                 self.status, self.message)


def orbit_from_hopf(ode: ODE, hopf: HopfPoint, amplitude: float, method: OrbitMethod = OrbitMethod(points=5, steps_per_period=100),
                    warm_start: OrbitResult | None = None) -> OrbitResult:
    """The periodic orbit of amplitude ``amplitude`` (along Re v) born at ``hopf``; the continued
    parameter is an unknown (``result.p[hopf.param]``, also in ``result.free_values``). A method
    without steps_per_period gets 128 (rounded to the segments); the result's error estimate says
    whether that is enough.

    Parameters
    ----------
    ode : ODE
        The system.
    hopf : HopfPoint
        A located Hopf point (from :func:`continue_equilibria` or :func:`locate_hopf`).
    amplitude : float
        The orbit's amplitude along Re v (small: the orbit near the Hopf point).
    method : OrbitMethod
        Shooting points, steps, integrator and solver.
    warm_start : OrbitResult, optional
        A previous orbit that starts the solve.

    Returns
    -------
    OrbitResult
        The orbit, the parameter solved (its sign tells super- from subcritical).
    """
    if not ode.autonomous:
        raise ValueError("orbit_from_hopf: the ODE must be autonomous")
    if not (np.isfinite(amplitude) and amplitude != 0):
        raise ValueError(f"orbit_from_hopf: amplitude must be a non-zero finite number, got {amplitude!r}")
    method.validate()
    nx, S = ode.nx, method.points - 1
    if method.steps_per_period is None:  # a fixed grid here; its error estimate is in the result
        method = replace(method, steps_per_period=S * int(np.ceil(128 / S)))
    v = hopf.eigenvector
    vr, vi = v.real, v.imag
    xh = hopf.x
    T = hopf.period
    if warm_start is not None:
        pts = warm_start.shooting_points
        T = warm_start.period
        p0 = warm_start.p.copy()
    else:
        th = 2 * np.pi * np.arange(S + 1) / S
        # x(t) = x_H + eps Re(v e^{i omega t}) solves the linearisation at the Hopf point
        pts = np.array([xh + amplitude / np.linalg.norm(vr) * (vr * np.cos(a) - vi * np.sin(a)) for a in th])
        p0 = hopf.p.copy()
    prob = OrbitProblem(ode, p0, pts, period_guess=T)
    # the automatic phase row (the section through x_ref = x_H + eps Re v orthogonal to f(x_ref), i.e.
    # ~ orthogonal to Im v) plus the amplitude row; the parameter is the extra unknown
    nz = nx * (S + 1) + 2
    A = np.zeros((1, nz))
    nr = np.linalg.norm(vr)
    A[0, :nx] = vr / nr
    b = np.array([xh @ vr / nr + amplitude])
    z0 = np.concatenate([np.asarray(pts).ravel(), [T, p0[hopf.param]]])
    return solve_orbit_system(prob, method, None, free_idx=(hopf.param,), lin=(A, b), z_start=z0,
                        x_ref=xh + amplitude * vr / np.linalg.norm(vr))


def hopf_branch(ode: ODE, hopf: HopfPoint, amplitudes, method: OrbitMethod = OrbitMethod(points=5, steps_per_period=100)) -> list:
    """Orbits at increasing amplitudes from a Hopf point, each warm-started from the previous one.

    Parameters
    ----------
    ode : ODE
        System.
    hopf : HopfPoint
        Start.
    amplitudes : sequence of float
        Amplitudes of the orbits.
    method : OrbitMethod
        Method of the orbit solves.

    Returns
    -------
    list
        The orbits.
    """
    out, prev = [], None
    for a in amplitudes:
        r = orbit_from_hopf(ode, hopf, float(a), method, warm_start=prev)
        out.append(r)
        prev = r if r.success else prev
    return out
