"""Benchmark: birdocp's autonomous-orbit shooting against a straightforward finite-difference
multiple shooting (written here, in the style of the reference toolbox: numpy RK4, segment Jacobians
by forward differences, the period's column too, Levenberg-Marquardt), on the Rossler orbit
(a = b = 0.2, c = 5.7) from x = (0.1, 5, 3.6), period guess 5, in one run on the same machine.

Both use the same discretisation (5 shooting points, 200 RK4 steps per period), the same phase
condition (Poincare section through the start point orthogonal to f) and the same tolerance
(max |residual| <= 1e-10), so the ratio measures the method (exact CasADi derivatives and graph
evaluation against finite differences and a Python step loop), not the problem.

    python scripts/benchmark_engine.py      writes results/engine/benchmark.json (``--out DIR``: DIR/benchmark.json)
"""
import sys
import time

import casadi as ca
import numpy as np

from birdocp.engine.ode import ODE
from birdocp.engine.orbits import OrbitMethod, OrbitProblem, solve_orbit
from birdocp.io.files import atomic_write_json
from script_common import parse_with_out, script_parser

P = (0.2, 0.2, 5.7)
X_START = np.array([0.1, 5.0, 3.6])
T_GUESS = 5.0
POINTS, STEPS, TOL = 5, 200, 1e-10


def f_np(x):
    a, b, c = P
    return np.array([-x[1] - x[2], x[0] + a * x[1], b + x[2] * (x[0] - c)])


def rk4_np(x, dt, n):
    for _ in range(n):
        k1 = f_np(x)
        k2 = f_np(x + dt / 2 * k1)
        k3 = f_np(x + dt / 2 * k2)
        k4 = f_np(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def baseline():
    """Finite-difference multiple shooting (period unknown), LM as in the paper's Algorithm 1."""
    S, n = POINTS - 1, STEPS // (POINTS - 1)
    nx = 3
    nref = f_np(X_START) / np.linalg.norm(f_np(X_START))
    X = [X_START.copy()]
    for _ in range(S):
        X.append(rk4_np(X[-1], T_GUESS / STEPS, n))
    z = np.concatenate([np.concatenate(X), [T_GUESS]])

    def resid(z):
        X, T = z[:-1].reshape(S + 1, nx), z[-1]
        g = [rk4_np(X[i], T / STEPS, n) - X[i + 1] for i in range(S)]
        return np.concatenate(g + [X[S] - X[0], [(X[0] - X_START) @ nref]])

    lam, it = 1e-8, 0
    r = resid(z)
    while np.max(np.abs(r)) > TOL and it < 100:
        J = np.zeros((r.size, z.size))
        for k in range(z.size):  # forward differences, one column per unknown
            h = 1e-7 * max(1.0, abs(z[k]))
            zp = z.copy()
            zp[k] += h
            J[:, k] = (resid(zp) - r) / h
        A = J.T @ J
        dz = np.linalg.solve(A + lam * np.diag(np.diag(A)), -J.T @ r)
        rn = resid(z + dz)
        if rn @ rn < r @ r:
            z, r, lam = z + dz, rn, lam / 10
        else:
            lam *= 10
        it += 1
    return z[-1], z[:3], it, float(np.max(np.abs(r)))


def main(argv=None):
    _, out_dir = parse_with_out(script_parser(__doc__, "results/engine"), argv)
    ode = ODE.from_function(lambda x, t, p: ca.vertcat(-x[1] - x[2], x[0] + p[0] * x[1], p[1] + x[2] * (x[0] - p[2])),
                            3, ("a", "b", "c"))
    prob = OrbitProblem(ode, P, X_START, period_guess=T_GUESS)
    method = OrbitMethod(points=POINTS, steps_per_period=STEPS, tol=TOL, error_estimate=False)
    t = time.perf_counter()
    cold = solve_orbit(prob, method)
    t_cold = time.perf_counter() - t
    reps = 5
    t = time.perf_counter()
    for _ in range(reps):
        warm = solve_orbit(prob, method)
    t_warm = (time.perf_counter() - t) / reps
    t = time.perf_counter()
    solve_orbit(prob, OrbitMethod(points=POINTS, steps_per_period=STEPS, tol=TOL))
    t_full = time.perf_counter() - t
    t = time.perf_counter()
    T_fd, x_fd, it_fd, r_fd = baseline()
    t_fd = time.perf_counter() - t
    assert cold.success and warm.success, cold.message
    out = {
        "problem": "Rossler a=b=0.2 c=5.7 from (0.1, 5, 3.6), period guess 5",
        "discretisation": {"points": POINTS, "rk4_steps_per_period": STEPS, "tol": TOL},
        "birdocp": {"period": cold.period, "iterations": cold.iterations, "max_residual": cold.max_residual,
                    "first_call_s": t_cold, "repeat_call_s": t_warm,
                    "with_error_estimate_s": t_full, "multipliers": [[v.real, v.imag] for v in cold.multipliers]},
        "finite_difference_baseline": {"period": T_fd, "iterations": it_fd, "max_residual": r_fd, "time_s": t_fd},
        "period_difference": abs(T_fd - cold.period),
        "speedup_first_call": t_fd / t_cold,
        "speedup_repeat_call": t_fd / t_warm,
        "python": sys.version.split()[0], "casadi": ca.__version__,
    }
    atomic_write_json(out_dir / "benchmark.json", out)
    print(f"birdocp: {t_cold:.3f} s first call (graph build included), {t_warm:.3f} s repeat, "
          f"{cold.iterations} iterations, T = {cold.period:.10f}")
    print(f"finite-difference multiple shooting: {t_fd:.3f} s, {it_fd} iterations, T = {T_fd:.10f}")
    print(f"ratio (FD / birdocp): {t_fd / t_cold:.1f}x first call, {t_fd / t_warm:.1f}x repeat")


if __name__ == "__main__":
    main()
