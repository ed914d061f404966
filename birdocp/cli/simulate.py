"""``birdocp simulate``: many wingbeats of the full model from the cycle, with a perturbation and/or a
gust, open loop or with a controller designed by ``birdocp control``."""

from __future__ import annotations

import argparse
import math
import sys
import time
from types import SimpleNamespace

from birdocp.bird.config import ConfigError
from birdocp.cli import common as cli

MAX_BEATS = 10000

HELP = "simulate many wingbeats with a perturbation or a gust, open or closed loop"

DESCRIPTION = """Integrate the full model from the cycle for K beats (state augmented with the inertial position X
forward, Z down). Perturbations add to the cycle's state at t = 0; gusts are 1 - cos, frozen in space, starting one
beat ahead; with --controller the feedback of a 'birdocp control' run is applied at each update, saturated at its
joint limits. Writes the time histories (arrays.npz), result.json and simulation.png. With model.degrees_of_freedom =
6 the 6-DOF bird is simulated (--side-gust besides --gust and --wind, --perturb on any of the 9 states, a 6-DOF
controller) and the stall of each wing is checked every beat."""
"""The text of ``birdocp simulate --help`` (argparse joins the lines)."""


def register(sub, common) -> None:
    """Add ``simulate`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = cli.add_run_command(sub, common, "simulate", cmd_simulate, help=HELP,
                            description=DESCRIPTION)
    p.add_argument("--beats", type=int, required=True, metavar="K", help="wingbeats to simulate")
    p.add_argument("--perturb", action="append", default=[], metavar="KEY=VALUE",
                   help="initial state deviation: u=, w= [m/s], q= [rad/s], theta= [rad] (repeatable)")
    p.add_argument("--gust", action="append", default=[], metavar="DIR=MPS:BEATS",
                   help="1 - cos gust: vertical (positive up) or horizontal (positive along the flight, i.e. "
                        "tailwind) peak in m/s and length in beats (or metres with a trailing m: 3:10m)")
    p.add_argument("--gust-start", type=float, metavar="BEATS",
                   help="distance to the gust's start, in beats of the cycle's flight distance (default 1)")
    p.add_argument("--wind", action="append", default=[], metavar="DIR=MPS",
                   help="constant wind: vertical (positive up) or horizontal (positive along the flight)")
    p.add_argument("--controller", metavar="RUN_DIR", help="a 'birdocp control' run folder (closed loop); its "
                   "configuration must be the simulated one")
    p.add_argument("--level", action="store_true", help="open loop: simulate about the level-flight cycle")
    p.add_argument("--side-gust", metavar="SHAPE=MPS[:BEATS]",
                   help="six degrees of freedom: a side wind towards the bird's right, pulse (1 - cos over BEATS, "
                        "default 1) or step, starting after --gust-start beats (default 1); with "
                        "model.degrees_of_freedom = 6 --perturb also takes v=, p=, r=, phi=, psi=")


def _first_difference(a: dict, b: dict, prefix: str = "") -> str | None:
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            d = _first_difference(va, vb, f"{prefix}{k}.")
            if d:
                return d
        elif va != vb:
            return f"{prefix}{k}"
    return None


def _load_controller(path_text: str, cfg):
    """(controller namespace, cycle cfg, result dict) from a control run folder, read and checked by
    :func:`birdocp.cli.inputs.read_run_folder` (its config.toml the one the controller was designed on)
    and :func:`_controller_fields`; ConfigError on --controller if it is not one, is damaged, or was
    designed for another configuration than ``cfg``."""
    from birdocp.bird import config as C
    from birdocp.cli.inputs import read_run_folder

    folder, cycle_cfg = read_run_folder(path_text, "--controller", commands=("control",),
                                        kind="a 'birdocp control' run folder", arrays=None)
    r, path = folder.result, folder.path
    if not r.get("success") or "gains" not in r:
        raise ConfigError("--controller", f"'{path}' holds no stabilising controller (status {r.get('status')})")
    if not isinstance(r.get("requested_config"), str):
        raise folder.error("result.json", "has no requested_config (the configuration the controller was asked for)")
    try:
        requested = C.loads(r["requested_config"])
    except ConfigError as exc:
        raise folder.error("result.json", f"requested_config: {cli.one_line(exc)}") from None
    ctl = _controller_fields(folder, cycle_cfg)
    if C.dumps(cfg) not in (C.dumps(requested), C.dumps(cycle_cfg)):
        key = _first_difference(C.to_dict(cfg), C.to_dict(requested))
        raise ConfigError("--controller", f"'{path}' was designed for another configuration (differs in {key}); "
                          "simulate with the same CONFIG/--set, or design a controller for this one")
    return ctl, cycle_cfg, r


def _array(folder, name: str, shape: tuple, value):
    import numpy as np

    try:
        a = np.array(value, float)
    except (TypeError, ValueError):
        raise folder.error("result.json", f"'{name}' is not an array of numbers") from None
    if a.shape != shape:
        raise folder.error("result.json", f"'{name}' has shape {a.shape}, the controller needs {shape}")
    if not np.all(np.isfinite(a)):
        raise folder.error("result.json", f"'{name}' holds values that are not finite numbers")
    return a


def _controller_fields(folder, cycle_cfg) -> SimpleNamespace:
    """The controller in a control run's result.json, every field checked against the stored
    configuration: known gait controls (no repeats), ``updates_per_beat`` dividing the RK4 steps, gains
    ``(N, m, n)``, cycle states ``(N, n)`` and ``cycle_x0`` finite (n = 4, or 8 in six degrees of freedom),
    limits ``(m, 2)`` with LO < HI."""
    from birdocp.studies.control import resolve_controls
    from birdocp.studies.lateral_control import resolve_lateral_controls

    six = cycle_cfg.model.degrees_of_freedom == 6
    resolve, nx = (resolve_lateral_controls, 8) if six else (resolve_controls, 4)
    r = folder.result
    controls = r.get("controls")
    if not isinstance(controls, list) or not controls or not all(isinstance(c, str) for c in controls):
        raise folder.error("result.json", "'controls' is not a list of configuration keys")
    try:
        if list(resolve(controls)) != controls:
            raise ConfigError("controls", f"{controls} are not in the resolved form")
    except ConfigError as exc:
        raise folder.error("result.json", f"'controls': {cli.config_message(exc)}") from None
    steps, n = r.get("steps_per_period"), r.get("updates_per_beat")
    if steps != cycle_cfg.solve.steps_per_period or isinstance(steps, bool):
        raise folder.error("result.json", f"'steps_per_period' is {steps!r}, config.toml says "
                                          f"{cycle_cfg.solve.steps_per_period}")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1 or steps % n:
        raise folder.error("result.json", f"'updates_per_beat' is {n!r}; it must be an integer >= 1 dividing the "
                                          f"{steps} RK4 steps per period")
    m = len(controls)
    limits = _array(folder, "limits", (m, 2), r.get("limits"))
    if not all(limits[:, 0] < limits[:, 1]):
        raise folder.error("result.json", "'limits' are not LO < HI for every control")
    _array(folder, "cycle_x0", (nx,), r.get("cycle_x0"))
    return SimpleNamespace(controls=list(controls), K=_array(folder, "gains", (n, m, nx), r.get("gains")),
                           x_starts=_array(folder, "x_starts", (n, nx), r.get("x_starts")), limits=limits,
                           updates_per_beat=n)


def _run_simulation(args, sim_cfg, x0, steps, dx0, gusts, wind, ctl):
    """The simulation of ``cmd_simulate`` with its progress bar."""
    from birdocp.io.progress import progress_callback
    from birdocp.studies.simulate import simulate

    say, bar = progress_callback("simulate", getattr(args, "quiet", False), total=args.beats)
    try:
        return simulate(sim_cfg, x0, args.beats, steps_per_period=steps, perturbation=dx0, gusts=gusts,
                        wind_mps=wind, controller=ctl, progress=say)
    finally:
        bar.close()


def _parse_inputs(args: argparse.Namespace):
    """(perturbation, gusts, wind) of the planar ``simulate``'s options, checked (ConfigError, exit 2)."""
    from birdocp.studies.simulate import parse_perturbation

    if args.side_gust is not None:
        raise ConfigError("--side-gust", "a side gust needs model.degrees_of_freedom = 6 (--set "
                                         "model.degrees_of_freedom=6); the planar bird has --gust")
    dx0 = parse_perturbation(args.perturb)
    return (dx0, *gusts_and_wind(args))


