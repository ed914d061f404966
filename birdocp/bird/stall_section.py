"""The stall-aware section law (static and separated lift and drag, Goman–Khrabrov separation point)
and the fixed-count Newton solve of the circulation through it (:mod:`birdocp.bird.unsteady` builds
the loads from them): the last steps' matrix may be held fixed for automatic differentiation
(:data:`FROZEN_NEWTON_MATRIX`), steps beyond :data:`INLINE_NEWTON_STEPS` run detached (a call whose
derivative is declared zero)."""
from __future__ import annotations

import functools

import casadi as ca

from birdocp.engine.cache import register_cache

__all__ = ["separation_point", "lift_coefficient", "separated_drag_coefficient", "lu_solve", "factored_solve",
           "expanded_instructions", "circulation", "INLINE_NEWTON_STEPS", "FROZEN_NEWTON_MATRIX"]

def separation_point(alpha, alpha1):
    """Static separation point f0(alpha) = 1 / (1 + (alpha/alpha1)^4) (1 = attached; alpha, alpha1 in rad).

    Parameters
    ----------
    alpha, alpha1 : casadi.SX or float
        Angle of attack and angle of half separation [rad].

    Returns
    -------
    casadi.SX or float
    """
    r2 = (alpha / alpha1) ** 2
    return 1.0 / (1.0 + r2 * r2)


def lift_coefficient(alpha, f, cla, cd90):
    """C_l(alpha, f) = f C_la alpha + (1 - f) C_D90 sin(2 alpha) / 2.

    Parameters
    ----------
    alpha, f : casadi.SX
        Angle of attack [rad] and separation point [-].
    cla, cd90 : float
        Lift slope [1/rad] and drag coefficient at 90 deg [-].

    Returns
    -------
    casadi.SX
    """
    return f * cla * alpha + (1.0 - f) * 0.5 * cd90 * ca.sin(2 * alpha)


def separated_drag_coefficient(alpha, f, cd90):
    """Pressure drag of the separated part C_d,sep = (1 - f) C_D90 sin^2(alpha).

    Parameters
    ----------
    alpha, f : casadi.SX
        Angle of attack [rad] and separation point [-].
    cd90 : float
        Drag coefficient at 90 deg [-].

    Returns
    -------
    casadi.SX
    """
    return (1.0 - f) * cd90 * ca.sin(alpha) ** 2


def _lift_slope(alpha, f, cla, cd90, alpha1, total):
    """dC_l/dalpha at fixed f, plus f0'(alpha) (C_la alpha - C_D90 sin 2alpha / 2) when ``total``."""
    s = f * cla + (1.0 - f) * cd90 * ca.cos(2 * alpha)
    if total:
        f0 = separation_point(alpha, alpha1)
        df0 = -4.0 * alpha ** 3 / alpha1 ** 4 * f0 * f0
        s = s + df0 * (cla * alpha - 0.5 * cd90 * ca.sin(2 * alpha))
    return s


# Time-only data of the unsteady terms (per element; appended to the bird's data vector).
def lu_solve(A, b):
    """x = A^-1 b by Gaussian elimination without pivoting, written out in SX (about n^3/3
    multiply-adds: a third of a symbolic QR): the factors of :func:`_lu_factors`, then the
    substitutions of :func:`factored_solve`. For the lifting-line matrices I + D K, whose eigenvalues
    keep a positive real part (docs/model_unsteady.md, well-posedness); no branches on the values.

    Parameters
    ----------
    A : casadi.SX, shape (n, n)
        Matrix.
    b : casadi.SX
        Right-hand side.

    Returns
    -------
    casadi.SX
    """
    return factored_solve(_lu_factors(A), b)


def _lu_factors(A) -> ca.SX:
    """Gaussian elimination without pivoting on A alone: the packed factors (n x n), U on and above
    the diagonal, the multipliers (the unit lower triangle) below."""
    n = A.shape[0]
    a = [[A[i, j] for j in range(n)] for i in range(n)]
    for k in range(n):
        inv = 1.0 / a[k][k]
        for i in range(k + 1, n):
            m = a[i][k] * inv
            for j in range(k + 1, n):
                a[i][j] = a[i][j] - m * a[k][j]
            a[i][k] = m
    return ca.vertcat(*[ca.horzcat(*row) for row in a])


