"""Cost of the unsteady and stall-aware aerodynamics, as ratios measured in one run.

1. A trim of the paper's gait (5 points, 148 steps) with ``aero.unsteady = "wagner"`` and with
   ``wagner`` + ``dynamic-stall`` (the default ``solve.solver = "auto"``: Newton-Picard, for the trim
   with the monodromy chord, ``OrbitMethod.chord``; each row's ``message`` says which; the rows
   ``<case>_full_newton``: IPOPT on the full state, and ``newton_picard_vs_full_newton`` the largest
   differences of x0 and of the multipliers between the two), against the default trim: wall time of the solve with the graphs
   already built (each case is trimmed twice, the second time is measured), and the size of the state
   right-hand side and of one RK4 step of the variational equations (the state and its Jacobian: what
   the shooting evaluates 148 times per iterate; CasADi instructions). Targets: wagner <= 4x,
   dynamic-stall <= 6x. ``--compiled`` adds the same trims with ``compiled=True`` (separate rows
   ``<case>_compiled``; ``ratios_compiled``: each against the compiled default; ``libraries``: the C
   libraries of the first solve, their generate/compile seconds and whether the cache had them; the
   first solve's wall time ``first_wall_s`` includes the builds; ``ratios_compiled_to_default``: each
   against the interpreted default). A variational step over ``MAX_INSTRUCTIONS`` (stall sections) is
   compiled as its piece ``rhs_tangent`` (the right-hand side with its nx tangents). The CPU time of
   the process (``cpu_s``, ``ratios_cpu``) is recorded too: on a loaded machine it is the steadier
   measure; ``load_average_start`` the 1, 5, 15 min load averages when the run started.
2. How the cost grows with the number of lifting-line elements n: instructions and evaluation time of
   the section model's right-hand side and of its Jacobian along the aerodynamic states (2n or 3n:
   the sensitivities), on the prescribed-kinematics wing of n elements (the same functions as the
   bird), for n = 8, 16, 32.

    python scripts/benchmark_aero.py --out results/aero

Writes DIR/benchmark.json and prints a table.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from script_common import parse_with_out, script_parser  # noqa: E402

CASES = {"default": {}, "wagner": {"aero.unsteady": "wagner"}, "wagner_stall": {"aero.unsteady": "wagner",
                                                                                 "aero.section": "stall"},
         "wagner_dynamic_stall": {"aero.unsteady": "wagner", "aero.section": "dynamic-stall"}}
CASES.update({f"{k}_full_newton": {**v, "solve.solver": "ipopt"} for k, v in list(CASES.items()) if k != "default"})
"""The cases: ``solve.solver = "auto"`` (Newton-Picard for the models with aerodynamic states) and, as
``<case>_full_newton``, the same trims by IPOPT on the full state (the solver before Newton-Picard)."""
TARGETS = {"wagner": 4.0, "wagner_dynamic_stall": 6.0}


def trim_cost(overrides: dict, repeats: int = 2, x_guess=None, compiled: bool = False) -> dict:
    from birdocp.bird.config import Config, with_values
    from birdocp.bird.model import get_model
    from birdocp.bird.model import N_EL
    from birdocp.bird.stall_section import expanded_instructions
    from birdocp.engine.integrate import RK4Grid
    from birdocp.studies.trim import trim

    cfg = with_values(Config(), overrides)
    m = get_model(cfg)
    from birdocp.export import compiled as comp

    walls, cpus, builds = [], [], {}
    for _ in range(repeats):
        comp.last_compile_s.clear()
        t0, c0 = time.perf_counter(), time.process_time()
        r = trim(cfg, x_guess=x_guess, compiled=compiled)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
        builds = builds or {k: {"generate_s": v["generate"], "compile_s": v["compile"], "cached": v["cached"]}
                            for k, v in comp.last_compile_s.items()}
    grid = RK4Grid(m.ode, cfg.solve.steps_per_period, cfg.solve.points - 1)
    s = m.structure

    def count(f, evaluations):  # the detached Newton iterates counted as the instructions they run
        return expanded_instructions(f, s.section, N_EL, s.newton_steps, evaluations)

    return {"wall_s": walls[-1], "cpu_s": cpus[-1], "first_wall_s": walls[0], "success": bool(r.success),
            "wall_parts_s": {k: float(v) for k, v in r.wall_s.items()}, "iterations": int(r.iterations),
            "rhs_instructions": count(m.rhs, 1), "states": int(m.ode.nx),
            "variational_step_instructions": count(grid.variational_step(), 4),
            "lambda1": float(abs(r.multipliers[0])) if r.success else None, "solver": r.cycle.method["solver"],
            "message": r.cycle.message,
            "x0": [float(v) for v in r.x0], "multipliers": [[float(v.real), float(v.imag)] for v in r.multipliers]
            if r.multipliers is not None else None,
            **({"libraries": builds} if compiled else {})}


def element_scaling(unsteady: str, section: str, n: int, evals: int = 200) -> dict:
    import casadi as ca
    import numpy as np

    from birdocp.bird.stall_section import expanded_instructions
    from birdocp.bird.unsteady_harness import PrescribedWing, harmonic

    w = PrescribedWing(unsteady, section, aspect_ratio=6.9, n=n)
    kin, om, T = harmonic(0.14, 18.0, 0.2, plunge_m=0.05, pitch_rad=0.1, mean_pitch_rad=0.1)
    t0 = time.perf_counter()
    f, _ = w.functions(kin)
    build = time.perf_counter() - t0
    z = np.zeros(w.nz)
    if section == "dynamic-stall":
        z[-n:] = 1.0
    zs, ts_ = ca.SX.sym("z", w.nz), ca.SX.sym("t")
    t0 = time.perf_counter()
    jac = ca.Function("section_jacobian", [zs, ts_], [ca.jacobian(f(zs, ts_), zs)])
    build_jac = time.perf_counter() - t0
    Z = ca.repmat(ca.DM(z), 1, evals)
    ts = ca.DM(np.linspace(0, T, evals)).T
    ns = w.opts["newton_steps"]
    out = {"n": n, "states": int(w.nz), "instructions": expanded_instructions(f, section, n, ns),
           "jacobian_instructions": expanded_instructions(jac, section, n, ns), "build_s": build, "jacobian_build_s": build_jac}
    for key, fn in (("eval_us", f), ("jacobian_eval_us", jac)):
        fm = fn.map(evals)
        fm(Z, ts)
        t0 = time.perf_counter()
        fm(Z, ts)
        out[key] = 1e6 * (time.perf_counter() - t0) / evals
    return out


def _agreement(rows: dict) -> dict:
    """Max |x0 difference| and max |multiplier difference| (matched) of each Newton-Picard trim against
    the same trim by the full Newton (``<case>_full_newton``)."""
    import numpy as np

    from birdocp.engine.floquet import matched_distances

    out = {}
    for k, full in rows.items():
        mine = rows.get(k.replace("_full_newton", ""))
        if not k.endswith("_full_newton") or mine is None or not (mine["multipliers"] and full["multipliers"]):
            continue
        lam = [complex(*v) for v in mine["multipliers"]]
        ref = [complex(*v) for v in full["multipliers"]]
        out[k.replace("_full_newton", "")] = {
            "x0_max_abs_diff": float(np.max(np.abs(np.subtract(mine["x0"], full["x0"])))),
            "multipliers_max_abs_diff": float(np.max(matched_distances(lam, ref)))}
    return out


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero")
    ap.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES),
                    help="trim cases (default all; 'default' is always run: it is the denominator)")
    ap.add_argument("--max-elements", type=int, default=32, help="largest n of the element scaling (8, 16, 32, ...)")
    args, out = parse_with_out(ap, argv)  # --compiled (script_parser): also the trims with compiled=True
    from birdocp.io.files import atomic_write_json

    cases = ["default"] + [c for c in args.cases if c != "default"]
    # every case starts from the same body state: the wagner cycle's of the aero study when present (the
    # stall sections' Newton circulation can be singular at the trial points of a far guess)
    start = out / "cases" / "wagner.json"
    guess = json.loads(start.read_text())["trim"]["x0_body"] if start.exists() else None
    res = {"load_average_start": list(os.getloadavg()), "cpu_count": os.cpu_count()}
    res.update({"trim": {k: trim_cost(CASES[k], x_guess=guess) for k in cases}, "x_guess": guess})
    if args.compiled:
        res["trim"].update({f"{k}_compiled": trim_cost(CASES[k], x_guess=guess, compiled=True) for k in cases})
    base = res["trim"]["default"]["wall_s"]
    res["ratios"] = {k: v["wall_s"] / base for k, v in res["trim"].items()}
    res["ratios_cpu"] = {k: v["cpu_s"] / res["trim"]["default"]["cpu_s"] for k, v in res["trim"].items()}
    if args.compiled:  # both sides compiled: the compiled trims against the compiled default
        cbase = res["trim"]["default_compiled"]["wall_s"]
        res["ratios_compiled"] = {k: v["wall_s"] / cbase for k, v in res["trim"].items() if k.endswith("_compiled")}
        res["ratios_compiled_to_default"] = {k: v["wall_s"] / base for k, v in res["trim"].items()
                                             if k.endswith("_compiled")}
    res["targets"] = TARGETS
    res["newton_picard_vs_full_newton"] = _agreement(res["trim"])
    res["elements"] = {f"{u}+{s}": [element_scaling(u, s, n) for n in (8, 16, 32, 64) if n <= args.max_elements]
                       for u, s in (("wagner", "linear"), ("wagner", "stall"),
                                    ("wagner", "dynamic-stall"))}
    atomic_write_json(out / "benchmark.json", res)
    print(f"trim of the paper's gait (graphs built; second solve timed); load average at the start "
          f"{res['load_average_start'][0]:.2f} on {res['cpu_count']} cores")
    for k, v in res["trim"].items():
        tgt = TARGETS.get(k)
        print(f"  {k:22s} {v['wall_s']:7.2f} s  x{res['ratios'][k]:5.2f} (CPU x{res['ratios_cpu'][k]:5.2f})"
              + (f" (target <= {tgt:g}x)" if tgt else "") + f"  states {v['states']}, rhs {v['rhs_instructions']}, "
              f"variational step {v['variational_step_instructions']} instr., {v['iterations']} iterations ({v['solver']})")
    for k, v in res["newton_picard_vs_full_newton"].items():
        print(f"  {k}: Newton-Picard against the full Newton: max |dx0| {v['x0_max_abs_diff']:.1e}, "
              f"max |dmultiplier| {v['multipliers_max_abs_diff']:.1e}")
    for k, v in res.get("ratios_compiled", {}).items():
        print(f"  {k:22s} x{v:5.2f} of default_compiled; first solve {res['trim'][k]['first_wall_s']:.1f} s, "
              f"builds {res['trim'][k]['libraries']}")
    print("section right-hand side / its state Jacobian against the number of elements n (instructions, us per evaluation)")
    for k, rows in res["elements"].items():
        print(f"  {k:22s} " + "  ".join(f"n={r['n']}: {r['instructions']} / {r['eval_us']:.0f}, "
                                        f"{r['jacobian_instructions']} / {r['jacobian_eval_us']:.0f}" for r in rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
