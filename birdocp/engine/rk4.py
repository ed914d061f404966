"""The one RK4 formula of the package and the CasADi step Functions built from it: one step of an
:class:`~birdocp.engine.ode.ODE` with the data at its stage times (and the quadrature of outputs), and
long runs of steps as chained ``mapaccum`` pieces. :mod:`birdocp.engine.integrate` builds its grids
on these.
"""
from __future__ import annotations

import casadi as ca

from birdocp.engine.ode import ODE

__all__ = ["rk4_update", "rk4_step", "accumulate", "column_blocks", "MAPACCUM_CHUNK"]


def rk4_update(f, x, D3, h, *args):
    """One classical RK4 step of ``x' = f(x, d, *args)`` with the data at the stage times
    ``D3 = [d(t), d(t + h/2), d(t + h)]``: the one RK4 formula of the package (shooting, simulation,
    C export). Returns ``(x_next, (x1, x2, x3, x4))``, the stage states for quadratures.

    Parameters
    ----------
    f : callable
        ``f(x, d, *args) -> x'``.
    x : casadi.SX or MX
        State at t.
    D3 : casadi.SX or MX
        Data at the three stage times (3 columns).
    h : casadi.SX or float
        Step [s].
    *args
        Further arguments of ``f``.

    Returns
    -------
    tuple
        ``(x_next, (x1, x2, x3, x4))``.
    """
    d0, dm, d1 = D3[:, 0], D3[:, 1], D3[:, 2]
    x1 = x
    k1 = f(x1, d0, *args)
    x2 = x + h / 2 * k1
    k2 = f(x2, dm, *args)
    x3 = x + h / 2 * k2
    k3 = f(x3, dm, *args)
    x4 = x + h * k3
    k4 = f(x4, d1, *args)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4), (x1, x2, x3, x4)


def rk4_step(ode: ODE, outputs=()) -> ca.Function:
    """One RK4 step ``step(x, D3, p, h) -> (x_next, q_inc)``; D3 = [d(t), d(t+h/2), d(t+h)].

    ``q_inc`` (nq x 1) is the RK4 increment of the integral of each output in ``outputs`` (an output
    may return a column: its entries are integrated together, in order).

    Parameters
    ----------
    ode : ODE
        System.
    outputs : sequence of casadi.Function
        Outputs integrated along the step.

    Returns
    -------
    casadi.Function
    """
    nx, nd, np_ = ode.nx, ode.nd, ode.np
    x = ca.SX.sym("x", nx)
    D3 = ca.SX.sym("D3", nd, 3)
    p = ca.SX.sym("p", np_)
    h = ca.SX.sym("h")
    xn, (x1, x2, x3, x4) = rk4_update(ode.rhs, x, D3, h, p)
    d0, dm, d1 = D3[:, 0], D3[:, 1], D3[:, 2]
    qs = []
    for g in outputs:
        qs.append(h / 6 * (g(x1, d0, p) + 2 * g(x2, dm, p) + 2 * g(x3, dm, p) + g(x4, d1, p)))
    q = ca.vertcat(*qs) if qs else ca.SX(0, 1)
    return ca.Function("rk4_step", [x, D3, p, h], [xn, q], ["x", "D3", "p", "h"], ["xn", "q"])


MAPACCUM_CHUNK = 74
"""Longest ``mapaccum`` built in one piece. CasADi's ``mapaccum`` of the bird's RK4 step took 0.16 s to
build at 148 steps against 0.01 s at 37 or 74 (measured, CasADi 3.8.2); longer runs are chained chunks,
the same steps in the same order (results bit-identical)."""


def accumulate(f: ca.Function, n: int, x, D, *args, name: str = "acc") -> list:
    """``f.mapaccum(n)(x, D, *args)`` for a step ``f(x, D3, *args) -> (x_next, ...)``: n steps, the
    state fed back, D holding 3 data columns per step, ``args`` the same at every step. Returns the
    outputs hstacked over the n steps (as ``mapaccum``), built in chunks of at most
    :data:`MAPACCUM_CHUNK` steps.

    Parameters
    ----------
    f : casadi.Function
        One step.
    n : int
        Number of steps.
    x : casadi.MX
        Initial state.
    D : casadi.MX
        Data, 3 columns per step.
    *args
        Further inputs of ``f``, the same at every step.
    name : str
        Name of the mapaccum Functions.

    Returns
    -------
    list of casadi.MX
    """
    n = int(n)
    k = max(d for d in range(1, min(n, MAPACCUM_CHUNK) + 1) if n % d == 0)
    if k == n or k < 8:  # short, or no useful divisor (e.g. a prime count of steps): one piece
        return f.mapaccum(name, n).call([x, D, *args])
    acc = f.mapaccum(name, k)
    parts, xi = [], x
    for c, Dc in enumerate(column_blocks(D, n // k)):
        out = acc.call([xi, Dc, *args])
        parts.append(out)
        xi = out[0][:, -1]
    return [ca.horzcat(*[o[i] for o in parts]) for i in range(len(parts[0]))]


def column_blocks(D, count: int) -> list:
    """``D`` cut into ``count`` blocks of equal column counts, left to right (one ``horzsplit`` node:
    slicing an MX column range builds an index list of every nonzero, ~3 ms per block of the bird's
    stage data).

    Parameters
    ----------
    D : casadi.MX
        Matrix whose column count is a multiple of ``count``.
    count : int
        Number of blocks.

    Returns
    -------
    list of casadi.MX
    """
    n = D.size2()
    if n % count:
        raise ValueError(f"{n} columns do not split into {count} equal blocks")
    return ca.horzsplit(D, list(range(0, n + 1, n // count)))
