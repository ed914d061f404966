"""``birdocp continue``: pseudo-arclength continuation of the periodic flight in one parameter."""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

from birdocp.bird import config as C
from birdocp.bird.config import ConfigError
from birdocp.cli.common import (AMPLITUDE_KEY, EXIT_NOT_CONVERGED, EXIT_OK, PROG, add_bounds_option, bounds_of,
                                compiled_requested, finite_values, noise_summary, resolve_config, run_folder,
                                validity_word)
from birdocp.cli.trim import solve_shortcuts


def register(sub, common) -> None:
    """Add ``continue`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    par = argparse.ArgumentParser(add_help=False)
    par.add_argument("param", metavar="PARAM", help="root_ahead_m | stability_margin (percent) | amplitude_deg | KEY")
    p = sub.add_parser("continue", parents=[par, common], help="follow a branch of periodic flights in one parameter "
                                                          "(pseudo-arclength continuation)",
                       description="Pseudo-arclength continuation of the trimmed flight from --from to --to, "
                                   "through folds, with fold / branch point / period doubling / Neimark-Sacker "
                                   "detection (located on the branch), and every crossing of a validity limit "
                                   "located as a validity_boundary special point naming the limit. PARAM: root_ahead_m (metres ahead of G), "
                                   "stability_margin (SM = -root_ahead_m / body.reference_chord_m, given in "
                                   "PERCENT: --from -32.5 --to -17.5), amplitude_deg, or a dotted model key. "
                                   "Writes branch.json, locus.png and moduli.png to the run folder.")
    p.add_argument("--from", dest="start", type=float, required=True, metavar="A", help="start value (a cycle is "
                   "solved there first)")
    p.add_argument("--to", dest="stop", type=float, required=True, metavar="B", help="end value")
    p.add_argument("--first-step", dest="step", type=float, metavar="S",
                   help="first step in PARAM's units (default |B-A|/10)")
    p.add_argument("--step", dest="step", type=float, help=argparse.SUPPRESS)  # the old name of --first-step
    p.add_argument("--max-points", type=int, default=200, metavar="N", help="at most N points (default 200, "
                   "at most 100000)")
    p.add_argument("--level", action="store_true",
                   help="hold level flight: the flapping amplitude is solved at every point (mean W = --climb-rate)")
    p.add_argument("--climb-rate", type=float, metavar="MPS", help="held mean vertical speed with --level (default 0)")
    add_bounds_option(p, "amplitude bounds with --level, --bounds amplitude=LO:HI (default 20:70 deg; LO < HI); "
                         "leaving them ends the branch")
    p.add_argument("--stop-at-invalid", action="store_true",
                   help="end the branch where it leaves the model's validity ([validity] limits): at the located "
                        "validity boundary, or at the start if the start is not valid (default: go on, the points "
                        "marked invalid; the boundary is a special point either way)")
    p.add_argument("--out", metavar="DIR", help="run folder to write (new or empty; with --resume an interrupted "
                                                "continuation's folder); default runs/<time>-continue-<id>/")
    p.add_argument("--resume", action="store_true",
                   help="continue the interrupted continuation in --out DIR (same arguments): the points on disk "
                        "(points/) are kept and the branch goes on from the last one")
    p.add_argument("--error-estimate", action="store_true",
                   help="give every point an error_estimate (a re-solve on twice the RK4 steps and the solver's "
                        "tolerance: multipliers, x0, means, free values); costs about one more solve per point")
    solve_shortcuts(p)
    p.set_defaults(func=cmd_continue)


def cmd_continue(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp continue``.

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
    from birdocp.studies.branch import resolve_parameter, root_of_sm

    t_start = time.perf_counter()
    model_key, display = resolve_parameter(args.param)
    cfg = resolve_config(args)
    for key in ("max_iter", "tol"):  # the corrector has its own settings: refused, not ignored
        if getattr(cfg.solve, key) != getattr(C.Solve(), key):
            raise ConfigError(f"solve.{key}", "is not used by continue (its corrector has its own settings); drop it")
    a, b = finite_values("--from/--to", [args.start, args.stop])
    if a == b:
        raise ConfigError("--to", "must differ from --from")
    conv = (lambda v: root_of_sm(v, cfg.body.reference_chord_m)) if display == "stability_margin" else (lambda v: v)
    for v in (a, b):
        C.with_values(cfg, {model_key: conv(v)})
    if args.level and model_key == AMPLITUDE_KEY:
        raise ConfigError("--level", "the amplitude is what --level solves for: continue another parameter")
    if args.step is not None and not (math.isfinite(args.step) and args.step > 0):
        raise ConfigError("--first-step", f"must be positive, got {args.step!r}")
    if not 2 <= args.max_points <= 100000:
        raise ConfigError("--max-points", f"must be in [2, 100000], got {args.max_points}")
    for flag, value in (("--climb-rate", args.climb_rate), ("--bounds", args.bounds)):
        if value is not None and not args.level:  # refused, not ignored
            raise ConfigError(flag, "is an option of level flight: add --level (or drop it)")
    (climb,) = finite_values("--climb-rate", [0.0 if args.climb_rate is None else args.climb_rate])
    bounds = bounds_of(args.bounds, AMPLITUDE_KEY)
    if args.resume and not args.out:
        raise ConfigError("--resume", "needs --out DIR, the folder of the continuation to continue")
    spec = {"param": args.param, "parameter": model_key, "from": a, "to": b, "level": bool(args.level),
            "climb_rate_mps": climb, "bounds": bounds, "step": args.step, "max_points": args.max_points,
            "stop_at_invalid": bool(args.stop_at_invalid),
            "config": C.to_dict(cfg)}
    if args.error_estimate:  # only then: the index of a run without it stays as it was (resume checks it)
        spec["error_estimate"] = True
    with run_folder(args, "continue", command_line, resume_file=INDEX if args.resume else None,
                    scaffold=(INDEX,)) as run:
        from birdocp.io.files import atomic_write_json
        from birdocp.io.resume import plain

        kept, kept_specials = _resumable(run.dir, spec, cfg, args.resume)
        atomic_write_json(run.dir / INDEX, plain(spec))
        rec = _Recorder(run.dir, cfg, spec, kept, kept_specials)
        try:
            br = _follow(args, cfg, model_key, display, a, b, climb, bounds, rec, run)
        except KeyboardInterrupt:
            if rec.points:
                _keep_partial(run, cfg, model_key, display, a, b, args.level, rec.points, rec.specials, t_start)
            raise
        return _finish(run, args, br, cfg, display, a, b, len(kept), t_start)


def _finish(run, args, br, cfg, display: str, a: float, b: float, resumed: int, t_start: float) -> int:
    """branch.json, the figures and result.json of a finished branch; the table or the JSON object;
    the exit code (1 when the branch ended before --to)."""
    from birdocp.io.files import atomic_write_json
    from birdocp.plots.branch import plot_branches

    d = br.to_dict()
    atomic_write_json(run.dir / "branch.json", d)
    figs = plot_branches({"level flight" if args.level else "branch": br}, run.dir) if br.points else []
    # a stop at the validity boundary is what --stop-at-invalid asked for, not a failure
    ok = br.end_reason in ("reached_to", "reached_from", "stopped_at_event") and bool(br.points)
    summary = {"success": ok, "status": br.end_reason, "parameter": br.parameter_name, "display": display,
               "from": a, "to": b, "level": bool(args.level), "end_reason": br.end_reason,
               "end_message": br.end_message, "n_points": len(br.points), "special_points": d["special_points"],
               "stable_anywhere": any(p.stable for p in br.points), "figures": [f.name for f in figs],
               "valid_points": sum(bool(p.validity and p.validity["valid"]) for p in br.points),
               "stop_at_invalid": bool(args.stop_at_invalid),
               "validity_boundaries": [s for s in d["special_points"] if s["kind"] == "validity_boundary"],
               "resumed_points": resumed, "wall_s": {"total": time.perf_counter() - t_start},
               "run_dir": str(run.dir)}
    if args.error_estimate:
        summary["error_estimate"] = _branch_error_summary(br)
    # six degrees of freedom: the per-point split of the multipliers (birdocp.studies.lateral_branch.add_lateral_split)
    summary.update({k: br.settings[k] for k in ("degrees_of_freedom", "longitudinal_multipliers",
                                                 "lateral_multipliers", "lateral_stable") if k in br.settings})
    run.write(cfg, summary)
    if args.json:
        run.output(dict(summary, branch=d), None)
    else:
        print(_table(br, cfg, display, args.level, figs, run.dir))
    if not ok:
        warn = noise_summary(run.noise)
        print(f"{PROG}: the branch ended before --to ({br.end_reason}: {br.end_message}); "
              f"{len(br.points)} points written to {run.dir}{warn}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _branch_error_summary(br) -> dict:
    """The largest error estimates over the points of ``br`` that have one (``points``: how many;
    ``failed``: how many 2N re-solves failed, their estimates NaN and left out of the maxima)."""
    ests = [p.error_estimate for p in br.points if p.error_estimate]
    ok = [e for e in ests if e.get("fine_status") == "converged"]
    out = {"points": len(ests), "failed": len(ests) - len(ok)}
    for k in ("multipliers", "multipliers_relative", "x0", "solver"):
        out[k] = max((float(e[k]) for e in ok), default=float("nan"))
    return out


INDEX = "continue.json"
"""The index file of a continuation's run folder: its definition (:mod:`birdocp.io.resume`)."""


