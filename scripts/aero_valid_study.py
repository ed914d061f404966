"""Do the quasi-steady model's most stable valid gaits hold with unsteady and stall-aware aerodynamics?
(docs/model_unsteady.md, "The most stable valid gait with the full model")

The validity-constrained most stable gaits of the quasi-steady model (``results/stability_optimum/valid``:
speed free, and at 18.53 m/s) are trimmed again at their gait and amplitude with each aerodynamic
model -- today's, full ``wagner``, ``wagner`` + ``stall`` and (with ``--cases``) ``wagner`` +
``dynamic-stall`` -- starting from the optimum's body state (a stall section from the ``wagner`` cycle's
at the same gait): |Lambda1|, the next multipliers, the mean
vertical speed (the quasi-steady optimum is level; another model climbs or sinks at the same gait), the
largest |alpha_E|, the stalled and separated fractions and the validity of every cycle.

    python scripts/aero_valid_study.py --out results/aero/valid

Writes DIR/cases/<gait>_<case>.json as each case finishes (a rerun skips finished cases), then
DIR/table.json and DIR/table.md.

With ``--optimize``: the validity-constrained most stable level gait *optimised with the full model*
(``optimize_gait(objective="stability", valid=True)``, the reduced NLP over the full state, body +
aerodynamic; the radius constrained is the spectral radius of the full monodromy through its dominant
block) for each ``--gaits`` of :data:`PROBLEMS` (speed free, 18.53 m/s, tail opening + incidence free)
and each ``--cases`` model, started from the quasi-steady optimum's gait on ``--steps`` RK4 steps per
period (default 48: the wagner trim diverges at 32). Writes DIR/cases/opt_<gait>_<case>.json as each
finishes, then DIR/optimized.json and DIR/optimized.md (r*, KKT residual, validity, active limits).

The committed rows (``scripts/check_results.py``'s ``aero-valid-optimize-*`` entries run exactly these): the
SR1 stage of each problem from the quasi-steady optimum (three independent runs),

    python scripts/aero_valid_study.py --optimize --cases wagner --gaits at_speed --out results/aero/valid
    python scripts/aero_valid_study.py --optimize --cases wagner --gaits free_speed --out results/aero/valid
    python scripts/aero_valid_study.py --optimize --cases wagner --gaits tail --out results/aero/valid

then, converging them (docs/model_unsteady.md), the exact-Hessian stage from the point the SR1 row reached
(``--hessian fd --from-reached --label fd_reached``: its gait, amplitude and full state; ``--from-label``
names another row to start from, default the unlabelled one); ``--max-iter`` and ``--valid-rounds`` bound
the cost (iteration counts, never wall time: a run reproduces); ``--own-state`` re-trims each optimum
from its own state; ``--stall-at-optimum N`` trims ``wagner`` + ``stall`` at each optimum's gait (at most N
iterations) and then solves its level flight. The tail stage stops at 8 iterations, not converged:

    python scripts/aero_valid_study.py --optimize --cases wagner --gaits free_speed --hessian fd --from-reached \
        --valid-rounds 2 --own-state --stall-at-optimum 30 --label fd_reached --max-iter 40 --out results/aero/valid
    python scripts/aero_valid_study.py --optimize --cases wagner --gaits tail --hessian fd --from-reached \
        --valid-rounds 2 --own-state --stall-at-optimum 30 --label fd_reached --max-iter 8 --out results/aero/valid

Not committed: the tail optimum on 96 steps (at its 18 m/s the lag's fast pole nears RK4's limit on 48
steps: |Lambda1| 1.016 on 48 against 0.958 on 96 at an earlier point), from the point the exact-Hessian
run on 48 steps reached:

    python scripts/aero_valid_study.py --optimize --gaits tail --cases wagner --hessian fd --steps 96 \
        --from-reached --from-label fd_reached --max-iter 30 --valid-rounds 2 --own-state --label fd96 \
        --out results/aero/valid
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from aero_study import _summary  # noqa: E402
from script_common import parse_with_out, script_parser  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OPTIMA = ROOT / "results" / "stability_optimum" / "valid" / "result.json"
CASES = {
    "today": {},
    "wagner": {"aero.unsteady": "wagner"},
    "wagner_stall": {"aero.unsteady": "wagner", "aero.section": "stall"},
    "wagner_dynamic_stall": {"aero.unsteady": "wagner", "aero.section": "dynamic-stall"},
}
"""Configuration overrides of each aerodynamic model."""
GAITS = ("free_speed", "at_speed")
TAIL_OPTIMUM = ROOT / "results" / "tail" / "optimum_valid.json"
PROBLEMS = {"free_speed": {"speed_mps": None, "tail": False}, "at_speed": {"speed_mps": 18.53, "tail": False},
            "tail": {"speed_mps": None, "tail": True}}
"""The optimisation problems of ``--optimize``: the speed held (None: free) and whether the tail is
open (its opening angle and incidence free, as scripts/tail_study.py)."""


def quasi_steady_optimum(gait: str) -> dict:
    """The committed quasi-steady validity-constrained optimum of a problem of :data:`PROBLEMS`."""
    if PROBLEMS[gait]["tail"]:
        d = json.loads(TAIL_OPTIMUM.read_text())
        return d | {"bounds": d["free_bounds"]}
    return json.loads(OPTIMA.read_text())[gait]


def optimize_case(gait: str, name: str, steps: int, max_iter: int, run: dict | None = None) -> dict:
    """The most stable valid level gait of problem ``gait`` with model ``name``, from the quasi-steady
    optimum (its gait, amplitude and body state) or, with ``run["reached"]`` (a committed ``--optimize``
    row), from that row's point (gait, amplitude and full state); ``run`` also holds the ``hessian``,
    ``threads`` and ``valid_rounds``. The optimum's summary."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.gait import optimize_gait

    run = run or {}
    qs = quasi_steady_optimum(gait)
    tail = {"tail.enabled": True} if PROBLEMS[gait]["tail"] else {}
    cfg = with_values(Config(), tail | CASES[name])
    free = {k: tuple(v) for k, v in qs["bounds"].items()}
    reached = (run.get("reached") or {}).get("optimum")
    start, x_guess = (gait_values(reached), reached["x0"]) if reached else (gait_values(qs), qs["x0"][:4])
    t0 = time.perf_counter()
    o = optimize_gait(cfg, free, objective="stability", speed_mps=PROBLEMS[gait]["speed_mps"], valid=True,
                      steps_per_period=steps, start=start, x_guess=x_guess, max_iter=max_iter,
                      hessian=run.get("hessian", "sr1"), threads=int(run.get("threads", 2)),
                      valid_rounds=run.get("valid_rounds"), progress=bool(run.get("progress")))
    d = json.loads(json.dumps(o.to_dict(), default=str))
    keep = ("success", "status", "message", "iterations", "objective_value", "largest_modulus", "free",
            "amplitude_deg", "multipliers", "kkt_residual", "constraint_violation", "validity",
            "validity_constraints", "mean_forward_speed_mps", "verification", "wall_s", "x0", "validity_rounds",
            "ipopt_multipliers")
    return {"gait": gait, "case": name, "steps_per_period": steps, "quasi_steady_radius": qs.get("radius"),
            "label": run.get("label", ""), "hessian": run.get("hessian", "sr1"), "max_iter": max_iter,
            "start": f"point reached by {run.get('reached_file')}" if reached else "quasi-steady optimum",
            "overrides": tail | CASES[name], "optimum": {k: d.get(k) for k in keep},
            "active_limits": [k for k, c in (d.get("validity_constraints") or {}).items() if c.get("active")],
            "active_bounds": [k for k, v in (d.get("free") or {}).items()
                              if min(abs(v - free[k][0]), abs(v - free[k][1])) < 1e-4],
            "wall_s": time.perf_counter() - t0}


