"""Which term of the section law separates birdocp's roll damping from the vortex lattice's? In the
gliding-limit comparison (``scripts/glide_comparison.py``) the model (c) (``aero.span_direction =
"element"``, ``aero.collocation = "three_quarter"``: Weissinger's lifting line) has 2.2 % more roll
damping L_p with its section law (``aero.normalwash = "angle"``: the normalwash |Vp| alpha, lift linear
in the section angle) than with the lattice's (``"tangency"``: |Vp| sin(alpha), the flow tangency of a
flat plate). This script takes that difference apart element by element at the compared glide
(``birdocp.studies.glide_refined.section_law_terms``): the roll rate's velocity along each section's
normal, chord and span; how much it turns the section's relative wind and changes its speed; the
normalwash's and the circulation's answer; each element's share of L_p; and the roll roots.

    python scripts/glide_section_law.py --out results/lateral/glide

writes ``section_law.json`` and ``section_law.md`` (a table per element of the right wing, the left
one is its mirror image) and prints the table.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from script_common import parse_with_out, script_parser  # noqa: E402

from birdocp.io.files import atomic_write_json, atomic_write_text  # noqa: E402
from birdocp.bird.config import with_values  # noqa: E402
from birdocp.studies.glide import (attached_config, lateral_glide_modes, lateral_matrix_with,  # noqa: E402
                                   load_derivatives_at, steady_glide)
from birdocp.studies.glide_refined import section_law_terms  # noqa: E402

MODEL_C = {"aero.span_direction": "element", "aero.collocation": "three_quarter"}
"""The model (c) of the comparison: span direction along the elements, Weissinger's collocation."""


def summary(terms: dict, glide: dict) -> dict:
    """The per-law numbers compared: L_p and the roll-subsidence root with the model (c)'s nine load
    derivatives at the compared glide (``terms[law]["derivatives"]``), and what explains the ratio."""
    a, t = terms["angle"], terms["tangency"]
    alpha = np.radians(a["alpha_deg"])
    dq = np.array(a["dq_dp"]) / np.array(t["dq_dp"])
    rotation = np.abs(np.array(a["dspeed_dp"]) / (np.array(a["speed_mps"]) * np.array(a["dalpha_dp"])))
    spanwise = np.abs(np.array(a["dVs_dp"])) / np.hypot(a["dVn_dp"], a["dVc_dp"])
    # every element's L_p of the tangency law scaled by 1/cos(alpha): the lift slope alone
    lp_slope = float(np.sum(np.array(t["L_p"]) / np.cos(alpha)))
    roots = {law: lateral_glide_modes(lateral_matrix_with(glide, terms[law]["derivatives"], attached_config()))
             ["roll_subsidence_per_s"] for law in ("angle", "tangency")}
    return {"L_p_angle": a["L_p_total"], "L_p_tangency": t["L_p_total"],
            "L_p_ratio": a["L_p_total"] / t["L_p_total"],
            "L_p_tangency_over_cos_alpha": lp_slope, "L_p_ratio_lift_slope_only": lp_slope / t["L_p_total"],
            "dq_ratio_min": float(dq.min()), "dq_ratio_max": float(dq.max()),
            "inverse_cos_alpha_min": float((1 / np.cos(alpha)).min()),
            "inverse_cos_alpha_max": float((1 / np.cos(alpha)).max()),
            "max_speed_change_per_turning": float(rotation.max()),
            "max_spanwise_share": float(spanwise.max()),
            "L_p_force_turning": float(np.sum(a["L_p_force_turning"])),
            "roll_subsidence_per_s": roots}


