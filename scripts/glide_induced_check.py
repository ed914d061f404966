"""A diagnostic of the gliding-limit comparison: does the lifting line's two-dimensional induced velocity
explain its difference to the vortex lattice? birdocp's lifting line of the attached frozen wing
(``birdocp.studies.glide_refined``) with the induced velocity of ``birdocp.bird.aero`` replaced, for this
run only, by a three-dimensional one: each trailing filament starts at its node and runs back along the
body axis (Biot-Savart factor 1 + cos of the angle from the filament's start, instead of 1), optionally
with the bound vortices of the other elements. The model keeps the 2-D one (docs/model.md).

    python scripts/glide_induced_check.py --out results/lateral/glide

writes ``induced_check.json`` (the nine load derivatives of each variant and the VLM's) and prints a table.
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from script_common import parse_with_out, script_parser  # noqa: E402

from birdocp.io.files import atomic_write_json  # noqa: E402
import birdocp.bird.aero as aero  # noqa: E402
from birdocp.studies.glide import attached_config, steady_glide  # noqa: E402
from birdocp.studies.glide_refined import refined_load_derivatives  # noqa: E402

TWO_D = aero.induced_matrices


def _segment(P, A, B):
    """Velocity at P of a unit vortex segment A -> B (Biot-Savart)."""
    r0, r1, r2 = B - A, P - A, P - B
    cr = np.cross(r1, r2)
    return cr / (cr @ cr) * (r0 @ (r1 / np.linalg.norm(r1) - r2 / np.linalg.norm(r2))) / (4 * math.pi)


def induced_3d(centres, nodes, bound: bool):
    """(Vx, Vy, K) as :func:`birdocp.bird.aero.induced_matrices`, with the 3-D filaments (and bound vortices)."""
    C = np.array([np.asarray(c, float).ravel() for c in centres])
    N = np.array([np.asarray(n, float).ravel() for n in nodes])
    D = np.eye(len(N), len(C)) - np.eye(len(N), len(C), -1)
    r = C[:, None, :] - N[None, :, :]
    h2 = r[..., 0] ** 2 + r[..., 1] ** 2
    f = 1 + r[..., 2] / np.linalg.norm(r, axis=2)  # the filament runs from the node to +infinity along e3
    Vx, Vy = (r[..., 1] / h2 * f / (4 * math.pi)) @ D, (-r[..., 0] / h2 * f / (4 * math.pi)) @ D
    if bound:
        for j in range(len(C)):
            for k in range(len(C)):
                if k != j:
                    v = _segment(C[j], N[k], N[k + 1])
                    Vx[j, k] += v[0]
                    Vy[j, k] += v[1]
    s = np.diff(N[:, :2], axis=0)
    s /= np.linalg.norm(s, axis=1)[:, None]
    K = s[:, 1:2] * Vx - s[:, 0:1] * Vy
    return ca.DM(Vx), ca.DM(Vy), ca.DM(K)


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/glide")
    _, out = parse_with_out(ap, argv)
    cfg = attached_config()
    s = steady_glide(cfg)["state"]
    variants = [("2-D (the model)", TWO_D, 1), ("2-D (the model)", TWO_D, 4),
                ("3-D trailing filaments", lambda c, n, *_: induced_3d(c, n, False), 1),
                ("3-D trailing filaments", lambda c, n, *_: induced_3d(c, n, False), 4),
                ("3-D trailing filaments and bound vortices", lambda c, n, *_: induced_3d(c, n, True), 1)]
    rows = []
    try:
        for name, fn, split in variants:
            aero.induced_matrices = fn
            d = refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], split)
            rows.append({"induced_velocity": name, "elements": d.pop("elements"), "derivatives": d})
    finally:
        aero.induced_matrices = TWO_D
    ref = out / "aerosandbox_linear.json"  # the VLM of the interpolated planform, as glide_refined's default cut
    if ref.exists():
        rows.append({"induced_velocity": "AeroSandbox VLM, body-axis wake", "elements": None,
                     "derivatives": json.loads(ref.read_text())["body_axis_wake"]["derivatives"]})
    atomic_write_json(out / "induced_check.json", rows)
    keys = ("L_p", "L_v", "N_v", "L_r", "N_r", "Y_p")
    print("| induced velocity | elements | " + " | ".join(keys) + " |")
    for r in rows:
        print(f"| {r['induced_velocity']} | {r['elements'] or '-'} | " + " | ".join(f"{r['derivatives'][k]:.4g}" for k in keys) + " |")


if __name__ == "__main__":
    main()
