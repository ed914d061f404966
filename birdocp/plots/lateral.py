"""Figures of the lateral Floquet modes of a six-degree-of-freedom cycle over one wingbeat: one PNG
per mode (roll subsidence, spiral, Dutch-roll-like pair: one figure for the pair), the periodic mode
shape of :func:`birdocp.studies.lateral_modes.lateral_mode_histories` in its four components
v/U, p T, r T and phi (normalised: the largest modulus over the wingbeat is 1). A complex mode shows
its real part (solid) and imaginary part (dashed): the shape at two instants a quarter of its
oscillation apart. The downstroke (the flapping angle decreasing) is shaded grey."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from birdocp.plots.figures import save_figure

__all__ = ["plot_lateral_modes", "plot_lateral_mode", "plot_lateral_run", "LATERAL_COMPONENT_LABELS"]

LATERAL_COMPONENT_LABELS = ("sideslip v / U", "roll rate p T", "yaw rate r T", r"bank angle $\phi$")
"""Axis labels of the four scaled components (U the mean forward speed, T the period)."""

_TITLES = {"roll_subsidence": "roll subsidence", "spiral": "spiral", "dutch_roll_like": "Dutch-roll-like pair",
           "lateral_real": "lateral (real)"}


def _growth(beats: float) -> str:
    if beats is None or not np.isfinite(beats):
        return "neutral"
    if beats == 0:
        return "gone in one wingbeat"
    return f"doubles in {beats:.3g} wingbeats" if beats > 0 else f"halves in {-beats:.3g} wingbeats"


def _downstroke_spans(t, flap) -> list[tuple[float, float]]:
    """Intervals of ``t`` where the flapping angle decreases (the wing tip moving down)."""
    if flap is None:
        return []
    down = np.diff(np.asarray(flap, float)) < 0
    spans, start = [], None
    for i, d in enumerate(down):
        if d and start is None:
            start = t[i]
        if not d and start is not None:
            spans.append((start, t[i]))
            start = None
    if start is not None:
        spans.append((start, t[-1]))
    return spans


def plot_lateral_mode(histories: dict, k: int, path, validity: str | None = None) -> Path:
    """One mode (index ``k`` of ``histories["modes"]``) over the wingbeat, written to ``path``.

    Parameters
    ----------
    histories : dict
        :func:`birdocp.studies.lateral_modes.lateral_mode_histories`'s result.
    k : int
        The mode's index.
    path : str or Path
        The PNG.
    validity : str, optional
        A note on the cycle's validity, printed under the title.

    Returns
    -------
    Path
        ``path``.
    """
    m = histories["modes"][k]
    t = np.asarray(histories["t_s"]) / histories["period_s"]
    q = np.asarray(m["history"])
    cplx = abs(m["multiplier"].imag) > 1e-12
    fig, axes = plt.subplots(4, 1, figsize=(7.5, 8), sharex=True)
    down = _downstroke_spans(t, histories.get("flap_angle_rad"))
    for j, ax in enumerate(axes):
        for a, b in down:
            ax.axvspan(a, b, color="0.92", lw=0, label="downstroke" if (j == 0 and a == down[0][0]) else None)
        ax.plot(t, q[:, j].real, color=f"C{j}", lw=1.8, label="real part" if cplx else None)
        if cplx:
            ax.plot(t, q[:, j].imag, color=f"C{j}", lw=1.2, ls="--", label="imaginary part")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylabel(LATERAL_COMPONENT_LABELS[j])
        ax.set_ylim(-1.1, 1.1)
        ax.grid(alpha=0.3)
    if cplx or down:
        axes[0].legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time in the wingbeat t / T")
    z = m["multiplier"]
    zs = f"{z.real:.4g} {'+' if z.imag >= 0 else '-'} {abs(z.imag):.4g}i" if cplx else f"{z.real:.4g}"
    title = (f"Lateral Floquet mode: {_TITLES.get(m['label'], m['label'])}\n"
             f"multiplier {zs} (|.| = {abs(z):.4g}): {_growth(m['beats_to_double'])}")
    if validity:
        title += f"\n{validity}"
    axes[0].set_title(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_lateral_modes(histories: dict, folder, validity: str | None = None) -> list[Path]:
    """One PNG per lateral mode in ``folder`` (``lateral_mode_<label>.png``; a complex pair once).

    Parameters
    ----------
    histories : dict
        :func:`birdocp.studies.lateral_modes.lateral_mode_histories`'s result.
    folder : str or Path
        Where the PNGs go.
    validity : str, optional
        A note on the cycle's validity, printed on every figure.

    Returns
    -------
    list of Path
    """
    folder = Path(folder)
    out, seen = [], {}
    for k, m in enumerate(histories["modes"]):
        z = m["multiplier"]
        if z.imag < -1e-12:
            continue  # the conjugate of a pair: the same mode
        n = seen[m["label"]] = seen.get(m["label"], 0) + 1
        name = f"lateral_mode_{m['label']}" + (f"_{n}" if n > 1 else "") + ".png"
        out.append(plot_lateral_mode(histories, k, folder / name, validity))
    return out


def plot_lateral_run(res: dict, run) -> list[Path]:
    """The lateral-mode figures of a 6-DOF ``birdocp trim`` run folder (its ``result.json`` dict
    ``res`` and its ``config.toml``), written into the folder.

    Parameters
    ----------
    res : dict
        The run's ``result.json``.
    run : str or Path
        The run folder.

    Returns
    -------
    list of Path
        The figures written.
    """
    from birdocp.bird.config import load
    from birdocp.studies.lateral_modes import lateral_mode_histories

    run = Path(run)
    valid = (res.get("validity") or {}).get("valid")
    note = None if valid is None else ("the model holds on this cycle" if valid else
                                       "the model does NOT hold on this cycle (validity limits exceeded)")
    return plot_lateral_modes(lateral_mode_histories(res, load(run / "config.toml")), run, note)
