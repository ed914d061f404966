"""One-step integrators with exact derivatives, as CasADi Functions ``step(x, t, q, h) -> x_next``.

* ``"rk4"``: classical explicit Runge-Kutta, order 4 (SX, cheapest per step).
* ``"radau"``: Radau IIA, 3 stages, order 5, L-stable: for stiff orbits (e.g. the redox
  oscillator, whose fast relaxation makes an explicit scheme take thousands of steps per period).
* ``"gauss"``: Gauss-Legendre, 2 stages, order 4, A-stable and symplectic.

The implicit stage equations ``K_i = f(x + h sum_j a_ij K_j, t + c_i h, q)`` are solved by a CasADi
``rootfinder`` (Newton with the exact stage Jacobian, from the linearly implicit slope
K_i = (I - h J)^-1 f(x), J = df/dx(x), which stays in Newton's basin when h |lambda| >> 1). A stage solve that does not
converge (stage residual above 1e-8 (1 + max|K|)) makes the step return NaN instead of an unconverged
value: the shooting solvers treat it as a failed evaluation and shorten their step, and no orbit can
be "found" on a discrete map that is not the Radau/Gauss one. CasADi differentiates the rootfinder by the
implicit function theorem, so the derivatives of a step with respect to x, t, q and h are exact (to
the Newton tolerance), and the segment Jacobians / monodromy built on them are too.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["METHOD_ORDER", "make_step", "make_variational_step", "tableau"]

METHOD_ORDER = {"rk4": 4, "radau": 5, "gauss": 4}


def tableau(method: str):
    """Butcher tableau (A, b, c) of an implicit method ("radau" or "gauss") as numpy arrays.

    Parameters
    ----------
    method : {"radau", "gauss"}
        Implicit method.

    Returns
    -------
    A, b, c : ndarray
    """
    if method == "radau":
        s6 = np.sqrt(6.0)
        A = np.array([[(88 - 7 * s6) / 360, (296 - 169 * s6) / 1800, (-2 + 3 * s6) / 225],
                      [(296 + 169 * s6) / 1800, (88 + 7 * s6) / 360, (-2 - 3 * s6) / 225],
                      [(16 - s6) / 36, (16 + s6) / 36, 1 / 9]])
        c = np.array([(4 - s6) / 10, (4 + s6) / 10, 1.0])
        return A, A[-1].copy(), c
    if method == "gauss":
        s3 = np.sqrt(3.0)
        A = np.array([[0.25, 0.25 - s3 / 6], [0.25 + s3 / 6, 0.25]])
        return A, np.array([0.5, 0.5]), np.array([0.5 - s3 / 6, 0.5 + s3 / 6])
    raise ValueError(f"no implicit tableau for {method!r}")


def make_step(rhs: ca.Function, method: str = "rk4", *, newton_tol: float = 1e-13) -> ca.Function:
    """One step ``step(x, t, q, h) -> x_next`` of ``x' = rhs(x, t, q)``.

    Parameters
    ----------
    rhs : casadi.Function
        (x[nx], t[1], q[nq]) -> xdot[nx], preferably SX.
    method : {"rk4", "radau", "gauss"}
    newton_tol : float
        Absolute tolerance of the stage Newton iteration (implicit methods).

    Returns
    -------
    casadi.Function
    """
    if method not in METHOD_ORDER:
        raise ValueError(f"integrator must be one of {sorted(METHOD_ORDER)}, got {method!r}")
    nx, nq = rhs.size1_in(0), rhs.size1_in(2)
    x = ca.SX.sym("x", nx)
    t = ca.SX.sym("t")
    q = ca.SX.sym("q", nq)
    h = ca.SX.sym("h")
    if method == "rk4":
        k1 = rhs(x, t, q)
        k2 = rhs(x + h / 2 * k1, t + h / 2, q)
        k3 = rhs(x + h / 2 * k2, t + h / 2, q)
        k4 = rhs(x + h * k3, t + h, q)
        return ca.Function("rk4_step", [x, t, q, h], [x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)],
                           ["x", "t", "q", "h"], ["x_next"])
    xm, tm, qm, hm = ca.MX.sym("x", nx), ca.MX.sym("t"), ca.MX.sym("q", nq), ca.MX.sym("h")
    xn = _implicit_step(rhs, method, newton_tol, xm, tm, qm, hm)[0]
    return ca.Function(f"{method}_step", [xm, tm, qm, hm], [xn], ["x", "t", "q", "h"], ["x_next"])


def _stage_residual(rhs, method: str, x, t, q, h, K):
    """The implicit stage equations ``K_i - rhs(x + h sum_j a_ij K_j, t + c_i h, q)`` (stacked)."""
    A, _, c = tableau(method)
    s, nx = len(c), x.numel()
    Km = ca.reshape(K, nx, s)
    return ca.vertcat(*[Km[:, i] - rhs(x + h * sum(float(A[i, j]) * Km[:, j] for j in range(s)), t + float(c[i]) * h, q)
                        for i in range(s)])


def _implicit_step(rhs, method: str, newton_tol: float, xm, tm, qm, hm):
    """(x_next, stages K, failed flag) of one implicit step from the MX symbols (x, t, q, h)."""
    nx, nq = rhs.size1_in(0), rhs.size1_in(2)
    _, b, _ = tableau(method)
    s = len(b)
    K, x, t, q, h = ca.SX.sym("K", nx * s), ca.SX.sym("x", nx), ca.SX.sym("t"), ca.SX.sym("q", nq), ca.SX.sym("h")
    G = ca.Function("stages", [K, ca.vertcat(x, t, q, h)], [_stage_residual(rhs, method, x, t, q, h, K)])
    solver = ca.rootfinder(f"{method}_stages", "newton", G,
                           {"abstol": newton_tol, "abstolStep": 1e-15, "max_iter": 50,
                            "error_on_fail": False, "show_eval_warnings": False})
    # stage start: the linearly implicit (backward-Euler) slope (I - h J)^-1 f(x) rather than f(x): for a
    # stiff system with h |lambda| >> 1 the latter is far outside Newton's basin (the redox oscillator
    # from the reference toolbox's guess); it changes where Newton starts, not what it converges to
    f0 = rhs(xm, tm, qm)
    Jx = ca.jacobian(f0, xm)
    k0 = ca.solve(ca.MX.eye(nx) - hm * Jx, f0, "qr")
    Kv = solver(ca.repmat(k0, s, 1), ca.vertcat(xm, tm, qm, hm))
    Km = ca.reshape(Kv, nx, s)
    xn = xm + hm * sum(float(b[j]) * Km[:, j] for j in range(s))
    # NaN when Newton did not converge (a short-circuit conditional: only the taken branch is
    # evaluated, and both branches are constants, so the derivatives of a converged step are untouched)
    bad = ca.mmax(ca.fabs(G(Kv, ca.vertcat(xm, tm, qm, hm)))) > 1e-8 * (1 + ca.mmax(ca.fabs(Kv)))
    return xn + ca.if_else(bad, ca.MX(np.nan), ca.MX(0.0), True), Kv, bad


def make_variational_step(rhs: ca.Function, method: str = "rk4", *, newton_tol: float = 1e-13) -> ca.Function:
    """One step of the state and of its sensitivities (the discrete variational equation):
    ``aug(a, t, q, h) -> a_next`` with ``a = [x; vec(P)]``, ``P = [Px, Pq]`` (nx x (nx + nq),
    column-major) the derivatives of x with respect to the start point and to q, and

    ``x_next = step(x)``,  ``Px_next = Jx Px``,  ``Pq_next = Jx Pq + Jq``,

    where ``Jx, Jq`` are the exact derivatives of :func:`make_step`'s step (the same discrete map: a
    chain of these steps gives the exact Jacobian of the chain of steps). RK4: one SX Function, the
    products by forward directional derivatives (``jtimes``). Radau/Gauss: the stages from the same
    Newton rootfinder as :func:`make_step`, their derivatives by the implicit function theorem with
    one factorisation of the SX stage Jacobian per step, ``dK = -(dG/dK)^-1 dG/d(x, q)`` (measured
    5x cheaper than CasADi's derivative of the rootfinder node, the same numbers to 1e-15).

    Parameters
    ----------
    rhs : casadi.Function
        (x[nx], t[1], q[nq]) -> xdot[nx], preferably SX.
    method : {"rk4", "radau", "gauss"}
        Integrator.
    newton_tol : float
        Absolute tolerance of the stage Newton iteration (implicit methods).

    Returns
    -------
    casadi.Function
        ``(a[nx + nx (nx + nq)], t, q, h) -> a_next``.
    """
    if method not in METHOD_ORDER:
        raise ValueError(f"integrator must be one of {sorted(METHOD_ORDER)}, got {method!r}")
    nx, nq = rhs.size1_in(0), rhs.size1_in(2)
    if method == "rk4":
        a, t, q, h = ca.SX.sym("a", nx + nx * (nx + nq)), ca.SX.sym("t"), ca.SX.sym("q", nq), ca.SX.sym("h")
        xa, P = a[:nx], ca.reshape(a[nx:], nx, nx + nq)
        xn = make_step(rhs, "rk4")(xa, t, q, h)
        dx = ca.jtimes(xn, xa, P) + ca.horzcat(ca.SX.zeros(nx, nx), ca.jacobian(xn, q))
        return ca.Function("rk4_variational_step", [a, t, q, h], [ca.vertcat(xn, ca.vec(dx))])
    _, b, _ = tableau(method)
    s = len(b)
    K, x, t, q, h = ca.SX.sym("K", nx * s), ca.SX.sym("x", nx), ca.SX.sym("t"), ca.SX.sym("q", nq), ca.SX.sym("h")
    G = _stage_residual(rhs, method, x, t, q, h, K)
    lin = ca.Function("stage_jacobians", [K, x, t, q, h], [ca.jacobian(G, K), ca.jacobian(G, ca.vertcat(x, q))])
    a, t, q, h = ca.MX.sym("a", nx + nx * (nx + nq)), ca.MX.sym("t"), ca.MX.sym("q", nq), ca.MX.sym("h")
    xa, P = a[:nx], ca.reshape(a[nx:], nx, nx + nq)
    xm = ca.MX.sym("x", nx)
    inner = ca.Function("stages_step", [xm, t, q, h], list(_implicit_step(rhs, method, newton_tol, xm, t, q, h)))
    xn, Kv, bad = inner(xa, t, q, h)
    GK, Gp = lin(Kv, xa, t, q, h)
    B = ca.horzcat(*[float(b[j]) * ca.DM.eye(nx) for j in range(s)])
    D = -h * (B @ ca.solve(GK, Gp, "qr"))  # d(x_next)/d(x, q) minus [I, 0]
    dx = P + D[:, :nx] @ P + ca.horzcat(ca.MX.zeros(nx, nx), D[:, nx:])
    dx = dx + ca.if_else(bad, ca.MX(np.nan), ca.MX(0.0), True)
    return ca.Function(f"{method}_variational_step", [a, t, q, h], [ca.vertcat(xn, ca.vec(dx))])
