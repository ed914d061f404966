"""How the (unstable) ibis stays in the air anyway: feedback of the gait from beat to beat.

At the paper's reference cycle (Config() trimmed, 148 RK4 steps): the exact linearised wingbeat map
with the three shoulder controls, the periodic LQR for N = 1, 2, 4 updates per beat, each joint
alone (stabilisable? minimal effort, LQR rate), open- vs closed-loop response to a perturbation and
to a 1 - cos gust in the full nonlinear model, and the gust envelope of the controlled bird.
Writes results/control/ (result.json, table.md, deviation.png, trajectory.png, gust.png, envelope.png).

    python scripts/control_study.py        # ~2-4 min on 2 cores
    python scripts/control_study.py --out /tmp/control   # elsewhere (default results/control)
"""

import time

import numpy as np

from birdocp.bird.config import Config
from birdocp.bird.validity import validity_text
from birdocp.io.files import atomic_write_json, atomic_write_text
from birdocp.plots.control import plot_deviation, plot_envelope, plot_multipliers, plot_simulation
from birdocp.studies.control import DEFAULT_CONTROLS, design_controller
from birdocp.studies.simulate import Gust, gust_envelope, simulate
from birdocp.studies.trim import trim
from script_common import parse_with_out, script_parser

SHORT = {"gait.shoulder_incidence.offset_deg": "incidence offset", "gait.shoulder_flap.amplitude_deg":
         "flapping amplitude", "gait.shoulder_sweep.offset_deg": "sweep offset"}


def main(argv=None):
    _, out_dir = parse_with_out(script_parser(__doc__, "results/control"), argv)
    t0 = time.perf_counter()
    cfg = Config()
    base = trim(cfg)
    assert base.success, base.message
    x0, steps = base.x0, int(base.cycle.method["steps_per_period"])
    out = {"amplitude_deg": base.amplitude_deg, "cycle_x0": list(map(float, x0)), "steps_per_period": steps,
           "mean_forward_speed_mps": base.mean_forward_speed_mps, "validity": base.validity.to_dict(),
           "valid": bool(base.validity.valid), "controllers": {}, "single_joint": {}}

    # controllers: all three shoulder controls, N = 1, 2, 4; each joint alone, N = 1 and 4
    ctls = {}
    for N in (1, 2, 4):
        ctls[f"all, N={N}"] = design_controller(base, DEFAULT_CONTROLS, N)
    for key in DEFAULT_CONTROLS:
        for N in (1, 4):
            ctls[f"{SHORT[key]}, N={N}"] = design_controller(base, [key], N)
    for name, c in ctls.items():
        d = c.to_dict()
        out["controllers"][name] = {k: d[k] for k in (
            "controls", "updates_per_beat", "open_loop_multipliers", "closed_loop_multipliers",
            "closed_loop_spectral_radius", "beats_to_reduce_100x", "gain", "gains", "controllable", "per_control",
            "limits", "cycle_amplitude_deg", "cycle_valid", "cycle_validity")}
    for N in (1, 4):
        for row in ctls[f"all, N={N}"].to_dict()["per_control"]:
            out["single_joint"].setdefault(f"N={N}", []).append(dict(row, cycle_valid=out["valid"]))
    plot_multipliers(ctls["all, N=1"].to_dict(), out_dir / "multipliers.png")
    rows1 = out["single_joint"]["N=1"]
    cheapest = min(rows1, key=lambda r: r["min_effort_per_unit_mode"] or np.inf)["control"]
    out["cheapest_joint"] = cheapest
    single = ctls[f"{SHORT[cheapest]}, N=1"]

    # perturbation: 0.5 m/s in w (as if from a short vertical gust), 20 beats
    sims = {}
    dx = np.array([0.0, 0.5, 0.0, 0.0])
    for label, ctl in (("open loop", None), ("closed loop, 3 controls", ctls["all, N=1"]),
                       (f"closed loop, {SHORT[cheapest]} alone", single),
                       ("closed loop, 3 controls, N=4", ctls["all, N=4"])):
        sims[label] = simulate(cfg, x0, 20, steps_per_period=steps, perturbation=dx, controller=ctl)
    out["perturbation"] = {"dx0": dx.tolist(), **{k: v.to_dict() for k, v in sims.items()}}
    plot_deviation({run_label(k, v): v.deviation_per_beat for k, v in sims.items()}, out_dir / "deviation.png",
                   "perturbation w + 0.5 m/s at the beat start: deviation from the cycle per beat")
    plot_simulation({k: dict(v.arrays(), control_keys=v.control_keys) for k, v in sims.items()
                     if k in ("open loop", "closed loop, 3 controls")}, out_dir / "trajectory.png",
                    "w + 0.5 m/s at t = 0: open loop diverges (left the model's validity), closed loop recovers")

    # gust: 2 m/s vertical, 2 beats long, starting one beat ahead
    gust = Gust("vertical", 2.0, 2.0)
    gs = {label: simulate(cfg, x0, 20, steps_per_period=steps, gusts=[gust], controller=ctl)
          for label, ctl in (("open loop", None), ("closed loop, 3 controls", ctls["all, N=1"]),
                             (f"closed loop, {SHORT[cheapest]} alone", single))}
    out["gust"] = {"gust": {"direction": "vertical", "amplitude_mps": 2.0, "length_beats": 2.0},
                   **{k: v.to_dict() for k, v in gs.items()}}
    plot_simulation({k: dict(v.arrays(), control_keys=v.control_keys) for k, v in gs.items()},
                    out_dir / "gust.png", "1 - cos vertical gust, 2 m/s peak, 2 beats long, from beat 1")

    # gust envelopes: 3 controls and the cheapest joint alone, N = 1, gusts 2 beats long
    envs = []
    for label, ctl in (("3 controls", ctls["all, N=1"]), (f"{SHORT[cheapest]} alone", single)):
        for direction, sign in (("vertical", 1), ("vertical", -1), ("horizontal", 1), ("horizontal", -1)):
            e = gust_envelope(cfg, x0, ctl, direction, sign=sign, length_beats=2.0, beats=40,
                              steps_per_period=steps, tol_mps=0.1)
            e["controller"] = label
            envs.append(e)
            print(f"envelope {label} {direction} {sign:+d}: {e['envelope_mps']:+.2f} m/s, "
                  f"{e['beats_to_recover']} beats to recover ({time.perf_counter() - t0:.0f} s)", flush=True)
    out["envelopes"] = envs
    plot_envelope([e for e in envs if e["controller"] == "3 controls"], out_dir / "envelope.png")
    out["wall_s"] = time.perf_counter() - t0
    atomic_write_json(out_dir / "result.json", out)
    atomic_write_text(out_dir / "table.md", table(out))
    print(table(out))


