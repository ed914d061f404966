"""Command-line interface: ``birdocp forces | trim | level | sweep | config | export-c``.

Configuration resolution (one helper, :func:`resolve_config`, used by every subcommand)::

    defaults  <-  CONFIG file  <-  --set KEY=VALUE ...  <-  dedicated flags (--amplitude, --points, ...)

The ``--set`` assignments and the dedicated flags are applied together in one step, so they may be
given in any order and e.g. ``--set solve.points=4 --steps 150`` is checked as a whole. The
configuration is fully validated before the model is imported or built.

Exit codes: 0 success; 1 the solver did not converge (the result is still written) or an unexpected
error; 2 bad input (one line on stderr naming the key at fault); 130 interrupted.
"""

from __future__ import annotations

import argparse
import importlib
import contextlib
import json
import math
import os
import sys
import time
import traceback
from pathlib import Path
from typing import Sequence

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.cli.common import (
    AMPLITUDE_KEY,
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_NOT_CONVERGED,
    EXIT_OK,
    PROG,
    Parser,
    common_options,
    config_message,
    finish_result,
    finite_values,
    fmt_num,
    format_trim_table,
    one_line,
    print_json,
    resolve_config,
    stdout_to_stderr,
    validity_notes,
    validity_word,
)

__all__ = ["main", "build_parser", "resolve_config", "EXIT_OK", "EXIT_NOT_CONVERGED", "EXIT_BAD_INPUT"]

COMMAND_MODULES = (
    "birdocp.cli.study",
    "birdocp.cli.animate",
)
"""Modules that add subcommands: each defines ``register(sub, common)`` (``sub`` the subparsers
action, ``common`` the parent parser with the configuration and output options) and sets
``func(args, command_line) -> exit code`` on its parsers. Add a new command by adding its module here."""

def build_parser() -> argparse.ArgumentParser:
    from birdocp import __version__

    parser = Parser(
        prog=PROG,
        description="Trimmed periodic flapping flight of a bird and its Floquet stability.",
        epilog="Exit codes: 0 ok, 1 solver did not converge or internal error, 2 bad input, 130 interrupted. "
               "Run 'birdocp COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True, parser_class=Parser)
    common = common_options()

    p = sub.add_parser("forces", parents=[common], help="body-frame loads and state derivative at one state and time",
                       description="Evaluate the model once: body-frame loads (x' forward, z' down, "
                                   "pitching moment nose-up positive) and the state derivative.")
    p.add_argument("--state", nargs=4, type=float, required=True, metavar=("U", "W", "Q", "THETA"),
                   help="body-frame velocities u, w [m/s], pitch rate q [rad/s], pitch angle theta [rad]")
    p.add_argument("--time", type=float, required=True, metavar="T", help="time in the flapping cycle [s]")
    p.set_defaults(func=cmd_forces)

    p = sub.add_parser("trim", parents=[common], help="find the trimmed periodic flight and its Floquet stability",
                       description="Find the periodic (trimmed) flapping flight by multiple shooting and its "
                                   "Floquet multipliers. Writes a run folder (config.toml, result.json, arrays.npz).")
    s = p.add_argument_group("solve (shortcuts for solve.* keys)")
    s.add_argument("--points", type=int, metavar="M", help="shooting points per period, closing point included (solve.points)")
    s.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period, a multiple of M-1 (solve.steps_per_period)")
    s.add_argument("--solver", choices=("ipopt", "lm"), help="nonlinear solver (solve.solver)")
    s.add_argument("--derivatives", choices=("exact", "fd"), help="Jacobians by AD or finite differences (solve.derivatives)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-trim-<id>/")
    p.add_argument("--compiled", action="store_true",
                   help="use the state RHS compiled to C (cached in $BIRDOCP_CACHE or ~/.cache/birdocp; "
                        "falls back to the interpreted path with a warning if compilation fails)")
    p.set_defaults(func=cmd_trim)

    p = sub.add_parser("export-c", parents=[common], help="export the model as a self-contained C folder",
                       description="Write C code for the configured gait: the state equations and their "
                                   "Jacobian, one RK4 step, the period map with its monodromy, the wing data "
                                   "on the RK4 stage grid as a table, bird.h (documented), a Makefile and an "
                                   "example main.c. Build with: make -C DIR && DIR/bird_period U W Q THETA")
    p.add_argument("--out", metavar="DIR", required=True, help="folder to write (new, empty, or an earlier export)")
    p.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period (solve.steps_per_period)")
    p.set_defaults(func=cmd_export_c)

    _add_level_parsers(sub, common)

    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub, common)

    p = sub.add_parser("config", parents=[common], help="print the resolved configuration as TOML",
                       description="Print the resolved configuration (defaults <- CONFIG <- --set <- flags) as "
                                   "TOML, e.g. to start a configuration file: birdocp config > bird.toml")
    p.set_defaults(func=cmd_config)
    return parser


