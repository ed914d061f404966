"""The paper's appendix comparison, on the reference case with the reference implementation's model
(variant (b): relaxed circulation, backward-difference kinematic velocity; M = 5, 148 RK4 steps):

  * LM with exact CasADi sensitivities of the segment flows (solver="lm", derivatives="exact");
  * LM with forward-difference Jacobians as in the paper (derivatives="fd", relative step 1e-3);
  * IPOPT (exact first derivatives, limited-memory Hessian) to its default tol 1e-10, and to 1e-5.

Each method is run twice from the same initial guess: the first ("cold") run includes building its
CasADi Functions (the shared RK4 graphs are built before, by a warm-up trim), the second ("warm") run
is the one timed per iteration. The multipliers the engine reports always come from exact segment
Jacobians at the converged points, so their differences show only where each method stopped; the
table also gives the multipliers of the *forward-difference* monodromy at the LM-fd result (what a
finite-difference implementation such as the paper's reports).

Writes jacobians.json, jacobians.md and the appendix figures convergence.png (max residual per
iteration of each method and of the reference implementation) and multipliers.png (the multipliers in
the complex plane with zooms) to --out.

    python scripts/appendix_jacobians.py --out results/appendix
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from birdocp.engine.floquet import matched_distances, monodromy_of, sort_multipliers
from birdocp.bird.config import Config, with_values
from birdocp.engine.integrate import RK4Grid
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.bird.model import get_model
from birdocp.studies.trim import trim
from birdocp.io.reference import load as load_reference
from birdocp.io.reference import multipliers as reference_multipliers
from script_common import parse_with_out, script_parser

RELAXED = {"aero.circulation": "relaxed", "aero.kinematic_velocity": "backward-difference"}
METHODS = {
    "lm_exact": ("LM, exact CasADi Jacobians", {"solver": "lm", "derivatives": "exact"}),
    "lm_fd": ("LM, forward-difference Jacobians (paper)", {"solver": "lm", "derivatives": "fd"}),
    "ipopt": ("IPOPT, tol 1e-10 (default)", {"solver": "ipopt"}),
    "ipopt_1e-5": ("IPOPT, tol 1e-5", {"solver": "ipopt", "tol": 1e-5}),
}


def matched_max(a, b) -> float:
    return float(np.max(matched_distances(a, b)))


def fd_monodromy(cfg, shooting_points, steps=148, points=5, floor=1e-3) -> np.ndarray:
    """Monodromy as the product of the forward-difference segment Jacobians of the engine's
    ``derivatives="fd"`` (:meth:`birdocp.engine.integrate.RK4Grid.fd_segment_jacobians`)."""
    m = get_model(cfg)
    grid = RK4Grid(m.ode, steps, points - 1)
    X = np.asarray(shooting_points, float)[: points - 1].T
    Js, _ = grid.fd_segment_jacobians(X, grid.blocks_numeric(0.0, m.p0), m.p0, floor)
    return monodromy_of(list(Js))


def pairs(lam):
    return [[float(z.real), float(z.imag)] for z in lam]


def fmt(lam) -> str:
    out = []
    for z in lam:
        if abs(z.imag) < 5e-7:
            out.append(f"{z.real:.5f}")
        elif z.imag > 0:
            out.append(f"{z.real:.5f} ± {z.imag:.5f}j")
    return ", ".join(out)


def figures(doc: dict, reference_history, out: Path) -> None:
    """The paper's appendix figure, as two PNGs: convergence and multipliers of the Jacobian methods."""
    from birdocp.plots import figures as plots

    m = doc["methods"]
    hist = {m[k]["label"]: m[k]["residual_history"] for k in ("lm_exact", "lm_fd", "ipopt")}
    hist["reference implementation (paper's code, LM with FD Jacobians)"] = reference_history
    plots.plot_convergence(hist, out / "convergence.png", tol=1e-5, tol_label="LM tolerance max|E| < 1e-5",
                           title="Appendix: convergence with exact (CasADi) and finite-difference Jacobians")
    f = doc["fd_monodromy_at_lm_fd_result"]
    mults = {m["lm_exact"]["label"]: m["lm_exact"]["multipliers"],
             m["lm_fd"]["label"] + ", exact monodromy": m["lm_fd"]["multipliers"],
             "LM-fd result, forward-difference monodromy": f["multipliers"]}
    rf = doc["reference"]
    plots.plot_multipliers(mults, out / "multipliers.png",
                           reference={"reference implementation (FD)": rf["reference_implementation_multipliers"],
                                      "reference RK4 period-map monodromy": rf["rk4_period_map_monodromy_multipliers"]},
                           title="Appendix: multipliers by Jacobian method")


