"""Wing masses and the tail in six degrees of freedom: the exact checks and the lateral modes with them.

1. Vacuum (no air, no gravity), one wingbeat by fixed-step RK4: the drift of the momentum and angular
   momentum of body plus wings, with both wings heavy and with the right wing alone heavy (asymmetric
   wing motion), at 50 .. 400 steps (RK4: 16x smaller per halving).
2. The paper's gait with wing masses (0.086 kg per wing), with the tail (opening 20 deg) and with both:
   the 6-DOF cycle against the planar cycle of the same configuration (longitudinal multipliers,
   coupling blocks) and the labelled lateral modes, with validity.
3. With both: the exact sensitivities of every lateral mode to the dihedral, sweep, elbow, wrist,
   incidence, lateral inertias and the tail opening, each against central differences of re-solved
   cycles.

Writes result.json and table.md to --out.

    python scripts/lateral_masses.py --out results/lateral/masses
"""
from __future__ import annotations

import time

import numpy as np

from birdocp.bird.config import Config, get_value, with_values
from birdocp.engine.results import to_jsonable
from birdocp.studies.lateral import lateral_trim
from birdocp.studies.lateral_sensitivity import lateral_sensitivities
from birdocp.studies.lateral_checks import vacuum_drift
from birdocp.studies.trim import trim
from script_common import parse_with_out, script_parser, write_result

CASES = {"wing masses": {"wing.mass_kg": 0.086}, "tail": {"tail.opening_angle_deg": 20.0},
         "wing masses and tail": {"wing.mass_kg": 0.086, "tail.opening_angle_deg": 20.0}}
STEPS = (50, 100, 200, 400)
FD_STEP = {"model.roll_inertia_kgm2": 1e-4, "model.yaw_inertia_kgm2": 1e-4}
"""Central-difference steps (per unit of the parameter; 0.01 deg for the angles)."""


def mode_moduli(res) -> dict:
    """|Lambda| per lateral mode label (a pair counted once)."""
    out = {}
    for m in res.lateral_modes:
        out.setdefault(m["label"], abs(m["multiplier"]))
    return out


def case(name: str, over: dict) -> dict:
    cfg = with_values(Config(), over)
    t = time.perf_counter()
    six = lateral_trim(cfg)
    planar = trim(cfg)
    lon = np.sort_complex(six.longitudinal_multipliers)
    return {"case": name, "settings": over, "success": bool(six.success and planar.success),
            "valid": bool(six.validity and six.validity.valid),
            "longitudinal_vs_planar_max": float(np.max(np.abs(lon - np.sort_complex(planar.multipliers)))),
            "coupling_max": six.coupling_max, "heading_multiplier": six.heading_multiplier,
            "lateral_modes": [{k: m[k] for k in ("label", "multiplier", "beats_to_double")} for m in six.lateral_modes],
            "longitudinal_multipliers": six.longitudinal_multipliers, "wall_s": time.perf_counter() - t}


def sensitivities(over: dict) -> list[dict]:
    cfg = with_values(Config(), over)
    base = lateral_trim(cfg)
    t = time.perf_counter()
    rows = lateral_sensitivities(base, cfg)
    wall = time.perf_counter() - t
    out = []
    for r in rows:
        key = r["parameter"]
        h = FD_STEP.get(key, 0.01)
        v0 = get_value(cfg, key)
        exact = {}
        for lab, d in zip(r["labels"], r["d_moduli"]):
            exact.setdefault(lab, float(d))
        row = {"parameter": key, "exact": exact}
        for name, step in (("", h), ("_small", h / 10)):  # two steps: a kink of the model shows as a step change
            plus = mode_moduli(lateral_trim(with_values(cfg, {key: v0 + step})))
            minus = mode_moduli(lateral_trim(with_values(cfg, {key: v0 - step})))
            fd = {lab: (plus[lab] - minus[lab]) / (2 * step) for lab in plus if lab in minus}
            row.update({f"central_difference{name}": fd, f"fd_step{name}": step,
                        f"max_abs_difference{name}": max(abs(exact[lab] - fd[lab]) for lab in fd if lab in exact)})
        out.append(row)
    out.append({"wall_s_exact": wall})
    return out


def table(res: dict) -> str:
    L = ["# Wing masses and the tail in six degrees of freedom", "",
         "## Vacuum: momentum and angular momentum of body plus wings over one wingbeat (RK4)", "",
         "| wings with mass | " + " | ".join(f"{n} steps" for n in STEPS) + " | ratios |",
         "|---|" + "---|" * (len(STEPS) + 1)]
    for name, v in res["vacuum"].items():
        L.append(f"| {name} | " + " | ".join(f"{d:.2e}" for d in v["drift"]) + " | "
                 + ", ".join(f"{q:.2f}" for q in v["ratios"]) + " |")
    L += ["", "## The paper's gait (A = 42 deg) in 6 DOF against the planar cycle", "",
          "| case | valid | longitudinal vs planar | coupling | spiral | Dutch-roll-like | roll subsidence |",
          "|---|---|---|---|---|---|---|"]
    for c in res["cases"]:
        mods = {m["label"]: m for m in c["lateral_modes"]}

        def fmt(lab):
            m = mods.get(lab)
            return "-" if m is None else f"{abs(complex(m['multiplier'])):.4f} ({m['beats_to_double']:+.1f} beats)"
        L.append(f"| {c['case']} | {'yes' if c['valid'] else 'no'} | {c['longitudinal_vs_planar_max']:.1e} | "
                 f"{c['coupling_max']:.1e} | {fmt('spiral')} | {fmt('dutch_roll_like')} | {fmt('roll_subsidence')} |")
    L += ["", "## Exact sensitivities with wing masses and tail (d|Λ| per unit) against central differences", "",
          "| parameter | spiral | Dutch-roll-like | roll subsidence | longitudinal | max abs(exact - CD) | "
          "same, step / 10 |", "|---|---|---|---|---|---|---|"]
    for r in res["sensitivities"]:
        if "parameter" not in r:
            continue
        e = r["exact"]
        L.append(f"| {r['parameter']} | " + " | ".join(f"{e.get(k, float('nan')):+.4g}" for k in (
            "spiral", "dutch_roll_like", "roll_subsidence", "longitudinal")) + f" | {r['max_abs_difference']:.1e} | "
                 f"{r['max_abs_difference_small']:.1e} |")
    L.append("")
    L.append(f"Wall time {res['wall_s']:.0f} s (the machine was shared).")
    return "\n".join(L) + "\n"


def main(argv=None) -> None:
    ap = script_parser(__doc__, "results/lateral/masses")
    args, out = parse_with_out(ap, argv)
    t0 = time.perf_counter()
    heavy = with_values(Config(), {"wing.mass_kg": 0.086})
    res = {"vacuum": {"both wings": vacuum_drift(heavy, STEPS, one_wing=False),
                      "right wing only": vacuum_drift(heavy, STEPS, one_wing=True)}}
    print("vacuum:", {k: v["drift"] for k, v in res["vacuum"].items()}, flush=True)
    res["cases"] = [case(name, over) for name, over in CASES.items()]
    print("cases done", flush=True)
    res["sensitivities"] = sensitivities(CASES["wing masses and tail"])
    res["wall_s"] = time.perf_counter() - t0
    write_result(out, to_jsonable(res), table(res))


if __name__ == "__main__":
    main()
