"""Benchmarks of the orbit engine, in one run on one machine.

1. The reference toolbox's small examples from its own starting guesses
   (scripts/examples/reference_toolbox.py), each solved in a fresh process: the first solve's wall
   time (graph build included, Python and CasADi import excluded) side by side with the reference
   toolbox's times quoted in issue 27, at the default accuracy (1e-6) and at 1e-8; the period's and
   x0's error against the same orbit found by single shooting on scipy's DOP853 (Radau for the stiff
   redox), rtol 1e-12, through the section at birdocp's x0. Writes
   results/engine/reference_examples.json and .md.

2. birdocp's autonomous-orbit shooting against a straightforward finite-difference
multiple shooting (written here, in the style of the reference toolbox: numpy RK4, segment Jacobians
by forward differences, the period's column too, Levenberg-Marquardt), on the Rossler orbit
(a = b = 0.2, c = 5.7) from x = (0.1, 5, 3.6), period guess 5, in one run on the same machine.

Both use the same discretisation (5 shooting points, 200 RK4 steps per period), the same phase
condition (Poincare section through the start point orthogonal to f) and the same tolerance
(max |residual| <= 1e-10), so the ratio measures the method (exact CasADi derivatives and graph
evaluation against finite differences and a Python step loop), not the problem.

    python scripts/benchmark_engine.py [--only reference|rossler] [--out DIR]
        writes DIR/reference_examples.{json,md} and DIR/benchmark.json (DIR: results/engine)
"""
import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from script_common import parse_with_out, script_parser

ROOT = Path(__file__).resolve().parents[1]
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


def one_example(name: str, accuracy: float) -> dict:
    """Solve one reference example (in this process) and check it with scipy."""

    sys.path.insert(0, str(ROOT / "scripts" / "examples"))
    from reference_toolbox import make

    ex = make(name)
    t, c = time.perf_counter(), time.process_time()
    r = solve(OrbitProblem(ex.ode, ex.p, ex.x, period_guess=ex.period),
              OrbitMethod(accuracy=accuracy, **ex.method))
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    out = {"example": name, "accuracy": accuracy, "status": r.status, "success": r.success, "accurate": r.accurate,
           "period": r.period, "covers": r.covers, "steps_per_period": r.method.get("steps_per_period"),
           "first_solve_wall_s": wall, "first_solve_cpu_s": cpu, "error_estimate_period": r.error_estimate.get("period"),
           "error_estimate_relative": r.error_estimate.get("relative"), "message": r.message}
    if r.success:
        T_s, x_s = scipy_orbit(ex.ode, r.p, r.x0, r.period, "Radau" if name == "redox" else "DOP853")
        out["scipy_period"] = T_s
        out["period_error_vs_scipy"] = abs(r.period - T_s)
        out["x0_error_vs_scipy"] = float(np.max(np.abs(r.x0 - x_s)))
        out["multipliers_abs"] = [float(abs(v)) for v in r.multipliers]
    return out


def scipy_orbit(ode, p, x0, T, method="DOP853", iters=6):
    """The orbit through the section at x0 orthogonal to f(x0), by single shooting on scipy's
    solve_ivp (rtol 1e-12, atol 1e-12): Newton on (x, T) with a forward-difference Jacobian, started
    at (x0, T). Returns (period, point)."""
    from scipy.integrate import solve_ivp

    f = lambda t, x: ode.evaluate(x, t, p)  # noqa: E731
    n = f(0.0, x0) / np.linalg.norm(f(0.0, x0))

    def G(z):
        y = solve_ivp(f, (0.0, z[-1]), z[:-1], method=method, rtol=1e-12, atol=1e-12).y[:, -1]
        return np.concatenate([y - z[:-1], [(z[:-1] - x0) @ n]])

    z = np.concatenate([x0, [T]])
    for _ in range(iters):
        g = G(z)
        J = np.zeros((z.size, z.size))
        for k in range(z.size):
            dz = np.zeros(z.size)
            dz[k] = 1e-7 * max(1.0, abs(z[k]))
            J[:, k] = (G(z + dz) - g) / dz[k]
        step = np.linalg.solve(J, -g)
        z = z + step
        if np.max(np.abs(step)) < 1e-13 * (1 + np.max(np.abs(z))):
            break
    return float(z[-1]), z[:-1]


