"""Experiment 3 of the paper: the wing-root position / stability margin, by pseudo-arclength continuation.

SM = (G - O'w)/c = -root_ahead_m / c (c = 0.2 m); the paper covers SM -32.5 % .. -17.5 % (root 6.5 cm
.. 3.5 cm ahead of G) and found no limit cycle beyond -17.5 %. Here two families are followed from the
reference cycle (root 5 cm, SM -25 %), each in both directions:

* ``fixed``: the paper's reference amplitude 42 deg;
* ``level``: level flight held, the flapping amplitude an unknown of every point (mean W = 0).

Towards the rear the continuation goes on beyond the paper's range (to root 1 cm, SM -5 %) to see
whether and how the branch ends. The four half-branches run as independent jobs through
:mod:`birdocp.engine.executors` (``--jobs``). Independent ``trim`` runs at three root positions check the
fixed-amplitude branch. Every point carries its model validity (:mod:`birdocp.bird.validity`); the
figures shade the paper's range, draw the invalid part grey and mark the branch ends by their reason
(stopped at the end of the requested range, or the end of the branch: the level-flight branch's
amplitude reaches its bound). Writes locus.png, moduli.png, level_*.png, branch JSONs, result.json, table.md.

    python scripts/experiment3.py --out results/experiment3 --jobs 2
"""
from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import numpy as np

from birdocp.bird.config import Config, with_values
from birdocp.engine.continuation import Branch
from birdocp.studies.branch import bird_branch, sm_percent
from birdocp.engine.executors import get_executor
from birdocp.io.files import atomic_write_json, atomic_write_text
from script_common import parse_with_out, script_parser

CHORD = 0.2
PAPER_RANGE_CM = (3.5, 6.5)


def run_half(job: dict) -> dict:
    t = time.perf_counter()
    br = bird_branch(Config(), "stability_margin", job["from_sm"], job["to_sm"], level=job["level"],
                     step=job["step"], max_dparam=job["max_dparam"], max_dstate=job["max_dstate"],
                     compiled=job.get("compiled", False))
    d = br.to_dict()
    d["job_wall_s"] = time.perf_counter() - t
    return {"name": job["name"], "branch": d}


def merge(down: Branch, up: Branch) -> Branch:
    """One branch ordered by root position (up: 5 -> 6.5 cm reversed, then down: 5 -> 1 cm)."""
    pts = list(reversed(up.points)) + down.points[1:]
    n_up = len(up.points)
    sps = [type(s)(**{**s.__dict__, "between": (n_up - 1 - s.between[1], n_up - 1 - s.between[0])})
           for s in up.special_points]
    sps += [type(s)(**{**s.__dict__, "between": (s.between[0] + n_up - 1, s.between[1] + n_up - 1)})
            for s in down.special_points]
    settings = dict(down.settings, display="stability_margin",
                    ends=[{"index": 0, "reason": up.end_reason, "message": up.end_message},
                          {"index": len(pts) - 1, "reason": down.end_reason, "message": down.end_message}])
    return Branch(down.parameter_name, pts, sps, down.end_reason, down.end_message, settings,
                  down.wall_s + up.wall_s, down.free_names)


LABELS = {"fixed": "A = 42 deg", "level": "level flight"}


def plot_job(job: dict) -> list:
    """One set of branch figures (run in a worker, beside the main process's trims)."""
    from birdocp.plots.branch import plot_branches  # matplotlib: only where a figure is drawn

    branches = {label: Branch.from_dict(d) for label, d in job["branches"].items()}
    return [str(p) for p in plot_branches(branches, Path(job["out"]), prefix=job["prefix"], span=tuple(job["span"]))]


