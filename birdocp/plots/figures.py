"""Figures of trimmed flights (matplotlib); each function writes one PNG atomically.

The module leaves the matplotlib backend to the caller (the command line uses Agg).

Inputs are result objects or their plain forms, so the functions serve both scripts (holding
:class:`~birdocp.studies.trim.TrimResult` objects) and a CLI that reads ``result.json``/``arrays.npz``:

* a *trim result*: a :class:`~birdocp.studies.trim.TrimResult` / :class:`~birdocp.engine.orbit_result.OrbitResult`,
  or a dict with ``trajectory_t_s`` (or ``trajectory_t``) and ``trajectory_x`` (``TrimResult.arrays()``);
* *multipliers*: complex arrays, or lists of ``[re, im]`` pairs (``TrimResult.to_dict()["multipliers"]``);
* a *residual history*: an array, a dict with ``residual_history``, or a result object.

Writing: the figure is saved to a temporary name in the target folder, then ``os.replace``-d over
the target, so a reader never sees a half-written PNG.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from birdocp.io.files import atomic_target

__all__ = ["plot_convergence", "plot_multipliers", "plot_states", "plot_phase_portrait", "plot_forces",
           "as_complex", "save_figure"]

STATE_LABELS = ("u [m/s]", "w [m/s]", "q [rad/s]", r"$\theta$ [rad]")
STATE_TITLES = ("forward body velocity u", "downward body velocity w", "pitch rate q", r"pitch angle $\theta$")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*")


# ----------------------------------------------------------------------------------------------
# input normalisation
def as_complex(v) -> np.ndarray:
    """Multipliers as a complex 1-D array from complex values, [re, im] pairs or {"real", "imag"}.

    Parameters
    ----------
    v : array_like or dict
        Complex values, an (n, 2) array of [re, im] pairs or ``{"real": [...], "imag": [...]}``.

    Returns
    -------
    ndarray of complex
    """
    if isinstance(v, dict) and "real" in v:
        return np.asarray(v["real"], float) + 1j * np.asarray(v["imag"], float)
    a = np.asarray(v)
    if np.iscomplexobj(a):
        return a.ravel()
    a = np.asarray(a, float)
    if a.ndim == 2 and a.shape[1] == 2:
        return a[:, 0] + 1j * a[:, 1]
    return a.ravel().astype(complex)


def _get(obj, *names):
    for n in names:
        if isinstance(obj, dict):
            if n in obj:
                return obj[n]
        elif hasattr(obj, n):
            return getattr(obj, n)
    raise KeyError(f"none of {names} in {type(obj).__name__}")


def _trajectory(res):
    t = np.asarray(_get(res, "trajectory_t_s", "trajectory_t"), float).ravel()
    x = np.asarray(_get(res, "trajectory_x"), float)
    if x.shape[0] != t.size and x.shape[1] == t.size:
        x = x.T
    return t, x


def _history(v) -> np.ndarray:
    if not isinstance(v, (np.ndarray, list, tuple)):
        v = _get(v, "residual_history")
    return np.asarray([np.nan if h is None else h for h in np.ravel(v)], float)


def _period(t) -> float:
    return float(t[-1] - t[0])


def save_figure(fig, path) -> Path:
    """Save ``fig`` as PNG to ``path`` atomically (temporary file in the same folder, os.replace).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        Figure to save; it is closed afterwards.
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    path = Path(path)
    try:
        with atomic_target(path, suffix=".png") as tmp:
            fig.savefig(tmp, format="png", dpi=130, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


# ----------------------------------------------------------------------------------------------
def plot_convergence(results_by_label: dict, path, tol: float | None = None,
                     title: str = "Convergence of the shooting solve", tol_label: str | None = None) -> Path:
    """Max residual per iteration (log scale) for each labelled result/history. Open markers of
    decreasing size and varying line styles keep coinciding histories distinguishable.

    Parameters
    ----------
    results_by_label : dict
        Label to a result with ``residual_history`` or the history itself (max residual per iteration).
    path : str or Path
        PNG file to write.
    tol : float, optional
        Tolerance drawn as a horizontal line.
    title : str
        Figure title.
    tol_label : str, optional
        Legend text of the tolerance line.

    Returns
    -------
    Path
    """
    fig, ax = plt.subplots(figsize=(8, 6))
    styles = ("-", "--", "-.", ":")
    n = len(results_by_label)
    for k, (label, res) in enumerate(results_by_label.items()):
        h = _history(res)
        ax.semilogy(np.arange(h.size), h, marker=_MARKERS[k % len(_MARKERS)], ms=11 - 5 * k / max(n - 1, 1),
                    mfc="none", mew=1.4, ls=styles[k % len(styles)], lw=1.4, label=label)
    if tol is not None:
        ax.axhline(tol, color="grey", ls="--", lw=1, label=tol_label or f"tolerance {tol:g}")
    ax.set_xlabel("iteration")
    ax.set_ylabel("max |residual| (continuity + periodicity)")
    ax.set_title(title)
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.grid(True, which="both", alpha=0.3)
    # below the axes: the curves fill the plot from the upper left to the lower right
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, frameon=False)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_multipliers(mults_by_label: dict, path, reference=None, zoom: bool = True,
                     title: str = "Floquet multipliers") -> Path:
    """Multipliers in the complex plane with the unit circle (equal aspect), one marker per variant.

    Parameters
    ----------
    mults_by_label : dict
        Label to the multipliers of a variant (any form :func:`as_complex` reads).
    path : str or Path
        PNG file to write.
    reference : array_like or dict, optional
        The paper's values (drawn as black crosses labelled "paper"), or label -> values for several sets.
    zoom : bool
        Add a row of panels magnifying each multiplier of the upper half plane (variants differ by ~1e-3).
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    sets = [(lab, as_complex(v), dict(marker=_MARKERS[k % len(_MARKERS)], ms=7, mfc="none", ls="none",
                                      mew=1.4))
            for k, (lab, v) in enumerate(mults_by_label.items())]
    if reference is not None:
        refs = reference if isinstance(reference, dict) else {"paper": reference}
        ref_styles = [dict(marker="x", ms=10, color="k", ls="none", mew=2),
                      dict(marker="+", ms=12, color="tab:red", ls="none", mew=2),
                      dict(marker="1", ms=12, color="tab:purple", ls="none", mew=2)]
        for k, (lab, v) in enumerate(refs.items()):
            sets.append((lab, as_complex(v), ref_styles[k % len(ref_styles)]))
    anchors = sorted({(round(z.real, 2), round(abs(z.imag), 2)) for z in sets[0][1]}, key=lambda a: -np.hypot(*a)) \
        if zoom and sets else []
    ncols = max(len(anchors), 1)
    if zoom and anchors:
        fig = plt.figure(figsize=(max(8, 3.0 * ncols), 10))
        gs = fig.add_gridspec(2, ncols, height_ratios=[2.2, 1])
        ax = fig.add_subplot(gs[0, :])
        zax = [fig.add_subplot(gs[1, i]) for i in range(ncols)]
    else:
        fig, ax = plt.subplots(figsize=(7, 7))
        zax = []
    th = np.linspace(0, 2 * np.pi, 400)
    ax.plot(np.cos(th), np.sin(th), color="grey", lw=1, label="unit circle |Λ| = 1")
    ax.axhline(0, color="grey", lw=0.5)
    ax.axvline(0, color="grey", lw=0.5)
    for lab, z, st in sets:
        ax.plot(z.real, z.imag, label=lab, **st)
    allz = np.concatenate([z for _, z, _ in sets]) if sets else np.zeros(0)
    r = max(1.1, float(np.max(np.abs(allz))) * 1.1 if allz.size else 1.1)
    ax.set_xlim(-r, r)
    ax.set_ylim(-r * 0.75, r * 0.75)
    ax.set_aspect("equal")
    ax.set_xlabel("Re Λ")
    ax.set_ylabel("Im Λ")
    ax.set_title(title + " (outside the unit circle: unstable)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    for zx, (re, im) in zip(zax, anchors):
        c = complex(re, im)
        near = np.array([w for _, z, _ in sets for w in z if abs(w - c) < 0.05])
        half = max(float(np.max(np.abs(near - near.mean()))) * 1.4 if near.size else 0, 2e-4)
        ctr = near.mean() if near.size else c
        for lab, z, st in sets:
            sel = np.abs(z - c) < 0.05
            zx.plot(z[sel].real, z[sel].imag, **st)
        zx.set_xlim(ctr.real - half, ctr.real + half)
        zx.set_ylim(ctr.imag - half, ctr.imag + half)
        zx.set_aspect("equal")
        zx.set_title(f"zoom near {re:.3g}{'+' if im >= 0 else '-'}{abs(im):.3g}j", fontsize=9)
        zx.set_xlabel("Re Λ", fontsize=8)
        zx.set_ylabel("Im Λ", fontsize=8)
        zx.tick_params(labelsize=7)
        zx.ticklabel_format(useOffset=False)
        for lbl in zx.get_xticklabels():
            lbl.set_rotation(30)
        zx.grid(True, alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_states(trim_result, path, title: str = "Trimmed flight: states over one wingbeat") -> Path:
    """The four states over one period (2 x 2 panels), shooting points marked when available.

    Parameters
    ----------
    trim_result : TrimResult or dict
        With ``trajectory_t_s`` [s] and ``trajectory_x`` (u, w [m/s], q [rad/s], theta [rad]);
        optionally ``shooting_times_s`` and ``shooting_points``.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    t, x = _trajectory(trim_result)
    T = _period(t)
    try:
        ts = np.asarray(_get(trim_result, "shooting_times", "shooting_times_s"), float)
        xs = np.asarray(_get(trim_result, "shooting_points"), float)
    except KeyError:
        ts = xs = None
    fig, axs = plt.subplots(2, 2, figsize=(10, 6.5), sharex=True)
    for k, ax in enumerate(axs.ravel()):
        ax.plot(t / T, x[:, k], lw=1.6, color=f"C{k}")
        if ts is not None and xs is not None and xs.shape[1] == 4:
            ax.plot(ts / T, xs[:, k], "ko", ms=4, mfc="none", label="shooting points")
            if k == 0:
                ax.legend(fontsize=8)
        ax.set_ylabel(STATE_LABELS[k])
        ax.set_title(STATE_TITLES[k], fontsize=10)
        ax.grid(True, alpha=0.3)
    for ax in axs[1]:
        ax.set_xlabel(f"t / T   (T = {T:.3g} s)")
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_phase_portrait(trim_result, path, title: str = "Limit cycle: phase portrait") -> Path:
    """u-w and w-q projections of the cycle, coloured by the pitch angle theta (colorbar).

    Parameters
    ----------
    trim_result : TrimResult or dict
        With ``trajectory_t_s`` [s] and ``trajectory_x`` (u, w [m/s], q [rad/s], theta [rad]).
    path : str or Path
        PNG file to write.
    title : str
        Figure title.

    Returns
    -------
    Path
    """
    _, x = _trajectory(trim_result)
    fig, axs = plt.subplots(1, 2, figsize=(11.5, 4.8), layout="constrained")
    th = np.degrees(x[:, 3])
    norm = plt.Normalize(th.min(), th.max())
    sc = None
    for ax, (i, j) in zip(axs, ((0, 1), (1, 2))):
        ax.plot(x[:, i], x[:, j], color="lightgrey", lw=1, zorder=1)
        sc = ax.scatter(x[:, i], x[:, j], c=th, cmap="viridis", norm=norm, s=14, zorder=2)
        ax.plot(x[0, i], x[0, j], "r*", ms=12, zorder=3, label="t = 0 (red arrow: direction of time)")
        # direction of travel
        k, s = len(x) // 8, max(len(x) // 30, 1)
        ax.annotate("", xy=(x[k + s, i], x[k + s, j]), xytext=(x[k, i], x[k, j]),
                    arrowprops=dict(arrowstyle="-|>", color="red", lw=2, mutation_scale=22), zorder=4)
        ax.set_xlabel(STATE_LABELS[i])
        ax.set_ylabel(STATE_LABELS[j])
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axs[0].set_title("u - w plane", fontsize=10)
    axs[1].set_title("w - q plane", fontsize=10)
    cb = fig.colorbar(sc, ax=list(axs), shrink=0.95)
    cb.set_label(r"pitch angle $\theta$ [deg]")
    fig.suptitle(title)
    return save_figure(fig, path)


