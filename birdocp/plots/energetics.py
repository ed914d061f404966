"""Figures of flight energetics: power over the wingbeat, the power curve, the Pareto front.

Inputs are plain dicts (``TrimResult.arrays()`` / ``arrays.npz`` for the power over a period, the
rows written by :mod:`birdocp.studies.energetics`), so scripts and the CLI share them. matplotlib is
imported inside the functions (Agg backend).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_power", "plot_power_curve", "plot_pareto"]


def _plt():
    import matplotlib.pyplot as plt

    return plt


def plot_power(arrays: dict, path, title: str = "Power over one wingbeat") -> Path:
    """Aerodynamic, shoulder (flapping + inertial) and body power over the period, with their means.

    ``arrays``: keys ``power_t_s`` and ``power_<name>`` (W) as in ``TrimResult.arrays()``.

    Parameters
    ----------
    arrays : dict
        Power histories over one period.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    from birdocp.plots.figures import save_figure

    plt = _plt()
    t = np.asarray(arrays["power_t_s"], float)
    T = float(t[-1] - t[0]) * len(t) / max(len(t) - 1, 1)
    tt = (t - t[0] + (t[1] - t[0])) / T
    series = [("power_aerodynamic_power_W", "aerodynamic $P_{aero}$ (to the air)", "C0"),
              ("power_shoulder_power_W", "shoulder $P_{sh}$ (joints)", "C3"),
              ("power_body_power_W", "body $P_{body}$ (loads on the rigid body)", "C2")]
    fig, ax = plt.subplots(figsize=(8.5, 4.8))
    for key, lab, col in series:
        if key not in arrays:
            continue
        v = np.asarray(arrays[key], float)
        ax.plot(tt, v, color=col, lw=1.6, label=f"{lab}; sample mean {np.mean(v):+.3g} W")
        ax.axhline(np.mean(v), color=col, ls="--", lw=0.9)
    if "power_shoulder_power_W" in arrays:
        v = np.asarray(arrays["power_shoulder_power_W"], float)
        ax.fill_between(tt, 0, np.maximum(v, 0), color="C3", alpha=0.12,
                        label=f"positive work: mean {np.mean(np.maximum(v, 0)):.3g} W")
    ax.axhline(0, color="grey", lw=0.6)
    ax.set_xlabel(f"t / T   (T = {T:.3g} s)")
    ax.set_ylabel("power [W]")
    ax.set_title(f"{title}\n(identity: $P_{{sh}} = P_{{aero}} + P_{{body}}$ for massless wings; dashed: period means)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    p = save_figure(fig, path)
    plt.close(fig)
    return p


def plot_power_curve(rows: list, path, title: str = "Power curve of level flight") -> Path:
    """Mean power against forward speed (aerodynamic and positive-work), the minimum-power and
    maximum-range speeds over the *valid* rows marked, and the largest multiplier modulus along the
    curve. Rows whose cycle is not valid (``valid`` False) are drawn as open grey markers and take no
    part in the marked optima; a marked optimum at an end of the valid rows says so (no interior one).

    ``rows``: dicts with ``speed_mps``, ``mean_shoulder_power_W``, ``mean_positive_power_W``,
    ``largest_modulus``, ``success`` and ``valid`` (a row without ``valid`` counts as valid).

    Parameters
    ----------
    rows : list of dict
        Rows of the power curve.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    from birdocp.plots.figures import save_figure

    plt = _plt()
    ok = [r for r in rows if r.get("success")]
    U = np.array([r["speed_mps"] for r in ok], float)
    P = np.array([r["mean_shoulder_power_W"] for r in ok], float)
    Pp = np.array([r["mean_positive_power_W"] for r in ok], float)
    R = np.array([r["largest_modulus"] for r in ok], float)
    v = np.array([r.get("valid") is not False for r in ok], bool)
    fig, ax = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax[0].plot(U, P, "-", color="0.75", lw=1)
    ax[0].plot(U[v], P[v], "o-", color="C0", label="mean mechanical power (= mean aerodynamic power, level)")
    ax[0].plot(U, Pp, "--", color="0.75", lw=1)
    ax[0].plot(U[v], Pp[v], "s--", color="C3", ms=4, label="mean positive-work power (no elastic storage)")
    if (~v).any():
        ax[0].plot(U[~v], P[~v], "o", color="0.55", mfc="none", label="model NOT valid there (grey, open)")
        ax[0].plot(U[~v], Pp[~v], "s", color="0.55", mfc="none", ms=4)
    Uv, Pv = U[v], P[v]
    if len(Uv) >= 3:
        i = int(np.argmin(Pv))
        end = "" if 0 < i < len(Uv) - 1 else " (end of the valid rows: no interior minimum)"
        ax[0].plot(Uv[i], Pv[i], "k*", ms=15, label=f"minimum power over valid rows: {Pv[i]:.3g} W at {Uv[i]:.3g} m/s{end}")
        j = int(np.argmin(Pv / Uv))
        end = "" if 0 < j < len(Uv) - 1 else " (end of the valid rows)"
        ax[0].plot([0, Uv[j] * 1.15], [0, Pv[j] * 1.15], ":", color="grey", lw=1)
        ax[0].plot(Uv[j], Pv[j], "kD", ms=8, mfc="none",
                   label=f"maximum range over valid rows (min P/U): {Pv[j]:.3g} W at {Uv[j]:.3g} m/s{end}")
    if len(U):
        ax[0].set_ylim(0, 1.1 * max(np.max(Pp), np.max(P)))
        ax[0].set_xlim(0.95 * U.min(), 1.03 * U.max())
    ax[0].set_ylabel("power [W]")
    ax[0].set_title(title, fontsize=11)
    ax[0].grid(alpha=0.3)
    ax[0].legend(fontsize=8, loc="upper left")
    ax[1].plot(U, R, "-", color="0.75", lw=1)
    ax[1].plot(U[v], R[v], "o", color="C1")
    ax[1].plot(U[~v], R[~v], "o", color="0.55", mfc="none")
    ax[1].axhline(1, color="k", lw=0.8)
    ax[1].set_ylabel("largest |multiplier|")
    ax[1].set_xlabel("mean forward speed U [m/s]")
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    p = save_figure(fig, path)
    plt.close(fig)
    return p


def plot_pareto(points: list, path, title: str = "Power against the stability bound") -> Path:
    """Minimum mean power against the bound R on the largest multiplier modulus (Pareto front).

    ``points``: dicts with ``bound``, ``objective_value`` (W), ``largest_modulus``, ``success``. The
    end points are marked: ``bound`` None is the unconstrained energy optimum, ``bound`` "most stable"
    the most stable gait.

    Parameters
    ----------
    points : list of dict
        Points of the front.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    from birdocp.plots.figures import save_figure

    plt = _plt()
    ok = sorted([q for q in points if q.get("success")], key=lambda q: q["largest_modulus"])
    R = np.array([q["largest_modulus"] for q in ok], float)
    P = np.array([q["objective_value"] for q in ok], float)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(R, P, "o-", color="C0", ms=4, label="energy-optimal gait with largest |multiplier| <= R")
    ends = (("energy optimum (no stability bound)", lambda q: q.get("bound") is None, "*", "C1"),
            ("most stable gait", lambda q: q.get("bound") == "most stable", "s", "C2"))
    for name, which, marker, color in ends:
        for q in (q for q in ok if which(q)):
            ax.plot(q["largest_modulus"], q["objective_value"], marker, color=color, ms=12, zorder=3,
                    label=f"{name}: {q['objective_value']:.3f} W, |multiplier| {q['largest_modulus']:.4f}")
    ax.set_xlabel("largest |multiplier| of the optimal gait, R (dimensionless)")
    ax.set_ylabel("minimum mean power [W]")
    ax.set_title(title, fontsize=11)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    p = save_figure(fig, path)
    plt.close(fig)
    return p
