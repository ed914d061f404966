"""The segment Jacobians of an :class:`~birdocp.engine.integrate.RK4Grid` (whose product is the
monodromy) from the right-hand side's state Jacobian at the RK4 stages, evaluated in batch and
chained by dense products.

One RK4 step ``x+ = x + h/6 (k1 + 2 k2 + 2 k3 + k4)`` with ``k1 = f(x1)``, ``x2 = x + h/2 k1``,
``k2 = f(x2)``, ``x3 = x + h/2 k2``, ``k3 = f(x3)``, ``x4 = x + h k3``, ``k4 = f(x4)`` (the data at
the stage times) has the exact Jacobian (chain rule, ``F_i = df/dx`` at stage i)::

    K1 = F_1,  K2 = F_2 (I + h/2 K1),  K3 = F_3 (I + h/2 K2),  K4 = F_4 (I + h K3)
    A  = I + h/6 (K1 + 2 K2 + 2 K3 + K4)

and a segment's Jacobian is the product of its steps' ``A``. The variational step of
:meth:`RK4Grid.variational_step` computes the same derivative (forward AD through the step, then
``A Phi`` in the CasADi virtual machine at every step, nx directions); here one SX Function returns
the four ``F_i`` of a step (the stage states computed inside it), mapped over a segment's steps, and
the ``nx x nx`` products run in numpy. ``F`` is formed by forward or by reverse AD, whichever has fewer
instructions (reverse wins when many states feed few intermediate sums, e.g. a flier's aerodynamic
loads summed into the body's equations). Equal to the variational pass to round-off (the sums in
another order). Measured on the ibis with dynamic stall (52 states, 148 steps; CPU, loaded 2-core
machine): the variational pass 1.18 s, this one 0.48 s (the right-hand side's Jacobian by reverse AD
has 167 000 instructions, by forward AD 327 000; the step's forward Jacobian with the ``A Phi``
product 1 960 000).

Used for the Floquet analysis after a Newton-Picard solve (the full blocks are formed only there);
the solvers that form the full shooting Jacobian at every iterate keep the variational step (its
blocks are reused at the solution).

A cheaper approximation of the monodromy, for a chord matrix (:func:`frozen_monodromy`): the
right-hand side's Jacobian ``F`` once per step, at the step's start, each step's Jacobian taken as
``I + hF + (hF)^2/2 + (hF)^3/6 + (hF)^4/24`` (RK4's step of the linearisation frozen over the step;
its error is of the order of h times F's change along the step, which only slows a chord iteration).
One Jacobian instead of four per step: 0.14 s instead of 0.48 s on the ibis with dynamic stall.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.rk4 import rk4_update

__all__ = ["stage_jacobians", "batched_segment_jacobians", "step_start_jacobians", "frozen_monodromy"]


def stage_jacobians(grid: RK4Grid) -> ca.Function:
    """``(X[nx x n], Dseg[nd x 3n], p) -> F[nx x 4 nx n]``: for each of a segment's n steps (start
    states ``X``, stage data ``Dseg``), the right-hand side's state Jacobians at its four RK4 stages,
    hstacked (step-major, then stage). Built once per grid (kept while the grid lives); an ODE
    compiled to C (``numeric.source``) is differentiated through its interpreted source.

    Parameters
    ----------
    grid : RK4Grid
        The grid (its ODE, step h and steps per segment n).

    Returns
    -------
    casadi.Function
    """
    return owned_cache(grid).build(("stage_jacobians",), lambda: _build(grid))


def _rhs_jacobian(ode, x, d, p):
    """``df/dx`` (dense SX) by forward or reverse AD, whichever has fewer instructions."""
    f = ode.rhs(x, d, p)
    fwd = ca.densify(ca.jacobian(f, x))
    rev = ca.densify(ca.jtimes(f, x, ca.DM.eye(x.numel()), True).T)
    count = [ca.Function("J", [x, d, p], [J]).n_instructions() for J in (fwd, rev)]
    return rev if count[1] < count[0] else fwd


def _state_jacobian(grid: RK4Grid) -> ca.Function:
    """``(x, d, p) -> df/dx`` (dense), built once per grid (:func:`_rhs_jacobian`) from the interpreted
    source of an ODE compiled to C."""
    def make():
        ode = getattr(grid.ode.numeric, "source", None) or grid.ode
        x, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", ode.nd), ca.SX.sym("p", ode.np)
        return ca.Function("rhs_state_jacobian", [x, d, p], [_rhs_jacobian(ode, x, d, p)])

    return owned_cache(grid).build(("rhs_state_jacobian",), make)


def _build(grid: RK4Grid) -> ca.Function:
    """:func:`stage_jacobians`, built."""
    ode = getattr(grid.ode.numeric, "source", None) or grid.ode
    nx, nd, np_ = ode.nx, ode.nd, ode.np
    x, p = ca.SX.sym("x", nx), ca.SX.sym("p", np_)
    jac = _state_jacobian(grid)
    D3 = ca.SX.sym("D3", nd, 3)
    _, stages = rk4_update(ode.rhs, x, D3, grid.h, p)
    F = ca.horzcat(*[jac(xs, D3[:, c], p) for xs, c in zip(stages, (0, 1, 1, 2))])
    step = ca.Function("rk4_stage_jacobians", [x, D3, p], [F], ["x", "D3", "p"], ["F"])
    return step.map("rk4_stage_jacobians_segment", "serial", grid.n, [2], [])


def _step_jacobians(F: np.ndarray, nx: int, n: int, h: float) -> np.ndarray:
    """The n steps' Jacobians ``A`` (n x nx x nx) from their stage Jacobians (nx x 4 nx n, as
    :func:`stage_jacobians` returns them)."""
    S = F.reshape(nx, n, 4, nx).transpose(1, 2, 0, 3)  # step, stage, row, column
    eye = np.eye(nx)
    K1 = S[:, 0]
    K2 = S[:, 1] @ (eye + h / 2 * K1)
    K3 = S[:, 2] @ (eye + h / 2 * K2)
    K4 = S[:, 3] @ (eye + h * K3)
    return eye + h / 6 * (K1 + 2 * K2 + 2 * K3 + K4)


def _dense_call(fn: ca.Function, args) -> np.ndarray:
    """``fn(*args)`` (dense numpy inputs, one dense output) through CasADi's function buffer: the
    output written straight into a numpy array (``DM.full()`` of the bird's 52 x 7696 stage Jacobians
    of a segment took 29 ms, a fifth of their evaluation)."""
    ins = [np.ascontiguousarray(np.asarray(a, float).ravel(order="F")) for a in args]
    if not fn.sparsity_out(0).is_dense() or any(fn.nnz_in(i) != a.size for i, a in enumerate(ins)):
        return fn(*args).full()
    res = np.empty(fn.nnz_out(0))
    buf, evaluate = fn.buffer()
    for i, a in enumerate(ins):
        buf.set_arg(i, memoryview(a))
    buf.set_res(0, memoryview(res))
    evaluate()
    return res.reshape(fn.size1_out(0), fn.size2_out(0), order="F")


def batched_segment_jacobians(grid: RK4Grid, points, trajectory, D, p) -> list:
    """The segment Jacobians (time order) of the orbit whose segments start at ``points``, from the
    stage Jacobians of every step (:func:`stage_jacobians`) chained in numpy: the Jacobians
    :meth:`RK4Grid.segment_jacobians` returns, to round-off.

    Parameters
    ----------
    grid : RK4Grid
        The grid.
    points : array_like (nx, S)
        The segments' start states (the shooting points).
    trajectory : array_like (nx, N)
        The states after each RK4 step, each segment integrated from its point (the steps' start
        states are the point, then this trajectory).
    D : casadi.DM
        Stage blocks, nd x 3N (:meth:`RK4Grid.blocks_numeric`).
    p : array_like or casadi.DM
        Parameters.

    Returns
    -------
    list of ndarray
        S matrices nx x nx.
    """
    nx, n, S = grid.ode.nx, grid.n, grid.S
    pts, Xt = np.asarray(points, float), np.asarray(trajectory, float)
    fn, pv = stage_jacobians(grid), np.asarray(p, float).ravel()
    out = []
    for i, Di in enumerate(np.split(np.asarray(D, float), S, axis=1)):
        starts = np.column_stack([pts[:, i], Xt[:, i * n:(i + 1) * n - 1]])
        A = _step_jacobians(_dense_call(fn, (starts, Di, pv)), nx, n, grid.h)
        J = A[0]
        for k in range(1, n):
            J = A[k] @ J
        out.append(J)
    return out


def step_start_jacobians(grid: RK4Grid) -> ca.Function:
    """``(X[nx x N], D0[nd x N], p) -> F[nx x nx N]``: the right-hand side's state Jacobian at each of
    the period's N step starts ``X`` (data ``D0``, each step's first stage column), hstacked. Built
    once per grid (kept while the grid lives).

    Parameters
    ----------
    grid : RK4Grid
        The grid (its ODE and steps per period N).

    Returns
    -------
    casadi.Function
    """
    return owned_cache(grid).build(("step_start_jacobians",), lambda: _state_jacobian(grid).map(
        "rhs_state_jacobian_period", "serial", grid.N, [2], []))


def frozen_monodromy(grid: RK4Grid, x0, X, D, p) -> np.ndarray:
    """An approximation of the one-period Jacobian ``dx_T/dx0`` of the trajectory ``X`` from ``x0`` for
    a chord matrix (module docstring): each RK4 step's Jacobian from the right-hand side's Jacobian
    at the step's start, ``A = I + hF + (hF)^2/2 + (hF)^3/6 + (hF)^4/24``, multiplied in time order.

    Parameters
    ----------
    grid : RK4Grid
        The grid.
    x0 : array_like (nx,)
        The state at t0.
    X : array_like (nx, N)
        The states after each of the N steps from ``x0``.
    D : casadi.DM
        Stage blocks, nd x 3N (:meth:`RK4Grid.blocks_numeric`).
    p : array_like or casadi.DM
        Parameters.

    Returns
    -------
    ndarray (nx, nx)
    """
    nx, N, h = grid.ode.nx, grid.N, grid.h
    starts = np.column_stack([np.asarray(x0, float), np.asarray(X, float)[:, :N - 1]])
    F = _dense_call(step_start_jacobians(grid), (starts, np.asarray(D, float)[:, 0::3],
                                                 np.asarray(p, float).ravel()))
    hF = h * F.reshape(nx, N, nx).transpose(1, 0, 2)  # step, row, column
    hF2 = hF @ hF
    A = np.eye(nx) + hF + hF2 / 2 + hF2 @ hF / 6 + hF2 @ hF2 / 24
    M = A[0]
    for k in range(1, N):
        M = A[k] @ M
    return M