def fine_grid_trim(row: dict) -> dict:
    """Level flight at the optimum's gait on the configured grid (148 steps per period; the amplitude
    solved, from the optimum's state): how far the optimiser's grid moves |Lambda1|."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level

    o = row["optimum"]
    cfg = with_values(Config(), row["overrides"] | o["free"] | {"gait.shoulder_flap.amplitude_deg": o["amplitude_deg"]})
    lv = level(cfg, x_guess=o["x0"])
    ok = bool(lv.success)
    return {"steps_per_period": cfg.solve.steps_per_period, "success": ok,
            "lambda1": float(abs(lv.multipliers[0])) if ok else None,
            "amplitude_deg": float(lv.amplitude_deg) if ok else None,
            "mean_forward_speed_mps": float(lv.mean_forward_speed_mps) if ok else None,
            "valid": bool(lv.validity.valid) if ok else None}


def own_state_trim(row: dict) -> dict:
    """A trim (5-point multiple shooting, the optimiser's grid) at the optimum's gait and amplitude from
    the optimum's own full state: the optimiser's verification starts from the *start* gait's cycle and,
    next to a fold of cycles, can find the other cycle of the same gait; this one checks the optimum's."""
    import numpy as np

    from birdocp.bird.config import Config, with_values
    from birdocp.studies.trim import trim

    o = row["optimum"]
    cfg = with_values(Config(), row["overrides"] | o["free"] | {"gait.shoulder_flap.amplitude_deg": o["amplitude_deg"]})
    tr = trim(cfg, x_guess=o["x0"], points=5, steps_per_period=row["steps_per_period"])
    if not tr.success:
        return {"success": False, "status": str(getattr(tr, "status", ""))}
    lam = np.array([complex(*z) for z in o["multipliers"]])
    return {"success": True, "x0_difference": float(np.max(np.abs(np.asarray(tr.x0) - np.asarray(o["x0"])))),
            "mean_vertical_speed_mps": float(tr.mean_vertical_speed_mps),
            "max_multiplier_difference": float(np.max(np.abs(np.sort_complex(tr.multipliers) - np.sort_complex(lam)))),
            "lambda1": float(abs(tr.multipliers[0]))}


def stall_at_optimum(row: dict, max_iter: int) -> dict:
    """``wagner`` + ``stall`` trimmed at a ``wagner`` optimum's gait and amplitude (148 steps), from the
    optimum's full state, at most ``max_iter`` IPOPT iterations: does the stall section keep it stable?"""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.trim import trim

    o = row["optimum"]
    over = row["overrides"] | CASES["wagner_stall"]
    cfg = with_values(Config(), over | o["free"] | {"gait.shoulder_flap.amplitude_deg": o["amplitude_deg"]})
    t0 = time.perf_counter()
    tr = trim(cfg, x_guess=o["x0"], max_iter=max_iter)
    return {"overrides": over, "max_iter": max_iter, "trim": _summary(tr), "trim_wall_s": time.perf_counter() - t0}


def stall_level_at_optimum(row: dict) -> dict:
    """Level flight with ``wagner`` + ``stall`` at a ``wagner`` optimum's gait (148 steps; the flapping
    amplitude solved, from the body state of :func:`stall_at_optimum`'s cycle)."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level

    o, st = row["optimum"], row["stall_at_optimum"]
    cfg = with_values(Config(), st["overrides"] | o["free"] | {"gait.shoulder_flap.amplitude_deg": o["amplitude_deg"]})
    t0 = time.perf_counter()
    lv = level(cfg, x_guess=st["trim"]["x0_body"])
    ok = bool(lv.success)
    v = lv.validity.to_dict() if ok else {}
    return {"success": ok, "status": str(getattr(lv, "status", "")), "wall_s": time.perf_counter() - t0,
            "lambda1": float(abs(lv.multipliers[0])) if ok else None,
            "amplitude_deg": float(lv.amplitude_deg) if ok else None,
            "mean_forward_speed_mps": float(lv.mean_forward_speed_mps) if ok else None,
            "valid": v.get("valid"), "reasons": v.get("reasons"), "stalled_fraction": v.get("stalled_fraction"),
            "separated_fraction": v.get("separated_fraction")}


def stall_table(rows: list[dict]) -> str:
    """Markdown lines of the ``stall_at_optimum`` results of the rows that have one."""
    lines = ["", "With `wagner` + `stall` at the gait and amplitude of a `wagner` optimum (148 steps, from its state):",
             "", "| problem | optimum | status | residual | \\|Λ1\\| | next multipliers | mean W (m/s) | "
             "max \\|α_E\\| (deg) | stalled / separated | valid |", "|" + "---|" * 10]
    for r in rows:
        t = (r.get("stall_at_optimum") or {}).get("trim")
        if not t:
            continue
        ok = t.get("success")
        nxt = ", ".join(f"{abs(complex(*z)):.4f}" for z in (t.get("multipliers") or [])[1:4])
        lines.append(f"| {r['gait']} | {_label(r)} | {t.get('status')} | {_f(t.get('max_residual'), '{:.1e}')} | "
                     f"{_f(t.get('lambda1'))} | {nxt or '—'} | {_f(t.get('mean_vertical_speed_mps'), '{:+.3f}')} | "
                     f"{_f(t.get('max_abs_alpha_E_deg'), '{:.1f}')} | {_f(t.get('stalled_fraction'), '{:.3f}')} / "
                     f"{_f(t.get('separated_fraction'), '{:.3f}')} | {t.get('valid') if ok else 'not converged'} |")
    for r in rows:
        lv = r.get("stall_level_at_optimum")
        if lv:
            lines.append(f"\nLevel flight there ({r['gait']}, {_label(r)}; amplitude solved): "
                         + (f"|Λ1| {lv['lambda1']:.4f}, amplitude {lv['amplitude_deg']:.2f} deg, "
                            f"{lv['mean_forward_speed_mps']:.2f} m/s, stalled / separated "
                            f"{_f(lv.get('stalled_fraction'), '{:.3f}')} / {_f(lv.get('separated_fraction'), '{:.3f}')}, "
                            f"valid {lv['valid']}{' (' + '; '.join(lv['reasons']) + ')' if lv.get('reasons') else ''}."
                            if lv["success"] else f"not converged ({lv['status']})."))
    return "\n".join(lines) + "\n" if len(lines) > 5 else ""


def _capped(r: dict) -> bool:
    """Whether a row's optimiser stopped at its iteration cap: the row is then an iterate of the
    optimiser's path, not an optimum (scripts/result_compare.py compares it by its statements)."""
    return r["optimum"].get("status") == "Maximum_Iterations_Exceeded"


def _label(r: dict) -> str:
    """A row's label, marked when it is an iterate at its iteration cap (:func:`_capped`)."""
    return (r.get("label") or "—") + (", an iterate at its iteration cap" if _capped(r) else "")


def _active(r: dict) -> str:
    """The active validity limits and the free keys at a bound of an optimum (two cells); an iterate at
    its iteration cap has no active set."""
    if _capped(r):
        return "— (not an optimum) | — (not an optimum)"
    return (f"{', '.join(r['active_limits']) or '—'} | "
            f"{', '.join(k.split('.', 1)[1] for k in r['active_bounds']) or '—'}")


def optimized_table(rows: list[dict]) -> str:
    """Markdown table of the ``--optimize`` rows."""
    lines = ["| problem | model | start; Hessian; iterations | steps | status | r / \\|Λ1\\| (quasi-steady r*) | "
             "\\|Λ5\\| | KKT | valid | active limits | free keys at a bound | "
             "re-trim \\|ΔΛ\\| (from the start's cycle; own state) | "
             "level on 148 steps: \\|Λ1\\| (U m/s) |", "|" + "---|" * 13]
    for r in rows:
        o = r["optimum"]
        lam = sorted((abs(complex(*z)) for z in (o.get("multipliers") or [])), reverse=True)
        v = (o.get("verification") or {}).get("max_multiplier_difference")
        fine = r.get("fine_grid_trim") or {}
        own = r.get("own_state_trim") or {}
        run = (f"{'point reached' if r.get('start', '').startswith('point') else 'quasi-steady optimum'}; "
               f"{'exact (FD)' if r.get('hessian') == 'fd' else 'SR1'}; {o.get('iterations')}")
        lines.append(f"| {r['gait']} | {r['case']} | {run} | {r['steps_per_period']} | {o.get('status')} | "
                     f"{_f(o.get('objective_value'))} / {_f(o.get('largest_modulus'))} ({_f(r.get('quasi_steady_radius'))}) | "
                     f"{_f(lam[4] if len(lam) > 4 else None)} | {_f(o.get('kkt_residual'), '{:.1e}')} | "
                     f"{(o.get('validity') or {}).get('valid')} | {_active(r)} | {_f(v, '{:.1e}')}; "
                     f"{_f(own.get('max_multiplier_difference'), '{:.1e}')} | "
                     f"{_f(fine.get('lambda1'))} ({_f(fine.get('mean_forward_speed_mps'), '{:.2f}')}) |")
    return "\n".join(lines) + "\n"


def optimize_all(args, out: Path) -> int:
    """``--optimize``: every (problem, model) not yet in DIR/cases, then the table."""
    from birdocp.io.files import atomic_write_json, atomic_write_text

    suffix = f"_{args.label}" if args.label else ""
    for gait in args.gaits:
        for name in args.cases:
            path = out / "cases" / f"opt_{gait}_{name}{suffix}.json"
            if not path.exists():
                run = {"label": args.label, "hessian": args.hessian, "threads": args.threads,
                       "valid_rounds": args.valid_rounds, "progress": args.progress}
                if args.from_reached:
                    run["reached_file"] = f"opt_{gait}_{name}{'_' + args.from_label if args.from_label else ''}.json"
                    run["reached"] = json.loads((out / "cases" / run["reached_file"]).read_text())
                print(f"optimize {gait} {name}{suffix} ...", flush=True)
                atomic_write_json(path, optimize_case(gait, name, args.steps, args.max_iter, run))
            row = json.loads(path.read_text())
            if "fine_grid_trim" not in row and row["optimum"].get("x0"):
                row["fine_grid_trim"] = fine_grid_trim(row)
                atomic_write_json(path, row)
            if "own_state_trim" not in row and row["optimum"].get("x0") and args.own_state:
                row["own_state_trim"] = own_state_trim(row)
                atomic_write_json(path, row)
            if "stall_at_optimum" not in row and row["optimum"].get("x0") and args.stall_at_optimum:
                print(f"wagner + stall at {path.name} ...", flush=True)
                row["stall_at_optimum"] = stall_at_optimum(row, args.stall_at_optimum)
                atomic_write_json(path, row)
            if "stall_level_at_optimum" not in row and (row.get("stall_at_optimum") or {}).get("trim", {}).get("success") \
                    and args.stall_at_optimum:
                print(f"wagner + stall level flight at {path.name} ...", flush=True)
                row["stall_level_at_optimum"] = stall_level_at_optimum(row)
                atomic_write_json(path, row)
    rows = [json.loads(p.read_text()) for p in sorted((out / "cases").glob("opt_*.json"))]
    atomic_write_json(out / "optimized.json", {"rows": rows})
    atomic_write_text(out / "optimized.md", optimized_table(rows) + stall_table(rows))
    print(optimized_table(rows) + stall_table(rows))
    return 0


def gait_values(optimum: dict) -> dict:
    """The configuration values of a committed optimum: its free gait keys and its amplitude."""
    return dict(optimum["free"]) | {"gait.shoulder_flap.amplitude_deg": optimum["amplitude_deg"]}


def run_case(gait: str, optimum: dict, name: str, x_guess=None) -> dict:
    """Trim of one model at one optimum's gait, from ``x_guess`` (default the optimum's body state)."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), gait_values(optimum) | CASES[name])
    t0 = time.perf_counter()
    tr = trim(cfg, x_guess=optimum["x0"] if x_guess is None else x_guess)
    return {"gait": gait, "case": name, "values": gait_values(optimum), "overrides": CASES[name],
            "quasi_steady_radius": optimum.get("radius"), "trim": _summary(tr),
            "trim_wall_s": time.perf_counter() - t0}


def _f(v, f="{:.4f}"):
    return "—" if v is None else f.format(v)


def _not_converged(t: dict) -> str:
    """A failed trim's status, residual and largest multiplier at the solver's last point."""
    lam = f"; \\|Λ1\\| {t['lambda1']:.7f} at the last point" if t.get("lambda1") is not None else ""
    return f"not converged: {t.get('status')} (residual {_f(t.get('max_residual'), '{:.1e}')}{lam})"


def table(rows: list[dict]) -> str:
    lines = ["| gait | model | \\|Λ1\\| | next multipliers | stable | mean W (m/s) | max \\|α_E\\| (deg) | "
             "stalled / separated | valid | reasons |", "|" + "---|" * 10]
    for r in rows:
        t = r["trim"]
        ok = t.get("success")
        nxt = ", ".join(f"{abs(complex(*z)):.4f}" for z in (t.get("multipliers") or [])[1:4]) if ok else "—"
        lam = t.get("lambda1") if ok else None
        v = t.get("validity") or {}
        lines.append(f"| {r['gait']} | {r['case']} | {_f(lam)} | {nxt} | "
                     f"{'—' if lam is None else ('yes' if lam < 1 else 'no')} | "
                     f"{_f(t.get('mean_vertical_speed_mps') if ok else None, '{:+.3f}')} | "
                     f"{_f(t.get('max_abs_alpha_E_deg') if ok else None, '{:.1f}')} | "
                     f"{_f(t.get('stalled_fraction') if ok else None, '{:.3f}')} / "
                     f"{_f(t.get('separated_fraction') if ok else None, '{:.3f}')} | "
                     f"{t.get('valid') if ok else _not_converged(t)} | "
                     f"{'; '.join(v.get('reasons') or []) or '—'} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/valid")
    ap.add_argument("--cases", nargs="*", default=["today", "wagner", "wagner_stall"],
                    help=f"aerodynamic models (default today wagner wagner_stall; also {', '.join(CASES)})")
    ap.add_argument("--gaits", nargs="*", default=list(GAITS),
                    help="optima to evaluate (default free_speed at_speed; with --optimize also tail)")
    ap.add_argument("--optimize", action="store_true", help="optimise with the full model (see the module)")
    ap.add_argument("--steps", type=int, default=48, help="RK4 steps per period of --optimize (default 48)")
    ap.add_argument("--max-iter", type=int, default=60, help="IPOPT iterations per solve of --optimize")
    ap.add_argument("--hessian", choices=("sr1", "fd"), default="sr1",
                    help="second derivatives of --optimize (optimize_gait's hessian; default sr1)")
    ap.add_argument("--threads", type=int, default=2, help="perturbed points at a time with --hessian fd")
    ap.add_argument("--from-reached", action="store_true",
                    help="--optimize starts from the point of DIR/cases/opt_<gait>_<case>.json (gait, amplitude, "
                         "full state) instead of the quasi-steady optimum")
    ap.add_argument("--from-label", default="", help="--from-reached starts from DIR/cases/opt_<gait>_<case>_<label>.json")
    ap.add_argument("--valid-rounds", type=int, default=None, help="validity rounds of --optimize at most")
    ap.add_argument("--own-state", action="store_true",
                    help="--optimize also re-trims each optimum from its own state (own_state_trim)")
    ap.add_argument("--stall-at-optimum", type=int, default=0, metavar="MAX_ITER",
                    help="--optimize also trims wagner + stall at each optimum's gait (at most MAX_ITER iterations)")
    ap.add_argument("--progress", action="store_true", help="IPOPT's iteration log on stderr (--optimize)")
    ap.add_argument("--label", default="", help="--optimize writes DIR/cases/opt_<gait>_<case>_<label>.json")
    args, out = parse_with_out(ap, argv)
    from birdocp.io.files import atomic_write_json, atomic_write_text

    (out / "cases").mkdir(exist_ok=True)
    if args.optimize:
        return optimize_all(args, out)
    optima = json.loads(OPTIMA.read_text())
    rows = []
    for gait in args.gaits:
        for name in args.cases:
            path = out / "cases" / f"{gait}_{name}.json"
            if path.exists():
                rows.append(json.loads(path.read_text()))
                continue
            print(f"{gait} {name} ...", flush=True)
            start = out / "cases" / f"{gait}_wagner.json"
            guess = None
            if "section" in str(CASES[name]) and start.exists():
                # a stall section starts from the linear-section wagner cycle at the same gait (from the
                # quasi-steady optimum's state IPOPT's trial points reach a singular Newton circulation)
                t = json.loads(start.read_text())["trim"]
                guess = t["x0_body"] if t.get("success") else None
            r = run_case(gait, optima[gait], name, guess)
            atomic_write_json(path, r)
            rows.append(r)
            print(f"  |Lambda1| {r['trim'].get('lambda1')}, valid {r['trim'].get('valid')} "
                  f"({r['trim_wall_s']:.0f} s)", flush=True)
    atomic_write_json(out / "table.json", {"rows": rows, "optima": str(OPTIMA.relative_to(ROOT))})
    atomic_write_text(out / "table.md", table(rows))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
