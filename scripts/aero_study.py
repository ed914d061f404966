"""Does the ibis's instability survive unsteady and stall-aware aerodynamics? (docs/model_unsteady.md)

For each aerodynamic model -- today's quasi-steady lifting line, lag only (Wagner states, no 3/4-chord
and added-mass terms), lag + added mass and lag + 3/4-chord (diagnostics: the two belong together),
full ``wagner``, ``wagner`` + ``stall``, ``wagner`` + ``dynamic-stall`` -- the trim at the paper's gait
(amplitude 42 deg, root 0.05 m ahead, 5 shooting points, 148 RK4 steps) and the level flight (the
amplitude solved for a zero mean vertical speed, warm-started from that trim): |Lambda1|, the next
multipliers, the largest aerodynamic multiplier, the level amplitude, mean flapping and aerodynamic
powers, the largest |alpha_E|, the stalled and separated fractions and the validity of every cycle,
beside the prototype estimate of the specification (the numbers quoted in PROTOTYPE).

    python scripts/aero_study.py --out results/aero

Writes DIR/cases/<case>.json as each case finishes (a rerun skips finished cases), then DIR/table.json
and DIR/table.md.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from script_common import parse_with_out, script_parser  # noqa: E402

CASES = {
    "today": {},
    "lag_only": {"aero.unsteady": "wagner", "aero.pitch_rate_weight": 0.0, "aero.added_mass_weight": 0.0},
    "lag_added_mass": {"aero.unsteady": "wagner", "aero.pitch_rate_weight": 0.0},
    "lag_three_quarter_chord": {"aero.unsteady": "wagner", "aero.added_mass_weight": 0.0},
    "wagner": {"aero.unsteady": "wagner"},
    "wagner_stall": {"aero.unsteady": "wagner", "aero.section": "stall"},
    "wagner_dynamic_stall": {"aero.unsteady": "wagner", "aero.section": "dynamic-stall"},
}
"""Configuration overrides of each case (the paper's gait is the default configuration)."""

PROTOTYPE = {  # the specification's prototype estimate (numpy re-implementation): |Lambda1|, mean W_ff, level A
    "today": (1.4090, -0.060, 43.238), "lag_only": (1.4307, -0.086, 44.711),
    "lag_added_mass": (1.3958, 0.455, 33.864), "lag_three_quarter_chord": (1.4588, -0.609, None),
    "wagner": (1.4189, -0.021, 42.515), "wagner_stall": (1.4108, -0.107, 44.222),
    "wagner_dynamic_stall": (1.4172, -0.107, 44.216),
}


def _body_modes(mult, vecs, n_body=4):
    """Indices of the n_body multipliers whose eigenvectors lie most in the body states (u, w, q, theta)."""
    v = np.asarray(vecs)
    share = np.linalg.norm(v[:n_body], axis=0) / np.linalg.norm(v, axis=0)
    return set(np.argsort(-share)[:n_body].tolist())


def _summary(r) -> dict:
    if r.success:
        r.energetics  # noqa: B018 - computed so that to_dict carries the powers
    d = r.to_dict()
    mult = np.asarray(r.multipliers)
    out = {"success": bool(r.success), "status": r.status, "max_residual": d.get("max_residual"),
           "amplitude_deg": d.get("amplitude_deg"), "x0_body": np.asarray(r.x0)[:4].tolist(),
           "mean_vertical_speed_mps": d.get("mean_vertical_speed_mps"),
           "mean_forward_speed_mps": d.get("mean_forward_speed_mps"),
           "mean_flapping_power_W": d.get("mean_flapping_power_W"),
           "mean_aerodynamic_power_W": d.get("mean_aerodynamic_power_W"),
           "validity": d.get("validity")}
    if mult.size and np.all(np.isfinite(mult)):
        order = np.argsort(-np.abs(mult))
        mult = mult[order]
        vecs = np.asarray(r.cycle.eigenvectors)[:, order]
        body = _body_modes(mult, vecs)
        aero = [i for i in range(mult.size) if i not in body]
        out.update(lambda1=float(abs(mult[0])), multipliers=[[float(z.real), float(z.imag)] for z in mult[:6]],
                   body_multipliers=[[float(mult[i].real), float(mult[i].imag)] for i in sorted(body)],
                   largest_aero_multiplier=None if not aero else [float(mult[aero[0]].real), float(mult[aero[0]].imag)])
    v = d.get("validity") or {}
    amin, amax = v.get("alpha_eff_min_deg"), v.get("alpha_eff_max_deg")
    out.update(max_abs_alpha_E_deg=max(abs(amin), abs(amax)) if amin is not None else None,
               stalled_fraction=v.get("stalled_fraction"),
               separated_fraction=v.get("separated_fraction") if r.cfg.aero.section != "linear" else None,
               valid=v.get("valid"))
    return out


def run_case(name: str, overrides: dict, x_guess=None) -> dict:
    """Trim and level flight of one case; ``x_guess``: the body state (u, w, q, theta) to start from
    (the aerodynamic states start on the quasi-steady manifold)."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), overrides)
    t0 = time.perf_counter()
    tr = trim(cfg, x_guess=x_guess)
    t1 = time.perf_counter()
    res = {"case": name, "overrides": overrides, "trim": _summary(tr), "trim_wall_s": t1 - t0,
           "x_guess": None if x_guess is None else list(x_guess)}
    try:
        lv = level(cfg, warm_start=tr if tr.success else None)
        res["level"] = _summary(lv)
    except Exception as e:  # noqa: BLE001 - a failed level solve is a row of the table, with its reason
        res["level"] = {"success": False, "status": "error", "message": f"{type(e).__name__}: {e}"}
    res["level_wall_s"] = time.perf_counter() - t1
    return res


def _fmt(v, f="{:.4f}"):
    return "—" if v is None else f.format(v)


def table(rows: list[dict]) -> str:
    head = ("| case | \\|Λ1\\| (prototype) | next multipliers | largest aero | mean W at 42° (m/s) (prototype) | "
            "level A (deg) (prototype) | level \\|Λ1\\| | P_flap / P_aero (W) | max \\|α_E\\| (deg) | stalled / separated | valid (trim; level) |")
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        t, lv = r["trim"], r.get("level", {})
        pl, pw, pa = PROTOTYPE.get(r["case"], (None, None, None))
        nxt = ", ".join(f"{abs(complex(*z)):.3f}" for z in (t.get("multipliers") or [])[1:4]) if t.get("lambda1") else "—"
        la = t.get("largest_aero_multiplier")
        lamp = lv.get("amplitude_deg") if lv.get("success") else None
        sep = t.get("separated_fraction")
        lines.append(
            f"| {r['case']} | {_fmt(t.get('lambda1'))} ({_fmt(pl)}) | {nxt} | "
            f"{'—' if la is None else f'{abs(complex(*la)):.3f}'} | {_fmt(t.get('mean_vertical_speed_mps'), '{:+.3f}')} "
            f"({_fmt(pw, '{:+.3f}')}) | {_fmt(lamp, '{:.3f}')} ({_fmt(pa, '{:.3f}') if pa else 'none in 25-43'}) | "
            f"{_fmt(lv.get('lambda1') if lv.get('success') else None)} | "
            f"{_fmt(t.get('mean_flapping_power_W'), '{:.2f}')} / {_fmt(t.get('mean_aerodynamic_power_W'), '{:.2f}')} | "
            f"{_fmt(t.get('max_abs_alpha_E_deg'), '{:.1f}')} | {_fmt(t.get('stalled_fraction'), '{:.3f}')} / "
            f"{_fmt(sep, '{:.3f}')} | {t.get('valid')}; {lv.get('valid') if lv.get('success') else 'no level solution'} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero")
    ap.add_argument("--cases", nargs="*", default=list(CASES), help="cases to run (default all)")
    args, out = parse_with_out(ap, argv)
    from birdocp.io.files import atomic_write_json, atomic_write_text

    (out / "cases").mkdir(exist_ok=True)
    rows = []
    for name in args.cases:
        path = out / "cases" / f"{name}.json"
        if path.exists():
            rows.append(json.loads(path.read_text()))
            continue
        print(f"{name} ...", flush=True)
        guess = None
        start = out / "cases" / "wagner.json"
        if "section" in str(CASES[name]) and start.exists():
            # the stall sections start from the linear-section wagner cycle's body state: the default
            # guess sends IPOPT's first trial points where the Newton circulation is singular (NaN)
            guess = json.loads(start.read_text())["trim"]["x0_body"]
        r = run_case(name, CASES[name], guess)
        atomic_write_json(path, r)
        rows.append(r)
        print(f"  trim {r['trim'].get('lambda1')}, level {r['level'].get('amplitude_deg')} "
              f"({r['trim_wall_s']:.0f} s + {r['level_wall_s']:.0f} s)", flush=True)
    atomic_write_json(out / "table.json", {"rows": rows, "prototype": PROTOTYPE})
    atomic_write_text(out / "table.md", table(rows))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
