"""The gliding limit against an independent vortex-lattice model: birdocp's steady glide of the
frozen wing (all flapping amplitudes 0, the pose ``birdocp.studies.glide.ATTACHED_POSE`` whose glide is
attached and valid) and its lateral roots next to AeroSandbox's.

    python scripts/glide_comparison.py --out results/lateral/glide

writes ``geometry.json`` (birdocp's frozen lifting line and glide: the input of
``scripts/reference_aerosandbox/run_aerosandbox.py``, run in AeroSandbox's own environment),
``birdocp.json`` (the glide, its eigenvalues, lateral matrix and derivatives) and, when
``aerosandbox.json`` (the VLM of the model's stepped planform) is in the folder, ``comparison.json`` and
``comparison.md`` (the roll-subsidence root, the Dutch-roll frequency and the other roots and
derivatives side by side, with the relative differences; and the roots of (a) the paper's model,
(b) the model with ``aero.span_direction = "element"`` and (c) also with ``aero.collocation =
"three_quarter"`` (Weissinger's extended lifting line), alone and with ``aero.normalwash = "tangency"``
(the vortex lattice's flow-tangency section law), each also with every element cut into ``--split`` pieces,
``birdocp.studies.glide_refined``; the VLM runs of :data:`OTHER_REFERENCES` (linear planform, 16
chordwise panels, one panel an element) are listed when present).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from script_common import parse_with_out, script_parser  # noqa: E402

from birdocp.io.files import atomic_write_json, atomic_write_text  # noqa: E402
from birdocp.bird.config import with_values  # noqa: E402
from birdocp.studies.glide import (attached_config, glide_geometry, lateral_glide_modes,  # noqa: E402
                                   lateral_matrix_with, load_derivatives_at, steady_glide)
from birdocp.studies.glide_refined import refined_load_derivatives  # noqa: E402

TOLERANCE = 0.05
"""The issue's agreement target for the roll-subsidence root and the Dutch-roll frequency."""


def rel(a: float, b: float) -> float:
    """(a - b) / |b|."""
    return (a - b) / abs(b)


OTHER_REFERENCES = (("aerosandbox_linear.json", "AeroSandbox VLM, linear planform, body-axis wake"),
                    ("aerosandbox_chordwise16.json", "AeroSandbox VLM, 8 spanwise x 16 chordwise panels, body-axis wake"),
                    ("aerosandbox_chordwise1.json", "AeroSandbox VLM, one panel an element (Weissinger's lattice), "
                     "body-axis wake"))
"""Other VLM runs listed in the refinement table when present: (file, row name)."""


def refinement(glide: dict, ref: dict, split: int, others: tuple = ()) -> list[dict]:
    """The lateral roots with the nine load derivatives of: (a) the paper's model (16 elements, the
    leading-line span direction), its lifting line cut ``split`` times, (b) the model with
    ``aero.span_direction = "element"`` (16 elements, then cut 2, 4 and ``split`` times), (c) the model
    with also ``aero.collocation = "three_quarter"`` (Weissinger's extended lifting line; 16 elements,
    cut 2 and ``split`` times), and (c) with ``aero.normalwash = "tangency"``, the vortex lattice's
    flow-tangency section law (lift linear in the sine of the angle: the like-for-like comparison), the VLM of the same stepped planform
    (``ref``, body-axis wake; the reference of the differences) and the VLM runs ``others`` ((name,
    result) pairs); each through birdocp's exact lateral matrix (:func:`lateral_matrix_with`)."""
    cfg, s = attached_config(), glide["state"]
    element = with_values(cfg, {"aero.span_direction": "element"})
    weissinger = with_values(element, {"aero.collocation": "three_quarter"})
    cases = [("(a) the paper's model: 16 elements, leading-line span direction", glide["derivatives"]),
             (f"(a) cut: {16 * split} elements, leading-line span direction",
              refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], split, "step", "section")),
             ("(b) aero.span_direction = element: 16 elements", load_derivatives_at(element, s["u_mps"], s["w_mps"]))]
    for n in sorted({2, 4, split} - {1}):
        cases.append((f"(b) cut: {16 * n} elements, span direction along each sub-element",
                      refined_load_derivatives(cfg, s["u_mps"], s["w_mps"], n, "step", "element")))
    cases.append(("(c) aero.collocation = three_quarter, span_direction = element: 16 elements",
                  load_derivatives_at(weissinger, s["u_mps"], s["w_mps"])))
    tangency = "(c) + aero.normalwash = tangency (the VLM's flow-tangency section law)"
    for law, name in (("angle", "(c)"), ("tangency", tangency)):
        if law == "tangency":  # the model option at 16 elements
            cases.append((f"{tangency}: 16 elements", load_derivatives_at(
                with_values(weissinger, {"aero.normalwash": "tangency"}), s["u_mps"], s["w_mps"])))
        for n in sorted({2, split} - {1}):
            cases.append((f"{name}: {16 * n} elements", refined_load_derivatives(
                cfg, s["u_mps"], s["w_mps"], n, "step", "element", "three_quarter", law)))
    cases.append(("AeroSandbox VLM, stepped planform, body-axis wake", ref["body_axis_wake"]["derivatives"]))
    cases += [(name, other["body_axis_wake"]["derivatives"]) for name, other in others]
    out = []
    for name, der in cases:
        der = {k: v for k, v in der.items() if k != "elements"}
        m = lateral_glide_modes(lateral_matrix_with(glide, der, cfg))
        out.append({"model": name, "roll_subsidence_per_s": m["roll_subsidence_per_s"],
                    "dutch_roll_frequency_radps": (m["dutch_roll"] or {}).get("frequency_radps"),
                    "spiral_per_s": m["spiral_per_s"], "derivatives": der})
    return out


