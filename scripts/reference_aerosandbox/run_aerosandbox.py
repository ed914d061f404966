"""Lateral stability of birdocp's frozen ibis wing by AeroSandbox's vortex-lattice method: an
OFFLINE, independent reference (AeroSandbox is not a dependency of birdocp; run this in its own
environment: ``python -m venv /work/venvs/asb && /work/venvs/asb/bin/pip install aerosandbox``).

    /work/venvs/asb/bin/python scripts/reference_aerosandbox/run_aerosandbox.py --planform step \\
        --spacing uniform --spanwise 16 --out results/lateral/glide/aerosandbox.json
    /work/venvs/asb/bin/python scripts/reference_aerosandbox/run_aerosandbox.py \\
        --out results/lateral/glide/aerosandbox_linear.json
    # convergence (8 spanwise x 16 chordwise) and Weissinger's lattice (one panel an element):
    /work/venvs/asb/bin/python scripts/reference_aerosandbox/run_aerosandbox.py --planform step \\
        --spacing uniform --spanwise 8 --chordwise 16 --out results/lateral/glide/aerosandbox_chordwise16.json
    /work/venvs/asb/bin/python scripts/reference_aerosandbox/run_aerosandbox.py --planform step \\
        --spacing uniform --spanwise 1 --chordwise 1 --out results/lateral/glide/aerosandbox_chordwise1.json

Input: the geometry JSON written by ``scripts/glide_comparison.py`` (birdocp's frozen lifting line in
its pose, the joint offsets, its glide state, mass, inertia, density). This script imports nothing of
birdocp. The output records the SHA-256 of the geometry file and its joint offsets (the configuration
that produced the numbers).

Geometry, ``--planform step`` (the model's own planform): one symmetric ``asb.Wing`` per right-wing
element, two cross-sections on its end nodes with the element's chord and chord direction (constant
chord; neighbouring wings meet at the nodes), uniform spanwise panels (``--spacing uniform``).
Geometry, ``--planform linear``: one symmetric ``asb.Wing`` whose cross-sections sit at the lifting line's nodes of the
right wing (the centre node to the tip), each with its quarter-chord point on the node, its chord the
element chords interpolated to the node (the tip chord extrapolated linearly, clipped at 0) divided
by the length of the chord direction's projection on the symmetry plane (a streamwise section with
the area of birdocp's element), its twist the chord direction's angle in that plane, a flat
camber line (NACA 0008: the vortex lattice uses the camber line only). Axes: AeroSandbox's geometry
axes (x back, y right, z up) are birdocp's (e3, e1, e2); the origin is the centre of mass.

Derivatives: central differences of the VLM's body-axis force and moment about the centre of mass
in sideslip velocity v, roll rate p and yaw rate r at birdocp's glide (speed, angle of attack); the
lateral state matrix over (v, p, r, phi) is then the rigid body's, linearised about the glide:

    v' = Y/m + p w0 - r u0 + g cos(theta0) phi
    (p', r') = I^-1 (L, N)     (I = [[Ixx, -Ixz], [-Ixz, Izz]])
    phi' = p + r tan(theta0)

The same derivatives at the geometry's ``check_states`` (a small section angle of attack: a
diagnostic of the section law, not an equilibrium). Two wakes: ``body_axis_wake`` (trailing legs along the geometry x axis: birdocp's straight wake
along the body axis) and ``wind_aligned_wake`` (along the free stream).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import time
from pathlib import Path

import aerosandbox as asb
import numpy as np

STEP = {"v": 0.05, "p": 0.05, "r": 0.05}  # m/s, rad/s, rad/s (the VLM is linear in them near 0)


def to_geometry_axes(e):
    """birdocp code frame (e1 right, e2 up, e3 back) -> AeroSandbox geometry axes (x back, y right, z up)."""
    e = np.asarray(e, dtype=float)
    return np.array([e[2], e[0], e[1]])


def node_sections(geo: dict) -> list[dict]:
    """Cross-sections at the right wing's nodes: quarter-chord point, streamwise chord, twist [deg]."""
    nodes = [to_geometry_axes(n) for n in geo["nodes_m"]]
    chords = np.asarray(geo["chords_m"])
    dirs = [to_geometry_axes(c) for c in geo["chord_directions"]]
    n_el = len(chords)
    half = n_el // 2
    out = []
    for k in range(half, n_el + 1):  # node k lies between elements k-1 and k
        if k == n_el:
            c = max(0.0, chords[-1] + 0.5 * (chords[-1] - chords[-2]))
            d = dirs[-1]
        else:
            c = 0.5 * (chords[k - 1] + chords[k])
            d = 0.5 * (dirs[k - 1] + dirs[k])
        d_xz = np.array([d[0], d[2]])
        proj = np.linalg.norm(d_xz) / np.linalg.norm(d)
        c_stream = c / proj
        twist_deg = float(np.degrees(np.arctan2(-d_xz[1], d_xz[0])))  # leading edge up positive
        quarter = nodes[k]
        t = np.radians(twist_deg)
        le = quarter - 0.25 * c_stream * np.array([np.cos(t), 0.0, -np.sin(t)])
        out.append({"xyz_le": le.tolist(), "chord": float(c_stream), "twist_deg": twist_deg,
                    "node": quarter.tolist()})
    return out


