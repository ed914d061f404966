"""Does the bird trim, solve level flight and continue with every aerodynamic option? (docs/model_unsteady.md)

For each combination of ``aero.unsteady`` (none, wagner) and ``aero.section`` (linear, stall,
dynamic-stall), on a coarse grid (5 shooting points, ``--steps`` RK4 steps per period, default 64: the
coarsest the lag states allow is about 44) and through the Python API with the configured solver
(``solve.solver = "auto"``: Newton-Picard for a model with aerodynamic states, IPOPT for the
quasi-steady default):

* the trim at the paper's gait (amplitude 42 deg; a stall section first trims the linear section,
  :func:`birdocp.studies.trim.linear_section_start`);
* level flight (the amplitude free, zero mean vertical speed), warm-started from that trim;
* a short pseudo-arclength continuation in the flapping amplitude at fixed gait from that trim
  (``--branch-to`` deg, at most ``--branch-points`` points).

Each solve records converged (the residual, not a status), its max residual, |Lambda1|, the validity
of the cycle, the wall and CPU time; the level flight its amplitude. The load average is recorded
with the times (the machine may be shared).

    python scripts/aero_options_matrix.py --out results/aero/options_matrix

Writes DIR/cases/<unsteady>_<section>.json as each combination finishes (a rerun skips finished
ones), then DIR/matrix.json and DIR/matrix.md. Exit status 1 when any solve did not converge.

``--optimum-scan`` (instead of the matrix): why ``wagner`` + ``stall`` level flight at the speed-free
``wagner`` optimum's gait (results/aero/valid/optimized.json) does not converge. Trims with ``wagner``
+ ``stall`` at that gait over a range of flapping amplitudes (from the optimum's amplitude down, then
up, each from the previous cycle) give the mean vertical speed against the amplitude:
DIR/optimum_stall_scan.json and .md.

``--level-solvers`` (instead of the matrix): level flight of ``wagner`` and ``wagner`` + ``stall`` at the
paper's gait by Newton-Picard and by IPOPT, each warm-started from the trim and solved twice (the
second solve timed: graphs built), wall and CPU time in one run: DIR/level_solvers.json.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from script_common import parse_with_out, script_parser  # noqa: E402

UNSTEADY = ("none", "wagner")
SECTIONS = ("linear", "stall", "dynamic-stall")


def _timed(fn):
    """(value, wall_s, cpu_s) of ``fn()``."""
    w, c = time.perf_counter(), time.process_time()
    v = fn()
    return v, time.perf_counter() - w, time.process_time() - c


def _cycle(r, wall: float, cpu: float) -> dict:
    """The row of one trim or level solve."""
    mult = np.asarray(r.multipliers)
    v = r.validity
    return {"converged": bool(r.success), "status": r.status, "solver_message": r.cycle.message,
            "iterations": int(r.iterations), "max_residual": float(r.max_residual),
            "lambda1": float(np.max(np.abs(mult))) if mult.size and np.all(np.isfinite(mult)) else None,
            "amplitude_deg": float(r.amplitude_deg), "mean_vertical_speed_mps": float(r.mean_vertical_speed_mps),
            "valid": bool(v.valid), "validity": v.summary(), "wall_s": wall, "cpu_s": cpu}


def _branch(cfg, start, stop: float, max_points: int, compiled: bool) -> dict:
    """The amplitude continuation at fixed gait from the trim ``start``."""
    from birdocp.studies.branch import bird_branch

    a0 = float(start.amplitude_deg)
    br, wall, cpu = _timed(lambda: bird_branch(cfg, "amplitude_deg", a0, stop, start=start, max_points=max_points,
                                               step=(stop - a0) / max(max_points - 1, 1), compiled=compiled))
    pts = br.points
    return {"converged": bool(len(pts) >= 2 and all(p.success for p in pts)), "end_reason": br.end_reason,
            "points": len(pts), "amplitude_deg": [float(p.parameter) for p in pts],
            "lambda1": [float(max(p.moduli)) for p in pts], "max_residual": max(float(p.max_residual) for p in pts),
            "valid": [None if p.validity is None else bool(p.validity.get("valid")) for p in pts],
            "wall_s": wall, "cpu_s": cpu}


def run_combination(unsteady: str, section: str, steps: int, branch_to: float, branch_points: int,
                    compiled: bool) -> dict:
    """Trim, level flight and the amplitude continuation of one combination."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level
    from birdocp.studies.trim import solver_of, trim

    cfg = with_values(Config(), {"aero.unsteady": unsteady, "aero.section": section,
                                 "solve.steps_per_period": steps})
    out = {"unsteady": unsteady, "section": section, "steps_per_period": steps, "solver": solver_of(cfg),
           "load_average_start": os.getloadavg()[0]}
    tr, w, c = _timed(lambda: trim(cfg, compiled=compiled))
    out["trim"] = _cycle(tr, w, c)
    lv, w, c = _timed(lambda: level(cfg, warm_start=tr if tr.success else None, compiled=compiled))
    out["level"] = _cycle(lv, w, c)
    if tr.success:
        out["continuation"] = _branch(cfg, tr, branch_to, branch_points, compiled)
    else:
        out["continuation"] = {"converged": False, "end_reason": "no converged trim to start from"}
    out["load_average_end"] = os.getloadavg()[0]
    out["all_converged"] = all(out[k]["converged"] for k in ("trim", "level", "continuation"))
    return out


