"""Shared helpers of the engine examples: the --out option, result.json, and the standard figure
(states over one period, a phase portrait, the multipliers against the unit circle)."""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from birdocp.engine.results import complex_pairs
from birdocp.io.files import atomic_write_json

ROOT = Path(__file__).resolve().parents[2]


def out_dir(system: str, doc: str) -> Path:
    """Parse ``--out DIR`` (default results/engine/<system>/) and create it."""
    ap = argparse.ArgumentParser(description=doc.strip().splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "engine" / system),
                    help="output folder (default results/engine/%(default)s)")
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def begin(system: str, doc: str, make_ode, params: dict):
    """The start of an example: its output folder (:func:`out_dir`), its ODE (``make_ode()``) and the
    parameter values in the order of ``params``."""
    return out_dir(system, doc), make_ode(), list(params.values())


def accurate_orbit(ode, p, x_guess, period_guess: float, points: int = 5, integrator: str = "rk4"):
    """The example's orbit from a guess: steps per period chosen by doubling until the error estimate of
    the period, x0 and the multipliers is below 1e-8 (relative)."""
    from birdocp.engine import OrbitMethod, OrbitProblem, solve

    return solve(OrbitProblem(ode, p, x_guess, period_guess=period_guess),
                 OrbitMethod(points=points, steps_per_period=None, integrator=integrator, accuracy=1e-8))


def write_result(out: Path, system: str, source: str, params: dict, orbit, lyapunov=None, extra=None) -> dict:
    """result.json: period, x0, multipliers ([re, im], largest modulus first, the trivial one included
    for autonomous orbits), lyapunov_exponents (largest first) when computed, accuracy and status."""
    res = {
        "system": system, "source": source, "params": params,
        "success": bool(orbit.success), "status": orbit.status, "message": orbit.message,
        "period": float(orbit.period), "x0": orbit.x0.tolist(),
        "multipliers": complex_pairs(orbit.multipliers) if orbit.multipliers is not None else None,
        "autonomous": orbit.autonomous,
        "trivial_multiplier_error": orbit.trivial_multiplier_error if orbit.autonomous else None,
        "stable": orbit.stable, "max_residual": orbit.max_residual,
        "error_estimate": {k: float(v) for k, v in orbit.error_estimate.items()},
        "accurate": orbit.accurate, "method": orbit.method,
        "wall_s": {k: float(v) for k, v in orbit.wall_s.items()},
    }
    if lyapunov is not None:
        res["lyapunov_exponents"] = lyapunov.exponents.tolist()
        res["lyapunov_standard_error"] = lyapunov.standard_error.tolist()
        res["lyapunov"] = lyapunov.to_dict()
    if extra:
        res.update(extra)
    atomic_write_json(out / "result.json", res)
    return res


def plot_orbit(out: Path, title: str, orbit, state_names, phase=(0, 1), time_unit="time units", extra_panel=None):
    """Figure <out>/orbit.png: states over one period, a phase portrait, multipliers and unit circle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = 4 if extra_panel else 3
    fig, axs = plt.subplots(1, n, figsize=(4.2 * n, 3.8))
    t = orbit.trajectory_t - orbit.trajectory_t[0]
    X = orbit.trajectory_x
    for i, nm in enumerate(state_names):
        axs[0].plot(t, X[:, i], label=nm)
    axs[0].set_xlabel(f"t ({time_unit})")
    axs[0].set_ylabel("state")
    axs[0].set_title(f"one period, T = {orbit.period:.6g}")
    axs[0].legend(fontsize=8)
    i, j = phase
    axs[1].plot(X[:, i], X[:, j], "k-", lw=1.2)
    pts = orbit.shooting_points
    axs[1].plot(pts[:, i], pts[:, j], "o", color="tab:red", ms=4, label="shooting points")
    axs[1].set_xlabel(state_names[i])
    axs[1].set_ylabel(state_names[j])
    axs[1].set_title("phase portrait")
    axs[1].legend(fontsize=8)
    th = np.linspace(0, 2 * np.pi, 200)
    axs[2].plot(np.cos(th), np.sin(th), color="0.6", lw=1)
    lam = orbit.multipliers
    if lam is not None:
        triv = orbit.trivial_multiplier
        for v in lam:
            is_triv = triv is not None and v == triv
            axs[2].plot(v.real, v.imag, "s" if is_triv else "o", color="tab:gray" if is_triv else "tab:blue", ms=6)
        axs[2].plot([], [], "o", color="tab:blue", label="multipliers")
        if triv is not None:
            axs[2].plot([], [], "s", color="tab:gray", label="trivial (= 1)")
        R = max(1.2, 1.1 * float(np.max(np.abs(lam))))
        axs[2].set_xlim(-R, R)
        axs[2].set_ylim(-R, R)
    axs[2].set_aspect("equal")
    axs[2].axhline(0, color="0.85", lw=0.8)
    axs[2].axvline(0, color="0.85", lw=0.8)
    axs[2].set_xlabel("Re")
    axs[2].set_ylabel("Im")
    axs[2].set_title("Floquet multipliers")
    axs[2].legend(fontsize=8, loc="lower left")
    if extra_panel:
        extra_panel(axs[3])
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out / "orbit.png", dpi=110)
    plt.close(fig)
