"""Measure the model against the reference fixtures; writes results/model_validation.json.

The deviations table of docs/deviations.md quotes these numbers. Run: python scripts/validate_model.py
"""

import argparse
import json

import casadi as ca
import numpy as np

from birdocp.bird import wing
from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json
from birdocp.bird.model import GEOMETRY_OUTPUTS, get_model, unpack_data
from birdocp.io.reference import reference_dir

REF = reference_dir()


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="results/model_validation.json")
    args = ap.parse_args()
    fx = json.loads((REF / "force_fixtures.json").read_text())
    out = {"geometry_max_abs_error": {}, "loads_max_abs_error": {}, "emulation_margins": {}}

    m = get_model(with_values(Config(), {"aero.kinematic_velocity": "backward-difference"}))
    me = get_model(Config())
    geo = {k: 0.0 for k in ("line_m", "chord_m", "chord_dir", "up_dir", "v_kin_backward_mps",
                            "v_kin_exact_vs_backward_mps", "v_kin_exact_rel")}
    for g in fx["geometry"]:
        o = dict(zip(GEOMETRY_OUTPUTS, [np.array(v) for v in m.geometry(g["t"], m.p0)]))
        geo["line_m"] = max(geo["line_m"], np.max(np.abs(o["line"].T - g["merged_line_points"])))
        geo["chord_m"] = max(geo["chord_m"], np.max(np.abs(o["chord_m"].ravel() - g["chord"])))
        geo["chord_dir"] = max(geo["chord_dir"], np.max(np.abs(o["chord_dir"].T[1::2] - np.array(g["chord_dir"])[1::2])))
        geo["up_dir"] = max(geo["up_dir"], np.max(np.abs(o["up_dir"].T[1::2] - np.array(g["up_dir"])[1::2])))
        ref = np.array(g["v_kin_at_centres"])
        vb = np.array(unpack_data(m.data(g["t"], m.p0))["v_kin_mps"]).T
        ve = np.array(unpack_data(me.data(g["t"], me.p0))["v_kin_mps"]).T
        geo["v_kin_backward_mps"] = max(geo["v_kin_backward_mps"], np.max(np.abs(vb - ref)))
        geo["v_kin_exact_vs_backward_mps"] = max(geo["v_kin_exact_vs_backward_mps"], np.max(np.abs(ve - ref)))
        geo["v_kin_exact_rel"] = max(geo["v_kin_exact_rel"], np.max(np.abs(ve - ref)) / np.max(np.abs(ref)))
    out["geometry_max_abs_error"] = {k: float(v) for k, v in geo.items()}

    for circ in ("exact", "relaxed"):
        for kv in ("backward-difference", "exact"):
            mm = get_model(with_values(Config(), {"aero.circulation": circ, "aero.kinematic_velocity": kv}))
            key = "exact_solve_body_frame" if circ == "exact" else "body_frame"
            gkey = "gamma_exact_linear_solve" if circ == "exact" else "gamma"
            err = np.zeros(3)
            rel = 0.0
            gerr = 0.0
            for pt in fx["points"]:
                r = mm.evaluate(pt["state"], pt["t"])
                ref = pt[key]
                e = np.abs([r["Fx_N"] - ref["Fx_prime"], r["Fz_N"] - ref["Fz_prime"], r["My_Nm"] - ref["My_prime"]])
                err = np.maximum(err, e)
                rel = max(rel, np.max(e) / abs(ref["Fz_prime"]))
                gam = np.array(mm.aero_detail(pt["state"], pt["t"], mm.p0)[0]).ravel()
                gerr = max(gerr, np.max(np.abs(gam - pt[gkey])))
            out["loads_max_abs_error"][f"circulation={circ}, kinematic_velocity={kv}"] = {
                "against": key, "Fx_N": float(err[0]), "Fz_N": float(err[1]), "My_Nm": float(err[2]),
                "max_relative_to_lift": float(rel), "gamma": float(gerr)}

    for A in (38.0, 42.0, 48.0):
        mm = get_model(with_values(Config(), {"gait.shoulder_flap.amplitude_deg": A}))
        p = ca.DM(mm.p0)
        times = np.linspace(0, mm.period_s, 100, endpoint=False)
        Gm = mm.geometry.map(len(times))
        diag = np.array(Gm(ca.DM(times).T, ca.repmat(p, 1, len(times)))[GEOMETRY_OUTPUTS.index("diagnostics")])
        d = dict(zip(wing.DIAGNOSTICS, diag))
        out["emulation_margins"][f"A={A:g}deg"] = {
            "times": len(times),
            "corner_step_fired_at_fraction_of_times": float(np.mean(d["halvings_pass1"] > 0)),
            "max_halvings_first_pass": float(np.max(d["halvings_pass1"])),
            "halvings_second_pass": float(np.max(d["halvings_pass2"])),
            "points_needing_more_halvings": float(np.max(d["halving_margin_used"])),
            "aliased_walk_unfinished": float(np.max(d["walk_unfinished"])),
            "max_improvement_change": float(np.max(d["improve_change"])),
            "n_mid_values": sorted(set(float(v) for v in d["n_mid"])),
        }
    atomic_write_json(args.out, out)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