def main(argv=None) -> int:
    args, out = parse_with_out(script_parser(__doc__, "results/appendix"), argv)
    t_start = time.perf_counter()
    ref = load_reference("reference_cycle")
    rk4 = ref["rk4_period_map_monodromy_central_differences"]
    ref_rk4 = reference_multipliers(rk4)
    impl = ref["reference_implementation"]
    ref_impl = reference_multipliers(impl)

    cfg = with_values(Config(), RELAXED)
    tw = time.perf_counter()
    trim(cfg, solver="lm", derivatives="fd", max_iter=0)  # model + shared RK4/shooting graphs only
    warmup_s = time.perf_counter() - tw
    print(f"warm-up (model + shared graphs): {warmup_s:.2f} s", flush=True)

    rows, objs = {}, {}
    for key, (label, over) in METHODS.items():
        runs = []
        for rep in ("cold", "warm"):
            r = trim(cfg, **over)
            runs.append(r)
            print(f"{label} [{rep}]: {r.status}, {r.iterations} it, solve {r.wall_s['solve']:.2f} s, "
                  f"total {r.wall_s['total']:.2f} s", flush=True)
        cold, warm = runs
        objs[key] = warm
        lam = sort_multipliers(warm.multipliers)
        it = max(int(warm.iterations), 1)
        rows[key] = {
            "label": label, "method": dict(warm.method), "success": bool(warm.success), "status": warm.status,
            "iterations": int(warm.iterations), "max_residual": float(warm.max_residual),
            "residual_history": [float(v) for v in np.asarray(warm.residual_history).ravel()],
            "solve_s": float(warm.wall_s["solve"]), "total_s": float(warm.wall_s["total"]),
            "time_per_iteration_s": float(warm.wall_s["solve"]) / it,
            "cold_solve_s": float(cold.wall_s["solve"]), "cold_total_s": float(cold.wall_s["total"]),
            "floquet_s": float(warm.wall_s["floquet"]),
            "x0": [float(v) for v in warm.x0],
            "multipliers": pairs(lam),
            "moduli": [float(abs(z)) for z in lam],
            "distance_to_reference_rk4_monodromy": matched_max(lam, ref_rk4),
        }
    base = sort_multipliers(objs["lm_exact"].multipliers)
    for key, row in rows.items():
        row["multiplier_difference_to_lm_exact"] = matched_max(sort_multipliers(objs[key].multipliers), base)
        row["x0_difference_to_lm_exact"] = float(np.max(np.abs(objs[key].x0 - objs["lm_exact"].x0)))

    tf = time.perf_counter()
    Mfd = fd_monodromy(cfg, objs["lm_fd"].shooting_points)
    lam_fd = sort_multipliers(np.linalg.eigvals(Mfd))
    fd_mono = {
        "description": "monodromy = product of forward-difference segment Jacobians (relative step 1e-3) "
                       "at the LM-fd shooting points; what a finite-difference implementation reports",
        "multipliers": pairs(lam_fd),
        "difference_to_exact_monodromy_same_points": matched_max(lam_fd, sort_multipliers(objs["lm_fd"].multipliers)),
        "distance_to_reference_rk4_monodromy": matched_max(lam_fd, ref_rk4),
        "distance_to_reference_implementation_multipliers": matched_max(lam_fd, ref_impl),
        "wall_s": time.perf_counter() - tf,
    }
    ex = rows["lm_exact"]["time_per_iteration_s"]
    doc = {
        "case": "reference case A = 42 deg, d = 0.05 m; relaxed circulation (39 evaluations), "
                "backward-difference kinematic velocity; M = 5, 148 RK4 steps; guess (18, 0.5, 0.1, 0.01)",
        "warmup_s": warmup_s,
        "methods": rows,
        "fd_monodromy_at_lm_fd_result": fd_mono,
        "speedup_per_iteration_exact_vs_fd": rows["lm_fd"]["time_per_iteration_s"] / ex,
        "reference": {"rk4_period_map_monodromy_multipliers": pairs(ref_rk4),
                      "reference_implementation_multipliers": pairs(ref_impl),
                      "reference_implementation_iterations": impl["iterations"],
                      "reference_implementation_s_per_iteration": 206.0,
                      "paper_s_per_iteration": 40.0},
        "wall_s_script": time.perf_counter() - t_start,
    }
    atomic_write_json(out / "jacobians.json", doc)
    figures(doc, impl["error_history"], out)
    md = table_md(doc)
    atomic_write_text(out / "jacobians.md", md)
    print(md)
    return 0


