"""Figures of continuation branches: the multipliers' locus and their moduli along the parameter."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from birdocp.engine.continuation import Branch
from birdocp.plots.figures import save_figure

__all__ = ["plot_branches", "valid_mask", "runs", "branch_ends", "end_label", "STOPPED", "plot_by_validity"]

def _x_of(branch: Branch, pts=None):
    """(x values, axis label) of branch points: SM in percent for the root position, else the parameter."""
    s = branch.settings
    vals = np.array([p.parameter for p in (branch.points if pts is None else pts)], float)
    if branch.parameter_name == "wing.root_ahead_m" and s.get("display", "stability_margin") == "stability_margin":
        return -100.0 * vals / float(s.get("reference_chord_m", 0.2)), "stability margin SM [%]"
    return vals, branch.parameter_name


def _sp_label(sp) -> str:
    """Legend text of a special point: its kind, and the event it locates (e.g. the validity limit)."""
    return sp.kind.replace("_", " ") + (f" ({sp.event})" if getattr(sp, "event", None) else "")


def valid_mask(branch: Branch) -> np.ndarray:
    """Per point: True where the model holds (``validity.valid``), also where it was not checked.

    Parameters
    ----------
    branch : Branch
        Continuation branch.

    Returns
    -------
    ndarray of bool
        One entry per point of the branch.
    """
    return np.array([(p.validity or {}).get("valid", True) is not False for p in branch.points], bool)


def runs(mask: np.ndarray) -> list:
    """Index ranges (start, stop) of the runs of equal values of ``mask``, each extended by one point so
    that consecutive runs join in a line plot: [(start, stop, value), ...].

    Parameters
    ----------
    mask : ndarray of bool
        One value per point.

    Returns
    -------
    list of tuple
        ``(start, stop, value)`` per run.
    """
    out, start = [], 0
    for i in range(1, len(mask) + 1):
        if i == len(mask) or mask[i] != mask[start]:
            out.append((start, min(i + 1, len(mask)), bool(mask[start])))
            start = i
    return out


def plot_by_validity(ax, x, y, valid, label: str | None = None, invalid_label: str | None = "model not valid",
                     **style) -> None:
    """``ax.plot(x, y, **style)`` with the runs where the model does not hold (``valid`` False per
    point) drawn grey, dashed and without markers, as in the branch figures; ``label`` goes to the
    first valid run, ``invalid_label`` to the first invalid one.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes to draw on.
    x, y : array_like
        Coordinates of the points.
    valid : sequence of bool or None
        Per point: False where the model does not hold (None: not checked, drawn as valid).
    label : str, optional
        Legend text of the first valid run.
    invalid_label : str, optional
        Legend text of the first invalid run.
    **style
        Keyword arguments of ``ax.plot`` for the valid runs.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.asarray([v is not False for v in valid], bool)
    seen = set()
    for a, z, good in runs(ok):
        st = dict(style) if good else dict(style, color="0.6", ls="--", marker=None, lw=1.0)
        lab = (label if good else invalid_label) if good not in seen else None
        seen.add(good)
        ax.plot(x[a:z], y[a:z], label=lab, **st)


STOPPED = ("reached_to", "reached_from", "max_points", "stopped_at_event")
"""End reasons that are where the continuation was stopped, not where the branch ends."""


def branch_ends(branch: Branch) -> list:
    """The ends to mark: ``settings['ends']`` (list of {index, reason, message}) or the last point.

    Parameters
    ----------
    branch : Branch
        Continuation branch.

    Returns
    -------
    list of dict
        ``{"index", "reason", "message"}`` per end.
    """
    ends = branch.settings.get("ends")
    if ends:
        return [dict(e, index=int(e["index"]) % len(branch.points)) for e in ends]
    return [{"index": len(branch.points) - 1, "reason": branch.end_reason, "message": branch.end_message}]


