"""Figures of the six-degree-of-freedom simulations (``birdocp simulate`` with
``model.degrees_of_freedom = 6``, ``scripts/lateral_control_study.py``), from arrays only."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_lateral_simulation"]


def plot_lateral_simulation(runs: dict, path, title: str = "") -> Path:
    """Bank, heading, sideslip and roll rate over time, the ground track and each run's first
    control, one line per run (``runs``: label -> :meth:`LateralSimulation.arrays` dict with
    ``control_keys``).

    Parameters
    ----------
    runs : dict of str to dict
        Label to the arrays of a lateral simulation.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(13, 7))
    panels = ((6, "bank phi [deg]", True), (8, "heading psi [deg]", True), (1, "side velocity v [m/s]", False),
              (3, "roll rate p [deg/s]", True))
    for label, a in runs.items():
        t, X = np.asarray(a["t_s"]), np.asarray(a["states"])
        for ax, (i, name, deg) in zip(axes.flat, panels):
            ax.plot(t, np.degrees(X[:, i]) if deg else X[:, i], lw=1, label=label)
            ax.set_ylabel(name)
        pos = np.asarray(a["position_m"])
        axes[1, 1].plot(pos[:, 0], pos[:, 1], lw=1, label=label)
        ct, cu = np.asarray(a["control_t_s"]), np.asarray(a["controls"])
        if cu.size:
            base = np.asarray(a.get("control_cycle", np.zeros(cu.shape[1])))
            for j, key in enumerate(a["control_keys"]):
                axes[1, 2].step(ct, cu[:, j] - base[j], where="post", lw=1, label=f"{label}: {key.split('.', 1)[1]}")
    axes[1, 1].set_xlabel("north (initial heading) [m]")
    axes[1, 1].set_ylabel("east drift [m]")
    axes[1, 2].set_ylabel("correction from the cycle value [deg]")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
        if ax is not axes[1, 1]:
            ax.set_xlabel(ax.get_xlabel() or "t [s]")
    axes[0, 0].legend(fontsize=8)
    if axes[1, 2].lines:
        axes[1, 2].legend(fontsize=7)
    else:
        axes[1, 2].text(0.5, 0.5, "open loop: no controls", ha="center", va="center", transform=axes[1, 2].transAxes)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
