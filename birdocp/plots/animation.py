"""The bird in motion: frames and animations of a flapping cycle.

Input: the dict of :func:`birdocp.bird.snapshots.motion` (geometry in the code frame, origin at the
centre of mass G) plus the path of G (:func:`birdocp.bird.snapshots.earth_path`). Each frame shows

* left: the bird in 3-D, seen from the front-left and above, pitched by theta about its centre of
  mass: a schematic body (an ellipsoid with neck, decurved beak and tail, not a measured shape),
  both wings' bones (arm, forearm, hand), the four master feathers, the smoothed leading and trailing
  edges, and the lifting line coloured by the circulation of each element;
* right, top: the path of G over the cycle relative to the mean flight (a frame moving with the mean
  velocity), with the body axis drawn through G at its pitch;
* right, bottom: pitch angle theta and shoulder flapping angle over the cycle, with a cursor.

matplotlib is imported inside the functions (never at import time).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from birdocp.io.files import atomic_target

__all__ = ["draw_frame", "draw_bird", "save_animation", "animation_writer", "BODY_NOTE"]

BODY_NOTE = "body: schematic (ellipsoid, neck, beak, tail), not a measured shape"

# Schematic body in body axes (forward x', span y, up h) [m].
_BODY_CENTRE_FWD_M = -0.02
_BODY_SEMI_AXES_M = (0.15, 0.055, 0.06)
_NECK_HEAD_BEAK_M = np.array([[0.12, 0.0, 0.02], [0.20, 0.0, 0.06], [0.27, 0.0, 0.07],
                              [0.33, 0.0, 0.05], [0.39, 0.0, 0.01], [0.43, 0.0, -0.04]])
_TAIL_M = np.array([[-0.15, -0.05, 0.0], [-0.27, -0.06, -0.01], [-0.27, 0.06, -0.01], [-0.15, 0.05, 0.0],
                    [-0.15, -0.05, 0.0]])


def _to_world(P: np.ndarray, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Code-frame points (3, K) relative to G -> (span, forward, up) in a horizontal frame at G.

    The body is pitched by ``theta`` (nose-up positive) about the span axis e1."""
    fwd, up = -P[2], P[1]
    c, s = np.cos(theta), np.sin(theta)
    return P[0], c * fwd - s * up, s * fwd + c * up


def _body_world(theta: float, world=None):
    """Schematic body as (span, forward, up) arrays: ellipsoid mesh, neck-beak polyline, tail
    (``world``: a code-frame (3, K) -> (X, Y, Z) transform; default pitched by ``theta``)."""
    world = world or (lambda P: _to_world(P, theta))
    a, b, c = _BODY_SEMI_AXES_M
    uu, vv = np.meshgrid(np.linspace(0, 2 * np.pi, 17), np.linspace(0, np.pi, 9))
    fwd = _BODY_CENTRE_FWD_M + a * np.cos(vv)
    span = b * np.sin(vv) * np.cos(uu)
    up = c * np.sin(vv) * np.sin(uu)
    pts = np.stack([span.ravel(), up.ravel(), -fwd.ravel()])
    X, Y, Z = world(pts)
    mesh = tuple(v.reshape(fwd.shape) for v in (X, Y, Z))
    extras = []
    for poly in (_NECK_HEAD_BEAK_M, _TAIL_M):
        pts = np.stack([poly[:, 1], poly[:, 2], -poly[:, 0]])
        extras.append(world(pts))
    return mesh, extras


def _mirror(P: np.ndarray) -> np.ndarray:
    Q = np.array(P, float, copy=True)
    Q[0] *= -1
    return Q


def _stroke(flap_rad: np.ndarray, k: int) -> str:
    """'downstroke' where the flapping angle decreases (tip moving down), 'upstroke' where it
    increases, 'reversal' at a turning point (the change over two frames is below 1e-6 of the range)."""
    n = len(flap_rad)
    d = flap_rad[(k + 1) % n] - flap_rad[(k - 1) % n]
    if abs(d) <= 1e-6 * max(float(np.ptp(flap_rad)), 1e-12):
        return "reversal"
    return "downstroke" if d < 0 else "upstroke"