def end_label(reason: str) -> str:
    """Legend text of a branch end by its ``end_reason``: stopped at the requested range, or a real end.

    Parameters
    ----------
    reason : str
        ``end_reason`` of the branch or of one of its ends.

    Returns
    -------
    str
    """
    if reason in STOPPED:
        return {"max_points": "continuation stopped here (point budget)",
                "stopped_at_event": "continuation stopped here (at the located event, e.g. the validity boundary)"}.get(
            reason, "continuation stopped here (end of the requested range)")
    return {"free_parameter_bound": "branch end: the free parameter reaches its bound",
            "corrector_failed": "branch end: the corrector fails", "rejected": "branch end: cycles rejected"}.get(
        reason, f"branch end: {reason}")


MARKS = {"fold": ("s", "tab:red"), "branch_point": ("D", "tab:orange"), "period_doubling": ("v", "tab:purple"),
         "neimark_sacker": ("*", "tab:green"), "validity_boundary": ("P", "0.25")}
"""Marker and colour of each kind of special point."""
STYLES = ["-", "--", ":", "-."]


def plot_branches(branches: dict, out_dir, prefix: str = "", span=None) -> list:
    """Figures of one or more branches (label -> Branch): ``locus.png`` (multipliers in the complex plane,
    coloured by the parameter, unit circle), ``moduli.png`` (moduli against the parameter, special
    points and the branch ends marked; with a free parameter a second panel shows it).

    Points where the model does not hold (``validity.valid`` false) are drawn grey (hollow in the
    locus, dashed grey lines in the moduli); branch ends are marked by why the branch ends (``x``: the
    continuation was stopped at the end of the requested range; filled square: the branch itself ends,
    e.g. its free parameter reaches a bound). ``span``: (lo, hi, label) of a parameter range to shade
    (e.g. the paper's range).

    Parameters
    ----------
    branches : dict of str to Branch
        Branches by legend label.
    out_dir : str or Path
        Folder of the figures.
    prefix : str
        Prefix of the file names.
    span : tuple, optional
        ``(lo, hi, label)``: parameter range to shade.

    Returns
    -------
    list of Path
        The figures written (empty without branches).
    """
    out_dir = Path(out_dir)
    labels = [k for k, b in branches.items() if b.points]
    if not labels:
        return []
    return [_locus_figure(branches, labels, out_dir / f"{prefix}locus.png"),
            _moduli_figure(branches, labels, out_dir / f"{prefix}moduli.png", span)]


def _unique_legend(ax, **kw) -> None:
    """The axes' legend with each label once."""
    h, l_ = ax.get_legend_handles_labels()
    uniq = dict(zip(l_, h))
    ax.legend(uniq.values(), uniq.keys(), fontsize=8, **kw)


def _locus_figure(branches: dict, labels: list, path: Path):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(labels), figsize=(6.2 * len(labels), 5.8), squeeze=False)
    for ax, lab in zip(axes[0], labels):
        _locus_panel(fig, ax, branches[lab], lab)
    uniq = {}
    for ax in axes[0]:  # one legend for the panels, below them: never over the data
        h, l_ = ax.get_legend_handles_labels()
        uniq |= dict(zip(l_, h))
    fig.legend(uniq.values(), uniq.keys(), fontsize=8, loc="lower center", ncol=3)
    fig.tight_layout(rect=(0, 0.13, 1, 1))
    out = save_figure(fig, path)
    plt.close(fig)
    return out


def _locus_panel(fig, ax, b: Branch, lab: str) -> None:
    """The multipliers of branch ``b`` in the complex plane, coloured by the parameter."""
    x, xl = _x_of(b)
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), "k-", lw=0.8, label="unit circle")
    L = b.multipliers()
    ok = valid_mask(b)
    sc = None
    for k in range(L.shape[1]):
        sc = ax.scatter(L[ok, k].real, L[ok, k].imag, c=x[ok], cmap="viridis", s=18, zorder=3,
                        vmin=x.min(), vmax=x.max())
        ax.scatter(L[~ok, k].real, L[~ok, k].imag, s=18, facecolors="none", edgecolors="0.55", lw=0.8, zorder=3,
                   label="model not valid" if k == 0 and (~ok).any() else None)
        ax.plot(L[:, k].real, L[:, k].imag, "-", color="0.6", lw=0.6, zorder=2)
    for sp in b.special_points:
        m, c = MARKS.get(sp.kind, ("o", "k"))
        Ls = np.array([complex(*v) for v in sp.multipliers])
        ax.plot(Ls.real, Ls.imag, m, color=c, ms=9, mfc="none", mew=2, label=_sp_label(sp), zorder=4)
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