def gusts_and_wind(args: argparse.Namespace, side_gust: bool = False):
    """(gusts, wind) of ``--gust``, ``--gust-start`` and ``--wind``, checked (ConfigError, exit 2);
    ``side_gust``: a ``--side-gust`` is given too (``--gust-start`` places it).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments.
    side_gust : bool
        A ``--side-gust`` is given too.

    Returns
    -------
    gusts : list of Gust
    wind : tuple of float
        (horizontal, vertical) [m/s].
    """
    from birdocp.studies.simulate import DIRECTIONS, check_speed, parse_gust

    gusts = [parse_gust(g) for g in args.gust]
    if len({g.direction for g in gusts}) < len(gusts):
        raise ConfigError("--gust", "at most one vertical and one horizontal gust")
    if args.gust_start is not None and not gusts and not side_gust:  # refused, not ignored
        raise ConfigError("--gust-start", "places a gust: add --gust DIR=MPS:BEATS (or drop --gust-start)")
    gust_start = _check_gust_start(args)
    gusts = [type(g)(g.direction, g.amplitude_mps, g.length_beats, g.length_m, gust_start) for g in gusts]
    wind = [0.0, 0.0]
    for text in args.wind:
        try:
            d, v = text.split("=", 1)
            val = float(v)
        except ValueError:
            raise ConfigError("--wind", f"expected vertical|horizontal=MPS, got '{text}'") from None
        if d.strip() not in DIRECTIONS or not math.isfinite(val):
            raise ConfigError("--wind", f"expected vertical|horizontal=MPS with a finite value, got '{text}'")
        wind[0 if d.strip() == "horizontal" else 1] = check_speed("--wind", "the wind", val)
    return gusts, wind