def _point_settings(spec: dict) -> dict:
    return {k: v for k, v in spec.items() if k != "config"}


def _resumable(out: Path, spec: dict, cfg, resume: bool) -> tuple[list, list]:
    """(points, special points) an interrupted continuation in ``out`` left, checked as every resume
    is (:mod:`birdocp.io.resume`): the same definition, each point computed for this configuration;
    the points kept are the unbroken run from the first."""
    from birdocp.engine.continuation import BranchPoint, SpecialPoint
    from birdocp.io import resume as R
    from birdocp.io.inputs import read_json_file
    from birdocp.io.provenance import config_hash

    if not resume:
        return [], []
    old, _ = R.read_index(out / INDEX)
    if old is not None:
        R.check_index(old, spec, out, "continuation")
    if os.path.lexists(out / "result.json"):
        done = read_json_file(out / "result.json", "--resume", what=f"'{out}': result.json")
        status = done.get("status") if isinstance(done, dict) else None
        if status != "interrupted":
            raise ConfigError("--resume", f"'{out}' holds a finished continuation (status {status}); nothing to "
                                          "resume: plot it, or continue into a new folder")
    found = R.kept_points(out, lambda i: config_hash(cfg), _point_settings(spec), old is not None,
                          match=lambda i, p: isinstance(p.get("point"), dict))
    points, specials = [], []
    while len(points) in found:
        entry = found[len(points)]
        try:
            pt = BranchPoint(**entry["point"])
            sps = [SpecialPoint(**dict(q, between=tuple(q["between"]))) for q in entry.get("special_points", [])]
        except (TypeError, KeyError, ValueError):
            break
        points.append(pt)
        specials += sps
    return points, specials


