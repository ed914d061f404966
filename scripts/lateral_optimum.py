"""The most stable level-flight gait in six degrees of freedom: optimize-stability with
``model.degrees_of_freedom = 6`` (symmetric gait; the largest of ALL multipliers minimised, the
longitudinal and the lateral ones, the heading's structural 1 left out). Writes ``OUT/result.json`` and
``OUT/table.md`` (default OUT: results/lateral/optimum).

* the planar optimum re-trimmed in six degrees of freedom: the gait and amplitude of the committed
  planar optimum (``--planar``, default results/stability_optimum/result.json, from
  scripts/stability_study.py), :func:`birdocp.studies.lateral.lateral_trim` at it: its longitudinal
  and lateral radii (do the lateral multipliers matter at the planar optimum?);
* the 6-DOF optimum: :func:`birdocp.studies.optimize.optimize_stability` (reduced space, default keys
  and bounds, coarse 32-step stage then ``solve.steps_per_period``), verified by a 6-DOF trim; with
  ``--valid`` the limits of ``[validity]`` as constraints.

    python scripts/lateral_optimum.py [--out DIR] [--valid] [--planar FILE]
"""

import json
import time
from pathlib import Path

import numpy as np

from script_common import parse_with_out, script_parser

from birdocp.bird.config import Config, with_values
from birdocp.io.files import atomic_write_json, atomic_write_text

ROOT = Path(__file__).resolve().parents[1]
SIX = {"model.degrees_of_freedom": 6}


def log(*a):
    print(time.strftime("%H:%M:%S"), *a, flush=True)


def planar_optimum_in_six_dof(path: Path) -> dict:
    """The committed planar optimum's gait, trimmed in six degrees of freedom (its radii per block)."""
    from birdocp.studies.lateral import lateral_trim

    d = json.loads(path.read_text())
    vals = dict(d["free"]) | {"gait.shoulder_flap.amplitude_deg": d["amplitude_deg"]}
    t0 = time.perf_counter()
    res = lateral_trim(with_values(Config(), vals | SIX), x_guess=[d["x0"][0], 0, d["x0"][1], 0, d["x0"][2], 0, 0,
                                                                   d["x0"][3], 0])
    r = res.to_dict()
    lon, lat = np.abs(res.longitudinal_multipliers), np.abs(res.lateral_multipliers)
    return {"source": str(path.resolve().relative_to(ROOT)), "gait": vals, "success": bool(res.success),
            "max_residual": r.get("max_residual"), "longitudinal_radius": float(lon.max()),
            "lateral_radius": float(lat.max()), "lateral_above_longitudinal": bool(lat.max() > lon.max()),
            "longitudinal_multipliers": r["longitudinal_multipliers"], "lateral_multipliers": r["lateral_multipliers"],
            "lateral_modes": [{"label": m["label"], "modulus": abs(m["multiplier"]),
                               "beats_to_double": m["beats_to_double"]} for m in res.lateral_modes],
            "validity": r.get("validity"), "wall_s": time.perf_counter() - t0}


def six_dof_optimum(valid: bool) -> dict:
    """optimize_stability in six degrees of freedom (default keys and bounds), as its JSON."""
    from birdocp.studies.optimize import optimize_stability

    res = optimize_stability(with_values(Config(), SIX), valid=valid, progress=lambda s: log("  ", s))
    return res.to_dict()


def _pairs(z) -> str:
    return ", ".join(f"{a:.4f}{b:+.4f}j" if abs(b) > 1e-12 else f"{a:.4f}" for a, b in z)


def table(d: dict) -> str:
    p, o = d["planar_optimum_in_six_dof"], d["six_dof_optimum"]
    keys = list(o["free"])
    v = lambda r: "valid" if (r.get("validity") or {}).get("valid") else "**NOT valid**: " + "; ".join(  # noqa: E731
        (r.get("validity") or {}).get("reasons") or ["not checked"])
    rows = [f"| flapping amplitude [deg] | {p['gait']['gait.shoulder_flap.amplitude_deg']:.3f} | {o['amplitude_deg']:.3f} |"]
    rows += [f"| {k} {list(o['bounds'][k])} | {p['gait'][k]:.3f} | {o['free'][k]:.3f} |" for k in keys]
    rows += [f"| longitudinal multipliers | {_pairs(p['longitudinal_multipliers'])} | {_pairs(o['longitudinal_multipliers'])} |",
             f"| lateral multipliers | {_pairs(p['lateral_multipliers'])} | {_pairs(o['lateral_multipliers'])} |",
             f"| longitudinal radius | {p['longitudinal_radius']:.5f} | {o['longitudinal_radius']:.5f} |",
             f"| lateral radius | {p['lateral_radius']:.5f} | {o['lateral_radius']:.5f} |",
             f"| model validity | {v(p)} | {v(o)} |"]
    ver = o.get("verification") or {}
    return "\n".join([
        "# The most stable level-flight gait in six degrees of freedom (symmetric gait)", "",
        "| quantity | planar optimum, trimmed in 6-DOF | 6-DOF optimum (all multipliers) |", "|---|---|---|", *rows, "",
        f"6-DOF optimisation{' with the validity limits as constraints' if d['valid'] else ''}: {o['status']}, "
        f"{o['iterations']} iterations, {o['wall_s'].get('total', float('nan')):.0f} s, r* = {o['radius']:.5f}, "
        f"KKT residual {o.get('kkt_residual')}; a 6-DOF trim at the optimum converges "
        f"({ver.get('six_dof_trim_success')}) with multipliers within {ver.get('max_multiplier_difference')}, "
        f"heading multiplier {ver.get('trim_heading_multiplier')}.", "",
        f"At the planar optimum the lateral radius ({p['lateral_radius']:.5f}) is "
        f"{'above' if p['lateral_above_longitudinal'] else 'below'} the longitudinal one ({p['longitudinal_radius']:.5f}).",
        ""])


def main(argv=None) -> None:
    ap = script_parser(__doc__, str(ROOT / "results" / "lateral" / "optimum"))
    ap.add_argument("--valid", action="store_true", help="the limits of [validity] as constraints")
    ap.add_argument("--planar", default=str(ROOT / "results" / "stability_optimum" / "result.json"),
                    help="the committed planar optimum (default %(default)s)")
    args, out = parse_with_out(ap, argv)
    t0 = time.perf_counter()
    log("planar optimum trimmed in six degrees of freedom")
    planar = planar_optimum_in_six_dof(Path(args.planar))
    log(f"  longitudinal radius {planar['longitudinal_radius']:.5f}, lateral {planar['lateral_radius']:.5f}")
    log("six-degree-of-freedom optimum")
    six = six_dof_optimum(args.valid)
    log(f"  {six['status']}: r* {six['radius']:.5f}, longitudinal {six['longitudinal_radius']:.5f}, lateral "
        f"{six['lateral_radius']:.5f}")
    d = {"problem": "optimize_stability with model.degrees_of_freedom = 6 (default keys and bounds)",
         "valid": bool(args.valid), "planar_optimum_in_six_dof": planar, "six_dof_optimum": six,
         "script_wall_s": time.perf_counter() - t0}
    atomic_write_json(out / "result.json", d)
    atomic_write_text(out / "table.md", table(d))
    log("written", out)


if __name__ == "__main__":
    main()
