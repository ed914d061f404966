"""``birdocp sweep``: a family of trims (or level solves) over one parameter, or a grid of such lines."""

from __future__ import annotations

import argparse
import sys
import time

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.cli.common import (EXIT_NOT_CONVERGED, EXIT_OK, PROG, compiled_requested, config_message, fmt_num,
                                noise_summary, one_line, resolve_config, run_folder, validity_notes, validity_word)
from birdocp.cli.level import LEVEL_FLAGS, level_kwargs, level_options
from birdocp.cli.trim import solve_shortcuts


def register(sub, common) -> None:
    """Add ``sweep`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    key = argparse.ArgumentParser(add_help=False)
    key.add_argument("key", metavar="KEY",
                     help="parameter to sweep: amplitude (gait.shoulder_flap.amplitude_deg), root_ahead_m / "
                          "root-ahead (wing.root_ahead_m), or any dotted model parameter key")
    p = sub.add_parser("sweep", parents=[key, common], help="a family of trims (or level solves) over one parameter",
                       description="Solve one limit cycle per value of KEY from --from to --to --by S, each "
                                   "warm-started from its neighbour, writing every point as soon as it is solved "
                                   "(points/, sweep.json, sweep.csv in the run folder). --resume DIR solves only "
                                   "the points missing there.")
    r = p.add_argument_group("range")
    r.add_argument("--from", dest="start", type=float, required=True, metavar="A", help="first value")
    r.add_argument("--to", dest="stop", type=float, required=True, metavar="B",
                   help="last value (inclusive, also when B - A is not a multiple of the step: the last "
                        "interval is then shorter)")
    r.add_argument("--by", dest="step", type=float, metavar="S",
                   help="step between values (> 0, at most |B - A|; at most 10000 values; required)")
    r.add_argument("--step", dest="step", type=float, help=argparse.SUPPRESS)  # the old name of --by
    p.add_argument("--level", action="store_true", help="each point a level-flight solve (see the level options)")
    p.add_argument("--cold", action="store_true", help="no warm starts: every point from the configured guess")
    p.add_argument("--out", metavar="DIR", help="run folder (new or empty; with --resume an earlier sweep's folder); "
                                                "default runs/<time>-sweep-<id>/")
    p.add_argument("--resume", action="store_true", help="continue the sweep (or grid) in --out DIR (same arguments)")
    level_options(p, True)
    solve_shortcuts(p)
    x = p.add_argument_group("grid and executors")
    x.add_argument("--rows", metavar="KEY=A:B:S",
                   help="a grid: one warm-started line over KEY's range per value of this second parameter "
                        "(from A to B by S, inclusive), e.g. --rows root_ahead_m=0.035:0.065:0.005; writes "
                        "rows/ as each row finishes, then grid.json, grid.csv (no wall times: identical "
                        "whatever the executor) and timing.json")
    x.add_argument("--jobs", type=int, metavar="N", help="run the rows of --rows in N local processes")
    x.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the rows of --rows on a Dask distributed cluster (e.g. tcp://host:8786; needs "
                        "pip install 'birdocp[cluster]' here and birdocp on the workers)")
    p.set_defaults(func=cmd_sweep)


def _format_sweep_table(rows: list[dict], key: str, level: bool) -> str:
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
    if rows and "lateral_modulus0" in rows[0]:  # six degrees of freedom: the split multipliers
        lines += ["", "six degrees of freedom: moduli of the lateral (v, p, r, phi) multipliers (heading's 1 apart)",
                  f"{'value':>10}  {'lateral moduli':<40}  {'spiral':>8}  lateral"]
        for r in rows:
            mods = " ".join(fmt_num(r.get(f"lateral_modulus{k}"), ".6f") for k in range(4))
            verdict = {True: "stable", False: "unstable"}.get(r.get("lateral_stable"), "unknown")
            lines.append(f"{fmt_num(r['value'], 'g'):>10}  {mods:<40}  {fmt_num(r.get('spiral_modulus'), '.6f'):>8}  "
                         f"{verdict}")
    return "\n".join(lines + validity_notes(rows))


def _format_grid_table(rows: list[dict], key: str, row_key: str, level: bool) -> str:
    lines = [f"grid {row_key} x {key}" + (" (level flight)" if level else ""),
             f"{'row value':>10}  {'value':>10}  {'ok':>3}  {'|lambda1|':>9}  {'U [m/s]':>8}  {'W [m/s]':>8}  model"]
    for r in rows:
        lines.append(f"{fmt_num(r['row_value'], 'g'):>10}  {fmt_num(r['value'], 'g'):>10}  "
                     f"{'yes' if r['success'] else 'NO':>3}  {fmt_num(r['modulus0'], '.6f'):>9}  "
                     f"{fmt_num(r['mean_forward_speed_mps'], '.4f'):>8}  {fmt_num(r['mean_vertical_speed_mps'], '+.4f'):>8}  "
                     f"{validity_word(r.get('valid'))}")
    return "\n".join(lines)


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
    try:
        return resolve_key(k, "--rows"), sweep_values(a, b, st)
    except ConfigError as exc:
        raise ConfigError("--rows", f"{exc.key}: {config_message(exc)}" if exc.key != "--rows" else config_message(exc)) \
            from None


def _report(run, rows: list[dict], ok: bool) -> int:
    if ok:
        return EXIT_OK
    bad = [fmt_num(r["value"], "g") + (f" (row {fmt_num(r['row_value'], 'g')})" if "row_value" in r else "")
           for r in rows if not r["success"]]
    warn = noise_summary(run.noise)
    print(f"{PROG}: {len(bad)} of {len(rows)} points did not converge ({', '.join(bad)}); "
          f"results written to {run.dir}{warn}", file=sys.stderr)
    return EXIT_NOT_CONVERGED


def cmd_sweep(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp sweep``.

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
    from birdocp.studies.level import resolve_key
    from birdocp.studies.sweep import sweep, sweep_values

    t_start = time.perf_counter()
    key = resolve_key(args.key, "KEY")
    if args.step is None:
        raise ConfigError("--by", "the step between values is required, e.g. --from 40 --to 46 --by 0.5")
    values = sweep_values(args.start, args.stop, args.step)
    cfg = resolve_config(args)
    for v in values:  # every value checked before anything is solved or written
        try:
            C.with_values(cfg, {key: v})
        except ConfigError as exc:
            raise ConfigError(exc.key, f"{config_message(exc)} (sweep value {v:g})") from None
    if not args.level:  # the level options mean nothing without --level: refused, not ignored
        for flag, attr in LEVEL_FLAGS:
            if getattr(args, attr) is not None:
                raise ConfigError(flag, "is an option of level flight: add --level (or drop it)")
    level_kw = level_kwargs(args, cfg) if args.level else None
    if level_kw is not None and level_kw["free"] == key:
        raise ConfigError("KEY", f"'{key}' is the free parameter of --level; sweep another parameter or pick --free")
    if args.resume and not args.out:
        raise ConfigError("--resume", "needs --out DIR, the folder of the sweep to continue")
    if args.rows or args.jobs is not None or args.scheduler:
        return _cmd_grid(args, command_line, cfg, key, values, level_kw, t_start)
    resume_file = "sweep.json" if args.resume else None
    with run_folder(args, "sweep", command_line, resume_file=resume_file,
                    scaffold=("config.toml", "sweep.json", "sweep.csv")) as run:
        with run.solving():
            rows = sweep(cfg, key, values, level=args.level, warm=not args.cold, out_dir=run.dir,
                         resume=args.resume, progress=not args.quiet, level_options=level_kw,
                         compiled=compiled_requested(args))
        ok = all(r["success"] for r in rows)
        result = {"success": ok, "status": "converged" if ok else "some_points_failed", "key": key,
                  "values": values, "level": bool(args.level), "level_options": level_kw,
                  "converged": sum(r["success"] for r in rows), "points": rows,
                  "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run.dir)}
        run.write(cfg, result)
        run.output(result, _format_sweep_table(rows, key, args.level)
                   + f"\nrun folder  {run.dir}  (sweep.csv, sweep.json, points/)")
        return _report(run, rows, ok)


def _grid_executor(args):
    """The executor of ``--jobs`` / ``--scheduler``, checked before any run folder exists: both at once,
    a missing 'distributed' or a scheduler that cannot be reached is a ConfigError (exit 2)."""
    from birdocp.engine.executors import get_executor

    if args.jobs is not None and args.scheduler:
        raise ConfigError("--scheduler", "runs the rows on a cluster and --jobs in local processes: give one of them")
    try:
        ex = get_executor(args.jobs, args.scheduler)
    except ImportError as exc:
        raise ConfigError("--scheduler", str(exc)) from None
    if args.scheduler:
        try:
            ex.start()
        except (OSError, ValueError) as exc:  # distributed: OSError on a timeout, ValueError on a bad address
            ex.close()
            raise ConfigError("--scheduler", f"cannot reach '{args.scheduler}' ({one_line(exc)[:200]}); start "
                                             "the scheduler or fix the address") from None
    return ex


def _cmd_grid(args, command_line, cfg, key, values, level_kw, t_start) -> int:
    row_key, row_values = _parse_rows(args.rows)
    if row_key == key:
        raise ConfigError("--rows", "the row parameter must differ from KEY")
    for v in row_values:
        C.with_values(cfg, {row_key: v})
    if args.jobs is not None and args.jobs < 1:
        raise ConfigError("--jobs", f"must be >= 1, got {args.jobs}")
    if args.jobs is not None and args.jobs > 256:
        raise ConfigError("--jobs", f"must be <= 256, got {args.jobs}")
    resume_file = "grid.json" if args.resume else None
    ex = _grid_executor(args)
    try:
        return _run_grid(args, command_line, cfg, key, values, level_kw, t_start, row_key, row_values, resume_file, ex)
    finally:
        ex.close()  # also when the run folder cannot be claimed


def _run_grid(args, command_line, cfg, key, values, level_kw, t_start, row_key, row_values, resume_file, ex) -> int:
    from birdocp.studies.sweep import grid_sweep

    with run_folder(args, "sweep", command_line, resume_file=resume_file, scaffold=("grid.json",)) as run:
        with run.solving(), ex:
            rows = grid_sweep(cfg, key, values, row_key, row_values, executor=ex, level=args.level,
                              warm=not args.cold, out_dir=run.dir, resume=args.resume, level_options=level_kw,
                              compiled=compiled_requested(args))
        ok = all(r["success"] for r in rows)
        result = {"success": ok, "status": "converged" if ok else "some_points_failed", "key": key,
                  "values": values, "row_key": row_key, "row_values": row_values,
                  "level": bool(args.level), "grid": True, "executor": ex.describe(),
                  "converged": sum(r["success"] for r in rows), "points": rows,
                  "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run.dir)}
        run.write(cfg, result)
        run.output(result, _format_grid_table(rows, key, row_key, args.level)
                   + f"\nrun folder  {run.dir}  (grid.csv, grid.json, timing.json)")
        return _report(run, rows, ok)
