"""Figure of the prescribed wing kinematics over one wingbeat (default configuration).

Writes ``results/wing_kinematics.png`` (or ``--out PATH``). Panels:

(a) 3-D snapshots of the right wing at 8 instants t = k T/8 (one small panel each, same limits and
    view, equal scales): bones (arm, forearm, hand) as thick lines, the 7 master feathers (the 4 that
    shape the trailing edge solid, feathers 1, 3, 5 with weight 0 dotted), the smoothed leading and trailing edges, the lifting line, and the edges projected on
    the floor (a top view);
(b) side view of the paths over one wingbeat of the wing tip (tip of the outermost feather) and of the
    centroid of the right wing's lifting line (chord-weighted), relative to the centre of mass G;
    the tip path is coloured by whether the tip is ahead of or behind G;
(c) front view of the whole merged lifting line (both wings) at the 8 instants.

Coordinates: the code frame of docs/model.md §1 (e1 span to the right, e2 up, e3 backwards), shown
with the forward body axis x' = -e3 where a fore-aft axis is needed; origin at G unless stated. The
wing root (shoulder) is ``cfg.wing.root_ahead_m`` ahead of G.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from birdocp.bird import kinematics  # noqa: E402
from birdocp.bird.config import JOINT_NAMES, Config  # noqa: E402
from birdocp.bird.snapshots import motion  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
N_SNAP = 8
CMAP = plt.get_cmap("viridis")


def sample(cfg: Config, times: np.ndarray) -> dict:
    """Right-wing bones, feathers and edges and the merged lifting line at ``times``
    (:func:`birdocp.bird.snapshots.motion`), origin on the body centre line at the shoulders."""
    mo = motion(cfg, times)
    up = np.array([[0.0], [0.0], [cfg.wing.root_ahead_m]])  # origin G -> the shoulders' centre line
    names = {"chain": "chain_m", "fbase": "feather_base_m", "ftip": "feather_tip_m", "obase": "minor_feather_base_m",
             "otip": "minor_feather_tip_m", "le": "leading_edge_m",
             "te": "trailing_edge_m", "le_raw": "leading_edge_raw_m", "line": "line_m"}
    out = {k: mo[v] + up for k, v in names.items()}
    out["chord"] = mo["chord_m"]
    return out


def to_G(P: np.ndarray, root_ahead: float) -> dict:
    """Code-frame points (origin at the shoulders' centre line) -> components relative to G [cm].

    Returns dict with span e1, up e2 and forward x' = -e3 (G is at e3 = +root_ahead)."""
    return {"e1": 100 * P[..., 0, :], "e2": 100 * P[..., 1, :], "xf": 100 * (root_ahead - P[..., 2, :])}


def right_wing_centroid(line: np.ndarray, chord: np.ndarray) -> np.ndarray:
    """Chord x length weighted centroid of the right half of the merged line (3 x K per time)."""
    n = line.shape[-1]
    mid = n // 2
    nodes = line[:, :, mid::2]         # nodes of the right wing (centre line to tip)
    centres = line[:, :, mid + 1::2]   # element centres between them
    c = chord[:, mid + 1::2]
    ds = np.linalg.norm(np.diff(nodes, axis=2), axis=1)
    wgt = c * ds
    return (centres * wgt[:, None, :]).sum(axis=2) / wgt.sum(axis=1)[:, None]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "results" / "wing_kinematics.png"))
    ap.add_argument("--dpi", type=int, default=150)
    args = ap.parse_args(argv)

    cfg = Config()
    T = cfg.gait.period_s
    d = cfg.wing.root_ahead_m
    amp = cfg.gait.shoulder_flap.amplitude_deg
    t_snap = np.arange(N_SNAP) * T / N_SNAP
    t_path = np.linspace(0.0, T, 241)
    S = sample(cfg, t_snap)
    Pth = sample(cfg, t_path)
    colors = [CMAP(0.92 * k / (N_SNAP - 1)) for k in range(N_SNAP)]

    fig = plt.figure(figsize=(16, 16))
    outer = fig.add_gridspec(2, 1, height_ratios=[1.4, 1.0], hspace=0.14)
    top = outer[0].subgridspec(2, 4, hspace=0.3, wspace=0.18)
    bottom = outer[1].subgridspec(1, 2, wspace=0.12, width_ratios=[1.0, 1.35])
    flap = np.degrees([float(kinematics.joint_angles(t, cfg.gait.frequency_hz, {
        j: (getattr(cfg.gait, j).offset_deg, getattr(cfg.gait, j).amplitude_deg, getattr(cfg.gait, j).phase_deg)
        for j in JOINT_NAMES})["shoulder_flap"]) for t in t_snap])

    # (a) 3-D snapshots of the right wing --------------------------------------------------------
    lim = {"xf": (-25.0, 10.0), "e1": (0.0, 70.0), "e2": (-45.0, 40.0)}
    for k in range(N_SNAP):
        ax = fig.add_subplot(top[k // 4, k % 4], projection="3d")
        c = colors[k]

        def plot3(P, **kw):
            Q = to_G(P, d)
            ax.plot(Q["e1"], Q["xf"], Q["e2"], color=c, **kw)

        plot3(S["chain"][k], lw=4.5, solid_capstyle="round")
        for i in range(4):
            plot3(np.stack([S["fbase"][k][:, i], S["ftip"][k][:, i]], axis=1), lw=1.8)
        for i in range(3):
            plot3(np.stack([S["obase"][k][:, i], S["otip"][k][:, i]], axis=1), lw=0.9, ls=":")
        plot3(S["le"][k], lw=1.0)
        plot3(S["te"][k], lw=1.0)
        plot3(S["line"][k][:, 16:], lw=1.2, ls="--")
        ax.scatter([0], [0], [0], color="k", marker="o", s=18)          # G
        ax.scatter([100 * cfg.wing.shoulder_half_separation_m], [100 * d], [0], color="k", marker="^", s=14)
        # shadow of the wing on the floor (top view), for depth
        for P in (S["le"][k], S["te"][k]):
            Q = to_G(P, d)
            ax.plot(Q["e1"], Q["xf"], np.full_like(Q["e1"], lim["e2"][0]), color="0.75", lw=0.8)
        ax.set_xlim(*lim["e1"])
        ax.set_ylim(*lim["xf"])
        ax.set_zlim(*lim["e2"])
        ax.set_box_aspect([np.ptp(lim[a]) for a in ("e1", "xf", "e2")], zoom=1.1)  # equal scale
        ax.view_init(elev=24, azim=-52)
        ax.tick_params(labelsize=6, pad=0)
        ax.set_xlabel("e1 span [cm]", fontsize=7, labelpad=-2)
        ax.set_ylabel("x' fwd [cm]", fontsize=7, labelpad=-4)
        ax.set_zlabel("e2 up [cm]", fontsize=7, labelpad=-4)
        ax.set_yticks([-20, -10, 0, 10])
        ax.set_xticks([0, 20, 40, 60])
        ax.set_zticks([-40, -20, 0, 20, 40])
        fl = 0.0 if abs(flap[k]) < 0.5 else flap[k]
        ax.set_title(f"t/T = {k}/8   shoulder flap {fl:+.0f} deg", color="w" if k < 5 else "k",
                     fontsize=9, pad=0, fontweight="bold",
                     bbox=dict(facecolor=c, edgecolor="none", boxstyle="round,pad=0.25"))
        if k == 0:
            handles = [Line2D([], [], color="0.3", lw=4.5, label="bones: arm, forearm, hand"),
                       Line2D([], [], color="0.3", lw=1.8, label="feathers 6, 4, 2, 0 (trailing edge)"),
                       Line2D([], [], color="0.3", lw=0.9, ls=":", label="feathers 5, 3, 1 (weight 0)"),
                       Line2D([], [], color="0.3", lw=1.0, label="smoothed leading/trailing edges"),
                       Line2D([], [], color="0.3", lw=1.2, ls="--", label="lifting line"),
                       Line2D([], [], color="0.75", lw=0.8, label="edges projected on the floor"),
                       Line2D([], [], color="k", marker="o", ls="", label="G"),
                       Line2D([], [], color="k", marker="^", ls="", label="right shoulder")]
            fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.925), ncol=8,
                       fontsize=8, frameon=False)
    fig.text(0.5, 0.93, "(a) right wing at t = k T/8 in 3-D, viewed from behind, above and to the right; "
             "origin at G, equal scales", ha="center", fontsize=10)

    # (b) side view of the tip and lifting-line centroid paths ----------------------------------
    ax = fig.add_subplot(bottom[0])
    tip = to_G(Pth["le_raw"][:, :, 4:5], d)
    xt, yt = tip["xf"].ravel(), tip["e2"].ravel()
    cen = to_G(right_wing_centroid(Pth["line"], Pth["chord"])[:, :, None], d)
    xc, yc = cen["xf"].ravel(), cen["e2"].ravel()
    segs = np.stack([np.stack([xt[:-1], yt[:-1]], 1), np.stack([xt[1:], yt[1:]], 1)], axis=1)
    ahead = 0.5 * (xt[:-1] + xt[1:]) > 0
    lc = LineCollection(segs, colors=np.where(ahead[:, None], np.array([[0.1, 0.35, 0.85, 1]]),
                                              np.array([[0.85, 0.2, 0.1, 1]])), lw=2.5)
    ax.add_collection(lc)
    ax.plot(xc, yc, color="0.35", lw=1.5, label="lifting-line centroid (right wing, chord-weighted)")
    ax.axvline(0, color="k", lw=0.6, ls=":")
    ax.plot(0, 0, "ko", ms=7, label="centre of mass G")
    ax.plot(100 * d, 0, "k^", ms=7, label=f"shoulder ({100 * d:.0f} cm ahead of G)")
    ks = np.arange(N_SNAP) * (len(t_path) - 1) // N_SNAP
    for k, i in enumerate(ks):
        ax.plot(xt[i], yt[i], "o", color=colors[k], mec="k", ms=6, zorder=5)
        ax.plot(xc[i], yc[i], "s", color=colors[k], mec="k", ms=5, zorder=5)
        ax.annotate(f"{k}/8", (xt[i], yt[i]), textcoords="offset points", xytext=(6, 2), fontsize=7)
    # direction of travel of the tip
    i = len(t_path) // 16
    ax.annotate("", xy=(xt[i + 3], yt[i + 3]), xytext=(xt[i], yt[i]),
                arrowprops=dict(arrowstyle="->", color="k", lw=1.2))
    ax.plot([], [], color=(0.1, 0.35, 0.85), lw=2.5, label="wing-tip path, tip ahead of G")
    ax.plot([], [], color=(0.85, 0.2, 0.1), lw=2.5, label="wing-tip path, tip behind G")
    ax.set_aspect("equal")
    ax.set_xlim(-22, 10)
    ax.set_ylim(-45, 42)
    ax.invert_xaxis()  # forward to the left, as a bird flying to the left in a side view
    ax.set_xlabel("x' = -e3, forward of G [cm]  (forward is to the left)")
    ax.set_ylabel("e2 (up) [cm]")
    ax.set_title("(b) side view over one wingbeat\n(circles: tip, squares: centroid, at t = k T/8)", fontsize=9)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    ax.grid(alpha=0.3)

    # (c) front view of the merged lifting line ------------------------------------------------
    ax = fig.add_subplot(bottom[1])
    for k in range(N_SNAP):
        Q = to_G(S["line"][k], d)
        ax.plot(Q["e1"], Q["e2"], color=colors[k], lw=1.6, label=f"t/T = {k}/8")
    ax.plot(0, 0, "ko", ms=6)
    ax.set_aspect("equal")
    ax.set_xlabel("e1 (span, to the right wing) [cm]")
    ax.set_ylabel("e2 (up) [cm]")
    ax.set_title("(c) front view: merged lifting line of both wings", fontsize=9)
    ax.legend(fontsize=7.5, ncol=4, loc="upper center", bbox_to_anchor=(0.5, -0.13), frameon=False)
    ax.grid(alpha=0.3)

    fig.suptitle(f"Northern bald ibis, prescribed wing kinematics over one wingbeat: flapping amplitude "
                 f"{amp:g} deg, {cfg.gait.frequency_hz:g} Hz (T = {1000 * T:g} ms), wing root "
                 f"{d:g} m ahead of the centre of mass G\n"
                 "code frame: e1 span to the right, e2 up, e3 backwards; x' = -e3 forward; "
                 "downstroke t/T in [-1/4, 1/4], upstroke [1/4, 3/4]; lengths in cm", fontsize=10.5)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=args.dpi, bbox_inches="tight")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
