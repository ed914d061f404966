"""The bird in six degrees of freedom: an animation in 3-D where roll and yaw show.

Input: the drawing data of :func:`birdocp.studies.lateral_motion.lateral_motion` (geometry in the
code frame, 9-states, 6-DOF circulation) and the flight of
:func:`birdocp.studies.lateral_motion.perturbed_flight` (path of G, states at every RK4 step). Each
frame shows

* left: the bird in 3-D in earth-fixed axes (east, north, up) centred on its centre of mass, turned
  by its full attitude (heading psi, pitch theta, bank phi), seen from behind and above: the same
  drawing as the planar animation (:mod:`birdocp.plots.animation`), the lifting line coloured by the
  circulation of the 6-DOF lifting line (the two wings differ in sideslip and roll);
* right, top: the ground track of G (north against east) with the heading drawn at G;
* right, bottom: bank phi, heading psi and pitch theta over the flight, with a cursor.

matplotlib is imported inside the functions (never at import time).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from birdocp.io.files import atomic_target
from birdocp.plots.animation import draw_bird, animation_writer

__all__ = ["save_lateral_animation", "draw_lateral_frame"]


def _world(phi: float, theta: float, psi: float):
    """Code-frame points (3, K) relative to G -> (east, north, up) through the attitude."""
    from birdocp.studies.lateral_motion import body_to_earth

    R = body_to_earth(phi, theta, psi)

    def f(P):
        P = np.asarray(P, float)
        ned = R @ np.stack([-P[2], P[0], -P[1]])  # body axes: x' forward = -e3, y' right = e1, z' down = -e2
        return ned[1], ned[0], -ned[2]
    return f


class _Scene3D:
    """Figure, axes and fixed artists of the lateral animation."""

    def __init__(self, mo: dict, flight: dict, title: str, figsize):
        import matplotlib.pyplot as plt
        from matplotlib import cm, colors

        self.mo, self.flight = mo, flight
        self.fig = plt.figure(figsize=figsize)
        self.ax3 = self.fig.add_axes([0.0, 0.12, 0.56, 0.74], projection="3d")
        gs = self.fig.add_gridspec(2, 2, width_ratios=[1.5, 1.0], left=0.0, right=0.9, top=0.86, bottom=0.12,
                                   wspace=0.25, hspace=0.55)
        self.axg, self.axt = self.fig.add_subplot(gs[0, 1]), self.fig.add_subplot(gs[1, 1])
        g = mo["gamma_m2ps"]
        lo, hi = float(g.min()), float(g.max())
        self.norm = colors.Normalize(lo, hi if hi > lo else lo + 1e-9)
        self.cmap = plt.get_cmap("plasma")
        cax = self.fig.add_axes([0.1, 0.07, 0.36, 0.022])
        cb = self.fig.colorbar(cm.ScalarMappable(norm=self.norm, cmap=self.cmap), cax=cax, orientation="horizontal")
        cb.set_label("circulation of the lifting-line elements Γ [m²/s]", fontsize=8)
        cb.ax.tick_params(labelsize=7)
        self.fig.suptitle(title, fontsize=10)
        self._static()

    def _static(self) -> None:
        fl, axg, axt = self.flight, self.axg, self.axt
        e, n = np.asarray(fl["east_m"]), np.asarray(fl["north_m"])
        axg.plot(e, n, color="0.6", lw=1.2)
        (self.track,) = axg.plot([], [], color="tab:blue", lw=1.8)
        (self.head,) = axg.plot([], [], color="k", lw=2.0)
        (self.g_dot,) = axg.plot([], [], "o", color="tab:red", ms=5)
        self.span = max(np.ptp(e), np.ptp(n), 0.5)
        axg.set_aspect("equal", adjustable="datalim")
        axg.set_xlabel("east [m]", fontsize=8)
        axg.set_ylabel("north [m]", fontsize=8)
        axg.set_title("ground track of G, heading at G (black)", fontsize=8)
        axg.tick_params(labelsize=7)
        axg.grid(alpha=0.3)
        T = fl["period_s"]
        tb = np.asarray(fl["t_s"]) / T
        X = np.asarray(fl["x"])
        for i, name, c in ((6, r"bank $\phi$", "tab:red"), (8, r"heading $\psi$", "tab:green"),
                           (7, r"pitch $\theta$", "tab:blue")):
            axt.plot(tb, np.degrees(X[:, i]), color=c, lw=1.4, label=name)
        axt.set_xlabel("wingbeats", fontsize=8)
        axt.set_ylabel("angle [deg]", fontsize=8)
        axt.legend(fontsize=7, loc="best")
        axt.tick_params(labelsize=7)
        axt.grid(alpha=0.3)
        axt.set_title("attitude of the body", fontsize=8)
        self.cursor = axt.axvline(tb[0], color="k", lw=0.8)

    def draw(self, k: int) -> None:
        mo, fl, ax = self.mo, self.flight, self.ax3
        phi, th, psi = (float(v) for v in mo["x"][k, 6:9])
        ax.cla()
        draw_bird(ax, mo, k, _world(phi, th, psi), self.cmap, self.norm)
        ax.scatter([0], [0], [0], color="k", s=12)
        ax.plot([-0.8, 0.8], [0, 0], [-0.5, -0.5], color="0.75", lw=0.8)  # level reference on the floor
        ax.plot([0, 0], [-0.8, 0.8], [-0.5, -0.5], color="0.75", lw=0.8)
        lim = 0.65
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_zlim(-0.5, 0.5)
        ax.set_box_aspect((2 * lim, 2 * lim, 1.0), zoom=1.15)
        ax.view_init(elev=20, azim=-102)
        ax.set_xlabel("east [m]", fontsize=7, labelpad=-4)
        ax.set_ylabel("north [m]", fontsize=7, labelpad=-4)
        ax.set_zlabel("up [m]", fontsize=7, labelpad=-6)
        ax.tick_params(labelsize=6, pad=-2)
        for setter in (ax.set_xticks, ax.set_yticks):
            setter([-0.6, 0, 0.6])
        ax.set_zticks([-0.4, 0, 0.4])
        T = fl["period_s"]
        ax.set_title(f"wingbeat {mo['t_s'][k] / T:5.2f}   bank φ = {np.degrees(phi):+6.1f} deg\n"
                     f"heading ψ = {np.degrees(psi):+6.1f} deg   pitch θ = {np.degrees(th):+6.1f} deg",
                     fontsize=9, family="monospace")
        i = int(np.argmin(np.abs(np.asarray(fl["t_s"]) - mo["t_s"][k])))
        e, n = fl["east_m"][i], fl["north_m"][i]
        L = 0.12 * self.span
        self.track.set_data(fl["east_m"][:i + 1], fl["north_m"][:i + 1])
        self.head.set_data([e, e + L * np.sin(psi)], [n, n + L * np.cos(psi)])
        self.g_dot.set_data([e], [n])
        tb = mo["t_s"][k] / T
        self.cursor.set_xdata([tb, tb])


def draw_lateral_frame(mo: dict, flight: dict, k: int, path, title: str = "", figsize=(10.0, 5.6),
                       dpi: int = 90) -> Path:
    """Draw frame ``k`` of a lateral motion to the PNG ``path``.

    Parameters
    ----------
    mo : dict
        :func:`birdocp.studies.lateral_motion.lateral_motion`'s result.
    flight : dict
        :func:`birdocp.studies.lateral_motion.perturbed_flight`'s result.
    k : int
        Frame index.
    path : str or Path
        PNG file to write.
    title : str
        Figure title.
    figsize : tuple of float
        Figure size [inch].
    dpi : int
        Resolution [dots per inch].

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib.pyplot as plt

    sc = _Scene3D(mo, flight, title, figsize)
    sc.draw(k)
    out = Path(path)
    sc.fig.savefig(out, dpi=dpi)
    plt.close(sc.fig)
    return out


def save_lateral_animation(mo: dict, flight: dict, path, fps: float = 12.0, title: str = "", figsize=(10.0, 5.6),
                           dpi: int = 80, progress=None) -> Path:
    """Write the lateral animation (one frame per time of ``mo``) to ``path`` (.gif or .mp4).

    Parameters
    ----------
    mo, flight
        As for :func:`draw_lateral_frame`.
    path : str or Path
        Output file; the suffix selects the writer (:func:`birdocp.plots.animation.animation_writer`).
    fps : float
        Frames per second of the file.
    title, figsize, dpi
        Figure title, size [inch] and resolution [dots per inch].
    progress : callable, optional
        Called with no argument after each frame.

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib.pyplot as plt

    out = Path(path)
    writer = animation_writer(out, fps)
    sc = _Scene3D(mo, flight, title, figsize)
    try:
        with atomic_target(out, suffix=out.suffix) as tmp, writer.saving(sc.fig, str(tmp), dpi):
            for k in range(len(mo["t_s"])):
                sc.draw(k)
                writer.grab_frame()
                if progress is not None:
                    progress()
    finally:
        plt.close(sc.fig)
    return out