def _check_gust_start(args: argparse.Namespace) -> float:
    """``--gust-start`` in beats (default 1), checked."""
    gust_start = 1.0 if args.gust_start is None else args.gust_start
    if not math.isfinite(gust_start) or not 0 <= gust_start <= MAX_BEATS:
        raise ConfigError("--gust-start", f"must lie in 0..{MAX_BEATS} beats (no simulation flies farther), "
                                          f"got {gust_start}")
    return gust_start


def _check_beats_and_controller(args: argparse.Namespace, cfg):
    """``--beats`` checked; the controller of ``--controller`` (None), its cycle's configuration and
    result (:func:`_load_controller`); ``--level`` refused with a controller."""
    if not 1 <= args.beats <= MAX_BEATS:
        raise ConfigError("--beats", f"must be an integer in [1, {MAX_BEATS}], got {args.beats}")
    if not args.controller:
        return None, None, None
    if args.level:
        raise ConfigError("--level", "the controller's cycle is used with --controller; drop --level")
    return _load_controller(args.controller, cfg)


def cmd_simulate(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp simulate``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of the command.
    command_line : list of str
        The command line, recorded in the provenance of the result.

    Returns
    -------
    int
        Exit code: 0 success, 1 the computation failed or its output could not be written, 2 bad input.
    """
    t0 = time.perf_counter()
    cfg = cli.resolve_config(args)
    if cfg.model.degrees_of_freedom == 6:
        return _cmd_lateral_simulate(args, command_line, cfg, t0)
    dx0, gusts, wind = _parse_inputs(args)
    ctl, sim_cfg, ctl_result = _check_beats_and_controller(args, cfg)
    with cli.run_folder(args, "simulate", command_line) as run:
        run_dir = run.dir
        head = {"controller": str(args.controller) if args.controller else None, "run_dir": str(run_dir),
                "perturbation": dx0.tolist(), "wind_mps": {"horizontal": wind[0], "vertical": wind[1]}}
        with run.solving():
            if ctl is not None:
                x0, steps = ctl_result["cycle_x0"], int(ctl_result["steps_per_period"])
            else:
                from birdocp.studies.control import reference_cycle

                base = reference_cycle(cfg, args.level)
                if base.success:
                    sim_cfg, x0, steps = base.cfg, base.x0, int(base.cycle.method["steps_per_period"])
            if ctl is None and not base.success:
                result = {"success": False, "status": base.status,
                          "message": f"the cycle did not converge: {base.message}", **head}
            else:
                sim = _run_simulation(args, sim_cfg, x0, steps, dx0, gusts, wind, ctl)
        if ctl is None and not base.success:  # stdout is the terminal's again: the JSON goes there
            run.write(cfg, result)
            run.output(result, None)
            return run.fail("the cycle did not converge", base.status, base.max_residual, base.message)
        result = {**sim.to_dict(), **head, "cycle_x0": [float(v) for v in x0],
                  "wall_s": {"total": time.perf_counter() - t0}}
        arrays = sim.arrays()
        if sim.states.shape[0] > 1:
            from birdocp.plots.control import plot_simulation

            runs = {("closed loop" if ctl is not None else "open loop"): dict(arrays, control_keys=sim.control_keys)}
            result["figure"] = str(plot_simulation(runs, run_dir / "simulation.png",
                                                   f"{args.beats} beats: {sim.status}"))
        run.write(sim_cfg, result, arrays)
        return report(args, result, sim, ctl is not None, run_dir)


def report(args: argparse.Namespace, result: dict, sim, closed: bool, run_dir) -> int:
    """Print the simulation's JSON or summary (and the failure line); the exit code.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (``json``).
    result : dict
        JSON-able result.
    sim : SimulationResult
        The simulation.
    closed : bool
        A controller closed the loop.
    run_dir : Path
        The run folder.

    Returns
    -------
    int
        Exit code.
    """
    if args.json:
        cli.print_json(result, cli.context_of(args))
    else:
        dev = result["deviation_per_beat"]
        print(f"simulate: {sim.status} ({'closed' if closed else 'open'} loop): {sim.message}")
        print("  deviation per beat: " + ", ".join(cli.fmt_num(v, ".3g") for v in dev[:12])
              + (" ..." if len(dev) > 12 else ""))
        print(f"  final deviation {cli.fmt_num(result['final_deviation'], '.3g')}, peak "
              f"{cli.fmt_num(result['peak_deviation'], '.3g')} at beat {result['peak_beat']}, beats to recover "
              f"{result['beats_to_recover']}, saturated {result['saturated']}")
        for key in ("max_abs_bank_deg", "final_heading_deg", "max_abs_east_drift_m"):
            if key in result:
                print(f"  {key} {cli.fmt_num(result[key], '.4g')}")
        print(f"  written to {run_dir}")
    if not sim.success:
        print(f"{cli.PROG}: simulation failed ({sim.status}): {sim.message}; result written to {run_dir}",
              file=sys.stderr)
        return cli.EXIT_NOT_CONVERGED
    return cli.EXIT_OK


def _six_dof_inputs(args: argparse.Namespace):
    """(perturbation (9), side gust or None, gusts, wind), checked."""
    from birdocp.studies.lateral_simulate import parse_lateral_perturbation, parse_side_gust

    gusts, wind = gusts_and_wind(args, side_gust=args.side_gust is not None)
    dx0 = parse_lateral_perturbation(args.perturb)
    gust = parse_side_gust(args.side_gust, _check_gust_start(args)) if args.side_gust is not None else None
    return dx0, gust, gusts, wind


def _cmd_lateral_simulate(args: argparse.Namespace, command_line: list[str], cfg, t0: float) -> int:
    """``birdocp simulate`` with a 6-DOF configuration: one run folder (result.json, arrays.npz,
    simulation.png); the exit code."""
    from birdocp.studies.lateral_simulate import check_lateral_simulation_config

    dx0, gust, gusts, wind = _six_dof_inputs(args)
    check_lateral_simulation_config(cfg, gust)  # a bad combination refused before any computation
    ctl, sim_cfg, ctl_result = _check_beats_and_controller(args, cfg)
    with cli.run_folder(args, "simulate", command_line) as run:
        head = {"controller": str(args.controller) if args.controller else None, "run_dir": str(run.dir)}
        with run.solving():
            from birdocp.studies.lateral_control import (lateral_reference_cycle, sides_parameter_vector,
                                                         sides_parameters)
            from birdocp.studies.lateral_simulate import simulate_lateral

            if ctl is not None:
                x0, steps, p = ctl_result["cycle_x0"], int(ctl_result["steps_per_period"]), sides_parameter_vector(sim_cfg)
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
                                   side_gust=gust, gusts=gusts, wind_mps=wind, controller=ctl)
        result = {**sim.to_dict(), **head, "cycle_x0": [float(v) for v in x0],
                  "wall_s": {"total": time.perf_counter() - t0}}
        arrays = sim.arrays()
        if sim.states.shape[0] > 1:
            from birdocp.plots.lateral_simulation import plot_lateral_simulation

            runs = {("closed loop" if ctl is not None else "open loop"): dict(arrays, control_keys=sim.control_keys)}
            result["figure"] = str(plot_lateral_simulation(runs, run.dir / "simulation.png",
                                                           f"{args.beats} beats: {sim.status}"))
        run.write(sim_cfg, result, arrays)
        return report(args, result, sim, ctl is not None, run.dir)