class _Recorder:
    """Writes every accepted point (and the special points located before it) to points/ as it comes
    (:func:`birdocp.io.resume.write_point`); holds the branch so far (kept points first)."""

    def __init__(self, out: Path, cfg, spec: dict, points: list, specials: list):
        from birdocp.io.provenance import config_hash

        self.out, self.hash, self.settings = out, config_hash(cfg), _point_settings(spec)
        self.points, self.specials = list(points), list(specials)
        self.pending: list = []
        self.resumed = self.skip = bool(points)  # a resumed branch starts at its last kept point: not a new one
        self.offset_points = max(len(points) - 1, 0)
        self.offset_arclength = points[-1].arclength if points else 0.0

    def special(self, sp) -> None:
        sp.between = tuple(int(i) + self.offset_points for i in sp.between)
        sp.arclength += self.offset_arclength
        self.pending.append(sp)
        self.specials.append(sp)

    def point(self, pt) -> None:
        if self.skip:
            self.skip = False
            return
        from birdocp.io.resume import write_point

        pt.arclength += self.offset_arclength
        write_point(self.out, len(self.points), {"point": pt.to_dict(),
                                                 "special_points": [q.to_dict() for q in self.pending]},
                    self.hash, self.settings)
        self.pending = []
        self.points.append(pt)