def plot_forces(trim_result, model, path, title: str = "Aerodynamic loads along the trimmed cycle",
                frame: str = "body") -> Path:
    """Loads over the period, from ``model.loads`` mapped over the trajectory, in units of the weight.

    ``frame="body"``: Fx'/(m g) (forward along the body axis), Fz'/(m g) (down, normal to it) and
    My'/(m g c̄) (nose-up); ``frame="inertial"`` (the fixed frame of the paper's figures): the
    horizontal force (forward) and the vertical force (up) over m g, ``F_X = Fx' cos(theta) + Fz' sin(theta)``,
    ``F_up = Fx' sin(theta) - Fz' cos(theta)``, and the same pitching moment.

    Parameters
    ----------
    trim_result : TrimResult or dict
        With ``trajectory_t_s`` [s] and ``trajectory_x``.
    model : BirdModel
        Model whose ``loads`` give the body-frame forces and moment.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.
    frame : {"body", "inertial"}
        Frame of the forces.

    Returns
    -------
    Path
    """
    from birdocp.bird.config import PARAM_NAMES  # local: keep this module importable without the model stack

    if frame not in ("body", "inertial"):
        raise ValueError(f"frame must be 'body' or 'inertial', got {frame!r}")
    t, x = _trajectory(trim_result)
    try:
        p = np.asarray(_get(trim_result, "p"), float).ravel()
    except KeyError:
        p = np.asarray(model.p0, float).ravel()
    mass = p[PARAM_NAMES.index("body.mass_kg")]
    grav = p[PARAM_NAMES.index("body.gravity_mps2")]
    cbar = p[PARAM_NAMES.index("body.reference_chord_m")]
    n = t.size
    L = np.asarray(model.loads.map(n)(x.T, t[None, :], p))
    T = _period(t)
    W = mass * grav
    moment = (L[2] / (W * cbar), r"$M_{y'}/(m g \bar c)$ (nose-up)")
    if frame == "body":
        series = [(L[0] / W, r"$F_{x'}/(m g)$ (forward)"), (L[1] / W, r"$F_{z'}/(m g)$ (down)"), moment]
        frame_text = "body frame: x' forward along the body axis, z' down"
    else:
        th = x[:, 3]
        FX = L[0] * np.cos(th) + L[1] * np.sin(th)
        Fup = L[0] * np.sin(th) - L[1] * np.cos(th)
        series = [(FX / W, r"$F_X/(m g)$ (horizontal, forward)"), (Fup / W, r"$F_{up}/(m g)$ (vertical, up)"), moment]
        frame_text = "fixed (inertial) frame: X horizontal forward, vertical up"
    fig, axs = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for k, (ax, (v, lab)) in enumerate(zip(axs, series)):
        ax.plot(t / T, v, color=f"C{k}", lw=1.6)
        mean = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)) / T)
        ax.axhline(mean, color=f"C{k}", ls="--", lw=1, label=f"period mean {mean:+.3f}")
        ax.axhline(0, color="grey", lw=0.5)
        ax.set_ylabel(lab + "  [-]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axs[-1].set_xlabel(f"t / T   (T = {T:.3g} s)")
    fig.suptitle(f"{title}\n({frame_text}; m g = {W:.3g} N, mean chord c̄ = {cbar:.3g} m)", fontsize=11)
    fig.tight_layout()
    return save_figure(fig, path)
