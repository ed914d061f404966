"""Is there a stable, valid, level tailless gait with ``wagner`` + ``stall``? (docs/model_unsteady.md,
"The most stable valid gait with the full model")

The validity-constrained most stable level gait (speed free, no tail; ``optimize_gait(objective=
"stability", valid=True)``) optimised with ``aero.unsteady = "wagner"`` and ``aero.section = "stall"``
(:func:`aero_valid_study.optimize_case`, by import). It cannot start at the converged ``wagner``
optimum (``results/aero/valid/cases/opt_free_speed_wagner_fd_reached.json``): with the stall section
that gait has no level flight at any amplitude (``results/aero/options_matrix/optimum_stall_scan.md``)
and the reduced problem needs a level cycle at its start. So a first stage (``scan``) walks the
straight segment of gaits from that optimum (s = 0) to the paper's reference gait (s = 1), solving
level flight with ``wagner`` + ``stall`` at each s (``--steps`` RK4 steps per period, from s = 1 down
to 0 by ``--scan-step``, each from the last level cycle; the first from the ``wagner`` optimum's full
state and amplitude) until level flight is lost; the optimiser starts from the level cycle nearest
the ``wagner`` optimum (its gait, amplitude and full state).

    python scripts/aero_stall_optimum.py --max-iter 6 --label explore6 --out results/aero/stall_optimum
    python scripts/aero_stall_optimum.py --from-label explore6 --max-iter 10 --label fd16 \
        --out results/aero/stall_optimum

Writes DIR/scan.json, then DIR/cases/opt_<label>.json per optimisation (a rerun skips finished
stages), the 148-step level flight at each optimum's gait, and DIR/result.json and DIR/result.md.
``--max-iter`` and ``--hessian`` as in aero_valid_study.py (iteration counts bound a run, never wall
time); ``--from-label L`` starts from the point the run labelled L reached instead of the scan.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from aero_valid_study import CASES, _f, fine_grid_trim, optimize_case, optimized_table  # noqa: E402
from script_common import parse_with_out, script_parser  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
WAGNER_OPTIMUM = ROOT / "results" / "aero" / "valid" / "cases" / "opt_free_speed_wagner_fd_reached.json"
"""The converged validity-constrained most stable level gait with ``wagner`` (speed free)."""
REFERENCE_GAIT = {"gait.shoulder_incidence.offset_deg": 11.459155902616466,
                  "gait.shoulder_incidence.amplitude_deg": 0.8021409131831525,
                  "gait.shoulder_sweep.offset_deg": -19.0, "gait.shoulder_sweep.amplitude_deg": 20.0}
"""The paper's reference gait (the configuration's defaults of the four free keys), the scan's s = 1."""


def scan_point(s: float, steps: int, amplitude_deg: float, x_guess) -> dict:
    """Level flight with ``wagner`` + ``stall`` at the gait s of the segment (the flapping amplitude
    solved from ``amplitude_deg``, the state from ``x_guess``): its gait, amplitude, full state x0,
    |Lambda1|, speed and validity."""
    from birdocp.bird.config import Config, with_values
    from birdocp.studies.level import level

    o = json.loads(WAGNER_OPTIMUM.read_text())["optimum"]
    gait = {k: o["free"][k] + s * (REFERENCE_GAIT[k] - o["free"][k]) for k in REFERENCE_GAIT}
    cfg = with_values(Config(), CASES["wagner_stall"] | gait | {"gait.shoulder_flap.amplitude_deg": amplitude_deg})
    t0 = time.perf_counter()
    lv = level(cfg, x_guess=x_guess, steps_per_period=steps)
    row = {"s": s, "free": gait, "success": bool(lv.success), "status": str(lv.status),
           "max_residual": float(lv.max_residual), "wall_s": time.perf_counter() - t0}
    if lv.success:
        v = lv.validity.to_dict()
        row |= {"amplitude_deg": float(lv.amplitude_deg), "x0": [float(x) for x in lv.x0],
                "lambda1": float(abs(lv.multipliers[0])), "mean_forward_speed_mps": float(lv.mean_forward_speed_mps),
                "valid": bool(v["valid"]), "reasons": v["reasons"], "stalled_fraction": v["stalled_fraction"],
                "separated_fraction": v.get("separated_fraction"), "max_abs_alpha_E_deg":
                    max(abs(v["alpha_eff_min_deg"]), abs(v["alpha_eff_max_deg"]))}
    return row


def scan(steps: int, step: float) -> dict:
    """Level flight along the segment from s = 1 down to 0 (continuation; stops at the first failure)."""
    o = json.loads(WAGNER_OPTIMUM.read_text())["optimum"]
    amp, x, rows = o["amplitude_deg"], o["x0"], []
    n = round(1.0 / step)
    for i in range(n, -1, -1):
        r = scan_point(i / n, steps, amp, x)
        rows.append(r)
        print(f"  s {r['s']:.3f}: " + (f"level, amplitude {r['amplitude_deg']:.3f} deg, |Lambda1| {r['lambda1']:.4f}, "
                                       f"valid {r['valid']}" if r["success"] else f"no level cycle ({r['status']})"),
              flush=True)
        if not r["success"]:
            break
        amp, x = r["amplitude_deg"], r["x0"]
    return {"steps_per_period": steps, "wagner_optimum": str(WAGNER_OPTIMUM.relative_to(ROOT)), "rows": rows}