def _f(v, fmt="{:.4f}"):
    return "n/a" if v is None else fmt.format(v)


def table(rows: list[dict]) -> str:
    """The markdown table of the matrix."""
    head = ("| unsteady | section | solver | trim | trim \\|Λ1\\| | level | level amplitude [deg] | level \\|Λ1\\| "
            "| valid (trim/level) | continuation | wall trim / level / branch [s] |")
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        t, lv, b = r["trim"], r["level"], r["continuation"]
        br = (f"{b['points']} pts {b['amplitude_deg'][0]:.2f}–{b['amplitude_deg'][-1]:.2f}°, \\|Λ1\\| "
              f"{min(b['lambda1']):.4f}–{max(b['lambda1']):.4f}" if b.get("points") else b["end_reason"])
        ok = lambda d: f"{'yes' if d['converged'] else 'NO'} ({_f(d.get('max_residual'), '{:.1e}')})"  # noqa: E731
        lines.append(f"| {r['unsteady']} | {r['section']} | {r['solver']} | {ok(t)} | {_f(t['lambda1'])} | {ok(lv)} "
                     f"| {_f(lv['amplitude_deg'], '{:.3f}')} | {_f(lv['lambda1'])} | {t['valid']} / {lv['valid']} "
                     f"| {'yes' if b['converged'] else 'NO'}: {br} "
                     f"| {t['wall_s']:.0f} / {lv['wall_s']:.0f} / {_f(b.get('wall_s'), '{:.0f}')} |")
    return "\n".join(lines) + "\n"


SCAN_DOWN = (41.0, 38.0, 35.0, 32.0, 29.0)
SCAN_UP = (44.5, 45.0, 48.0, 50.0, 53.0, 56.0, 60.0, 65.0)