def compare(ours: dict, ref: dict) -> dict:
    """The comparison rows: birdocp's value, AeroSandbox's (body-axis and wind-aligned wakes), relative
    differences (also the load derivatives at the reference's check states); ``within_tolerance``
    for the two quantities the issue names."""
    def pick(d):
        dr = d["dutch_roll"] or {}
        return {"roll_subsidence_per_s": d["roll_subsidence_per_s"], "dutch_roll_frequency_radps":
                dr.get("frequency_radps"), "dutch_roll_real_per_s": dr.get("real_per_s"),
                "dutch_roll_natural_frequency_radps": dr.get("natural_frequency_radps"),
                "spiral_per_s": d["spiral_per_s"], **{f"d{k}": v for k, v in d["derivatives"].items()}}
    mine = pick(ours)
    rows = []
    for key, value in mine.items():
        row = {"quantity": key, "birdocp": value}
        for wake in ("body_axis_wake", "wind_aligned_wake"):
            r = pick(ref[wake])[key]
            row[wake] = r
            row[f"relative_{wake}"] = None if (r is None or value is None or r == 0) else rel(value, r)
        rows.append(row)
    for i, st in enumerate(ref["body_axis_wake"].get("check_states", [])):
        mine_d = load_derivatives_at(attached_config(), st["u_mps"], st["w_mps"])
        for k, value in mine_d.items():
            row = {"quantity": f"{st['name']}: d{k}", "birdocp": value}
            for wake in ("body_axis_wake", "wind_aligned_wake"):
                r = ref[wake]["check_states"][i]["derivatives"][k]
                row[wake] = r
                row[f"relative_{wake}"] = None if r == 0 else rel(value, r)
            rows.append(row)
    named_rows = _attribution(ours, ref["body_axis_wake"])
    named = [r for r in rows if r["quantity"] in ("roll_subsidence_per_s", "dutch_roll_frequency_radps")]
    ok = all(r["relative_body_axis_wake"] is not None and abs(r["relative_body_axis_wake"]) <= TOLERANCE
             for r in named)
    return {"tolerance": TOLERANCE, "within_tolerance": ok, "rows": rows, "attribution": named_rows}


def _attribution(ours: dict, ref: dict) -> list[dict]:
    """birdocp's roll-subsidence root and Dutch-roll frequency with one of the VLM's derivatives (body-axis
    wake) put in place of birdocp's at a time, then all nine (that is the VLM's lateral matrix: its
    roots must be the VLM's, a check of the two rigid-body linearisations)."""
    out = []
    swaps = [(k, {k: v}) for k, v in ref["derivatives"].items()] + [("all nine", dict(ref["derivatives"]))]
    for name, swap in swaps:
        m = lateral_glide_modes(lateral_matrix_with(ours, swap, attached_config()))
        dr = m["dutch_roll"] or {}
        out.append({"replaced": name, "roll_subsidence_per_s": m["roll_subsidence_per_s"],
                    "dutch_roll_frequency_radps": dr.get("frequency_radps"), "spiral_per_s": m["spiral_per_s"]})
    return out