def trim_checks(halves: dict, fixed: Branch, compiled: bool = False) -> list:
    """Independent trims at three root positions of the fixed-amplitude branch."""
    from birdocp.studies.trim import trim

    checks = []
    n_up = len(halves["fixed_up"].points)
    for idx in (n_up - 3, n_up - 1, n_up + 2):
        pt = fixed.points[idx]
        t = time.perf_counter()
        cfg_i = with_values(Config(), {"wing.root_ahead_m": pt.parameter})
        tr = trim(cfg_i, compiled=compiled)  # cold, from the configured guess
        start = "configured guess"
        if not tr.success:  # from the branch's x0 rounded to 1 decimal (a perturbed guess)
            tr = trim(cfg_i, x_guess=np.round(np.array(pt.x0), 1), compiled=compiled)
            start = "branch x0 rounded to 0.1"
        L = np.sort_complex(np.array([complex(*m) for m in pt.multipliers]))
        Lt = np.sort_complex(np.asarray(tr.multipliers))
        checks.append({"root_ahead_m": pt.parameter, "sm_percent": sm_percent(pt.parameter, CHORD),
                       "trim_success": bool(tr.success), "trim_start": start, "trim_wall_s": time.perf_counter() - t,
                       "max_abs_multiplier_difference": float(np.max(np.abs(L - Lt))),
                       "max_abs_x0_difference": float(np.max(np.abs(np.array(pt.x0) - tr.x0)))})
    return checks


def figures_and_checks(ex, jobs: int, res: list, out: Path, compiled: bool = False, checks: list | None = None):
    """The branch figures (drawn by the executor's workers, in a thread of this process, while this
    process runs the independent trims) and the trim checks; given ``checks`` (a redraw, ``--reuse``),
    the figures only, drawn in this process."""
    halves = {r["name"]: Branch.from_dict(r["branch"]) for r in res}
    fams = {"fixed": merge(halves["fixed_down"], halves["fixed_up"]),
            "level": merge(halves["level_down"], halves["level_up"])}
    span = [-32.5, -17.5, "the paper's range, SM -32.5 .. -17.5 %"]
    plots = [{"branches": {LABELS[k]: v.to_dict() for k, v in fams.items()}, "prefix": "", "span": span,
              "out": str(out)},
             {"branches": {LABELS["level"]: fams["level"].to_dict()}, "prefix": "level_", "span": span,
              "out": str(out)}]
    drawn: list = []
    if checks is not None:
        drawn = [plot_job(job) for job in plots]
    elif jobs > 1:
        th = threading.Thread(target=lambda: drawn.extend(ex.map(plot_job, plots)))
        th.start()
        checks = trim_checks(halves, fams["fixed"], compiled)
        th.join()
    else:
        drawn = [plot_job(job) for job in plots]
        checks = trim_checks(halves, fams["fixed"], compiled)
    if len(drawn) != len(plots):
        raise RuntimeError("drawing the branch figures failed")
    return halves, fams, [Path(p) for ps in drawn for p in ps], checks


def reused_run(out: Path, jobs: list) -> tuple[list, dict | None]:
    """``--reuse``: the half-branches of an earlier run of this script in ``out``, and that run's
    result.json (None if there is none): its trim checks, wall times and executor are kept as it
    measured them (no trim is redone), so that a redraw writes result.json again byte for byte."""
    res = [{"name": j["name"], "branch": json.loads((out / f"branch_{j['name']}.json").read_text())}
           for j in jobs]
    try:
        prev = json.loads((out / "result.json").read_text())
        prev = {k: prev[k] for k in ("trim_checks", "wall_s", "executor")}
    except (OSError, ValueError, KeyError):
        prev = None
    return res, prev