def optimum_stall_scan(steps: int, compiled: bool) -> dict:
    """Trims with ``wagner`` + ``stall`` at the speed-free ``wagner`` optimum's gait (the converged
    ``fd_reached`` row of results/aero/valid/optimized.json) over the flapping amplitude."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.trim import trim

    rows = json.loads((Path(__file__).resolve().parents[1] / "results/aero/valid/optimized.json").read_text())["rows"]
    row = next(r for r in rows if r.get("label") == "fd_reached" and r["optimum"]["success"])
    o = row["optimum"]
    base = row["overrides"] | {"aero.section": "stall"} | o["free"] | {"solve.steps_per_period": steps}
    points, load0 = [], os.getloadavg()[0]
    for amps in ((o["amplitude_deg"],) + SCAN_DOWN, SCAN_UP):
        ws = None if not points else points[0]["_result"]
        for a in amps:
            cfg = with_values(Config(), base | {"gait.shoulder_flap.amplitude_deg": float(a)})
            tr, w, c = _timed(lambda: trim(cfg, x_guess=o["x0"] if ws is None else None, warm_start=ws,
                                           compiled=compiled))
            points.append({**_cycle(tr, w, c), "mean_forward_speed_mps": float(tr.mean_forward_speed_mps),
                           "_result": tr})
            ws = tr if tr.success else ws
    for p in points:
        p.pop("_result")
    points.sort(key=lambda p: p["amplitude_deg"])
    best = max((p for p in points if p["converged"]), key=lambda p: p["mean_vertical_speed_mps"])
    return {"gait": o["free"], "optimum_amplitude_deg": o["amplitude_deg"], "overrides": base, "points": points,
            "max_mean_vertical_speed_mps": best["mean_vertical_speed_mps"], "at_amplitude_deg": best["amplitude_deg"],
            "all_converged": all(p["converged"] for p in points), "load_average_start": load0,
            "load_average_end": os.getloadavg()[0]}


def scan_table(scan: dict) -> str:
    """The markdown table of :func:`optimum_stall_scan`."""
    lines = ["| amplitude [deg] | converged | mean vertical speed [m/s] | forward speed [m/s] | \\|Λ1\\| | valid |",
             "|---|---|---|---|---|---|"]
    for p in scan["points"]:
        lines.append(f"| {p['amplitude_deg']:.2f} | {'yes' if p['converged'] else 'NO'} "
                     f"| {p['mean_vertical_speed_mps']:.4f} | {p['mean_forward_speed_mps']:.3f} | {_f(p['lambda1'])} "
                     f"| {p['valid']} |")
    return "\n".join(lines) + "\n"


def level_solvers(steps: int, compiled: bool) -> dict:
    """Level flight by Newton-Picard and by IPOPT (second solves timed) for ``wagner`` (+ ``stall``)."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level
    from birdocp.studies.trim import trim

    rows = []
    for sec in ("linear", "stall"):
        cfg = with_values(Config(), {"aero.unsteady": "wagner", "aero.section": sec, "solve.steps_per_period": steps})
        tr = trim(cfg, compiled=compiled)
        timed = {}
        for solver in ("newton-picard", "ipopt") * 2:
            c = with_values(cfg, {"solve.solver": solver})
            timed[solver] = _timed(lambda: level(c, warm_start=tr, compiled=compiled))
        row = {"section": sec, "load_average": os.getloadavg()[0]}
        for solver, (lv, w, c) in timed.items():
            row[solver] = {**_cycle(lv, w, c), "solve_wall_s": lv.cycle.wall_s.get("solve")}
        row["cpu_ratio_ipopt_over_newton_picard"] = row["ipopt"]["cpu_s"] / row["newton-picard"]["cpu_s"]
        row["amplitude_difference_deg"] = abs(row["ipopt"]["amplitude_deg"] - row["newton-picard"]["amplitude_deg"])
        rows.append(row)
    return {"steps_per_period": steps, "rows": rows}


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/options_matrix")
    ap.add_argument("--steps", type=int, default=64, help="RK4 steps per period (default 64)")
    ap.add_argument("--unsteady", nargs="*", default=list(UNSTEADY), choices=UNSTEADY)
    ap.add_argument("--sections", nargs="*", default=list(SECTIONS), choices=SECTIONS)
    ap.add_argument("--branch-to", type=float, default=44.0, help="end of the amplitude continuation [deg]")
    ap.add_argument("--branch-points", type=int, default=4, help="points of the continuation (at most)")
    ap.add_argument("--optimum-scan", action="store_true",
                    help="instead of the matrix: wagner + stall trims over the amplitude at the wagner optimum's gait")
    ap.add_argument("--level-solvers", action="store_true",
                    help="instead of the matrix: level flight by Newton-Picard and by IPOPT, timed")
    args, out = parse_with_out(ap, argv)
    from birdocp.io.files import atomic_write_json, atomic_write_text

    if args.level_solvers:
        res = level_solvers(args.steps, args.compiled)
        atomic_write_json(out / "level_solvers.json", res)
        print(json.dumps(res, indent=1))
        return 0 if all(r[s]["converged"] for r in res["rows"] for s in ("ipopt", "newton-picard")) else 1

    if args.optimum_scan:
        scan = optimum_stall_scan(args.steps, args.compiled)
        atomic_write_json(out / "optimum_stall_scan.json", scan)
        atomic_write_text(out / "optimum_stall_scan.md", scan_table(scan))
        print(scan_table(scan))
        return 0 if scan["all_converged"] else 1
    (out / "cases").mkdir(exist_ok=True)
    rows = []
    for u in args.unsteady:
        for s in args.sections:
            path = out / "cases" / f"{u}_{s}.json"
            if path.exists():
                rows.append(json.loads(path.read_text()))
                continue
            print(f"{u} + {s} ...", flush=True)
            r = run_combination(u, s, args.steps, args.branch_to, args.branch_points, args.compiled)
            atomic_write_json(path, r)
            rows.append(r)
            print(f"  trim {r['trim']['converged']} level {r['level']['converged']} "
                  f"({r['level']['amplitude_deg']:.3f} deg) continuation {r['continuation']['converged']}", flush=True)
    atomic_write_json(out / "matrix.json", {"steps_per_period": args.steps, "compiled": bool(args.compiled),
                                            "rows": rows})
    atomic_write_text(out / "matrix.md", table(rows))
    print(table(rows))
    return 0 if all(r["all_converged"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
