"""The six-degree-of-freedom path of ``birdocp simulate`` (``model.degrees_of_freedom = 6``): a side
gust and/or a perturbation of any of the 9 states, open loop or with a 6-DOF ``birdocp control`` run."""

from __future__ import annotations

import argparse
import time

from birdocp.bird.config import ConfigError
from birdocp.cli import common as cli


def _inputs(args: argparse.Namespace):
    """(perturbation (9), side gust or None), checked; --gust and --wind refused (planar options)."""
    from birdocp.cli.simulate import check_gust_start
    from birdocp.studies.lateral_simulate import parse_lateral_perturbation, parse_side_gust

    for flag, given in (("--gust", args.gust), ("--wind", args.wind)):
        if given:
            raise ConfigError(flag, "with model.degrees_of_freedom = 6 the wind is a side gust: use --side-gust "
                                    "pulse|step=MPS[:BEATS]")
    if args.gust_start is not None and args.side_gust is None:
        raise ConfigError("--gust-start", "places a gust: add --side-gust SHAPE=MPS[:BEATS] (or drop --gust-start)")
    dx0 = parse_lateral_perturbation(args.perturb)
    gust = parse_side_gust(args.side_gust, check_gust_start(args)) if args.side_gust is not None else None
    return dx0, gust


def cmd_lateral_simulate(args: argparse.Namespace, command_line: list[str], cfg, t0: float) -> int:
    """``birdocp simulate`` with a 6-DOF configuration: one run folder (result.json, arrays.npz,
    simulation.png); the exit code."""
    from birdocp.cli.simulate import check_beats_and_controller, report

    dx0, gust = _inputs(args)
    ctl, sim_cfg, ctl_result = check_beats_and_controller(args, cfg)
    with cli.run_folder(args, "simulate", command_line) as run:
        head = {"controller": str(args.controller) if args.controller else None, "run_dir": str(run.dir)}
        with run.solving():
            from birdocp.studies.lateral_control import _p0, lateral_reference_cycle, sides_parameters
            from birdocp.studies.lateral_simulate import simulate_lateral

            if ctl is not None:
                x0, steps, p = ctl_result["cycle_x0"], int(ctl_result["steps_per_period"]), _p0(sim_cfg)
            else:
                base, sim_cfg = lateral_reference_cycle(cfg, args.level)
                c = base.cycle
                if not base.success:
                    result = {"success": False, "status": c.status, "message": f"the cycle did not converge: "
                                                                                 f"{c.message}", **head}
                    run.write(cfg, result)
                    run.output(result, None)
                    return run.fail("the cycle did not converge", c.status, c.max_residual, c.message)
                x0, steps, p = c.x0, int(c.method["steps_per_period"]), sides_parameters(c.p)
            sim = simulate_lateral(sim_cfg, x0, p, args.beats, steps_per_period=steps, perturbation=dx0,
                                   side_gust=gust, controller=ctl)
        result = {**sim.to_dict(), **head, "cycle_x0": [float(v) for v in x0],
                  "wall_s": {"total": time.perf_counter() - t0}}
        arrays = sim.arrays()
        if sim.states.shape[0] > 1:
            from birdocp.plots.lateral import plot_lateral_simulation

            runs = {("closed loop" if ctl is not None else "open loop"): dict(arrays, control_keys=sim.control_keys)}
            result["figure"] = str(plot_lateral_simulation(runs, run.dir / "simulation.png",
                                                           f"{args.beats} beats: {sim.status}"))
        run.write(sim_cfg, result, arrays)
        return report(args, result, sim, ctl is not None, run.dir)