def table(result: dict) -> str:
    """The per-element table (right wing) and the summary as Markdown."""
    a, t, s = result["angle"], result["tangency"], result["summary"]
    n = len(a["alpha_deg"])
    lines = [f"Model (c) at the compared glide (u = {result['glide_state']['u_mps']:.4g} m/s, "
             f"w = {result['glide_state']['w_mps']:.4g} m/s), {n} elements; right wing, root to tip "
             "(the left wing is its mirror image). Per unit roll rate p [rad/s]: dVn, dVc, dVs the change of "
             "the velocity along the section normal, chord and span [m/s]; dalpha [rad], d|Vp| [m/s]; dq the "
             "normalwash's change [m/s] with the model's law (angle) and the lattice's (tangency); L_p each "
             "element's roll damping [N m s].", "",
             "| element | alpha [deg] | dVn | dVc | dVs | dalpha | d\\|Vp\\| | dq angle | dq tangency | ratio | "
             "1/cos alpha | L_p angle | L_p tangency |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for j in range(n // 2, n):
        lines.append(f"| {j} | {a['alpha_deg'][j]:.3f} | {a['dVn_dp'][j]:.4f} | {a['dVc_dp'][j]:.4f} | "
                     f"{a['dVs_dp'][j]:.4f} | {a['dalpha_dp'][j]:.5f} | {a['dspeed_dp'][j]:.5f} | "
                     f"{a['dq_dp'][j]:.5f} | {t['dq_dp'][j]:.5f} | {a['dq_dp'][j] / t['dq_dp'][j]:.5f} | "
                     f"{1 / np.cos(np.radians(a['alpha_deg'][j])):.5f} | {a['L_p'][j]:.5f} | {t['L_p'][j]:.5f} |")
    r = s["roll_subsidence_per_s"]
    lines += ["", f"- L_p: angle {s['L_p_angle']:.5f}, tangency {s['L_p_tangency']:.5f} N m s "
              f"(ratio {s['L_p_ratio']:.5f}); the tangency law's L_p of every element divided by cos(alpha) "
              f"sums to {s['L_p_tangency_over_cos_alpha']:.5f} (ratio {s['L_p_ratio_lift_slope_only']:.5f}).",
              f"- dq ratio {s['dq_ratio_min']:.5f}..{s['dq_ratio_max']:.5f}; 1/cos(alpha) "
              f"{s['inverse_cos_alpha_min']:.5f}..{s['inverse_cos_alpha_max']:.5f}.",
              f"- The roll rate turns each section's relative wind: |d|Vp|| / (|Vp| |dalpha|) at most "
              f"{s['max_speed_change_per_turning']:.3g}; its spanwise share |dVs| / |(dVn, dVc)| at most "
              f"{s['max_spanwise_share']:.3g} (removed by both laws alike).",
              f"- The turning of the force at a held circulation adds {s['L_p_force_turning']:.3g} N m s to L_p: "
              "the roll damping is the circulation's answer.",
              f"- Roll-subsidence root with the nine derivatives of each law: angle {r['angle']:.4g} 1/s, "
              f"tangency {r['tangency']:.4g} 1/s."]
    for law, g in result.get("own_glide", {}).items():
        lines.append(f"- Model (c) with aero.normalwash = {law} trimmed on its own (not the compared state): glide "
                     f"{g['speed_mps']:.4g} m/s, body angle of attack {g['alpha_body_deg']:.3g} deg, roll subsidence "
                     f"{g['roll_subsidence_per_s']:.4g} 1/s, Dutch roll {g['dutch_roll_frequency_radps']:.4g} rad/s, "
                     + ("valid" if g["valid"] else "NOT valid: " + "; ".join(g["reasons"])) + ".")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/glide")
    _, out = parse_with_out(ap, argv)
    cfg = attached_config()
    glide = steady_glide(cfg)
    s = glide["state"]
    result = {"model": MODEL_C, "glide_state": {"u_mps": s["u_mps"], "w_mps": s["w_mps"]}}
    for law in ("angle", "tangency"):
        result[law] = section_law_terms(cfg, s["u_mps"], s["w_mps"], law)
        result[law]["derivatives"] = load_derivatives_at(with_values(cfg, {**MODEL_C, "aero.normalwash": law}),
                                                         s["u_mps"], s["w_mps"])
    result["summary"] = summary(result, glide)
    result["own_glide"] = {}
    for law in ("angle", "tangency"):  # each model trimmed on its own (not the compared state)
        own = steady_glide(with_values(cfg, {**MODEL_C, "aero.normalwash": law}))
        result["own_glide"][law] = {
            "success": own["success"], "residual": own["residual"], "speed_mps": own["speed_mps"],
            "alpha_body_deg": own["alpha_body_deg"], "valid": own["validity"]["valid"],
            "reasons": own["validity"]["reasons"], "roll_subsidence_per_s": own["roll_subsidence_per_s"],
            "dutch_roll_frequency_radps": own["dutch_roll"]["frequency_radps"]}
    atomic_write_json(out / "section_law.json", result)
    text = table(result)
    atomic_write_text(out / "section_law.md", text)
    print(text)


if __name__ == "__main__":
    main()