def reference_examples() -> list:
    """Each example in a fresh process (a first solve), at accuracy 1e-6 and 1e-8."""
    sys.path.insert(0, str(ROOT / "scripts" / "examples"))
    from reference_toolbox import FAILURES, NAMES, REFERENCE_WALL_S

    rows = []
    for acc in (1e-6, 1e-8):
        for name in NAMES + (FAILURES if acc == 1e-6 else []):
            cmd = [sys.executable, __file__, "--one", name, "--accuracy", str(acc)]
            row = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout.splitlines()[-1])
            row["reference_wall_s"] = None if name in FAILURES else REFERENCE_WALL_S.get(name.split("_")[0])
            rows.append(row)
            print(f"{name:14s} acc {acc:.0e}: {row['status']:13s} T = {row['period']:.10f} covers {row['covers']} "
                  f"{row['first_solve_wall_s']:.2f} s wall ({row['first_solve_cpu_s']:.2f} s CPU), period error vs "
                  f"scipy {row.get('period_error_vs_scipy', float('nan')):.1e}", flush=True)
    return rows


def write_reference(rows: list, out_dir: Path) -> None:
    out = {"load_average_at_start": os.getloadavg()[0], "python": sys.version.split()[0], "casadi": ca.__version__,
           "rows": rows}
    atomic_write_json(out_dir / "reference_examples.json", out)
    lines = ["# Reference toolbox examples from their own guesses (scripts/benchmark_engine.py)", "",
             f"Load average at the start: {out['load_average_at_start']:.1f} (2 cores, shared).", "",
             "| example | accuracy | status | covers | period | steps | wall s | CPU s | reference s | "
             "period error vs scipy | its estimate | x0 error vs scipy |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ref = "" if r["reference_wall_s"] is None else f"{r['reference_wall_s']:g}"
        lines.append(f"| {r['example']} | {r['accuracy']:.0e} | {r['status']} | {r['covers']} | {r['period']:.10f} | "
                     f"{r['steps_per_period']} | {r['first_solve_wall_s']:.2f} | {r['first_solve_cpu_s']:.2f} | {ref} | "
                     f"{r.get('period_error_vs_scipy', float('nan')):.1e} | {r['error_estimate_period'] or 0:.1e} | "
                     f"{r.get('x0_error_vs_scipy', float('nan')):.1e} |")
    lines += ["", "Lorenz: the reference's ~4 s is for its Lorenz runs; compare the sum of the four rows. "
              "lorenz_10: no periodic orbit near the guess (r = 10), the time to the failure."]
    atomic_write_text(out_dir / "reference_examples.md", "\n".join(lines) + "\n")


def main():
    ap = script_parser(__doc__, "results/engine")
    ap.add_argument("--only", choices=("reference", "rossler"))
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--accuracy", type=float, default=1e-6, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.one:
        print(json.dumps(one_example(a.one, a.accuracy)))
        return
    _, out_dir = parse_with_out(ap)
    if a.only in (None, "reference"):
        write_reference(reference_examples(), out_dir)
    if a.only in (None, "rossler"):
        rossler(out_dir)


def rossler(out_dir: Path):
    ode = ODE.from_function(lambda x, t, p: ca.vertcat(-x[1] - x[2], x[0] + p[0] * x[1], p[1] + x[2] * (x[0] - p[2])),
                            3, ("a", "b", "c"))
    prob = OrbitProblem(ode, P, X_START, period_guess=T_GUESS)
    method = OrbitMethod(points=POINTS, steps_per_period=STEPS, tol=TOL, error_estimate=False)
    t = time.perf_counter()
    cold = solve(prob, method)
    t_cold = time.perf_counter() - t
    reps = 5
    t = time.perf_counter()
    for _ in range(reps):
        warm = solve(prob, method)
    t_warm = (time.perf_counter() - t) / reps
    t = time.perf_counter()
    solve(prob, OrbitMethod(points=POINTS, steps_per_period=STEPS, tol=TOL))
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