@functools.lru_cache(maxsize=8)
def _frozen_factorization(n: int) -> ca.Function:
    """A (n x n) -> its :func:`_lu_factors` (multipliers below the diagonal, U on and above), as a
    Function called (never inlined) with its derivative declared zero: the Newton matrix held fixed."""
    A = ca.SX.sym("A", n, n)
    return ca.Function(f"frozen_lu_{n}", [A], [_lu_factors(A)], {"never_inline": True, "is_diff_in": [False]})


register_cache("bird.stall_frozen_factorizations", _frozen_factorization)  # one called Function per size


def factored_solve(F, b):
    """x = A^-1 b from the factors F of :func:`_lu_factors`: the forward and the back substitution
    (about n^2 multiply-adds).

    Parameters
    ----------
    F : casadi.SX
        Packed LU factors (n x n): unit lower triangle below the diagonal, upper triangle on and above.
    b : casadi.SX
        Right-hand side (n x 1).

    Returns
    -------
    casadi.SX
        The solution x (n x 1).
    """
    n = F.shape[0]
    y = [b[i] for i in range(n)]
    for k in range(n):
        for i in range(k + 1, n):
            y[i] = y[i] - F[i, k] * y[k]
    x = [None] * n
    for i in reversed(range(n)):
        acc = y[i]
        for j in range(i + 1, n):
            acc = acc - F[i, j] * x[j]
        x[i] = acc / F[i, i]
    return ca.vertcat(*x)


INLINE_NEWTON_STEPS = 2
"""Newton steps of a stall circulation that carry the derivatives: the iterates before them are
computed in a separate Function whose derivative is declared zero (``is_diff_in``), so AD sees only
the last two steps. The values are those of all the steps, bit for bit; at the fixed point a Newton
step's derivative along its starting iterate vanishes, so first derivatives are exact up to the
residual after N_N - 1 steps and second derivatives up to the residual after N_N - 2 steps
(docs/model_unsteady.md, cost)."""

FROZEN_NEWTON_MATRIX = True
"""The differentiated Newton steps hold their matrix J = dR/dGamma fixed for AD (its factorization is
a call with a zero derivative, :func:`_frozen_factorization`): a step's derivative is then
-J^-1 (dR - J dGamma) instead of also carrying dJ J^-1 R, which the residual R makes vanish at the
fixed point (first order) and, after a first step has made dGamma the implicit-function
derivative, at second order too (docs/model_unsteady.md, cost). The values are unchanged; per
direction a step costs two triangular solves (n^2) instead of the derivative of the elimination (n^3)."""


def _newton(section, a0, cla, cd90, al1, q_t, zsum, Vn, chord, K, f_state, gam, steps, frozen=False):
    """``steps`` Newton steps of R(Gamma) = Gamma - c |Vp| C_l(alpha_E(Gamma), f) / 2 = 0 from ``gam``
    (``frozen``: the matrix held fixed for AD, :data:`FROZEN_NEWTON_MATRIX`); returns the iterate and
    the last step's residual function."""
    n = chord.shape[0]
    dyn = section == "dynamic-stall"

    def resid(g):
        aE = (a0 * (q_t - K @ g) + zsum) / Vn
        f = f_state if dyn else separation_point(aE, al1)
        return g - 0.5 * chord * Vn * lift_coefficient(aE, f, cla, cd90), aE, f

    for _ in range(steps):
        R, aE, f = resid(gam)
        slope = _lift_slope(aE, f, cla, cd90, al1, total=not dyn)
        J = ca.SX.eye(n) + a0 * ca.diag(0.5 * chord * slope) @ K
        gam = gam - (factored_solve(_frozen_factorization(n)(J), R) if frozen else lu_solve(J, R))
    return gam, resid


def _linear_start(a0, cla, q_t, zsum, chord, K):
    """The linear lifting-line solve (I + A0 H K) Gamma = H (A0 q~ + z1 + z2), H = diag(c C_la / 2)."""
    h = 0.5 * chord * cla
    return lu_solve(ca.SX.eye(chord.shape[0]) + a0 * ca.diag(h) @ K, h * (a0 * q_t + zsum))


@functools.lru_cache(maxsize=16)
def _detached_newton(section: str, n: int, steps: int) -> ca.Function:
    """(a0, cla, cd90, alpha1, q~, z1 + z2, |Vp|, c, K, f) -> the linear start and ``steps`` Newton
    steps, as a Function called (never inlined) with its derivative declared zero."""
    sc = [ca.SX.sym(k) for k in ("a0", "cla", "cd90", "alpha1")]
    cols = [ca.SX.sym(k, n) for k in ("q_t", "zsum", "Vn", "chord", "f")]
    K = ca.SX.sym("K", n, n)
    q_t, zsum, Vn, chord, f = cols
    gam = _linear_start(sc[0], sc[1], q_t, zsum, chord, K)
    gam, _ = _newton(section, *sc, q_t, zsum, Vn, chord, K, f, gam, steps)
    args = sc + cols[:4] + [K, f]
    return ca.Function(f"newton_start_{section.replace('-', '_')}_{steps}", args, [gam],
                       {"never_inline": True, "is_diff_in": [False] * len(args)})