def draw_bird(ax, mo: dict, k: int, world, cmap, norm) -> None:
    """The bird of frame ``k`` on the 3-D axes ``ax``: schematic body, both wings' outline, bones and
    master feathers, the lifting line coloured by circulation.

    Parameters
    ----------
    ax : Axes3D
        The axes to draw on.
    mo : dict
        The drawing data (:func:`birdocp.bird.snapshots.motion` with ``gamma_m2ps``).
    k : int
        Frame index.
    world : callable
        Maps code-frame points (3, K) relative to G to the axes' (X, Y, Z).
    cmap, norm
        Colour map and normalisation of the circulation.
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    mesh, extras = _body_world(0.0, world)
    ax.plot_wireframe(*mesh, color="0.5", lw=0.35, alpha=0.6)
    ax.plot(*extras[0], color="0.25", lw=2.2)   # neck, head, beak
    ax.plot(*extras[1], color="0.35", lw=1.2)   # tail
    for mirror in (False, True):
        fix = _mirror if mirror else (lambda P: P)
        le = fix(mo["leading_edge_m"][k])
        te = fix(mo["trailing_edge_m"][k])
        outline = np.concatenate([le, te[:, ::-1]], axis=1)
        X, Y, Z = world(outline)
        ax.add_collection3d(Poly3DCollection([list(zip(X, Y, Z))], facecolor=(0.55, 0.7, 0.9, 0.25),
                                             edgecolor="none"))
        ax.plot(*world(le), color="k", lw=1.0)
        ax.plot(*world(te), color="0.35", lw=0.9)
        ax.plot(*world(fix(mo["chain_m"][k])), color="saddlebrown", lw=3.0,
                solid_capstyle="round")
        for i in range(mo["feather_base_m"].shape[2]):
            seg = np.stack([mo["feather_base_m"][k][:, i], mo["feather_tip_m"][k][:, i]], axis=1)
            ax.plot(*world(fix(seg)), color="peru", lw=1.3)
    line = mo["line_m"][k]
    gam = mo["gamma_m2ps"][k]
    for j in range(len(gam)):
        seg = line[:, 2 * j:2 * j + 3]
        ax.plot(*world(seg), color=cmap(norm(gam[j])), lw=2.4)


class _Scene:
    """Figure, axes and fixed artists, shared by every frame."""

    def __init__(self, mo: dict, path_fwd_m, path_up_m, title: str, figsize, gamma_lim=None):
        import matplotlib.pyplot as plt
        from matplotlib import colors, cm

        self.mo = mo
        self.fig = plt.figure(figsize=figsize)
        gs = self.fig.add_gridspec(2, 2, width_ratios=[1.5, 1.0], height_ratios=[1.0, 1.0],
                                   left=0.0, right=0.91, top=0.88, bottom=0.13, wspace=0.25, hspace=0.6)
        self.ax3 = self.fig.add_axes([0.0, 0.12, 0.56, 0.74], projection="3d")
        self.axp = self.fig.add_subplot(gs[0, 1])
        self.axt = self.fig.add_subplot(gs[1, 1])
        g = mo["gamma_m2ps"]
        lo, hi = gamma_lim if gamma_lim is not None else (float(g.min()), float(g.max()))
        if not hi > lo:
            hi = lo + 1e-9
        self.norm = colors.Normalize(lo, hi)
        self.cmap = plt.get_cmap("plasma")
        sm = cm.ScalarMappable(norm=self.norm, cmap=self.cmap)
        cax = self.fig.add_axes([0.1, 0.07, 0.36, 0.022])
        cb = self.fig.colorbar(sm, cax=cax, orientation="horizontal")
        cb.set_label("circulation of the lifting-line elements Γ [m²/s]", fontsize=8)
        cb.ax.tick_params(labelsize=7)
        self.fig.suptitle(title, fontsize=10)

        t = mo["t_s"]
        T = float(t[-1] - t[0]) * len(t) / max(len(t) - 1, 1) if len(t) > 1 else 1.0
        self.T = T
        # path of G relative to the mean flight (straight line through the cycle's ends)
        f, h = np.asarray(path_fwd_m, float), np.asarray(path_up_m, float)
        s = np.linspace(0.0, 1.0, len(f))
        self.rel_f = 100 * (f - f[0] - s * (f[-1] - f[0]))
        self.rel_h = 100 * (h - h[0] - s * (h[-1] - h[0]))
        self.mean_speed = (f[-1] - f[0]) / max(float(mo["path_t_s"][-1] - mo["path_t_s"][0]), 1e-12)
        self.mean_climb = (h[-1] - h[0]) / max(float(mo["path_t_s"][-1] - mo["path_t_s"][0]), 1e-12)
        self.flap = mo["joint_angles_rad"][:, 1] if mo["joint_angles_rad"].shape[1] > 1 else None
        self._static_panels()

    def _static_panels(self) -> None:
        """Path of G and the time traces, drawn once; :meth:`draw` moves their cursors."""
        mo = self.mo
        axp = self.axp
        axp.plot(self.rel_f, self.rel_h, color="0.6", lw=1.2)
        (self.path_done,) = axp.plot([], [], color="tab:blue", lw=1.8)
        (self.axis_line,) = axp.plot([], [], color="k", lw=2.0)
        (self.nose,) = axp.plot([], [], "o", color="k", ms=3)
        (self.g_dot,) = axp.plot([], [], "o", color="tab:red", ms=5)
        self.span_cm = max(np.ptp(self.rel_f), np.ptp(self.rel_h), 0.5)
        pad = 0.6 * self.span_cm
        axp.set_xlim(self.rel_f.min() - pad, self.rel_f.max() + pad)
        axp.set_ylim(self.rel_h.min() - pad, self.rel_h.max() + pad)
        axp.set_aspect("equal", adjustable="box")
        axp.set_xlabel("forward, relative to the mean flight [cm]", fontsize=8)
        axp.set_ylabel("up [cm]", fontsize=8)
        axp.set_title(f"path of G over the cycle, body axis at its pitch\nmean flight {self.mean_speed:.2f} m/s "
                      f"forward, {self.mean_climb:+.3f} m/s up", fontsize=8)
        axp.tick_params(labelsize=7)
        axp.grid(alpha=0.3)

        axt = self.axt
        ts = 1000 * mo["t_s"]
        theta_deg = np.degrees(mo["x"][:, 3])
        axt.plot(ts, theta_deg, color="tab:blue", lw=1.5)
        axt.set_xlabel("t [ms]", fontsize=8)
        axt.set_ylabel("pitch θ [deg]", fontsize=8, color="tab:blue")
        axt.tick_params(labelsize=7)
        axt.set_title("pitch θ (blue) and shoulder flapping angle (orange)", fontsize=8)
        axt.grid(alpha=0.3)
        self.cursor = axt.axvline(ts[0], color="k", lw=0.8)
        (self.th_dot,) = axt.plot([], [], "o", color="tab:blue", ms=4)
        self.fl_dot = None
        if self.flap is not None:
            axf = axt.twinx()
            axf.plot(ts, np.degrees(self.flap), color="tab:orange", lw=1.2)
            (self.fl_dot,) = axf.plot([], [], "o", color="tab:orange", ms=4)
            axf.set_ylabel("shoulder flap [deg] (tip up +)", fontsize=8, color="tab:orange")
            axf.tick_params(labelsize=7)

    # ------------------------------------------------------------------------------------------
    def draw(self, k: int) -> None:
        mo = self.mo
        th = float(mo["x"][k, 3])
        ax = self.ax3
        ax.cla()
        draw_bird(ax, mo, k, lambda P: _to_world(P, th), self.cmap, self.norm)
        ax.scatter([0], [0], [0], color="k", s=12)
        lim = 0.7
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-0.45, 0.45)
        ax.set_zlim(-0.45, 0.45)
        ax.set_box_aspect((2 * lim, 0.9, 0.9), zoom=1.1)
        ax.view_init(elev=28, azim=-58)
        ax.set_xlabel("span [m]", fontsize=7, labelpad=-4)
        ax.set_ylabel("forward [m]", fontsize=7, labelpad=-4)
        ax.set_zlabel("up [m]", fontsize=7, labelpad=-6)
        ax.tick_params(labelsize=6, pad=-2)
        ax.set_xticks([-0.6, -0.3, 0, 0.3, 0.6])
        ax.set_yticks([-0.4, 0, 0.4])
        ax.set_zticks([-0.4, 0, 0.4])
        phase = k / len(mo["t_s"])
        stroke = _stroke(self.flap, k) if self.flap is not None else ""
        ax.set_title(f"t = {1000 * mo['t_s'][k]:5.1f} ms   t/T = {phase:.3f}   {stroke:<10}\n"
                     f"pitch θ = {np.degrees(th):+.2f} deg", fontsize=9, family="monospace")

        ip = int(np.argmin(np.abs(mo["path_t_s"] - mo["t_s"][k])))
        x0, y0 = self.rel_f[ip], self.rel_h[ip]
        L = 0.4 * self.span_cm
        c, s = np.cos(th), np.sin(th)
        self.path_done.set_data(self.rel_f[:ip + 1], self.rel_h[:ip + 1])
        self.axis_line.set_data([x0 - L * c, x0 + L * c], [y0 - L * s, y0 + L * s])
        self.nose.set_data([x0 + L * c], [y0 + L * s])
        self.g_dot.set_data([x0], [y0])
        ts = 1000 * mo["t_s"][k]
        self.cursor.set_xdata([ts, ts])
        self.th_dot.set_data([ts], [np.degrees(th)])
        if self.fl_dot is not None:
            self.fl_dot.set_data([ts], [np.degrees(self.flap[k])])


def draw_frame(mo: dict, path_fwd_m, path_up_m, k: int, path, title: str = "", figsize=(10.0, 5.6),
               dpi: int = 90) -> Path:
    """Draw frame ``k`` of a motion to a PNG file ``path`` and return the path.

    Parameters
    ----------
    mo : dict
        :func:`birdocp.bird.snapshots.motion` output plus ``path_t_s`` (times of the path samples).
    path_fwd_m, path_up_m : array_like
        Path of G (:func:`birdocp.bird.snapshots.earth_path`) at ``mo["path_t_s"]`` [m].
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

    sc = _Scene(mo, path_fwd_m, path_up_m, title, figsize)
    sc.draw(k)
    out = Path(path)
    sc.fig.savefig(out, dpi=dpi)
    plt.close(sc.fig)
    return out


