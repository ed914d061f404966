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

__all__ = ["METHOD_ORDER", "make_step", "tableau"]

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
    A, b, c = tableau(method)
    s = len(b)
    K = ca.SX.sym("K", nx, s)
    res = []
    for i in range(s):
        xi = x + h * sum(float(A[i, j]) * K[:, j] for j in range(s))
        res.append(K[:, i] - rhs(xi, t + float(c[i]) * h, q))
    par = ca.vertcat(x, t, q, h)
    G = ca.Function("stages", [ca.vec(K), par], [ca.vertcat(*res)])
    solver = ca.rootfinder(f"{method}_stages", "newton", G,
                           {"abstol": newton_tol, "abstolStep": 1e-15, "max_iter": 50,
                            "error_on_fail": False, "show_eval_warnings": False})
    xm, tm, qm, hm = ca.MX.sym("x", nx), ca.MX.sym("t"), ca.MX.sym("q", nq), ca.MX.sym("h")
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
    xn = xn + ca.if_else(bad, ca.MX(np.nan), ca.MX(0.0), True)
    return ca.Function(f"{method}_step", [xm, tm, qm, hm], [xn], ["x", "t", "q", "h"], ["x_next"])