def main():
    ap = script_parser(__doc__, "results/experiment3")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--rear-sm", type=float, default=-5.0, help="how far towards the rear (SM %%) to continue")
    ap.add_argument("--reuse", action="store_true",
                    help="reuse the branch_*.json of --out (no continuation) and the trim checks and wall times "
                         "of its result.json (no trim): redraw the figures and tables")
    a, out = parse_with_out(ap)
    t0 = time.perf_counter()
    # longest first (measured: level-down ~16 s, fixed-down ~5.5 s, level-up ~5 s, fixed-up ~1.8 s), so
    # that two workers finish together
    jobs = [{"name": f"{fam}_{d}", "level": fam == "level", "from_sm": -25.0,
             "to_sm": (-32.5 if d == "up" else a.rear_sm), "step": 0.5,
             "max_dparam": 1.0, "max_dstate": 1.5, "compiled": a.compiled}
            for d in ("down", "up") for fam in ("level", "fixed")]
    res, prev = reused_run(out, jobs) if a.reuse else (None, None)
    ex = get_executor(jobs=a.jobs)
    with ex:
        if not a.reuse:
            res = ex.map(run_half, jobs)
        wall_branches = time.perf_counter() - t0
        halves, fams, figs, checks = figures_and_checks(ex, a.jobs, res, out, a.compiled,
                                                        prev["trim_checks"] if prev else None)
    job_wall = {r["name"]: r["branch"].get("job_wall_s", r["branch"]["wall_s"]) for r in res}
    for r in res:
        atomic_write_json(out / f"branch_{r['name']}.json", r["branch"])

    def summary(br: Branch, name):
        M = np.array([p.moduli for p in br.points])
        sm = np.array([sm_percent(p.parameter, CHORD) for p in br.points])
        inrange = (sm >= -32.5 - 1e-9) & (sm <= -17.5 + 1e-9)
        s = {"points": len(br.points), "sm_range_percent": [float(sm.min()), float(sm.max())],
             "rear_end": {"reason": halves[f"{name}_down"].end_reason, "message": halves[f"{name}_down"].end_message,
                          "sm_percent": float(sm[-1])},
             "front_end": {"reason": halves[f"{name}_up"].end_reason, "message": halves[f"{name}_up"].end_message,
                           "sm_percent": float(sm[0])},
             "special_points": [dict(sp.to_dict(), sm_percent=sm_percent(sp.parameter, CHORD))
                                for sp in br.special_points],
             "stable_points": int(sum(p.stable for p in br.points)),
             "stable_anywhere": bool(any(p.stable for p in br.points)),
             "expanding_modulus_range_in_paper_range": [float(M[inrange, 0].min()), float(M[inrange, 0].max())],
             "expanding_modulus_min": float(M[:, 0].min()),
             "sm_at_min_expanding_percent": float(sm[np.argmin(M[:, 0])])}
        ok = np.array([bool(p.validity and p.validity["valid"]) for p in br.points])
        s["valid_points"] = int(ok.sum())
        s["valid_sm_range_percent"] = [float(sm[ok].min()), float(sm[ok].max())] if ok.any() else None
        s["valid_everywhere_in_paper_range"] = bool(ok[inrange].all())
        bad = np.nonzero(~ok)[0]
        if bad.size:
            # the first invalid point going rearward from the reference (SM -25 %)
            rear = [i for i in bad if sm[i] > -25.0]
            i = rear[0] if rear else bad[0]
            s["first_invalid_rearward"] = {"sm_percent": float(sm[i]), "reasons": br.points[i].validity["reasons"]}
        s["max_pitch_deg_range"] = [float(min(p.validity["max_abs_pitch_deg"] for p in br.points)),
                                    float(max(p.validity["max_abs_pitch_deg"] for p in br.points))]
        s["min_forward_speed_mps_min"] = float(min(p.validity["min_forward_speed_mps"] for p in br.points))
        s["max_airflow_body_angle_deg_max"] = float(max(p.validity["max_airflow_body_angle_deg"] for p in br.points))
        if br.free_names:
            F = np.array([p.free_values[br.free_names[0]] for p in br.points])
            s["amplitude_deg_range"] = [float(F.min()), float(F.max())]
        return s

    result = {"families": {k: summary(v, k) for k, v in fams.items()}, "trim_checks": checks,
              "wall_s": {"branches_total": wall_branches, "per_half_branch": job_wall,
                         "total": time.perf_counter() - t0},
              "executor": f"processes, jobs={a.jobs}",
              "grid": {"points": fams["fixed"].settings.get("points"),
                       "steps_per_period": fams["fixed"].settings.get("steps_per_period")},
              "figures": [p.name for p in figs]}
    if prev is not None:  # a redraw: as the run that computed the branches and the checks measured them
        result.update(wall_s=prev["wall_s"], executor=prev["executor"])
    atomic_write_json(out / "result.json", result)

    lines = ["# Experiment 3: wing-root position (stability margin), continued branches", "",
             "SM = -root_ahead / 0.2 m. `fixed`: amplitude 42 deg; `level`: amplitude solved for mean W = 0.", ""]
    for k, br in fams.items():
        lines += [f"## {LABELS[k]}", "",
                  "| SM [%] | root [cm] | " + ("A [deg] | " if br.free_names else "")
                  + "Λ1 | abs Λ2 | abs Λ3 | abs Λ4 | U [m/s] | W [m/s] | stable | model valid |",
                  "|---:|---:|" + ("---:|" if br.free_names else "") + "---:|---:|---:|---:|---:|---:|:---:|:---|"]
        for p in br.points:
            L = [complex(*m) for m in p.multipliers]
            row = f"| {sm_percent(p.parameter, CHORD):.2f} | {100 * p.parameter:.3f} | "
            if br.free_names:
                row += f"{p.free_values[br.free_names[0]]:.3f} | "
            row += (f"{L[0].real:.4f}{L[0].imag:+.4f}j | {abs(L[1]):.4f} | {abs(L[2]):.4f} | {abs(L[3]):.4f} | "
                    f"{p.means.get('forward_speed_mps', float('nan')):.3f} | "
                    f"{p.means.get('vertical_speed_mps', float('nan')):+.4f} | {'yes' if p.stable else 'no'} | "
                    + ("yes" if p.validity["valid"] else "NO: " + "; ".join(p.validity["reasons"])) + " |")
            lines.append(row)
        s = result["families"][k]
        lines += ["", f"Front end: {s['front_end']['reason']} ({s['front_end']['message']}); rear end: "
                      f"{s['rear_end']['reason']} ({s['rear_end']['message']}).",
                  "Special points: " + (", ".join(f"{sp['kind']} at SM {sp['sm_percent']:.4f} %"
                                                   for sp in s["special_points"]) or "none") + ".",
                  f"Stable cycle anywhere on the branch: {'YES' if s['stable_anywhere'] else 'NO'}.",
                  f"Model valid (birdocp.bird.validity, default thresholds) on {s['valid_points']} of {s['points']} "
                  f"points" + (f", SM {s['valid_sm_range_percent'][0]:.2f} .. {s['valid_sm_range_percent'][1]:.2f} %"
                               if s["valid_sm_range_percent"] else "")
                  + f"; everywhere in the paper's range: {'yes' if s['valid_everywhere_in_paper_range'] else 'NO'}"
                  + (f"; first invalid point rearward: SM {s['first_invalid_rearward']['sm_percent']:.2f} % ("
                     + "; ".join(s["first_invalid_rearward"]["reasons"]) + ")" if "first_invalid_rearward" in s else "")
                  + ".", ""]
    lines += ["## Independent trims (A = 42 deg)", "", "| SM [%] | max abs ΔΛ | max abs Δx0 |", "|---:|---:|---:|"]
    lines += [f"| {c['sm_percent']:.3f} | {c['max_abs_multiplier_difference']:.2e} | {c['max_abs_x0_difference']:.2e} |"
              for c in checks]
    atomic_write_text(out / "table.md", "\n".join(lines) + "\n")
    print(json.dumps({k: {kk: v.get(kk) for kk in ("front_end", "rear_end", "stable_anywhere", "valid_sm_range_percent",
                                                     "first_invalid_rearward")}
                      for k, v in result["families"].items()}, indent=1))
    print("wall", result["wall_s"])


if __name__ == "__main__":
    main()