def animation_writer(path, fps: float):
    """The matplotlib writer for ``path``: Pillow for ``.gif``, ffmpeg for ``.mp4``.

    Parameters
    ----------
    path : str or Path
        Output file; its suffix chooses the writer.
    fps : float
        Frames per second [1/s].

    Returns
    -------
    matplotlib.animation.AbstractMovieWriter

    Raises
    ------
    ValueError
        If the suffix is neither ``.gif`` nor ``.mp4``.
    RuntimeError
        For ``.mp4`` when ffmpeg is not available (message says to use ``.gif``).
    """
    from matplotlib import animation

    suffix = Path(path).suffix.lower()
    if suffix == ".gif":
        return animation.PillowWriter(fps=fps)
    if suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise RuntimeError("MP4 needs ffmpeg, which is not installed here; write a .gif instead "
                               "(no external program needed) or install ffmpeg")
        return animation.FFMpegWriter(fps=fps, bitrate=1800)
    raise ValueError(f"unknown animation format '{suffix}': use .gif or .mp4")


def save_animation(mo: dict, path_fwd_m, path_up_m, path, fps: float = 12.0, title: str = "",
                   figsize=(10.0, 5.6), dpi: int = 80, progress=None) -> Path:
    """Write the animation of a motion (one frame per time of ``mo``) to ``path`` (.gif or .mp4).

    Parameters
    ----------
    mo, path_fwd_m, path_up_m
        As for :func:`draw_frame`.
    path : str or Path
        Output file; the suffix selects the writer (:func:`animation_writer`).
    fps : float
        Frames per second of the file.
    title, figsize, dpi
        Figure title, size [inch] and resolution [dots per inch].
    progress : callable, optional
        Called with no argument after each frame (e.g. a progress bar's ``update``).

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib.pyplot as plt

    out = Path(path)
    writer = animation_writer(out, fps)
    sc = _Scene(mo, path_fwd_m, path_up_m, title, figsize)
    try:
        # the one atomic write (a temporary file per call, suffix kept for the writer): two animations
        # of one file at once each write a whole file; an interrupt leaves the earlier file
        with atomic_target(out, suffix=out.suffix) as tmp, writer.saving(sc.fig, str(tmp), dpi):
            for k in range(len(mo["t_s"])):
                sc.draw(k)
                writer.grab_frame()
                if progress is not None:
                    progress()
    finally:
        plt.close(sc.fig)
    return out