register_cache("bird.stall_newton_starts", _detached_newton)  # one called Function per (section, size, steps)


def expanded_instructions(f: ca.Function, section: str, n: int, newton_steps: int, evaluations: int = 1) -> int:
    """CasADi instructions of an SX Function ``f`` that evaluates the section model ``evaluations``
    times, with the calls of :func:`_detached_newton` and of :func:`_frozen_factorization` of each
    evaluation counted as the instructions they run (``n_instructions`` counts a call as one; their
    derivatives are zero by declaration).

    Parameters
    ----------
    f : casadi.Function
        SX Function.
    section : str
        ``aero.section``.
    n : int
        Number of elements.
    newton_steps : int
        Newton steps of the section model.
    evaluations : int
        Evaluations of the section model in ``f``.

    Returns
    -------
    int
    """
    total = int(f.n_instructions())
    if section == "linear":
        return total
    inline = min(newton_steps, INLINE_NEWTON_STEPS)
    if FROZEN_NEWTON_MATRIX and inline:
        total += evaluations * inline * (_frozen_factorization(n).n_instructions() - 1)
    if newton_steps <= INLINE_NEWTON_STEPS:
        return total
    inner = _detached_newton(section, n, newton_steps - INLINE_NEWTON_STEPS).n_instructions()
    return total + evaluations * (inner - 1)


def circulation(opts, prm, q_t, zsum, Vn, chord, K, f_state):
    """Gamma (n x 1) and the final relative Newton residual (0 for a linear section): the linear
    lifting-line solve, then for a stall section a fixed count of Newton steps (the ones before the
    last :data:`INLINE_NEWTON_STEPS` in :func:`_detached_newton`).

    Parameters
    ----------
    opts : dict
        Section options: ``section`` (``aero.section``) and ``newton_steps`` (``aero.newton_steps``).
    prm : dict
        Section parameters: ``a0`` the immediate share of the Wagner response (1 - A1 - A2 times the
        Wagner weight; 1 without lag states), ``cla`` lift slope [1/rad], and for a stall section
        ``cd90`` (normal-force coefficient at 90 deg) and ``alpha1`` (separation angle [rad]).
    q_t : casadi.SX
        Quasi-steady normalwash of each element (normal-plane speed times angle, plus the 3/4-chord
        pitch-rate term) [m/s] (n x 1), before the trailing-wake downwash.
    zsum : casadi.SX
        Wagner lag-state sum per element [m/s] (n x 1; zero without lag states).
    Vn : casadi.SX
        Element normal-plane air speeds [m/s] (n x 1).
    chord : casadi.SX
        Element chords [m] (n x 1).
    K : casadi.SX
        Trailing-wake downwash influence matrix [1/m] (n x n): downwash = K Gamma.
    f_state : casadi.SX or None
        Dynamic-stall separation states (n x 1), or None for the static separation point.

    Returns
    -------
    tuple of casadi.SX
        Circulation Gamma [m^2/s] (n x 1) and the final relative Newton residual.
    """
    a0, cla = prm["a0"], prm["cla"]
    n = chord.shape[0]
    if opts["section"] == "linear":
        return _linear_start(a0, cla, q_t, zsum, chord, K), ca.SX(0)
    cd90, al1 = prm["cd90"], prm["alpha1"]
    steps = int(opts["newton_steps"])
    inline = min(steps, INLINE_NEWTON_STEPS)
    f = f_state if f_state is not None else ca.SX.zeros(n, 1)
    if steps > inline:
        gam = _detached_newton(opts["section"], n, steps - inline)(a0, cla, cd90, al1, q_t, zsum, Vn, chord, K, f)
    else:
        gam = _linear_start(a0, cla, q_t, zsum, chord, K)
    gam, resid = _newton(opts["section"], a0, cla, cd90, al1, q_t, zsum, Vn, chord, K, f_state, gam, inline,
                         frozen=FROZEN_NEWTON_MATRIX)
    R, _, _ = resid(gam)
    rel = ca.mmax(ca.fabs(R)) / ca.mmax(ca.fabs(gam))
    return gam, rel
