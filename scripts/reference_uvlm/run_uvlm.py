"""Reference loads of the flapping ibis wing from PteraSoftware's unsteady vortex-lattice method.

Run in PteraSoftware's OWN environment (never birdocp's; this script imports no birdocp)::

    /work/venvs/ptera/bin/python scripts/reference_uvlm/run_uvlm.py \
        [--inputs results/aero/uvlm/inputs.json] [--out results/aero/uvlm] \
        [--chordwise 4] [--spanwise 12] [--cycles 4] [--cases gait,k0.17,k0.25] [--free-wake]

It reads ``inputs.json`` (written by ``make_inputs.py`` from birdocp) and, per case, builds:

* the wing: both half wings as one symmetric PteraSoftware ``Wing`` (x aft, y right, z up; origin at
  the centre of mass G), a flat body strip from the centre line to the shoulder (root chord) and
  ``--spanwise`` uniform strips from the shoulder to 98 % of the tip (the planform's tip chord is 0),
  ``--chordwise`` uniform chordwise panels, a flat camber line (NACA 0012's);
* the motion: the shoulder cross section rotates about the chordwise axis through the shoulder
  (flapping, positive tip up), ``offset + A sin(2 pi f t + phase)``, the shoulder flap law of the
  gait; the outer wing follows rigidly;
* the body held: free stream = the held airspeed, angle of attack = the body's (atan2(w, u)) + the
  gait's mean shoulder incidence (birdocp's incidence rotation is the outermost of the shoulder's, so
  its flapping axis turns with it: the same as flapping about the wing's own chordwise axis);
* the wake: PteraSoftware's prescribed wake (shed rows convected with the free stream) by default,
  ``--free-wake`` for the free wake; truncated after ``--wake-cycles`` cycles (default 2);
* ``--steady``: only the wing held at flap angle 0 in the same flight (the steady ring-vortex VLM),
  written to ``OUT/steady/``: the steady part of the comparison.

Per case it writes ``OUT/runs/<case>_c<nc>_s<ns>_<wake>_n<cycles>_w<wake cycles>.json`` (skipped when present, so an interrupted
sweep resumes) with the lift (perpendicular to the free stream, up) and thrust (along the flight
direction) at every step [N], the cycle means of the last cycle and of the one before, the phase of the
lift peak within the wingbeat (deg, 0 = the beat's start, flap angle at its offset going down), the CPU
time (process time of the solve, JIT compilation excluded by a warm-up run) and the panel counts; and
``OUT/uvlm.json`` with every run found.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cycle_phase import peak_phase_deg  # this folder: numpy only, shared with compare.py

TIP_TRIM = 0.02
"""Fraction of the shoulder-to-tip span dropped at the tip (the planform's tip chord is 0)."""
WAKE_CYCLES = 2
"""Wake rows kept by default, in cycles (older rows are dropped; ``--wake-cycles``)."""


def write_json(path: Path, obj) -> None:
    """Write ``obj`` as JSON atomically (temporary file in the same folder, then rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump(obj, fh, indent=1)
    os.replace(tmp, path)


def stations(inputs: dict, n_span: int) -> dict:
    """Spanwise stations of the half wing (centre line, shoulder, ``n_span`` strips to the tip).

    Returns ``y_m`` (from the centre line), ``x_le_m`` (aft, from G) and ``chord_m`` arrays."""
    w = inputs["wing"]
    le, te = w["edges"]["leading_edge"], w["edges"]["trailing_edge"]
    tip = min(le["span_m"][-1], te["span_m"][-1])
    s = np.linspace(0.0, (1.0 - TIP_TRIM) * tip, n_span + 1)
    x_le = np.interp(s, le["span_m"], le["aft_m"])
    x_te = np.interp(s, te["span_m"], te["aft_m"])
    sep = w["shoulder_half_separation_m"]
    y = np.concatenate([[0.0], sep + s])
    chord = x_te - x_le
    return {"y_m": y, "x_le_m": np.concatenate([[x_le[0]], x_le]) - w["root_ahead_m"],
            "chord_m": np.concatenate([[chord[0]], chord])}


def build_airplane(ps, inputs: dict, n_chord: int, n_span: int):
    """The wing at flap angle ``flap_offset_deg``: (Airplane, its WingCrossSections, the stations)."""
    st = stations(inputs, n_span)
    w = inputs["wing"]
    wcs = []
    for i in range(len(st["y_m"])):
        tip = i == len(st["y_m"]) - 1
        lp = (0.0, 0.0, 0.0) if i == 0 else (st["x_le_m"][i] - st["x_le_m"][i - 1], st["y_m"][i] - st["y_m"][i - 1], 0.0)
        angles = (w["flap_offset_deg"], 0.0, 0.0) if i == 1 else (0.0, 0.0, 0.0)
        wcs.append(ps.geometry.wing_cross_section.WingCrossSection(
            airfoil=ps.geometry.airfoil.Airfoil(name="naca0012"), num_spanwise_panels=None if tip else 1,
            chord=float(st["chord_m"][i]), Lp_Wcsp_Lpp=lp, angles_Wcsp_to_Wcs_ixyz=angles,
            control_surface_symmetry_type="symmetric", spanwise_spacing=None if tip else "uniform"))
    wing = ps.geometry.wing.Wing(wing_cross_sections=wcs, name="ibis wing", Ler_Gs_Cgs=(st["x_le_m"][0], 0.0, 0.0),
                                 symmetric=True, symmetryNormal_G=(0.0, 1.0, 0.0), symmetryPoint_G_Cg=(0.0, 0.0, 0.0),
                                 num_chordwise_panels=n_chord, chordwise_spacing="uniform")
    return ps.geometry.airplane.Airplane(wings=[wing], name="ibis"), wcs, st


def operating_point(ps, inputs: dict):
    """The held flight: free stream at the held airspeed, angle of attack = body's + mean incidence."""
    trim = inputs["trim"]
    alpha = trim["body_alpha_deg"] + inputs["wing"]["incidence_deg"]
    return ps.operating_point.OperatingPoint(rho=inputs["air_density_kgm3"], vCg__E=trim["airspeed_mps"],
                                             alpha=alpha, beta=0.0)


def build_problem(ps, inputs: dict, case: dict, n_chord: int, n_span: int, cycles: int,
                  wake_cycles: int = WAKE_CYCLES):
    """The PteraSoftware UnsteadyProblem of one case; also the run's settings (a dict)."""
    airplane, wcs, st = build_airplane(ps, inputs, n_chord, n_span)
    w = inputs["wing"]
    period = 1.0 / case["frequency_hz"]
    moves = [ps.movements.wing_cross_section_movement.WingCrossSectionMovement(base_wing_cross_section=c) for c in wcs]
    moves[1] = ps.movements.wing_cross_section_movement.WingCrossSectionMovement(
        base_wing_cross_section=wcs[1], ampAngles_Wcsp_to_Wcs_ixyz=(w["flap_amplitude_deg"], 0.0, 0.0),
        periodAngles_Wcsp_to_Wcs_ixyz=(period, 0.0, 0.0), phaseAngles_Wcsp_to_Wcs_ixyz=(w["flap_phase_deg"], 0.0, 0.0))
    wing_move = ps.movements.wing_movement.WingMovement(base_wing=airplane.wings[0], wing_cross_section_movements=moves)
    plane_move = ps.movements.airplane_movement.AirplaneMovement(base_airplane=airplane, wing_movements=[wing_move])
    op = operating_point(ps, inputs)
    op_move = ps.movements.operating_point_movement.OperatingPointMovement(base_operating_point=op)
    speed = inputs["trim"]["airspeed_mps"]
    # time step: wake rows about as long as the bound trailing-edge panels (mean chord / n_chord)
    half_area = float(np.sum(np.diff(st["y_m"]) * 0.5 * (st["chord_m"][1:] + st["chord_m"][:-1])))
    mean_chord = half_area / st["y_m"][-1]
    steps_per_cycle = max(40, math.ceil(period * speed * n_chord / mean_chord))
    movement = ps.movements.movement.Movement(
        airplane_movements=[plane_move], operating_point_movement=op_move, delta_time=period / steps_per_cycle,
        num_steps=cycles * steps_per_cycle, max_wake_cycles=wake_cycles)
    problem = ps.problems.UnsteadyProblem(movement=movement, only_final_results=False)
    settings = {"steps_per_cycle": steps_per_cycle, "delta_time_s": period / steps_per_cycle,
                "alpha_deg": op.alpha, "airspeed_mps": speed, "mean_chord_m": mean_chord,
                "planform_area_m2": 2.0 * half_area, "span_m": 2.0 * float(st["y_m"][-1]),
                "stations": {k: v.tolist() for k, v in st.items()}}
    return problem, settings


def run_steady(ps, inputs: dict, n_chord: int, n_span: int) -> dict:
    """The wing held at flap angle 0 (no flapping): PteraSoftware's steady ring-vortex VLM."""
    airplane, _, _ = build_airplane(ps, inputs, n_chord, n_span)
    problem = ps.problems.SteadyProblem(airplanes=[airplane], operating_point=operating_point(ps, inputs))
    solver = ps.steady_ring_vortex_lattice_method.SteadyRingVortexLatticeMethodSolver(steady_problem=problem)
    t0 = time.process_time()
    solver.run(calculate_streamlines=False)
    forces = np.asarray(problem.airplanes[0].forces_W, float)
    return {"case": {"name": "steady", "frequency_hz": 0.0, "k": 0.0}, "chordwise_panels": n_chord,
            "spanwise_panels_per_half_wing": n_span + 1, "lift_N": float(-forces[2]), "thrust_N": float(forces[0]),
            "cpu_s": time.process_time() - t0, "solver": "steady ring vortex lattice",
            "pterasoftware_version": ps_version()}


def run_case(ps, inputs: dict, case: dict, n_chord: int, n_span: int, cycles: int, free_wake: bool,
             wake_cycles: int) -> dict:
    """Solve one case and measure it (see the module docstring)."""
    problem, settings = build_problem(ps, inputs, case, n_chord, n_span, cycles, wake_cycles)
    solver = ps.unsteady_ring_vortex_lattice_method.UnsteadyRingVortexLatticeMethodSolver(unsteady_problem=problem)
    t0, w0 = time.process_time(), time.perf_counter()
    solver.run(prescribed_wake=not free_wake, calculate_streamlines=False, show_progress=False)
    cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    forces = np.array([sp.airplanes[0].forces_W for sp in solver.steady_problems])  # wind axes
    lift, thrust = -forces[:, 2], forces[:, 0]
    n = settings["steps_per_cycle"]
    last, before = slice((cycles - 1) * n, cycles * n), slice((cycles - 2) * n, (cycles - 1) * n)
    wing = solver.steady_problems[n // 4].airplanes[0].wings[0]
    centres = np.array([p.Cpp_G_Cg for p in wing.panels.ravel()])
    tip_z_quarter = float(centres[np.argmax(centres[:, 1]), 2])
    means = {
        "mean_lift_N": float(np.mean(lift[last])), "mean_thrust_N": float(np.mean(thrust[last])),
        "mean_lift_previous_cycle_N": float(np.mean(lift[before])),
        "mean_thrust_previous_cycle_N": float(np.mean(thrust[before])),
    }
    means["mean_lift_change_last_two_cycles_N"] = means["mean_lift_N"] - means["mean_lift_previous_cycle_N"]
    means["mean_thrust_change_last_two_cycles_N"] = means["mean_thrust_N"] - means["mean_thrust_previous_cycle_N"]
    return {
        "case": case, "chordwise_panels": n_chord, "spanwise_panels_per_half_wing": n_span + 1,
        "panels": int(wing.num_panels), "wake": "free" if free_wake else "prescribed", "cycles": cycles,
        "wake_cycles_kept": wake_cycles, **settings, **means,
        "lift_peak_phase_deg": peak_phase_deg(lift[last]),
        "max_lift_N": float(np.max(lift[last])), "min_lift_N": float(np.min(lift[last])),
        "cpu_s": cpu, "wall_s": wall, "cpu_s_per_cycle": cpu / cycles,
        "tip_height_at_quarter_period_m": tip_z_quarter,
        "last_cycle": {"phase_deg": (np.arange(n) / n * 360.0).tolist(), "lift_N": lift[last].tolist(),
                       "thrust_N": thrust[last].tolist()},
        "pterasoftware_version": ps_version(),
    }


def ps_version() -> str:
    from importlib.metadata import version

    return version("pterasoftware")


def warm_up(ps, inputs: dict) -> None:
    """A tiny run so that numba's compilation is not counted in the timed runs."""
    case = dict(inputs["cases"][0])
    problem, _ = build_problem(ps, inputs, case, 2, 3, 1)
    ps.unsteady_ring_vortex_lattice_method.UnsteadyRingVortexLatticeMethodSolver(unsteady_problem=problem).run(
        prescribed_wake=True, calculate_streamlines=False, show_progress=False)


def collect(out: Path) -> None:
    """``OUT/uvlm.json``: every run of ``OUT/runs`` without its histories, plus the histories."""
    runs = [json.loads(p.read_text()) for p in sorted((out / "runs").glob("*.json"))]
    steady = [json.loads(p.read_text()) for p in sorted((out / "steady").glob("*.json"))]
    write_json(out / "uvlm.json", {"runs": runs, "steady": steady})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--inputs", default="results/aero/uvlm/inputs.json")
    ap.add_argument("--out", default="results/aero/uvlm")
    ap.add_argument("--chordwise", type=int, default=4)
    ap.add_argument("--spanwise", type=int, default=12, help="strips from the shoulder to the tip (one wing)")
    ap.add_argument("--cycles", type=int, default=4)
    ap.add_argument("--cases", default=None, help="comma-separated case names (default: all of inputs.json)")
    ap.add_argument("--free-wake", action="store_true")
    ap.add_argument("--wake-cycles", type=int, default=WAKE_CYCLES, help="wake kept, in cycles")
    ap.add_argument("--steady", action="store_true", help="only the wing held at flap angle 0 (steady VLM)")
    args = ap.parse_args(argv)
    if args.cycles < 2 or args.chordwise < 1 or args.spanwise < 2 or args.wake_cycles < 1:
        print("run_uvlm: --cycles must be >= 2, --chordwise >= 1, --spanwise >= 2, --wake-cycles >= 1", file=sys.stderr)
        return 2
    inputs_path = Path(args.inputs)
    if not inputs_path.is_file():
        print(f"run_uvlm: --inputs {inputs_path} not found; write it with make_inputs.py", file=sys.stderr)
        return 2
    inputs = json.loads(inputs_path.read_text())
    cases = inputs["cases"]
    if args.cases:
        names = args.cases.split(",")
        unknown = sorted(set(names) - {c["name"] for c in cases})
        if unknown:
            print(f"run_uvlm: --cases: unknown {unknown}; known {[c['name'] for c in cases]}", file=sys.stderr)
            return 2
        cases = [c for c in cases if c["name"] in names]
    import pterasoftware as ps

    out = Path(args.out)
    if args.steady:
        res = run_steady(ps, inputs, args.chordwise, args.spanwise)
        write_json(out / "steady" / f"steady_c{args.chordwise}_s{args.spanwise}.json", res)
        print(f"steady: lift {res['lift_N']:.3f} N, thrust {res['thrust_N']:.4f} N")
        collect(out)
        return 0
    warmed = False
    for case in cases:
        wake = "free" if args.free_wake else "prescribed"
        path = out / "runs" / (f"{case['name']}_c{args.chordwise}_s{args.spanwise}_{wake}"
                               f"_n{args.cycles}_w{args.wake_cycles}.json")
        if path.is_file():
            print(f"{path.name}: present, skipped")
            continue
        if not warmed:
            warm_up(ps, inputs)
            warmed = True
        res = run_case(ps, inputs, case, args.chordwise, args.spanwise, args.cycles, args.free_wake, args.wake_cycles)
        write_json(path, res)
        print(f"{path.name}: k = {case['k']:.3f}, mean lift {res['mean_lift_N']:.3f} N "
              f"(change {res['mean_lift_change_last_two_cycles_N']:+.2e}), mean thrust {res['mean_thrust_N']:.3f} N, "
              f"lift peak at {res['lift_peak_phase_deg']:.1f} deg, {res['cpu_s_per_cycle']:.1f} s CPU per cycle, "
              f"{res['panels']} panels", flush=True)
    collect(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