def table_md(doc) -> str:
    L = ["# Appendix: exact vs finite-difference Jacobians (reference case, variant (b) model)", "",
         doc["case"] + ". Times: warm runs (CasADi Functions already built); *cold* = the method's "
         "first run, which includes building its solver/Jacobian Functions. Multipliers from exact "
         "segment Jacobians at each converged orbit; Δ = largest matched difference.", "",
         "| method | iterations | final max\\|E\\| | time / iteration [s] | solve [s] | total [s] | cold total [s] "
         "| multipliers | Δ to LM exact | Δ to RK4 ref | max \\|Δx0\\| to LM exact |",
         "|---|---|---|---|---|---|---|---|---|---|---|"]
    for k, r in doc["methods"].items():
        L.append(f"| {r['label']} | {r['iterations']} | {r['max_residual']:.1e} | {r['time_per_iteration_s']:.3f} "
                 f"| {r['solve_s']:.2f} | {r['total_s']:.2f} | {r['cold_total_s']:.2f} "
                 f"| {fmt([complex(*p) for p in r['multipliers']])} | {r['multiplier_difference_to_lm_exact']:.1e} "
                 f"| {r['distance_to_reference_rk4_monodromy']:.1e} | {r['x0_difference_to_lm_exact']:.1e} |")
    f = doc["fd_monodromy_at_lm_fd_result"]
    rf = doc["reference"]
    L.append(f"| forward-difference monodromy at the LM-fd orbit | | | | | | "
             f"| {fmt([complex(*p) for p in f['multipliers']])} | {f['difference_to_exact_monodromy_same_points']:.1e} "
             f"(vs exact, same points) | {f['distance_to_reference_rk4_monodromy']:.1e} | |")
    L.append(f"| reference implementation (paper's code: FD Jacobians) | {rf['reference_implementation_iterations']} "
             f"| | ~{rf['reference_implementation_s_per_iteration']:.0f} (paper: {rf['paper_s_per_iteration']:.0f}) | | | "
             f"| {fmt([complex(*p) for p in rf['reference_implementation_multipliers']])} | | "
             f"{matched_max([complex(*p) for p in rf['reference_implementation_multipliers']], [complex(*p) for p in rf['rk4_period_map_monodromy_multipliers']]):.1e} | |")
    impl_d = matched_max([complex(*p) for p in rf["reference_implementation_multipliers"]],
                         [complex(*p) for p in rf["rk4_period_map_monodromy_multipliers"]])
    L += ["", f"Per iteration, LM with forward differences takes "
              f"{doc['speedup_per_iteration_exact_vs_fd']:.2f}x the time of LM with exact Jacobians "
              f"(here the per-time model data are precomputed once per solve, so a forward difference costs "
              f"only 4 extra RK4 sweeps of the small state right-hand side). All methods converge to the "
              f"same orbit within their tolerances. The forward-difference monodromy at the same orbit "
              f"differs from the exact one by {f['difference_to_exact_monodromy_same_points']:.1e}; the "
              f"reference implementation's multipliers (its own FD Jacobians) differ from the RK4 "
              f"period-map reference by {impl_d:.1e}.",
          "", f"Warm-up (model + shared graphs): {doc['warmup_s']:.1f} s; script wall time "
              f"{doc['wall_s_script']:.1f} s.", ""]
    return "\n".join(L)


if __name__ == "__main__":
    raise SystemExit(main())