# ---------------------------------------------------------------------------------------------
# Commands

def cmd_config(args: argparse.Namespace, command_line: list[str]) -> int:
    cfg = resolve_config(args)
    if args.json:
        print_json(C.to_dict(cfg))
    else:
        sys.stdout.write("# birdocp configuration (resolved)\n"
                         f"# body alone (without the wings): {C.body_alone_mass_kg(cfg):.6g} kg\n" + C.dumps(cfg))
    return EXIT_OK


def cmd_forces(args: argparse.Namespace, command_line: list[str]) -> int:
    state = finite_values("--state", args.state)
    (t,) = finite_values("--time", [args.time])
    cfg = resolve_config(args)

    import numpy as np

    from birdocp.bird.model import get_model

    with stdout_to_stderr():
        model = get_model(cfg)
        out = model.evaluate(state, t)
    res = {
        "Fx_N": float(np.asarray(out["Fx_N"], dtype=float).reshape(-1)[0]),
        "Fz_N": float(np.asarray(out["Fz_N"], dtype=float).reshape(-1)[0]),
        "My_Nm": float(np.asarray(out["My_Nm"], dtype=float).reshape(-1)[0]),
        "xdot": [float(v) for v in np.asarray(out["xdot"], dtype=float).reshape(-1)],
    }
    if args.json:
        print_json(res)
        return EXIT_OK
    u, w, q, th = state
    xd = res["xdot"] + [float("nan")] * (4 - len(res["xdot"]))
    rows = [
        ("state", f"u = {u:g} m/s, w = {w:g} m/s, q = {q:g} rad/s, theta = {th:g} rad"),
        ("time", f"t = {t:g} s"),
        ("", ""),
        ("body-frame loads", "(x' forward, z' down, pitching moment nose-up positive)"),
        ("  Fx", f"{res['Fx_N']: .6g} N"),
        ("  Fz", f"{res['Fz_N']: .6g} N"),
        ("  My", f"{res['My_Nm']: .6g} N m"),
        ("state derivative", ""),
        ("  du/dt", f"{xd[0]: .6g} m/s^2"),
        ("  dw/dt", f"{xd[1]: .6g} m/s^2"),
        ("  dq/dt", f"{xd[2]: .6g} rad/s^2"),
        ("  dtheta/dt", f"{xd[3]: .6g} rad/s"),
    ]
    width = max(len(k) for k, _ in rows)
    print("\n".join(f"{k:<{width}}  {v}".rstrip() for k, v in rows))
    return EXIT_OK


