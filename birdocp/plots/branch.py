"""Figures of continuation branches: the multipliers' locus and their moduli along the parameter."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from birdocp.engine.continuation import Branch
from birdocp.plots.figures import save_figure

__all__ = ["plot_branches"]

def _x_of(branch: Branch, pts=None):
    """(x values, axis label) of branch points: SM in percent for the root position, else the parameter."""
    s = branch.settings
    vals = np.array([p.parameter for p in (branch.points if pts is None else pts)], float)
    if branch.parameter_name == "wing.root_ahead_m" and s.get("display", "stability_margin") == "stability_margin":
        return -100.0 * vals / float(s.get("reference_chord_m", 0.2)), "stability margin SM [%]"
    return vals, branch.parameter_name


def plot_branches(branches: dict, out_dir, prefix: str = "") -> list:
    """Figures of one or more branches (label -> Branch): ``locus.png`` (multipliers in the complex plane,
    coloured by the parameter, unit circle), ``moduli.png`` (moduli against the parameter, special
    points and the branch ends marked; with a free parameter a second panel shows it)."""
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    paths = []
    labels = [k for k, b in branches.items() if b.points]
    if not labels:
        return paths
    marks = {"fold": ("s", "tab:red"), "branch_point": ("D", "tab:orange"), "period_doubling": ("v", "tab:purple"),
             "neimark_sacker": ("*", "tab:green")}
    # locus
    fig, axes = plt.subplots(1, len(labels), figsize=(6.2 * len(labels), 5.8), squeeze=False)
    for ax, lab in zip(axes[0], labels):
        b = branches[lab]
        x, xl = _x_of(b)
        th = np.linspace(0, 2 * np.pi, 400)
        ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8, label="unit circle")
        L = b.multipliers()
        sc = None
        for k in range(L.shape[1]):
            sc = ax.scatter(L[:, k].real, L[:, k].imag, c=x, cmap="viridis", s=18, zorder=3)
            ax.plot(L[:, k].real, L[:, k].imag, "-", color="0.6", lw=0.6, zorder=2)
        for sp in b.special_points:
            m, c = marks.get(sp.kind, ("o", "k"))
            Ls = np.array([complex(*v) for v in sp.multipliers])
            ax.plot(Ls.real, Ls.imag, m, color=c, ms=9, mfc="none", mew=2, label=f"{sp.kind}", zorder=4)
        ax.axhline(0, color="0.85", lw=0.5, zorder=0)
        ax.axvline(0, color="0.85", lw=0.5, zorder=0)
        ax.set_aspect("equal")
        lim = max(1.15, float(np.max(np.abs(L))) * 1.08)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-min(lim, 1.2), min(lim, 1.2))
        ax.set_xlabel("Re Λ")
        ax.set_ylabel("Im Λ")
        ax.set_title(f"{lab}: multipliers along the branch")
        cb = fig.colorbar(sc, ax=ax, shrink=0.7)
        cb.set_label(xl)
        h, l_ = ax.get_legend_handles_labels()
        uniq = dict(zip(l_, h))
        ax.legend(uniq.values(), uniq.keys(), loc="upper left", fontsize=8)
    fig.tight_layout()
    paths.append(save_figure(fig, out_dir / f"{prefix}locus.png"))
    plt.close(fig)
    # moduli (+ free parameter)
    has_free = any(branches[lab].free_names for lab in labels)
    fig, axes = plt.subplots(2 if has_free else 1, 1, figsize=(8, 7.5 if has_free else 4.8), sharex=True,
                             squeeze=False)
    ax = axes[0, 0]
    styles = ["-", "--", ":", "-."]
    for i, lab in enumerate(labels):
        b = branches[lab]
        x, xl = _x_of(b)
        M = np.array([p.moduli for p in b.points])
        ax.plot(x, M[:, 0], styles[i % 4], color="tab:red", marker=".", label=f"{lab}: |Λ1| (expanding)")
        for k in range(1, M.shape[1]):
            ax.plot(x, M[:, k], styles[i % 4], color="tab:blue", lw=0.8, label=f"{lab}: |Λ2..4|" if k == 1 else None)
        ax.plot(x[-1:], M[-1:, 0], "kx", ms=10, mew=2, label="branch end" if i == 0 else None)
        for sp in b.special_points:
            m, c = marks.get(sp.kind, ("o", "k"))
            xs, _ = _x_of(b, [sp])
            ax.plot(xs, [max(sp.moduli)], m, color=c, ms=9, mfc="none", mew=2, label=sp.kind)
        if has_free and b.free_names:
            F = np.array([[p.free_values[n] for n in b.free_names] for p in b.points])
            axes[1, 0].plot(x, F[:, 0], styles[i % 4], marker=".", label=f"{lab}: {b.free_names[0]}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_ylabel("|Λ|")
    ax.set_title("Floquet multipliers' moduli along the branch (|Λ| > 1: unstable)")
    h, l_ = ax.get_legend_handles_labels()
    uniq = dict(zip(l_, h))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    if has_free:
        axes[1, 0].set_ylabel("solved free parameter")
        axes[1, 0].legend(fontsize=8)
        axes[1, 0].grid(alpha=0.3)
    axes[-1, 0].set_xlabel(xl)
    fig.tight_layout()
    paths.append(save_figure(fig, out_dir / f"{prefix}moduli.png"))
    plt.close(fig)
    return paths