def _section(quarter, d, c) -> dict:
    """A cross-section with its quarter-chord point on ``quarter``, the streamwise chord of a chord
    ``c`` along the direction ``d`` (geometry axes) and its twist [deg] (leading edge up positive)."""
    d_xz = np.array([d[0], d[2]])
    c_stream = c / (np.linalg.norm(d_xz) / np.linalg.norm(d))
    twist_deg = float(np.degrees(np.arctan2(-d_xz[1], d_xz[0])))
    t = np.radians(twist_deg)
    le = quarter - 0.25 * c_stream * np.array([np.cos(t), 0.0, -np.sin(t)])
    return {"xyz_le": le.tolist(), "chord": float(c_stream), "twist_deg": twist_deg, "node": quarter.tolist()}


def step_sections(geo: dict) -> list[dict]:
    """The model's stepped planform: every right-wing element a constant-chord strip (its own chord and
    chord direction) between two cross-sections at its end nodes (pairs: element j is sections 2j, 2j+1)."""
    nodes = [to_geometry_axes(n) for n in geo["nodes_m"]]
    chords = np.asarray(geo["chords_m"])
    dirs = [to_geometry_axes(c) for c in geo["chord_directions"]]
    out = []
    for j in range(len(chords) // 2, len(chords)):
        out += [_section(q, dirs[j], chords[j]) for q in (nodes[j], nodes[j + 1])]
    return out


def airplane(sections: list[dict], planform: str = "linear") -> asb.Airplane:
    """One symmetric wing through the sections (``linear``), or one symmetric wing per pair of sections
    (``step``: every element its own constant-chord wing, joined to its neighbours at the nodes; at a
    node the trailing legs of both sides' horseshoes meet, no panel spans the chord jump)."""
    foil = asb.Airfoil("naca0008")
    groups = [sections] if planform == "linear" else [sections[i:i + 2] for i in range(0, len(sections), 2)]
    wings = [asb.Wing(name=f"ibis wing (frozen) {i}", symmetric=True, xsecs=[
        asb.WingXSec(xyz_le=s["xyz_le"], chord=s["chord"], twist=s["twist_deg"], airfoil=foil) for s in g])
        for i, g in enumerate(groups)]
    return asb.Airplane(name="ibis", xyz_ref=[0.0, 0.0, 0.0], wings=wings)


def loads(plane, u, v, w, p, r, rho, resolution, wind_wake):
    """Body-axis force (X, Y, Z) [N] and moment (L, M, N) [N m] about the centre of mass."""
    V = float(np.sqrt(u * u + v * v + w * w))
    op = asb.OperatingPoint(velocity=V, alpha=float(np.degrees(np.arctan2(w, u))),
                            beta=float(np.degrees(np.arcsin(v / V))), p=p, q=0.0, r=r)
    spacing = {"spanwise_spacing_function": np.linspace} if resolution[2] == "uniform" else {}
    vlm = asb.VortexLatticeMethod(airplane=plane, op_point=op, spanwise_resolution=resolution[0], **spacing,
                                  chordwise_resolution=resolution[1], align_trailing_vortices_with_wind=wind_wake)
    out = vlm.run()
    scale = rho / float(op.atmosphere.density())
    return np.asarray(out["F_b"], dtype=float) * scale, np.asarray(out["M_b"], dtype=float) * scale


def derivatives(plane, geo, resolution, wind_wake, s=None) -> tuple[dict, dict]:
    """Central differences in v, p, r at the state ``s`` (u, w; default the glide)."""
    s, rho = s or geo["glide_state"], geo["air_density_kgm3"]
    base = {"u": s["u_mps"], "v": 0.0, "w": s["w_mps"], "p": 0.0, "r": 0.0}
    F0, M0 = loads(plane, *base.values(), rho, resolution, wind_wake)
    der = {}
    for var, h in STEP.items():
        hi, lo = dict(base, **{var: h}), dict(base, **{var: -h})
        Fp, Mp = loads(plane, *hi.values(), rho, resolution, wind_wake)
        Fm, Mm = loads(plane, *lo.values(), rho, resolution, wind_wake)
        der[f"Y_{var}"] = float((Fp[1] - Fm[1]) / (2 * h))
        der[f"L_{var}"] = float((Mp[0] - Mm[0]) / (2 * h))
        der[f"N_{var}"] = float((Mp[2] - Mm[2]) / (2 * h))
    trim = {"force_body_N": F0.tolist(), "moment_body_Nm": M0.tolist(),
            "weight_N": geo["mass_kg"] * geo["gravity_mps2"]}
    return der, trim


def lateral_matrix(der: dict, geo: dict) -> np.ndarray:
    s = geo["glide_state"]
    m, g, th = geo["mass_kg"], geo["gravity_mps2"], s["theta_rad"]
    ixx, izz, ixz = geo["roll_inertia_kgm2"], geo["yaw_inertia_kgm2"], geo["product_inertia_xz_kgm2"]
    Iinv = np.linalg.inv(np.array([[ixx, -ixz], [-ixz, izz]]))
    A = np.zeros((4, 4))
    A[0, :3] = [der["Y_v"] / m, der["Y_p"] / m + s["w_mps"], der["Y_r"] / m - s["u_mps"]]
    A[0, 3] = g * np.cos(th)
    LN = np.array([[der["L_v"], der["L_p"], der["L_r"]], [der["N_v"], der["N_p"], der["N_r"]]])
    A[1:3, :3] = Iinv @ LN
    A[3, :] = [0.0, 1.0, np.tan(th), 0.0]
    return A


def modes(A) -> dict:
    lam = np.linalg.eigvals(A)
    cplx = [z for z in lam if abs(z.imag) > 1e-9 * max(1.0, abs(z))]
    real = sorted(float(z.real) for z in lam if abs(z.imag) <= 1e-9 * max(1.0, abs(z)))
    out = {"eigenvalues": [[float(z.real), float(z.imag)] for z in sorted(lam, key=lambda z: (z.real, z.imag))],
           "roll_subsidence_per_s": None, "spiral_per_s": None, "dutch_roll": None}
    if len(real) == 2 and len(cplx) == 2:
        out["roll_subsidence_per_s"], out["spiral_per_s"] = real
        z = cplx[0]
        out["dutch_roll"] = {"real_per_s": float(z.real), "frequency_radps": float(abs(z.imag)),
                             "natural_frequency_radps": float(abs(z)), "damping_ratio": float(-z.real / abs(z))}
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--geometry", default="results/lateral/glide/geometry.json")
    ap.add_argument("--out", default="results/lateral/glide/aerosandbox.json")
    ap.add_argument("--spanwise", type=int, default=4, help="VLM panels per node interval")
    ap.add_argument("--chordwise", type=int, default=8)
    ap.add_argument("--planform", choices=("linear", "step"), default="linear",
                    help="linear: chords interpolated between the nodes; step: the model's constant-chord elements")
    ap.add_argument("--spacing", choices=("cosine", "uniform"), default="cosine",
                    help="spanwise panel spacing in every section interval (AeroSandbox's default: cosine; the "
                    "step planform needs uniform: cosine panels at a chord jump put collocation points a fraction "
                    "of a millimetre from the neighbouring wing's trailing legs)")
    a = ap.parse_args(argv)
    text = Path(a.geometry).read_text()
    geo = json.loads(text)
    sections = node_sections(geo) if a.planform == "linear" else step_sections(geo)
    plane = airplane(sections, a.planform)
    res = (a.spanwise, a.chordwise, a.spacing)
    result = {"aerosandbox_version": asb.__version__, "method": "asb.VortexLatticeMethod",
              "resolution": {"spanwise_per_section": a.spanwise, "chordwise": a.chordwise,
                                                      "spanwise_spacing": a.spacing},
              "planform": a.planform,
              "steps": STEP, "sections": sections, "area_m2": float(sum(w.area() for w in plane.wings)),
              "geometry_file": a.geometry, "geometry_sha256": hashlib.sha256(text.encode()).hexdigest(),
              "joint_offsets_deg": geo.get("joint_offsets_deg"), "glide_state": geo["glide_state"]}
    for name, wind in (("body_axis_wake", False), ("wind_aligned_wake", True)):
        t0 = time.time()
        der, trim = derivatives(plane, geo, res, wind)
        A = lateral_matrix(der, geo)
        result[name] = {"derivatives": der, "trim_loads": trim, "lateral_matrix": A.tolist(), **modes(A),
                        "wall_time_s": time.time() - t0}
        for st in geo.get("check_states", []):
            result[name].setdefault("check_states", []).append(
                {**st, "derivatives": derivatives(plane, geo, res, wind, st)[0]})
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(result, indent=1) + "\n")
    print(json.dumps({k: result[k]["roll_subsidence_per_s"] for k in ("body_axis_wake", "wind_aligned_wake")}))
    print(json.dumps({k: result[k]["dutch_roll"] for k in ("body_axis_wake", "wind_aligned_wake")}))


if __name__ == "__main__":
    main()