def cmd_trim(args: argparse.Namespace, command_line: list[str]) -> int:
    from birdocp.io.runs import claim_out_dir, new_run_dir, write_run

    t_start = time.perf_counter()
    cfg = resolve_config(args)
    run_dir = claim_out_dir(args.out, "trim") if args.out else new_run_dir(None, "trim")
    try:
        with stdout_to_stderr():
            from birdocp.studies.trim import trim

            res = trim(cfg, compiled=True) if getattr(args, "compiled", False) else trim(cfg)
            result = dict(res.to_dict())
            arrays = res.arrays() if hasattr(res, "arrays") else None
    except BaseException:
        # nothing was written: do not leave an empty run folder behind
        with contextlib.suppress(OSError):
            run_dir.rmdir()
        raise
    finish_result(result, "trim", t_start, run_dir)
    write_run(run_dir, cfg, result, arrays, command_line, command="trim")

    if args.json:
        print_json(result)
    else:
        print(format_trim_table(result))
    if not res.success:
        hist = result.get("residual_history") or []
        last = result.get("max_residual")
        if last is None and hist:
            last = hist[-1]
        print(f"{PROG}: trim did not converge (status: {one_line(res.status)}, last residual: {fmt_num(last, '.3e')}): "
              f"{one_line(res.message)}; result written to {run_dir}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def cmd_export_c(args: argparse.Namespace, command_line: list[str]) -> int:
    cfg = resolve_config(args)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ConfigError("--out", f"{out} exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / "bird.h").exists():
        raise ConfigError("--out", f"{out} is not empty and holds no earlier export (no bird.h); choose a new folder")
    with stdout_to_stderr():
        from birdocp.export.codegen import export_c

        info = export_c(cfg, out)
    if args.json:
        print_json(info.to_dict())
    else:
        print(f"wrote {out}/: {', '.join(info.files)}")
        print(f"  {info.steps_per_period} RK4 steps of {info.step_s:.6g} s per period {info.period_s:.6g} s; "
              f"data table {2 * info.steps_per_period + 1} x {info.n_data}")
        print(f"  runtime parameters p[]: {', '.join(info.runtime_params)} (everything else is baked in)")
        print(f"  build and run: make -C {out} && {out / 'bird_period'} 18 0.5 0.1 0.01")
    return EXIT_OK


# ---------------------------------------------------------------------------------------------
# level and sweep (birdocp.studies.level, birdocp.studies.sweep)

def _solve_shortcuts(p: argparse.ArgumentParser) -> None:
    s = p.add_argument_group("solve (shortcuts for solve.* keys)")
    s.add_argument("--points", type=int, metavar="M", help="shooting points per period, closing point included (solve.points)")
    s.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period, a multiple of M-1 (solve.steps_per_period)")
    s.add_argument("--solver", choices=("ipopt", "lm"), help="nonlinear solver (solve.solver)")
    s.add_argument("--derivatives", choices=("exact", "fd"), help="Jacobians by AD or finite differences (solve.derivatives)")


def _level_options(p: argparse.ArgumentParser, in_sweep: bool) -> None:
    g = p.add_argument_group("level flight" + (" (with --level)" if in_sweep else ""))
    g.add_argument("--free", metavar="KEY", default="amplitude",
                   help="parameter solved for: a dotted model parameter key or an alias (amplitude, "
                        "root_ahead_m); default amplitude (gait.shoulder_flap.amplitude_deg)")
    g.add_argument("--climb-rate", type=float, default=0.0, metavar="MPS",
                   help="target mean vertical speed in m/s, positive climbing (default 0: level flight)")
    g.add_argument("--constrain", default="vertical_speed_mps", metavar="MEAN",
                   help="condition: vertical_speed_mps (default; target --climb-rate), forward_speed_mps or "
                        "flight_path_angle_deg (target --target)")
    g.add_argument("--target", type=float, metavar="VALUE",
                   help="target of --constrain forward_speed_mps [m/s] or flight_path_angle_deg [deg]")
    g.add_argument("--bounds", type=float, nargs=2, metavar=("LO", "HI"),
                   help="bounds of the free parameter (default: 20..70 deg for the amplitude, value +-30 for "
                        "other _deg keys, -0.2..0.3 m for the wing root; required otherwise)")


def _add_level_parsers(sub, common) -> None:
    p = sub.add_parser("level", parents=[common], help="level (or climbing) flight: solve for the flapping amplitude",
                       description="Find the periodic flight with the flapping amplitude (or --free KEY) as an "
                                   "unknown such that the mean vertical speed is zero (or --climb-rate), in one "
                                   "NLP, and its Floquet multipliers. Writes a run folder like 'trim'.")
    _level_options(p, False)
    _solve_shortcuts(p)
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-level-<id>/")
    p.set_defaults(func=cmd_level)

    key = argparse.ArgumentParser(add_help=False)
    key.add_argument("key", metavar="KEY",
                     help="parameter to sweep: amplitude (gait.shoulder_flap.amplitude_deg), root_ahead_m / "
                          "root-ahead (wing.root_ahead_m), or any dotted model parameter key")
    p = sub.add_parser("sweep", parents=[key, common], help="a family of trims (or level solves) over one parameter",
                       description="Solve one limit cycle per value of KEY from --from to --to by --step, each "
                                   "warm-started from its neighbour, writing every point as soon as it is solved "
                                   "(points/, sweep.json, sweep.csv in the run folder). --resume DIR solves only "
                                   "the points missing there.")
    r = p.add_argument_group("range")
    r.add_argument("--from", dest="start", type=float, required=True, metavar="A", help="first value")
    r.add_argument("--to", dest="stop", type=float, required=True, metavar="B", help="last value (inclusive)")
    r.add_argument("--step", type=float, required=True, metavar="S", help="step (> 0)")
    p.add_argument("--level", action="store_true", help="each point a level-flight solve (see the level options)")
    p.add_argument("--cold", action="store_true", help="no warm starts: every point from the configured guess")
    p.add_argument("--out", metavar="DIR", help="run folder (new or empty; with --resume an earlier sweep's folder); "
                                                "default runs/<time>-sweep-<id>/")
    p.add_argument("--resume", action="store_true", help="continue the sweep in --out DIR (same arguments)")
    _level_options(p, True)
    _solve_shortcuts(p)
    x = p.add_argument_group("grid and executors")
    x.add_argument("--rows", metavar="KEY=A:B:S",
                   help="a grid: one warm-started line over KEY's range per value of this second parameter "
                        "(from A to B by S, inclusive), e.g. --rows root_ahead_m=0.035:0.065:0.005; writes "
                        "grid.json, grid.csv (no wall times: identical whatever the executor) and timing.json")
    x.add_argument("--jobs", type=int, metavar="N", help="run the rows of --rows in N local processes")
    x.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the rows of --rows on a Dask distributed cluster (e.g. tcp://host:8786; needs "
                        "pip install 'birdocp[cluster]' here and birdocp on the workers)")
    p.set_defaults(func=cmd_sweep)

    par = argparse.ArgumentParser(add_help=False)
    par.add_argument("param", metavar="PARAM", help="root_ahead_m | stability_margin (percent) | amplitude_deg | KEY")
    p = sub.add_parser("continue", parents=[par, common], help="follow a branch of periodic flights in one parameter "
                                                          "(pseudo-arclength continuation)",
                       description="Pseudo-arclength continuation of the trimmed flight from --from to --to, "
                                   "through folds, with fold / branch point / period doubling / Neimark-Sacker "
                                   "detection (located on the branch). PARAM: root_ahead_m (metres ahead of G), "
                                   "stability_margin (SM = -root_ahead_m / body.reference_chord_m, given in "
                                   "PERCENT: --from -32.5 --to -17.5), amplitude_deg, or a dotted model key. "
                                   "Writes branch.json, locus.png and moduli.png to the run folder.")
    p.add_argument("--from", dest="start", type=float, required=True, metavar="A", help="start value (a cycle is "
                   "solved there first)")
    p.add_argument("--to", dest="stop", type=float, required=True, metavar="B", help="end value")
    p.add_argument("--step", type=float, metavar="S", help="first step in PARAM's units (default |B-A|/10)")
    p.add_argument("--max-points", type=int, default=200, metavar="N", help="at most N points (default 200)")
    p.add_argument("--level", action="store_true",
                   help="hold level flight: the flapping amplitude is solved at every point (mean W = --climb-rate)")
    p.add_argument("--climb-rate", type=float, default=0.0, metavar="MPS", help="held mean vertical speed with --level")
    p.add_argument("--bounds", type=float, nargs=2, metavar=("LO", "HI"),
                   help="amplitude bounds with --level (default 20 70 deg); leaving them ends the branch")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty); default runs/<time>-continue-<id>/")
    _solve_shortcuts(p)
    p.set_defaults(func=cmd_continue)

    p = sub.add_parser("plot", help="redraw the figures of a run folder (trim, level, sweep, continue)",
                       description="Read RUN_DIR/result.json (and arrays.npz, sweep.json, branch.json) and write "
                                   "the run's figures into RUN_DIR.")
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    p.add_argument("--json", action="store_true", help="print the list of figures as JSON")
    p.set_defaults(func=cmd_plot)


def _level_kwargs(args: argparse.Namespace, cfg) -> dict:
    """Checked keyword arguments of birdocp.studies.level.level from the level options (no model import)."""
    from birdocp.studies.level import default_bounds, resolve_constraint, resolve_key

    free = resolve_key(args.free, "--free")
    constrain = resolve_constraint(args.constrain, "--constrain")
    (climb,) = finite_values("--climb-rate", [args.climb_rate])
    kw: dict = {"free": free, "constrain": constrain, "climb_rate_mps": climb}
    if constrain != "vertical_speed_mps":
        if args.target is None:
            raise ConfigError("--target", f"--constrain {constrain} needs --target VALUE")
        (kw["target"],) = finite_values("--target", [args.target])
        if constrain == "flight_path_angle_deg" and not -89 < kw["target"] < 89:
            raise ConfigError("--target", f"flight path angle must lie in (-89, 89) deg, got {kw['target']!r}")
    elif args.target is not None:
        (kw["climb_rate_mps"],) = finite_values("--target", [args.target])
    if args.bounds is not None:
        lo, hi = finite_values("--bounds", args.bounds)
        if not lo < hi:
            raise ConfigError("--bounds", f"need LO < HI, got {lo} {hi}")
        kw["bounds"] = (lo, hi)
    else:
        try:
            default_bounds(cfg, free)
        except ConfigError as exc:
            raise ConfigError("--bounds", f"{config_message(exc)} (--bounds LO HI)") from None
    return kw


def cmd_level(args: argparse.Namespace, command_line: list[str]) -> int:
    from birdocp.io.runs import claim_out_dir, new_run_dir, write_run

    t_start = time.perf_counter()
    cfg = resolve_config(args)
    kw = _level_kwargs(args, cfg)
    run_dir = claim_out_dir(args.out, "level") if args.out else new_run_dir(None, "level")
    try:
        with stdout_to_stderr():
            from birdocp.studies.level import level

            res = level(cfg, **kw)
            result = dict(res.to_dict())
            arrays = res.arrays()
    except BaseException:
        with contextlib.suppress(OSError):
            run_dir.rmdir()
        raise
    free = kw["free"]
    result["free_key"] = free
    result["free_value"] = result.get("free_values", {}).get(free)
    result["constrain"] = kw["constrain"]
    result["target"] = kw.get("target", kw["climb_rate_mps"])
    finish_result(result, "level", t_start, run_dir)
    write_run(run_dir, cfg, result, arrays, command_line, command="level")

    if args.json:
        print_json(result)
    else:
        table = format_trim_table(result).replace("trim:", "level:", 1)
        name = "amplitude A" if free == AMPLITUDE_KEY else free
        unit = " deg" if free.endswith("_deg") else " m" if free.endswith("_m") else ""
        head = [f"level flight: {name} = {fmt_num(result['free_value'], '.6f')}{unit} "
                f"(mean {kw['constrain']} = {fmt_num(result['target'], 'g')})"]
        if free != AMPLITUDE_KEY:
            head.append(f"amplitude: {fmt_num(result.get('amplitude_deg'), '.6f')} deg")
        print("\n".join(head) + "\n" + table)
    if not res.success:
        print(f"{PROG}: level flight not found (status: {one_line(res.status)}, max residual: "
              f"{fmt_num(result.get('max_residual'), '.3e')}): {one_line(res.message)}; result written to {run_dir}",
              file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _sweep_out_dir(args: argparse.Namespace) -> Path:
    from birdocp.io.runs import claim_out_dir, new_run_dir

    if not args.resume:
        return claim_out_dir(args.out, "sweep") if args.out else new_run_dir(None, "sweep")
    if not args.out:
        raise ConfigError("--resume", "needs --out DIR, the folder of the sweep to continue")
    path = Path(args.out)
    if path.exists() and not path.is_dir():
        raise ConfigError("--out", f"'{path}' is an existing file; give the folder of a sweep")
    if path.is_dir() and any(path.iterdir()) and not (path / "sweep.json").exists():
        raise ConfigError("--out", f"'{path}' holds no sweep (no sweep.json) to resume")
    path.mkdir(parents=True, exist_ok=True)
    return path


def format_sweep_table(rows: list[dict], key: str, level: bool) -> str:
    head = f"{'value':>10}  {'ok':>3}  {'it':>3}  {'|lambda1|':>9}  {'|lambda2,3|':>11}  {'|lambda4|':>9}  " \
           f"{'U [m/s]':>8}  {'W [m/s]':>8}  {'beta [deg]':>10}" + (f"  {'A [deg]':>9}" if level else "") + \
           f"  {'wall [s]':>8}  model"
    lines = [f"sweep of {key}" + (" (level flight)" if level else ""), head]
    for r in rows:
        line = (f"{fmt_num(r['value'], 'g'):>10}  {'yes' if r['success'] else 'NO':>3}  {fmt_num(r['iterations'], 'd'):>3}  "
                f"{fmt_num(r['modulus0'], '.6f'):>9}  {fmt_num(r['modulus1'], '.6f'):>11}  {fmt_num(r['modulus3'], '.6f'):>9}  "
                f"{fmt_num(r['mean_forward_speed_mps'], '.4f'):>8}  {fmt_num(r['mean_vertical_speed_mps'], '+.4f'):>8}  "
                f"{fmt_num(r['flight_path_angle_deg'], '+.4f'):>10}")
        if level:
            line += f"  {fmt_num(r['amplitude_deg'], '.4f'):>9}"
        lines.append(line + f"  {fmt_num(r['wall_s'], '.2f'):>8}  {validity_word(r.get('valid'))}")
    return "\n".join(lines + validity_notes(rows))


def cmd_sweep(args: argparse.Namespace, command_line: list[str]) -> int:
    from birdocp.studies.level import resolve_key
    from birdocp.studies.sweep import sweep, sweep_values

    t_start = time.perf_counter()
    key = resolve_key(args.key, "KEY")
    values = sweep_values(args.start, args.stop, args.step)
    cfg = resolve_config(args)
    for v in values:  # every value checked before anything is solved or written
        try:
            C.with_values(cfg, {key: v})
        except ConfigError as exc:
            raise ConfigError(exc.key, f"{config_message(exc)} (sweep value {v:g})") from None
    level_kw = _level_kwargs(args, cfg) if args.level else None
    if level_kw is not None and level_kw["free"] == key:
        raise ConfigError("KEY", f"'{key}' is the free parameter of --level; sweep another parameter or pick --free")
    if args.rows or args.jobs is not None or args.scheduler:
        return _cmd_grid(args, command_line, cfg, key, values, level_kw, t_start)
    run_dir = _sweep_out_dir(args)
    fresh = not any(run_dir.iterdir())
    try:
        with stdout_to_stderr():
            rows = sweep(cfg, key, values, level=args.level, warm=not args.cold, out_dir=run_dir,
                         resume=args.resume, progress=not args.quiet, level_options=level_kw)
    except BaseException:
        if fresh:
            with contextlib.suppress(OSError):
                if not any(p for p in run_dir.iterdir() if p.name != "config.toml"):
                    (run_dir / "config.toml").unlink(missing_ok=True)
                    run_dir.rmdir()
        raise
    from birdocp.io.runs import write_run

    ok = all(r["success"] for r in rows)
    result = {"success": ok, "key": key, "values": values, "level": bool(args.level),
              "level_options": level_kw, "converged": sum(r["success"] for r in rows), "points": rows,
              "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run_dir)}
    write_run(run_dir, cfg, result, None, command_line, command="sweep")
    if args.json:
        print_json(result)
    else:
        print(format_sweep_table(rows, key, args.level))
        print(f"run folder  {run_dir}  (sweep.csv, sweep.json, points/)")
    if not ok:
        bad = [fmt_num(r["value"], "g") for r in rows if not r["success"]]
        print(f"{PROG}: {len(bad)} of {len(rows)} points did not converge ({', '.join(bad)}); "
              f"results written to {run_dir}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _parse_rows(text: str | None):
    from birdocp.studies.level import resolve_key
    from birdocp.studies.sweep import sweep_values

    if not text:
        raise ConfigError("--rows", "--jobs and --scheduler run the rows of a grid: give --rows KEY=A:B:S")
    try:
        k, rng = text.split("=", 1)
        a, b, st = (float(v) for v in rng.split(":"))
    except ValueError:
        raise ConfigError("--rows", f"expected KEY=A:B:S, got {text!r}") from None
    return resolve_key(k, "--rows"), sweep_values(a, b, st)


def _cmd_grid(args, command_line, cfg, key, values, level_kw, t_start) -> int:
    from birdocp.engine.executors import get_executor
    from birdocp.io.runs import claim_out_dir, new_run_dir
    from birdocp.studies.sweep import grid_sweep

    row_key, row_values = _parse_rows(args.rows)
    if row_key == key:
        raise ConfigError("--rows", "the row parameter must differ from KEY")
    for v in row_values:
        C.with_values(cfg, {row_key: v})
    if args.jobs is not None and args.jobs < 1:
        raise ConfigError("--jobs", f"must be >= 1, got {args.jobs}")
    if args.resume:
        raise ConfigError("--resume", "not available for grids (--rows)")
    run_dir = claim_out_dir(args.out, "sweep") if args.out else new_run_dir(None, "sweep")
    ex = get_executor(args.jobs, args.scheduler)
    try:
        with stdout_to_stderr(), ex:
            rows = grid_sweep(cfg, key, values, row_key, row_values, executor=ex, level=args.level,
                              warm=not args.cold, out_dir=run_dir, level_options=level_kw)
    except ImportError as exc:
        raise ConfigError("--scheduler", str(exc)) from None
    from birdocp.io.runs import write_run

    ok = all(r["success"] for r in rows)
    result = {"success": ok, "key": key, "values": values, "row_key": row_key, "row_values": row_values,
              "level": bool(args.level), "grid": True, "executor": ex.describe(),
              "converged": sum(r["success"] for r in rows), "points": rows,
              "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run_dir)}
    write_run(run_dir, cfg, result, None, command_line, command="sweep")
    if args.json:
        print_json(result)
    else:
        print(f"grid {row_key} x {key}" + (" (level flight)" if args.level else ""))
        print(f"{'row value':>10}  {'value':>10}  {'ok':>3}  {'|lambda1|':>9}  {'U [m/s]':>8}  {'W [m/s]':>8}  model")
        for r in rows:
            print(f"{fmt_num(r['row_value'], 'g'):>10}  {fmt_num(r['value'], 'g'):>10}  {'yes' if r['success'] else 'NO':>3}  "
                  f"{fmt_num(r['modulus0'], '.6f'):>9}  {fmt_num(r['mean_forward_speed_mps'], '.4f'):>8}  "
                  f"{fmt_num(r['mean_vertical_speed_mps'], '+.4f'):>8}  {validity_word(r.get('valid'))}")
        print(f"run folder  {run_dir}  (grid.csv, grid.json, timing.json)")
    return EXIT_OK if ok else EXIT_NOT_CONVERGED


# ---------------------------------------------------------------------------------------------
# continue and plot (birdocp.engine.continuation)

def cmd_continue(args: argparse.Namespace, command_line: list[str]) -> int:
    from birdocp.studies.branch import resolve_parameter, root_of_sm

    t_start = time.perf_counter()
    model_key, display = resolve_parameter(args.param)
    cfg = resolve_config(args)
    a, b = finite_values("--from/--to", [args.start, args.stop])
    if a == b:
        raise ConfigError("--to", "must differ from --from")
    conv = (lambda v: root_of_sm(v, cfg.body.reference_chord_m)) if display == "stability_margin" else (lambda v: v)
    for v in (a, b):
        C.with_values(cfg, {model_key: conv(v)})
    if args.level and model_key == AMPLITUDE_KEY:
        raise ConfigError("--level", "the amplitude is what --level solves for: continue another parameter")
    if args.step is not None and not (math.isfinite(args.step) and args.step > 0):
        raise ConfigError("--step", f"must be positive, got {args.step!r}")
    if args.max_points < 2:
        raise ConfigError("--max-points", "must be >= 2")
    from birdocp.io.runs import claim_out_dir, new_run_dir

    run_dir = claim_out_dir(args.out, "continue") if args.out else new_run_dir(None, "continue")
    from birdocp.plots.branch import plot_branches
    from birdocp.studies.branch import bird_branch
    from birdocp.io.files import atomic_write_json

    from birdocp.io.progress import progress_callback

    say, bar = progress_callback(f"continue {args.param}", args.quiet)
    with stdout_to_stderr(), bar:
        br = bird_branch(cfg, args.param, a, b, level=args.level, climb_rate_mps=args.climb_rate, bounds=args.bounds,
                         step=args.step, max_points=args.max_points, progress=say)
    d = br.to_dict()
    atomic_write_json(run_dir / "branch.json", d)
    figs = plot_branches({"level flight" if args.level else "branch": br}, run_dir) if br.points else []
    from birdocp.io.runs import write_run

    ok = br.end_reason in ("reached_to", "reached_from") and bool(br.points)
    summary = {"success": ok, "parameter": br.parameter_name, "display": display, "from": a, "to": b,
               "level": bool(args.level), "end_reason": br.end_reason, "end_message": br.end_message,
               "n_points": len(br.points), "special_points": d["special_points"],
               "stable_anywhere": any(p.stable for p in br.points), "figures": [f.name for f in figs],
               "valid_points": sum(bool(p.validity and p.validity["valid"]) for p in br.points),
               "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run_dir)}
    write_run(run_dir, cfg, summary, None, command_line, command="continue")
    if args.json:
        print_json(dict(summary, branch=d))
    else:
        sm = display == "stability_margin"
        print(f"continuation in {display}" + (" (level flight held)" if args.level else ""))
        print(f"{'SM [%]' if sm else 'value':>12}  {'|lambda1|':>9}  {'|lambda2|':>9}  {'|lambda4|':>9}  stable"
              + ("  A [deg]" if args.level else "") + "  model")
        for p in br.points:
            v = -100 * p.parameter / cfg.body.reference_chord_m if sm else p.parameter
            line = (f"{v:12.6g}  {p.moduli[0]:9.6f}  {p.moduli[1]:9.6f}  {p.moduli[-1]:9.6f}  "
                    f"{'yes' if p.stable else 'no':>6}")
            if args.level:
                line += f"  {list(p.free_values.values())[0]:7.3f}"
            print(line + f"  {validity_word((p.validity or {}).get('valid'))}")
        invalid = [p for p in br.points if p.validity and not p.validity["valid"]]
        if invalid:
            first = invalid[0]
            v = -100 * first.parameter / cfg.body.reference_chord_m if sm else first.parameter
            print(f"model validity: {len(invalid)} of {len(br.points)} points NOT valid; the first at {v:.6g}: "
                  + "; ".join(first.validity["reasons"]))
        for sp in br.special_points:
            v = -100 * sp.parameter / cfg.body.reference_chord_m if sm else sp.parameter
            print(f"special point: {sp.kind} at {v:.8g} ({sp.message})")
        print(f"end: {br.end_reason}: {br.end_message}")
        print(f"run folder  {run_dir}  (branch.json, {', '.join(f.name for f in figs)})")
    return EXIT_OK if ok else EXIT_NOT_CONVERGED


def cmd_plot(args: argparse.Namespace, command_line: list[str]) -> int:
    run = Path(args.run_dir)
    res_path = run / "result.json"
    if not res_path.is_file():
        raise ConfigError("RUN_DIR", f"'{run}' holds no result.json (not a birdocp run folder)")
    try:
        res = json.loads(res_path.read_text())
    except ValueError as exc:
        raise ConfigError("RUN_DIR", f"unreadable result.json: {exc}") from None
    command = (res.get("provenance") or {}).get("command")
    figs = []
    with stdout_to_stderr():
        if (run / "branch.json").is_file():
            from birdocp.engine.continuation import Branch
            from birdocp.plots.branch import plot_branches

            br = Branch.from_dict(json.loads((run / "branch.json").read_text()))
            figs = plot_branches({"level flight" if br.settings.get("level") else "branch": br}, run)
        elif (run / "grid.json").is_file():
            figs = _plot_grid(run)
        elif (run / "sweep.json").is_file():
            figs = _plot_sweep(run)
        elif command in ("trim", "level") or "x0" in res:
            from birdocp.plots import figures as plots

            arrays = {}
            if (run / "arrays.npz").is_file():
                import numpy as np

                with np.load(run / "arrays.npz") as z:
                    arrays = {k: z[k] for k in z.files}
            cyc = dict(res, **arrays)
            if "trajectory_x" in cyc:
                figs.append(plots.plot_states(cyc, run / "states.png"))
                figs.append(plots.plot_phase_portrait(cyc, run / "phase.png"))
            if cyc.get("multipliers") is not None:
                figs.append(plots.plot_multipliers({command or "cycle": cyc["multipliers"]}, run / "multipliers.png"))
            if cyc.get("residual_history") is not None:
                figs.append(plots.plot_convergence({command or "cycle": cyc["residual_history"]}, run / "convergence.png"))
        else:
            raise ConfigError("RUN_DIR", f"do not know how to plot a '{command}' run")
    names = [Path(f).name for f in figs]
    if args.json:
        print_json({"run_dir": str(run), "figures": names})
    else:
        print(f"wrote {', '.join(names) or 'no figures'} in {run}")
    return EXIT_OK


def _plot_rows(rows, xkey, path, title, xlabel):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from birdocp.plots.figures import save_figure

    fig, ax = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    groups = {}
    for r in rows:
        groups.setdefault(r.get("row_value"), []).append(r)
    for g, rs in groups.items():
        x = np.array([r[xkey] for r in rs], float)
        lab = "" if g is None else f" ({g:g})"
        for k in range(4):
            y = np.array([np.nan if r.get(f"modulus{k}") is None else r[f"modulus{k}"] for r in rs], float)
            ax[0].plot(x, y, "o-" if k == 0 else ".--", ms=4, label=f"|L{k + 1}|{lab}" if k in (0, 1) else None)
        w = np.array([np.nan if r.get("mean_vertical_speed_mps") is None else r["mean_vertical_speed_mps"] for r in rs])
        ax[1].plot(x, w, "o-", ms=4, label=f"mean W{lab}")
        bad = np.array([r.get("valid") is False for r in rs])
        if bad.any():  # the model does not hold on these cycles (birdocp.bird.validity)
            m0 = np.array([np.nan if r.get("modulus0") is None else r["modulus0"] for r in rs], float)
            ax[0].plot(x[bad], m0[bad], "x", color="0.4", ms=9, mew=2, label="model not valid")
            ax[1].plot(x[bad], w[bad], "x", color="0.4", ms=9, mew=2, label="model not valid")
    ax[0].axhline(1, color="k", lw=0.8)
    ax[0].set_ylabel("|multiplier|")
    ax[0].set_title(title)
    ax[0].legend(fontsize=7)
    ax[1].set_ylabel("mean vertical speed [m/s]")
    ax[1].set_xlabel(xlabel)
    ax[1].legend(fontsize=7)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    p = save_figure(fig, path)
    plt.close(fig)
    return p


def _plot_sweep(run: Path):
    d = json.loads((run / "sweep.json").read_text())
    return [_plot_rows(d.get("points", []), "value", run / "sweep.png", f"sweep of {d.get('key')}", d.get("key"))]


def _plot_grid(run: Path):
    d = json.loads((run / "grid.json").read_text())
    return [_plot_rows(d.get("points", []), "value", run / "grid.png",
                       f"grid: lines over {d.get('key')}, one per {d.get('row_key')}", d.get("key"))]


# ---------------------------------------------------------------------------------------------
# Entry point

def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script passes it to ``sys.exit``)."""
    if argv is None:
        argv = sys.argv[1:]
        command_line = [PROG, *argv]
    else:
        argv = list(argv)
        command_line = [PROG, *argv]
    debug = "--debug" in argv
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help, --version, or a usage error (already printed)
            return exc.code if isinstance(exc.code, int) else EXIT_BAD_INPUT
        debug = args.debug
        return args.func(args, command_line)
    except KeyboardInterrupt:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ConfigError as exc:
        if debug:
            traceback.print_exc()
        msg = one_line(config_message(exc))
        print(f"{PROG}: error: {exc.key}: {msg}" if exc.key else f"{PROG}: error: {msg}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:  # e.g. birdocp config | head -1
        with contextlib.suppress(OSError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        return EXIT_OK
    except Exception as exc:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: internal error: {type(exc).__name__}: {one_line(exc)}"
              + ("" if debug else "; rerun with --debug for the traceback"), file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