def _follow(args, cfg, model_key: str, display: str, a: float, b: float, climb: float, bounds, rec: _Recorder, run):
    """The branch from ``a`` to ``b``, or from the last kept point of a resumed one; every point recorded
    by ``rec`` as it comes."""
    from types import SimpleNamespace

    from birdocp.engine.continuation import Branch
    from birdocp.io.progress import progress_callback
    from birdocp.studies.branch import STABILITY_MARGIN, add_validity, bird_branch, sm_percent

    chord = cfg.body.reference_chord_m
    start, start_value, orient, max_points = None, a, None, args.max_points
    if rec.points:
        last = rec.points[-1]
        start = SimpleNamespace(shooting_points=last.shooting_points, p=last.p)
        start_value = sm_percent(last.parameter, chord) if display == STABILITY_MARGIN else last.parameter
        orient, max_points = last.tangent_parameter, args.max_points - len(rec.points) + 1
    done_at_end = rec.points and (max_points < 2 or abs(start_value - b) <= 1e-12 * max(1.0, abs(b)))
    if done_at_end:
        reason = "max_points" if max_points < 2 else "reached_to"
        new = Branch(model_key, [], [], reason, f"{reason} (found on resume)", {"level": bool(args.level)})
    else:
        say, bar = progress_callback(f"continue {args.param}", args.quiet)
        with run.solving(), bar:
            new = bird_branch(cfg, args.param, start_value, b, level=args.level, climb_rate_mps=climb, bounds=bounds,
                              step=args.step, max_points=max_points, progress=say, on_point=rec.point,
                              on_special=rec.special, start=start, orient=orient,
                              stop_at_invalid=args.stop_at_invalid, compiled=compiled_requested(args),
                              **({"error_estimate": True} if args.error_estimate else {}))
    if not rec.resumed:
        return new
    settings = dict(new.settings, resumed_at_point=rec.offset_points)
    if display == STABILITY_MARGIN:
        settings["stability_margin_percent"] = [sm_percent(p.parameter, chord) for p in rec.points]
    merged = Branch(model_key, list(rec.points), list(rec.specials), new.end_reason, new.end_message, settings,
                    new.wall_s, new.free_names or list(rec.points[0].free_values))
    return add_validity(cfg, merged, cfg.solve.steps_per_period)  # the kept points were written before it


def _keep_partial(run, cfg, model_key: str, display: str, a: float, b: float, level: bool, points: list,
                  specials: list, t_start: float) -> None:
    """branch.json and result.json of an interrupted continuation: the points accepted so far."""
    from birdocp.engine.continuation import Branch
    from birdocp.io.files import atomic_write_json

    message = f"interrupted (Ctrl-C) after {len(points)} points"
    br = Branch(model_key, list(points), list(specials), "interrupted", message, {"level": bool(level), "interrupted": True},
                time.perf_counter() - t_start, list(points[0].free_values))
    d = br.to_dict()
    atomic_write_json(run.dir / "branch.json", d)
    run.write(cfg, {"success": False, "status": "interrupted", "parameter": model_key, "display": display,
                    "from": a, "to": b, "level": bool(level), "end_reason": "interrupted", "end_message": message,
                    "n_points": len(points), "special_points": [sp.to_dict() for sp in specials], "figures": [],
                    "wall_s": {"total": time.perf_counter() - t_start}, "run_dir": str(run.dir)})


def _table(br, cfg, display: str, level: bool, figs, run_dir) -> str:
    sm = display == "stability_margin"
    lines = [f"continuation in {display}" + (" (level flight held)" if level else ""),
             f"{'SM [%]' if sm else 'value':>12}  {'|lambda1|':>9}  {'|lambda2|':>9}  {'|lambda4|':>9}  stable"
             + ("  A [deg]" if level else "") + "  model"]
    for p in br.points:
        v = -100 * p.parameter / cfg.body.reference_chord_m if sm else p.parameter
        line = (f"{v:12.6g}  {p.moduli[0]:9.6f}  {p.moduli[1]:9.6f}  {p.moduli[-1]:9.6f}  "
                f"{'yes' if p.stable else 'no':>6}")
        if level:
            line += f"  {list(p.free_values.values())[0]:7.3f}"
        lines.append(line + f"  {validity_word((p.validity or {}).get('valid'))}")
    invalid = [p for p in br.points if p.validity and not p.validity["valid"]]
    if invalid:
        first = invalid[0]
        v = -100 * first.parameter / cfg.body.reference_chord_m if sm else first.parameter
        lines.append(f"model validity: {len(invalid)} of {len(br.points)} points NOT valid; the first at {v:.6g}: "
                     + "; ".join(first.validity["reasons"]))
    for sp in br.special_points:
        v = -100 * sp.parameter / cfg.body.reference_chord_m if sm else sp.parameter
        lines.append(f"special point: {sp.kind} at {v:.8g} ({sp.message})")
    est = _branch_error_summary(br)
    if est["points"]:
        lines.append(f"error estimate (largest over {est['points']} points): multipliers {est['multipliers']:.2g}, "
                     f"x0 {est['x0']:.2g}, solver {est['solver']:.2g}"
                     + (f"; {est['failed']} re-solves failed" if est["failed"] else ""))
    lines.append(f"end: {br.end_reason}: {br.end_message}")
    lines.append(f"run folder  {run_dir}  (branch.json, {', '.join(f.name for f in figs)})")
    return "\n".join(lines)