def scan_table(sc: dict) -> str:
    """Markdown table of the scan."""
    lines = [f"Level flight with `wagner` + `stall` along the gait segment from the `wagner` optimum (s = 0) to the "
             f"reference gait (s = 1), {sc['steps_per_period']} steps:", "",
             "| s | level | amplitude (deg) | \\|Λ1\\| | U (m/s) | max \\|α_E\\| (deg) | stalled / separated | valid |",
             "|" + "---|" * 8]
    for r in sc["rows"]:
        ok = r["success"]
        lines.append(f"| {r['s']:.2f} | {'yes' if ok else 'no: ' + r['status']} | {_f(r.get('amplitude_deg'), '{:.2f}')} | "
                     f"{_f(r.get('lambda1'))} | {_f(r.get('mean_forward_speed_mps'), '{:.2f}')} | "
                     f"{_f(r.get('max_abs_alpha_E_deg'), '{:.1f}')} | {_f(r.get('stalled_fraction'), '{:.3f}')} / "
                     f"{_f(r.get('separated_fraction'), '{:.3f}')} | {r.get('valid') if ok else '—'} |")
    return "\n".join(lines) + "\n"


def scan_start(sc: dict) -> dict:
    """The optimiser's start: the level cycle of the scan nearest the ``wagner`` optimum (smallest s)."""
    r = min((r for r in sc["rows"] if r["success"]), key=lambda r: r["s"])
    return {"reached_file": f"scan.json s={r['s']:.3f}",
            "reached": {"optimum": {"free": r["free"], "amplitude_deg": r["amplitude_deg"], "x0": r["x0"]}}}


def fractions_table(rows: list[dict]) -> str:
    """Markdown lines: each optimum's speed, amplitude, stalled and separated fractions and validity."""
    lines = ["", "| run | r / \\|Λ1\\| | amplitude (deg) | U (m/s) | max \\|α_E\\| (deg) | stalled / separated | valid | "
                 "reasons |", "|" + "---|" * 8]
    for r in rows:
        o = r["optimum"]
        v = o.get("validity") or {}
        lines.append(f"| {r['label']} | {_f(o.get('objective_value'))} / {_f(o.get('largest_modulus'))} | "
                     f"{_f(o.get('amplitude_deg'), '{:.2f}')} | {_f(o.get('mean_forward_speed_mps'), '{:.2f}')} | "
                     f"{_f(max(abs(v.get('alpha_eff_min_deg', 0)), abs(v.get('alpha_eff_max_deg', 0))) if v else None, '{:.1f}')} | "
                     f"{_f(v.get('stalled_fraction'), '{:.3f}')} / {_f(v.get('separated_fraction'), '{:.3f}')} | "
                     f"{v.get('valid')} | {'; '.join(v.get('reasons') or []) or '—'} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/stall_optimum")
    ap.add_argument("--steps", type=int, default=48, help="RK4 steps per period of the scan and the optimiser (default 48)")
    ap.add_argument("--scan-step", type=float, default=0.1, help="step in s of the scan (default 0.1)")
    ap.add_argument("--max-iter", type=int, default=40, help="IPOPT iterations per solve (default 40)")
    ap.add_argument("--hessian", choices=("sr1", "fd"), default="fd", help="second derivatives (default fd)")
    ap.add_argument("--threads", type=int, default=2, help="perturbed points at a time with --hessian fd")
    ap.add_argument("--valid-rounds", type=int, default=2, help="validity rounds at most (default 2)")
    ap.add_argument("--from-label", default=None,
                    help="start from the point of DIR/cases/opt_<label>.json instead of the scan's")
    ap.add_argument("--label", default="scan_start", help="writes DIR/cases/opt_<label>.json (default scan_start)")
    ap.add_argument("--progress", action="store_true", help="IPOPT's iteration log on stderr")
    args = ap.parse_args(argv)  # checked before parse_with_out creates the folder: bad input writes nothing
    for name, v in (("--steps", args.steps), ("--max-iter", args.max_iter), ("--valid-rounds", args.valid_rounds)):
        if v < 1:
            ap.exit(2, f"{name} must be a positive integer, got {v}\n")
    if not 0 < args.scan_step <= 1:
        ap.exit(2, f"--scan-step must be in (0, 1], got {args.scan_step}\n")
    if args.from_label is not None and not (Path(args.out) / "cases" / f"opt_{args.from_label}.json").exists():
        ap.exit(2, f"--from-label: no {Path(args.out) / 'cases' / f'opt_{args.from_label}.json'}; "
                   "give a finished run's label\n")
    args, out = parse_with_out(ap, argv)
    from birdocp.io.files import atomic_write_json, atomic_write_text

    (out / "cases").mkdir(exist_ok=True)
    if not (out / "scan.json").exists():
        print("scan ...", flush=True)
        atomic_write_json(out / "scan.json", scan(args.steps, args.scan_step))
    sc = json.loads((out / "scan.json").read_text())
    path = out / "cases" / f"opt_{args.label}.json"
    if not path.exists():
        if args.from_label is not None:
            f = f"opt_{args.from_label}.json"
            run = {"reached_file": f, "reached": json.loads((out / "cases" / f).read_text())}
        else:
            run = scan_start(sc)
        run |= {"label": args.label, "hessian": args.hessian, "threads": args.threads,
                "valid_rounds": args.valid_rounds, "progress": args.progress}
        print(f"optimize from {run['reached_file']} ...", flush=True)
        atomic_write_json(path, optimize_case("free_speed", "wagner_stall", args.steps, args.max_iter, run))
    row = json.loads(path.read_text())
    if "fine_grid_trim" not in row and row["optimum"].get("x0"):
        row["fine_grid_trim"] = fine_grid_trim(row)
        atomic_write_json(path, row)
    rows = [json.loads(p.read_text()) for p in sorted((out / "cases").glob("opt_*.json"))]
    atomic_write_json(out / "result.json", {"scan": sc, "rows": rows})
    md = scan_table(sc) + "\n" + optimized_table(rows) + fractions_table(rows)
    atomic_write_text(out / "result.md", md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