def _moduli_figure(branches: dict, labels: list, path: Path, span):
    import matplotlib.pyplot as plt

    has_free = any(branches[lab].free_names for lab in labels)
    fig, axes = plt.subplots(2 if has_free else 1, 1, figsize=(12, 7.5 if has_free else 4.8), sharex=True,
                             squeeze=False)
    ax = axes[0, 0]
    ax_free = axes[1, 0] if has_free else None
    if span is not None:
        ax.axvspan(min(span[0], span[1]), max(span[0], span[1]), color="tab:green", alpha=0.08, label=span[2])
        if has_free:
            ax_free.axvspan(min(span[0], span[1]), max(span[0], span[1]), color="tab:green", alpha=0.08)
    xl = ""
    for i, lab in enumerate(labels):
        xl = _moduli_branch(ax, ax_free, branches[lab], lab, STYLES[i % 4], i)
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_ylabel("|Λ|")
    ax.set_title("Floquet multipliers' moduli along the branch (|Λ| > 1: unstable)")
    _unique_legend(ax, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(alpha=0.3)
    if has_free:
        ax_free.set_ylabel("solved free parameter")
        _unique_legend(ax_free, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        ax_free.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(xl)
    fig.tight_layout()
    out = save_figure(fig, path)
    plt.close(fig)
    return out


def _moduli_branch(ax, ax_free, b: Branch, lab: str, style: str, i: int) -> str:
    """The moduli (and the free parameter on ``ax_free``) of one branch, its ends and special points;
    returns the parameter's axis label."""
    x, xl = _x_of(b)
    M = np.array([p.moduli for p in b.points])
    ok = valid_mask(b)
    F = np.array([[p.free_values[n] for n in b.free_names] for p in b.points]) if b.free_names else None
    for a, z, valid in runs(ok):
        col1, col = ("tab:red", "tab:blue") if valid else ("0.55", "0.7")
        tag = "" if valid else ", model not valid"
        ax.plot(x[a:z], M[a:z, 0], style, color=col1, marker="." if valid else None,
                lw=1.5 if valid else 1.2, label=f"{lab}: |Λ1| (expanding){tag}")
        for k in range(1, M.shape[1]):
            ax.plot(x[a:z], M[a:z, k], style, color=col, lw=0.8, label=f"{lab}: |Λ2..4|{tag}" if k == 1 else None)
        if ax_free is not None and F is not None:
            ax_free.plot(x[a:z], F[a:z, 0], style, color=f"C{i}" if valid else "0.55",
                         marker="." if valid else None, label=f"{lab}: {b.free_names[0]}{tag}")
    for e in branch_ends(b):
        j = e["index"]
        stopped = e["reason"] in STOPPED
        ax.plot(x[j], M[j, 0], "x" if stopped else "s", color="k", ms=10 if stopped else 8, mew=2,
                label=end_label(e["reason"]), zorder=5)
        if ax_free is not None and F is not None:
            ax_free.plot(x[j], F[j, 0], "x" if stopped else "s", color="k", ms=10 if stopped else 8, mew=2, zorder=5)
    for sp in b.special_points:
        m, c = MARKS.get(sp.kind, ("o", "k"))
        xs, _ = _x_of(b, [sp])
        ax.plot(xs, [max(sp.moduli)], m, color=c, ms=9, mfc="none", mew=2, label=_sp_label(sp))
    return xl
