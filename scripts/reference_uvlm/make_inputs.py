"""Inputs of the UVLM reference runs, from birdocp: planform, trim state, flapping law, frequencies.

Run in the birdocp environment::

    python scripts/reference_uvlm/make_inputs.py [--out results/aero/uvlm] [--config CFG.toml]

Writes ``OUT/inputs.json``, the only thing the PteraSoftware script (``run_uvlm.py``, run in its own
environment, which has no birdocp) reads. It holds:

* ``trim``: the trimmed reference cycle (``birdocp trim``) and the body state the comparison holds
  fixed: the cycle means of u and w, q = 0 (body frame x' forward, z' down; m/s), its airspeed and
  the body's angle of attack ``atan2(w, u)``.
* ``wing``: the planform of the *rigid* wing the UVLM flaps: birdocp's right wing at the reference gait's
  mid-downstroke (t = 0, flap angle 0, elbow and wrist straight, sweep +1 deg) with the shoulder
  incidence and the hand twist set to 0 so that it is planar; its smoothed leading and trailing edges
  (16 points each) in the shoulder frame (``span_m`` along e1 from the shoulder, ``aft_m`` along e3,
  backwards). The incidence (the gait's mean shoulder incidence) goes into the UVLM's angle of attack.
* ``rigid_gait``: the joint laws (``gait.*`` keys) that give birdocp the same rigid flapping wing
  (incidence held at its mean);
* ``cases``: the flapping frequencies at the target reduced frequencies k = pi f c / U (c =
  ``body.reference_chord_m``, U = the held airspeed): the speed is held at the trim state and the
  frequency varies; the first case is the reference gait's own 4 Hz.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from script_common import parse_with_out, script_parser  # noqa: E402

from birdocp.bird.config import Config, load, param_vector, to_dict, with_values  # noqa: E402
from birdocp.bird.model import GEOMETRY_OUTPUTS, get_model  # noqa: E402
from birdocp.io.files import atomic_write_json  # noqa: E402
from birdocp.io.provenance import birdocp_version, git_revision  # noqa: E402
from birdocp.studies.trim import trim  # noqa: E402

K_TARGETS = (0.17, 0.25)
"""Reduced frequencies of the cases after the reference gait's own (k = 0.14 at 4 Hz)."""


def rigid_gait(cfg: Config) -> dict:
    """``gait.*`` keys of a rigid, planar wing flapping with the shoulder law of ``cfg``.

    Every joint but the flap is frozen at its value at t = 0 of the reference gait (mid-downstroke,
    wing spread), except the hand twist, set to 0 (a planar wing), and the shoulder incidence, held
    at its mean (the offset)."""
    g = cfg.gait
    out = {}
    for name in ("shoulder_incidence", "shoulder_sweep", "elbow_flex", "hand_twist", "wrist_flex", "wrist_spread"):
        j = getattr(g, name)
        at_t0 = j.offset_deg + j.amplitude_deg * math.sin(math.radians(j.phase_deg))
        frozen = {"shoulder_incidence": j.offset_deg, "hand_twist": 0.0}.get(name, at_t0)
        out.update({f"gait.{name}.offset_deg": round(frozen, 12), f"gait.{name}.amplitude_deg": 0.0,
                    f"gait.{name}.phase_deg": 0.0})
    return out


def planform(cfg: Config) -> dict:
    """Smoothed leading and trailing edges of the rigid planar wing at zero incidence (shoulder frame,
    metres)."""
    rigid = with_values(cfg, {**rigid_gait(cfg), "gait.shoulder_incidence.offset_deg": 0.0})
    m = get_model(rigid)
    g = dict(zip(GEOMETRY_OUTPUTS, m.geometry(0.0, param_vector(rigid))))
    le, te = np.array(g["leading_edge"]), np.array(g["trailing_edge"])
    out_of_plane = float(max(np.max(np.abs(le[1])), np.max(np.abs(te[1]))))
    if out_of_plane > 1e-9:
        raise RuntimeError(f"the rigid wing is not planar ({out_of_plane:.3g} m out of its plane)")
    line, chord = np.array(g["line"]), np.array(g["chord_m"]).ravel()
    ds = np.linalg.norm(line[:, 2::2] - line[:, 0:-2:2], axis=0)
    return {"leading_edge": {"span_m": le[0].tolist(), "aft_m": le[2].tolist()},
            "trailing_edge": {"span_m": te[0].tolist(), "aft_m": te[2].tolist()},
            "lifting_line_area_m2": float(np.sum(chord[1::2] * ds)),
            "lifting_line_span_m": float(line[0, -1] - line[0, 0])}


def held_state(cfg: Config) -> dict:
    """The trimmed reference cycle and the body state held fixed (cycle means of u and w, q = 0)."""
    res = trim(cfg)
    t = np.asarray(res.trajectory_t, float)
    x = np.asarray(res.trajectory_x, float)
    mean = np.trapezoid(x, t, axis=0) / (t[-1] - t[0])
    u, w = float(mean[0]), float(mean[1])
    return {"success": bool(res.success), "max_residual": float(res.max_residual),
            "x0": [float(v) for v in res.x0], "mean_u_mps": u, "mean_w_mps": w,
            "mean_theta_rad": float(mean[3]), "airspeed_mps": math.hypot(u, w),
            "body_alpha_deg": math.degrees(math.atan2(w, u)),
            "validity_valid": bool(res.validity.valid),
            "validity": res.validity.summary()}


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/uvlm")
    ap.add_argument("--config", default=None, help="birdocp configuration TOML (default: the paper's case)")
    args, out = parse_with_out(ap, argv)
    cfg = load(args.config) if args.config else Config()
    held = held_state(cfg)
    if not held["success"]:
        print(f"make_inputs: the trim did not converge (residual {held['max_residual']:.3g})", file=sys.stderr)
        return 1
    c = cfg.body.reference_chord_m
    U = held["airspeed_mps"]
    f0 = cfg.gait.frequency_hz
    cases = [{"name": "gait", "frequency_hz": f0, "k": math.pi * f0 * c / U}]
    cases += [{"name": f"k{k:.2f}", "frequency_hz": k * U / (math.pi * c), "k": k} for k in K_TARGETS]
    inc = cfg.gait.shoulder_incidence
    flap = cfg.gait.shoulder_flap
    doc = {
        "birdocp": {"version": birdocp_version(), "git": git_revision()},
        "config": to_dict(cfg),
        "air_density_kgm3": cfg.aero.air_density_kgm3,
        "reference_chord_m": c,
        "trim": held,
        "wing": {"edges": planform(cfg), "shoulder_half_separation_m": cfg.wing.shoulder_half_separation_m,
                 "root_ahead_m": cfg.wing.root_ahead_m, "incidence_deg": inc.offset_deg,
                 "flap_amplitude_deg": flap.amplitude_deg, "flap_phase_deg": flap.phase_deg,
                 "flap_offset_deg": flap.offset_deg},
        "rigid_gait": rigid_gait(cfg),
        "cases": cases,
        "frames": "birdocp code frame: e1 span (right), e2 up, e3 backwards; PteraSoftware geometry axes "
                  "x aft, y right, z up = (e3, e1, e2)",
    }
    atomic_write_json(out / "inputs.json", doc)
    print(f"wrote {out / 'inputs.json'}: U = {U:.3f} m/s, body alpha = {held['body_alpha_deg']:.3f} deg, "
          f"frequencies {[round(cs['frequency_hz'], 3) for cs in cases]} Hz")
    return 0


if __name__ == "__main__":
    sys.exit(main())
