"""birdocp beside the UVLM: cycle-mean lift and thrust, lift-peak phase and CPU time per cycle.

Run in the birdocp environment, after ``make_inputs.py`` and ``run_uvlm.py``::

    python scripts/reference_uvlm/compare.py [--unsteady none|wagner] [--out results/aero/uvlm]

For every case of ``OUT/inputs.json`` (a flapping frequency; the body held at the trim state: the
cycle means of u and w, q = 0) it evaluates birdocp's loads over one wingbeat for two kinematics:

* ``rigid``: the UVLM's kinematics (``inputs.json`` ``rigid_gait``: every joint frozen at the
  reference gait's mid-downstroke, the shoulder flap law of the gait, incidence at its mean);
* ``gait``: the reference gait itself (elbow and wrist folding, hand twist, sweep) at that frequency.

``--unsteady none`` is the quasi-steady lifting line. ``--unsteady wagner`` needs a birdocp with the
``aero.unsteady`` option; its lag states are integrated with the body held (RK4, the configuration's
steps per period, ``--lag-cycles`` wingbeats from zero) and the loads read on the last wingbeat.

Lift is the force perpendicular to the held air velocity (up), thrust the force along the flight
direction (body frame x' forward, z' down: V = (u, w), thrust = (Fx u + Fz w)/|V|, lift =
(Fx w - Fz u)/|V|). The CPU time per cycle is the process time of evaluating the model over one
wingbeat at the RK4 stage times of one trim period (4 x ``solve.steps_per_period``), not a solve.

Writes ``OUT/result.json`` (the numbers of every model run so far are kept: a ``wagner`` run adds
its column), ``OUT/table.md`` and ``OUT/lift_over_wingbeat.png``.
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from script_common import parse_with_out, script_parser  # noqa: E402

from cycle_phase import peak_phase_deg  # noqa: E402  (this folder: numpy only, shared with run_uvlm.py)

from birdocp.bird.config import Aero, from_dict, with_values  # noqa: E402
from birdocp.bird.model import get_model  # noqa: E402
from birdocp.io.files import atomic_write_json, atomic_write_text  # noqa: E402

MODEL_KEYS = {"none": "quasi_steady", "wagner": "wagner"}


def unsteady_supported() -> bool:
    """Whether this birdocp has the ``aero.unsteady`` option."""
    return "unsteady" in getattr(Aero, "__dataclass_fields__", {})


def case_config(inputs: dict, case: dict, kinematics: str, unsteady: str):
    """The birdocp configuration of one case: ``inputs.json``'s configuration at the case's frequency,
    with the rigid joint laws for ``kinematics == "rigid"`` and ``aero.unsteady`` when asked."""
    values = {"gait.frequency_hz": float(case["frequency_hz"])}
    if kinematics == "rigid":
        values.update(inputs["rigid_gait"])
    if unsteady != "none":
        values["aero.unsteady"] = unsteady
    return with_values(from_dict(inputs["config"]), values)


def _rk4_lag_states(m, x_body: np.ndarray, p, period_s: float, steps: int, cycles: int) -> tuple[np.ndarray, np.ndarray]:
    """Integrate the aerodynamic states (all but the first 4) with the body states held.

    Returns the step times of the last cycle (n) and the full states there (n x nx)."""
    nx = m.rhs.size1_in(0)
    h = period_s / steps
    half = np.arange(2 * steps + 1) * (h / 2)
    D = np.asarray(m.data.map(len(half))(ca.DM(half).T, ca.repmat(ca.DM(p), 1, len(half))))
    x = np.concatenate([x_body, np.zeros(nx - 4)])
    out = np.empty((steps, nx))

    def f(xv, col):  # the body is held: the aerodynamic states' derivative with zero body acceleration
        dz = np.asarray(m.held_d(ca.DM(xv), ca.DM(D[:, col % (2 * steps)]), ca.DM(p))[0]).ravel()
        return np.concatenate([np.zeros(4), dz])

    for c in range(cycles):
        for i in range(steps):
            if c == cycles - 1:
                out[i] = x
            k1 = f(x, 2 * i)
            k2 = f(x + h / 2 * k1, 2 * i + 1)
            k3 = f(x + h / 2 * k2, 2 * i + 1)
            k4 = f(x + h * k3, 2 * i + 2)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.arange(steps) * h, out


def held_loads(cfg, x_body: np.ndarray, samples: int, lag_cycles: int) -> dict:
    """Body-frame loads over one wingbeat with the body held at ``x_body`` (u, w, q, theta)."""
    m = get_model(cfg)
    p = np.asarray(m.p0, float)
    period = 1.0 / cfg.gait.frequency_hz
    nx = m.rhs.size1_in(0)
    t0 = time.process_time()
    if nx == 4:
        t = np.arange(samples) * (period / samples)
        D = m.data.map(samples)(ca.DM(t).T, ca.repmat(ca.DM(p), 1, samples))
        X = ca.repmat(ca.DM(x_body), 1, samples)
        L = np.asarray(m.loads_d.map(samples)(X, D, ca.repmat(ca.DM(p), 1, samples)))
    else:
        t, X = _rk4_lag_states(m, x_body, p, period, samples, lag_cycles)
        D = m.data.map(samples)(ca.DM(t).T, ca.repmat(ca.DM(p), 1, samples))
        # held loads: the added-mass reaction with zero body acceleration (loads_d would add the reaction
        # to the acceleration of a free body at this state, -0.7 % of the steady lift)
        L = np.asarray(m.held_d.map(samples)(ca.DM(X.T), D, ca.repmat(ca.DM(p), 1, samples))[1])
    cpu = time.process_time() - t0
    if nx != 4:
        cpu /= lag_cycles
    return {"t_s": t, "Fx_N": L[0], "Fz_N": L[1], "cpu_s_per_cycle": cpu}


def birdocp_case(inputs: dict, case: dict, kinematics: str, unsteady: str, lag_cycles: int) -> dict:
    """Cycle means, lift-peak phase, CPU time and the lift/thrust histories of one birdocp run."""
    cfg = case_config(inputs, case, kinematics, unsteady)
    tr = inputs["trim"]
    u, w = tr["mean_u_mps"], tr["mean_w_mps"]
    x_body = np.array([u, w, 0.0, tr["mean_theta_rad"]])
    samples = 4 * cfg.solve.steps_per_period
    held_loads(cfg, x_body, samples, 1)  # graphs built or read, Functions loaded: not timed
    r = held_loads(cfg, x_body, samples, lag_cycles)
    V = math.hypot(u, w)
    lift = (r["Fx_N"] * w - r["Fz_N"] * u) / V
    thrust = (r["Fx_N"] * u + r["Fz_N"] * w) / V
    if not (np.all(np.isfinite(lift)) and np.all(np.isfinite(thrust))):
        raise FloatingPointError(f"non-finite loads in case {case['name']} ({kinematics}, {unsteady})")
    return {"kinematics": kinematics, "unsteady": unsteady, "samples_per_cycle": samples,
            "mean_lift_N": float(np.mean(lift)), "mean_thrust_N": float(np.mean(thrust)),
            "lift_peak_phase_deg": peak_phase_deg(lift), "max_lift_N": float(np.max(lift)),
            "min_lift_N": float(np.min(lift)), "cpu_s_per_cycle": r["cpu_s_per_cycle"],
            "history": {"phase_deg": (np.arange(samples) / samples * 360.0).tolist(), "lift_N": lift.tolist(),
                        "thrust_N": thrust.tolist()}}


def birdocp_steady(inputs: dict, unsteady: str, lag_cycles: int) -> dict:
    """The rigid wing held at flap angle 0 (no flapping), body held: lift and thrust [N]."""
    case = {"name": "steady", "frequency_hz": float(inputs["config"]["gait"]["frequency_hz"])}
    cfg = with_values(case_config(inputs, case, "rigid", unsteady), {"gait.shoulder_flap.amplitude_deg": 0.0})
    tr = inputs["trim"]
    x_body = np.array([tr["mean_u_mps"], tr["mean_w_mps"], 0.0, tr["mean_theta_rad"]])
    r = held_loads(cfg, x_body, cfg.solve.steps_per_period, lag_cycles)  # the trim's step: lag states stable
    u, w = tr["mean_u_mps"], tr["mean_w_mps"]
    V = math.hypot(u, w)
    return {"lift_N": float(np.mean((r["Fx_N"] * w - r["Fz_N"] * u) / V)),
            "thrust_N": float(np.mean((r["Fx_N"] * u + r["Fz_N"] * w) / V))}


def uvlm_runs(out: Path) -> tuple[list[dict], list[dict]]:
    """The UVLM runs and the steady VLM runs of ``OUT/uvlm.json``."""
    path = out / "uvlm.json"
    doc = json.loads(path.read_text()) if path.is_file() else {}
    return doc.get("runs", []), doc.get("steady", [])


def main(argv=None) -> int:
    ap = script_parser(__doc__, "results/aero/uvlm")
    ap.add_argument("--unsteady", default="none", help="birdocp's aero.unsteady: none or wagner")
    ap.add_argument("--lag-cycles", type=int, default=4, help="wingbeats to settle the lag states (wagner)")
    args, out = parse_with_out(ap, argv)
    if args.unsteady not in MODEL_KEYS:
        print(f"compare: --unsteady must be none or wagner, got {args.unsteady!r}", file=sys.stderr)
        return 2
    if args.unsteady != "none" and not unsteady_supported():
        print(f"compare: --unsteady {args.unsteady}: this birdocp has no aero.unsteady option yet; "
              "run with --unsteady none", file=sys.stderr)
        return 2
    if not (out / "inputs.json").is_file():
        print(f"compare: {out / 'inputs.json'} not found; write it with make_inputs.py", file=sys.stderr)
        return 2
    inputs = json.loads((out / "inputs.json").read_text())
    result_path = out / "result.json"
    result = json.loads(result_path.read_text()) if result_path.is_file() else {}
    result["inputs"] = {k: inputs[k] for k in ("trim", "cases", "rigid_gait", "air_density_kgm3", "reference_chord_m")}
    result["uvlm"], result["uvlm_steady"] = uvlm_runs(out)
    birdocp = result.setdefault("birdocp", {})
    model = MODEL_KEYS[args.unsteady]
    birdocp[model] = {case["name"]: {kin: birdocp_case(inputs, case, kin, args.unsteady, args.lag_cycles)
                                     for kin in ("rigid", "gait")} for case in inputs["cases"]}
    result.setdefault("birdocp_steady", {})[model] = birdocp_steady(inputs, args.unsteady, args.lag_cycles)
    atomic_write_json(result_path, result)
    from report import plot_lift, table_markdown  # noqa: E402 (this folder)

    atomic_write_text(out / "table.md", table_markdown(result))
    plot_lift(result, out / "lift_over_wingbeat.png")
    print((out / "table.md").read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
