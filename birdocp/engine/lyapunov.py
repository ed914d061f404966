"""Lyapunov exponents of any ODE (forced or autonomous) by the QR (Benettin) method.

The state and k tangent vectors W (nx x k) are advanced together by the *exact* tangent of the
integrator step: ``W_{n+1} = (d step / d x) W_n``, computed by CasADi forward AD (jtimes) through
the step -- the discrete variational equations, no finite differences. Every ``renorm_time`` the
tangent vectors are re-orthonormalised by a QR factorisation, ``W = Q R``, and ``log |R_ii|`` is
accumulated; the exponents are ``lambda_i = sum log|R_ii| / t`` (1 / time unit of the system),
largest first.

Convergence estimate: the averaging time is cut into ``n_blocks`` equal blocks; the exponents of the
blocks scatter around the overall value, and ``standard_error = std(blocks) / sqrt(n_blocks)`` is the
statistical uncertainty of the result (blocks much longer than the correlation time make it a
fair estimate). ``n_exponents=1`` is the cheap case (one tangent vector, the largest exponent).
The discretisation error of the step is separate; it is controlled by ``dt`` (compare two dt).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache
from birdocp.engine.ode import ODE
from birdocp.engine.problem import finite_vector
from birdocp.engine.results import result_dict, serial
from birdocp.engine.steppers import make_step

__all__ = ["LyapunovResult", "lyapunov_exponents", "largest_lyapunov_exponent", "kaplan_yorke_dimension"]


@dataclass
class LyapunovResult:
    """Exponents (largest first, 1/time unit), their standard errors and running estimates.

    history_t / history: the running estimates of the exponents after each renormalisation
    (k columns). kaplan_yorke_dimension: when the full spectrum is computed (nan otherwise).
    """

    exponents: np.ndarray = field(metadata=serial(key="lyapunov_exponents"))
    standard_error: np.ndarray
    averaging_time: float
    dt: float
    renorm_time: float
    n_blocks: int
    block_exponents: np.ndarray = field(metadata=serial(skip=True))
    history_t: np.ndarray = field(metadata=serial(skip=True))
    history: np.ndarray = field(metadata=serial(skip=True))
    x_end: np.ndarray = field(metadata=serial(skip=True))
    kaplan_yorke_dimension: float = float("nan")
    wall_s: float = 0.0
    method: dict = field(default_factory=dict)

    @property
    def sum(self) -> float:
        return float(np.sum(self.exponents))

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`; the histories are left out).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, derived=("sum",), extra={"wall_s": {"total": self.wall_s}})


def _chunk(ode: ODE, k: int, n_sub: int, integrator: str) -> ca.Function:
    """``chunk(x, W, t, p, h) -> (x, W)`` after n_sub steps (state and tangent vectors), kept by ``ode``."""
    return owned_cache(ode).build(("tangent_chunk", k, n_sub, integrator),
                                  lambda: _build_chunk(ode, k, n_sub, integrator))


def _build_chunk(ode: ODE, k: int, n_sub: int, integrator: str) -> ca.Function:
    rhs = ode.rhs
    if ode.data is not None:  # rhs(x, d, p) with d = data(t, p): the steppers take f(x, t, p)
        xs, ts, ps = ca.MX.sym("x", ode.nx), ca.MX.sym("t"), ca.MX.sym("p", ode.np)
        rhs = ca.Function("time_rhs", [xs, ts, ps], [ode.time_rhs(xs, ts, ps)])
    step = make_step(rhs, integrator)
    S = ca.SX if step.is_a("SXFunction") else ca.MX
    x, W = S.sym("x", ode.nx), S.sym("W", ode.nx, k)
    t, p, h = S.sym("t"), S.sym("p", ode.np), S.sym("h")
    xn = step(x, t, p, h)
    Wn = ca.jtimes(xn, x, W)
    aug = ca.Function("tangent_step", [x, W, t, p, h], [xn, Wn])
    acc = aug.mapaccum("tangent_chunk", n_sub, 2)
    xm, Wm, tm, pm, hm = ca.MX.sym("x", ode.nx), ca.MX.sym("W", ode.nx, k), ca.MX.sym("t"), \
        ca.MX.sym("p", ode.np), ca.MX.sym("h")
    ts = tm + hm * ca.DM(np.arange(n_sub)).T
    Xo, Wo = acc(xm, Wm, ts, pm, hm)
    return ca.Function("tangent_chunk", [xm, Wm, tm, pm, hm], [Xo[:, -1], Wo[:, -k:]])


def _benettin(chunk, x, Q, t: float, pd, dt: float, tau: float, n: int, orient: bool = True) -> tuple:
    """``n`` chunks of length ``tau`` from state ``x`` and orthonormal tangent vectors ``Q`` at time
    ``t``, re-orthonormalised (QR) after each (with ``orient``: signs kept continuous); returns ``(x,
    Q, t, logs)`` with ``logs[c]`` the log growths of chunk ``c`` (one per tangent vector)."""
    nx, k = Q.shape
    logs = np.zeros((n, k))
    for c in range(n):
        xo, Wo = chunk(ca.DM(x), ca.DM(Q), t, pd, dt)
        x = np.asarray(xo).ravel()
        Q, R = np.linalg.qr(np.asarray(Wo).reshape(nx, k))
        d = np.diag(R)
        if orient:
            Q = Q * np.sign(np.where(d == 0, 1.0, d))  # keep a continuous orientation
        logs[c] = np.log(np.abs(d))
        t += tau
    return x, Q, t, logs


def kaplan_yorke_dimension(lam) -> float:
    """The Kaplan-Yorke dimension of a full Lyapunov spectrum ``lam`` (largest first): ``j + S_j /
    |lam_{j+1}|`` with ``j`` the largest index where the partial sum ``S_j >= 0`` (0 when the largest
    exponent is negative, nx when the sum is not).

    Parameters
    ----------
    lam : array_like
        Lyapunov exponents, largest first [1/s].

    Returns
    -------
    float
    """
    cs = np.cumsum(lam)
    if cs[0] < 0:
        return 0.0
    if cs[-1] >= 0:
        return float(len(lam))
    j = int(np.max(np.nonzero(cs >= 0)[0]))
    return float((j + 1) + cs[j] / abs(lam[j + 1]))


def lyapunov_exponents(ode: ODE, x0, p, *, t_total: float = 1000.0, dt: float = 0.01,
                       t_transient: float = 50.0, n_exponents: int | None = None,
                       renorm_time: float = 1.0, n_blocks: int = 10, t0: float = 0.0,
                       integrator: str = "rk4", seed: int = 0) -> LyapunovResult:
    """Lyapunov spectrum of ``ode`` along the trajectory from ``x0`` (QR / Benettin method).

    Parameters
    ----------
    ode : ODE
    x0, p : array_like
        Initial state and parameters.
    t_total : float
        Averaging time (time units of the system), after the transient.
    dt : float
        Integrator step (time units).
    t_transient : float
        Time integrated first (state and tangent vectors) and discarded.
    n_exponents : int, optional
        Number of exponents (default all nx; 1 = largest only).
    renorm_time : float
        Time between QR re-orthonormalisations (rounded to a multiple of dt).
    n_blocks : int
        Blocks of the averaging time for the standard error.
    t0 : float
        Start time (for a forced system).
    integrator : {"rk4", "radau", "gauss"}
    seed : int
        Seed of the random initial tangent vectors.

    Returns
    -------
    LyapunovResult
        The exponents (largest first), their standard errors and the Kaplan-Yorke dimension.
    """
    tw = time.perf_counter()
    nx = ode.nx
    k = nx if n_exponents is None else int(n_exponents)
    if not 1 <= k <= nx:
        raise ValueError(f"n_exponents must be in 1..{nx}, got {n_exponents!r}")
    if not (dt > 0 and t_total > 0 and renorm_time >= dt):
        raise ValueError("dt, t_total must be positive and renorm_time >= dt")
    if not (isinstance(n_blocks, (int, np.integer)) and n_blocks >= 1):
        raise ValueError(f"n_blocks must be a positive integer, got {n_blocks!r}")
    x0 = finite_vector(x0, "lyapunov_exponents x0", nx, f"the ODE has nx={nx}")
    p = finite_vector(p, "lyapunov_exponents p", ode.np, f"the ODE has np={ode.np}")
    n_sub = max(1, int(round(renorm_time / dt)))
    tau = n_sub * dt
    n_chunks = max(n_blocks, int(round(t_total / tau)))
    n_chunks -= n_chunks % n_blocks
    chunk = _chunk(ode, k, n_sub, integrator)
    pd = ca.DM(np.asarray(p, float))
    x = np.asarray(x0, float).ravel()
    Q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((nx, k)))
    x, Q, t, _ = _benettin(chunk, x, Q, float(t0), pd, dt, tau, int(round(t_transient / tau)), False)
    x, Q, t, logs = _benettin(chunk, x, Q, t, pd, dt, tau, n_chunks)
    if not np.all(np.isfinite(logs)):
        raise FloatingPointError("non-finite tangent growth (trajectory diverged?)")
    avg_t = n_chunks * tau
    lam = logs.sum(axis=0) / avg_t
    blocks = logs.reshape(n_blocks, -1, k).sum(axis=1) / (avg_t / n_blocks)
    se = blocks.std(axis=0, ddof=1) / np.sqrt(n_blocks) if n_blocks > 1 else np.full(k, np.nan)
    order = np.argsort(-lam)
    lam, se, blocks = lam[order], se[order], blocks[:, order]
    hist = np.cumsum(logs, axis=0)[:, order] / (tau * np.arange(1, n_chunks + 1))[:, None]
    dky = kaplan_yorke_dimension(lam) if k == nx else float("nan")
    return LyapunovResult(lam, se, avg_t, dt, tau, n_blocks, blocks, tau * np.arange(1, n_chunks + 1), hist,
                          x, dky, time.perf_counter() - tw,
                          {"integrator": integrator, "t_transient": t_transient, "n_exponents": k, "seed": seed})


def largest_lyapunov_exponent(ode: ODE, x0, p, **kw) -> LyapunovResult:
    """The largest exponent alone (one tangent vector): see :func:`lyapunov_exponents`.

    Parameters
    ----------
    ode : ODE
        The system.
    x0, p : array_like
        Initial state and parameters.
    **kw
        Keyword arguments of :func:`lyapunov_exponents` (``t_total``, ``dt``, ...).

    Returns
    -------
    LyapunovResult
        With one exponent.
    """
    kw["n_exponents"] = 1
    return lyapunov_exponents(ode, x0, p, **kw)