def table(cmp: dict) -> str:
    def f(x, pct=False):
        if x is None:
            return "-"
        return f"{100 * x:+.1f} %" if pct else f"{x:.4g}"
    g = cmp.get("glide")
    lines = [] if g is None else [
        f"The steady glide of the frozen wing (joint offsets {g['joint_offsets_deg']} deg, amplitudes 0): "
        f"{g['speed_mps']:.4g} m/s, body angle of attack {g['alpha_body_deg']:.3g} deg, flight path "
        f"{g['flight_path_angle_deg']:.3g} deg, effective section angles {g['alpha_eff_min_deg']:.3g}.."
        f"{g['alpha_eff_max_deg']:.3g} deg: {'valid' if g['valid'] else 'NOT VALID'} by birdocp's validity check. "
        "Like for like is the VLM with the body-axis wake (birdocp's wake is straight along the body axis, "
        "also in sideslip); diff = (birdocp - VLM) / |VLM|.", ""]
    lines += ["| quantity | birdocp | AeroSandbox VLM (body-axis wake) | diff | AeroSandbox VLM (wind-aligned wake) | diff |",
             "|---|---|---|---|---|---|"]
    for r in cmp["rows"]:
        lines.append(f"| {r['quantity']} | {f(r['birdocp'])} | {f(r['body_axis_wake'])} | "
                     f"{f(r['relative_body_axis_wake'], True)} | {f(r['wind_aligned_wake'])} | "
                     f"{f(r['relative_wind_aligned_wake'], True)} |")
    lines += ["", "birdocp's roots with the VLM's (body-axis wake) derivatives put in, one at a time, then all nine:", "",
              "| replaced | roll subsidence [1/s] | Dutch-roll frequency [rad/s] | spiral [1/s] |", "|---|---|---|---|"]
    for r in cmp["attribution"]:
        lines.append(f"| {r['replaced']} | {f(r['roll_subsidence_per_s'])} | {f(r['dutch_roll_frequency_radps'])} | "
                     f"{f(r['spiral_per_s'])} |")
    if cmp.get("refinement"):
        vlm = next(r for r in cmp["refinement"] if r["model"].startswith("AeroSandbox VLM, stepped"))
        lines += ["", "The lateral roots (birdocp's exact lateral matrix) with the nine load derivatives of each model; "
                  "in brackets the difference to the VLM of the same (stepped) planform:", "",
                  "| derivatives of | roll subsidence [1/s] | Dutch-roll frequency [rad/s] | spiral [1/s] | L_p [N m s] "
                  "| L_v [N s] | N_v [N s] |", "|---|---|---|---|---|---|---|"]
        for r in cmp["refinement"]:
            cells = [f"{f(r[k])} ({f(rel(r[k], vlm[k]), True)})" for k in
                     ("roll_subsidence_per_s", "dutch_roll_frequency_radps", "spiral_per_s")]
            cells += [f"{f(r['derivatives'][k])} ({f(rel(r['derivatives'][k], vlm['derivatives'][k]), True)})"
                      for k in ("L_p", "L_v", "N_v")]
            lines.append(f"| {r['model']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/glide")
    ap.add_argument("--split", type=int, default=8, help="pieces per lifting-line element of the refined "
                    "lifting line (default %(default)s; 8 takes about a minute)")
    args, out = parse_with_out(ap, argv)
    cfg = attached_config()
    glide = steady_glide(cfg)
    if not glide["success"]:
        raise SystemExit(f"the steady glide did not converge (residual {glide['residual']:.3g})")
    atomic_write_json(out / "birdocp.json", glide)
    atomic_write_json(out / "geometry.json", glide_geometry(cfg, glide=glide))
    v = glide["validity"]
    print(f"glide {'valid' if v['valid'] else 'NOT VALID: ' + '; '.join(v['reasons'])}: effective section angles "
          f"{v['alpha_eff_min_deg']:.2f}..{v['alpha_eff_max_deg']:.2f} deg")
    print(f"glide: speed {glide['speed_mps']:.4f} m/s, body angle of attack {glide['alpha_body_deg']:.2f} deg, "
          f"flight path {glide['flight_path_angle_deg']:.2f} deg; roll subsidence "
          f"{glide['roll_subsidence_per_s']:.4f} 1/s, Dutch roll {glide['dutch_roll']['frequency_radps']:.4f} rad/s")
    ref_file = out / "aerosandbox.json"
    if ref_file.exists():
        ref = json.loads(ref_file.read_text())
        cmp = compare(glide, ref)
        others = tuple((name, json.loads((out / f).read_text())) for f, name in OTHER_REFERENCES if (out / f).exists())
        cmp["refinement"] = refinement(glide, ref, args.split, others)
        cmp["glide"] = {"joint_offsets_deg": glide_geometry(cfg, glide=glide)["joint_offsets_deg"],
                        **{k: glide[k] for k in ("speed_mps", "alpha_body_deg", "flight_path_angle_deg")},
                        **{k: v[k] for k in ("valid", "alpha_eff_min_deg", "alpha_eff_max_deg")}}
        atomic_write_json(out / "comparison.json", cmp)
        atomic_write_text(out / "comparison.md", table(cmp))
        print(table(cmp))
    else:
        print(f"no {ref_file}: run scripts/reference_aerosandbox/run_aerosandbox.py in AeroSandbox's environment")


if __name__ == "__main__":
    main()