def run_label(label: str, sim) -> str:
    """The legend label of a simulation, saying where it left the model's validity."""
    return f"{label} (stopped: {sim.status.replace('_', ' ')})" if sim.status != "ok" else label


def _fmt(v, f=".3g"):
    return "-" if v is None else format(v, f)


def table(out) -> str:
    lines = [f"# Feedback of the gait at the reference cycle (amplitude {out['amplitude_deg']:g} deg, "
             f"{out['steps_per_period']} RK4 steps)", "",
             f"Model validity of the reference cycle (every controller below is designed around it): "
             f"{validity_text(out['validity'])}. Simulations stop where they leave the model's validity "
             "(status left_validity).", "",
             "## Each joint alone (Bryson weights: 1 m/s, 1 m/s, 1 rad/s, 5 deg; 5 deg per joint)", "",
             "| N | control | stabilisable | modal input |w1 B| [1/deg] | minimal effort [deg per unit mode] | "
             "LQR spectral radius |", "|---|---|---|---|---|---|"]
    for N, rows in out["single_joint"].items():
        for r in rows:
            lines.append(f"| {N[2:]} | {r['control']} | {r['stabilisable']} | {_fmt(r['modal_input_per_unit'])} | "
                         f"{_fmt(r['min_effort_per_unit_mode'])} | {_fmt(r['lqr_spectral_radius'], '.4f')} |")
    lines += ["", "## Controllers (periodic LQR)", "",
              "| controller | closed-loop multipliers | spectral radius | beats to reduce 100x | cycle valid |",
              "|---|---|---|---|---|"]
    for name, c in out["controllers"].items():
        mult = ", ".join(f"{z[0]:.3f}{z[1]:+.3f}j" for z in c["closed_loop_multipliers"])
        lines.append(f"| {name} | {mult} | {c['closed_loop_spectral_radius']:.4f} | "
                     f"{_fmt(c['beats_to_reduce_100x'], '.1f')} | {'yes' if c['cycle_valid'] else 'NO'} |")
    lines += ["", "## Nonlinear response (20 beats)", "",
              "| case | status | peak deviation | final deviation | beats to recover | saturated |", "|---|---|---|---|---|---|"]
    for what in ("perturbation", "gust"):
        for k, v in out[what].items():
            if isinstance(v, dict) and "status" in v:
                lines.append(f"| {what}: {k} | {v['status']} | {_fmt(v['peak_deviation'])} | "
                             f"{_fmt(v['final_deviation'])} | {_fmt(v['beats_to_recover'])} | {v['saturated']} |")
    lines += ["", "## Gust envelope (1 - cos, 2 beats long; recovered = deviation / 100 within 40 beats, no joint "
              "saturated, within validity)", "",
              "| controller | gust | largest recovered [m/s] | beats to recover | first failure [m/s] |",
              "|---|---|---|---|---|"]
    for e in out["envelopes"]:
        fail = e["first_failure_mps"]
        status = next((("saturated" if t["saturated"] else "") + (" + " if t["saturated"] and t["status"] != "ok" else "")
                       + (t["status"] if t["status"] != "ok" else "" if t["saturated"] else "not recovered")
                       for t in e["trials"] if fail is not None and t["amplitude_mps"] == fail), "")
        lines.append(f"| {e['controller']} | {e['direction']} {'+' if e['sign'] > 0 else '-'} | "
                     f"{e['envelope_mps']:+.2f} | {_fmt(e['beats_to_recover'])} | {_fmt(fail, '+.2f')} {status} |")
    lines.append("")
    lines.append(f"wall time {out['wall_s']:.0f} s")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
