"""Figures of the feedback study (``birdocp control`` / ``birdocp simulate``), from result dicts and
arrays only. matplotlib is imported inside the functions (Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_multipliers", "plot_simulation", "plot_deviation", "plot_envelope"]


def _plt():
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path, dpi) -> Path:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)


def plot_multipliers(result: dict, path) -> Path:
    """Open- and closed-loop multipliers against the unit circle.

    Parameters
    ----------
    result : dict
        With ``open_loop_multipliers`` and ``closed_loop_multipliers`` (complex or [re, im] pairs).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 5))
    t = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(t), np.sin(t), "k-", lw=0.8, label="unit circle")
    for key, mark, label in (("open_loop_multipliers", "x", "open loop"),
                             ("closed_loop_multipliers", "o", "closed loop")):
        z = np.array(result[key], float)
        ax.plot(z[:, 0], z[:, 1], mark, ms=9, mfc="none", label=label)
    ax.set_aspect("equal")
    ax.set_xlabel("Re")
    ax.set_ylabel("Im")
    v = result.get("cycle_validity")
    note = "" if v is None else ("\nmodel valid on the cycle" if v.get("valid") else "\nmodel NOT valid on the cycle")
    ax.set_title(f"multipliers, N = {result.get('updates_per_beat', 1)} update(s) per beat{note}")
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path, 120)


def plot_deviation(curves: dict, path, title: str = "deviation from the cycle at each beat start") -> Path:
    """Deviation per beat on a log axis; ``curves`` maps a label to the deviation list.

    Parameters
    ----------
    curves : dict of str to sequence of float
        Label to the deviation at each beat start [norm of the state deviation].
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for label, dev in curves.items():
        dev = np.asarray(dev, float)
        ax.semilogy(np.arange(dev.size), np.where(dev > 0, dev, np.nan), "o-", ms=3, label=label)
    ax.set_xlabel("beat")
    ax.set_ylabel("|x(kT) - x_cycle|  (u, w m/s; q rad/s; theta rad)")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return _save(fig, path, 120)


def plot_simulation(runs: dict, path, title: str = "") -> Path:
    """Trajectories: altitude -Z against X, pitch, forward speed and the controls against time.
    ``runs`` maps a label to a :meth:`birdocp.studies.simulate.SimulationResult.arrays` dict (plus
    ``control_keys``).

    Parameters
    ----------
    runs : dict of str to dict
        Label to the arrays of a simulation.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    plt = _plt()
    fig, axes = plt.subplots(4, 1, figsize=(7.5, 9))
    for label, a in runs.items():
        axes[0].plot(a["X_m"], -np.asarray(a["Z_m"]), label=label)
        axes[1].plot(a["t_s"], a["pitch_deg"], label=label)
        axes[2].plot(a["t_s"], np.asarray(a["states"])[:, 0], label=label)
        c = np.asarray(a["controls"])
        if c.size:
            for j, key in enumerate(a.get("control_keys", [])):
                ref = np.asarray(a.get("control_cycle", c[0]))[j]
                axes[3].step(a["control_t_s"], c[:, j] - ref, where="post",
                             label=f"{label}: {key.replace('gait.', '')}")
    axes[0].set_xlabel("X forward [m]")
    axes[0].set_ylabel("altitude -Z [m]")
    axes[1].set_ylabel("pitch [deg]")
    axes[2].set_ylabel("u [m/s]")
    axes[3].set_ylabel("correction from the cycle [deg]")
    for ax in axes[1:]:
        ax.set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    if title:
        axes[0].set_title(title, fontsize=10)
    return _save(fig, path, 110)


def plot_envelope(envelopes: list, path) -> Path:
    """Beats to recover and the largest control excursion against the gust amplitude, per direction
    (the trials of :func:`birdocp.studies.simulate.gust_envelope`); failures marked with x.

    Parameters
    ----------
    envelopes : list of dict
        Results of :func:`birdocp.studies.simulate.gust_envelope` (``direction``, ``sign``, ``trials``).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for env in envelopes:
        tr = sorted(env["trials"], key=lambda r: r["amplitude_mps"])
        kind = {("vertical", 1): "up-gust", ("vertical", -1): "down-gust", ("horizontal", 1): "tailwind gust",
                ("horizontal", -1): "headwind gust"}[(env["direction"], 1 if env["sign"] > 0 else -1)]
        label = f"{kind}, {env['length_beats']:g} beat(s) long"
        a = np.array([r["amplitude_mps"] for r in tr])
        ok = np.array([r["recovered"] for r in tr])
        rec = np.array([r["beats_to_recover"] if r["beats_to_recover"] is not None else np.nan for r in tr], float)
        exc = np.array([max((abs(hi - lo) for lo, hi in r["control_range"]), default=np.nan) for r in tr])
        line, = axes[0].plot(a[ok], rec[ok], "o-", ms=4, label=label)
        axes[0].plot(a[~ok], np.zeros((~ok).sum()), "x", ms=8, color=line.get_color())
        axes[1].plot(a[ok], exc[ok], "o-", ms=4, color=line.get_color(), label=label)
    axes[0].set_xlabel("gust peak [m/s] (vertical: + up; horizontal: + along the flight)")
    axes[0].set_ylabel("beats to recover (deviation / 100)")
    axes[1].set_xlabel("gust peak [m/s] (vertical: + up; horizontal: + along the flight)")
    axes[1].set_ylabel("largest control range, max - min [deg]")
    axes[0].set_title("x at 0: not recovered (a joint saturated or the model's validity left)", fontsize=9)
    axes[0].legend(fontsize=7, loc="center right")  # the right panel uses the same colours
    axes[1].set_title("same colours as on the left", fontsize=9)
    for ax in axes:
        ax.grid(alpha=0.3)
    return _save(fig, path, 120)
