"""``birdocp animate RUN_DIR [--out FILE.gif|.mp4]``: the bird flapping over its cycle.

Reads a trim or level run folder (``config.toml``, ``arrays.npz`` with the cycle's trajectory and
parameter vector), evaluates the wing geometry and the lifting line's circulation at every frame
(:func:`birdocp.bird.snapshots.motion`) and writes a GIF (Pillow, no external program) or an MP4
(needs ffmpeg). A six-degree-of-freedom run is drawn in 3-D: the flight from the cycle's start with
its bank disturbed by ``--bank-deg`` over ``--wingbeats`` (:mod:`birdocp.plots.animation_lateral`).
Everything is checked before any computation: a bad RUN_DIR, an unknown suffix or
an MP4 without ffmpeg is one line on stderr and exit 2.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from birdocp.bird.config import ConfigError
from birdocp.cli import common as cli

DEFAULT_FRAMES = 48
"""Frames per cycle by default (one per T/48; the issue asks for at least one per T/40)."""
DEFAULT_FRAMES_6DOF = 16
"""Frames per wingbeat of a 6-DOF run's perturbed flight by default."""
DEFAULT_BANK_DEG, MAX_BANK_DEG = 15.0, 60.0
"""Bank-angle perturbation of a 6-DOF animation by default and its largest magnitude [deg]."""
DEFAULT_WINGBEATS, MAX_WINGBEATS = 6, 50
"""Wingbeats of a 6-DOF animation by default and at most."""
MAX_FRAMES = 1000
"""Most frames per cycle (20 times the default; each frame is drawn and stored in the file)."""
FPS_RANGE = (0.1, 100.0)
"""Frames per second a file can hold: a GIF frame lasts a whole number of hundredths of a second
(at most 100 fps; at 0.1 fps a frame lasts 10 s)."""


def register(sub, common) -> None:
    """Add ``animate`` to the CLI's subparsers (no configuration options: the run folder has them).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("animate", help="animate a trimmed cycle: the bird flapping, its path and pitch (GIF/MP4)",
                       description="Draw the bird over one cycle of a trim or level run: schematic body, both "
                                   "wings' bones, master feathers, leading and trailing edges, the lifting line "
                                   "coloured by circulation; the path of the centre of mass relative to the "
                                   "mean flight and the pitch angle. A 6-DOF run: the bird in 3-D flying from "
                                   "the cycle with its bank disturbed (--bank-deg, --wingbeats), its ground "
                                   "track, bank, heading and pitch. GIF needs no external program; MP4 needs "
                                   "ffmpeg.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a trim or level run folder (with arrays.npz)")
    p.add_argument("--out", metavar="FILE", help="output file, .gif or .mp4 (default RUN_DIR/animation.gif)")
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help=f"frames per cycle (default {DEFAULT_FRAMES}; a 6-DOF run: per wingbeat, default "
                        f"{DEFAULT_FRAMES_6DOF}; at least 8, at most {MAX_FRAMES})")
    p.add_argument("--bank-deg", type=float, default=None, metavar="DEG",
                   help=f"6-DOF runs: bank-angle perturbation of the cycle's start [deg], |DEG| <= {MAX_BANK_DEG:g} "
                        f"(default {DEFAULT_BANK_DEG:g}): the animation is the flight from there, in 3-D")
    p.add_argument("--wingbeats", type=int, default=None, metavar="N",
                   help=f"6-DOF runs: wingbeats of the perturbed flight, 1..{MAX_WINGBEATS} (default {DEFAULT_WINGBEATS})")
    p.add_argument("--fps", type=float, default=12.0, metavar="F",
                   help="frames per second of the file, 0.1..100 (default 12: one wingbeat in 4 s, 16x slower "
                        "than life)")
    p.add_argument("--dpi", type=int, default=80, metavar="D", help="resolution (default 80: 800 x 448 pixels)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    p.add_argument("--verbose", action="store_true",
                   help="accepted as by every command (animate runs no solver: its warnings always show)")
    p.set_defaults(func=cmd_animate)


CYCLE_COMMANDS = ("trim", "level")
"""The commands whose run folders hold a cycle that animate draws."""


def _load_cycle(run_dir: str | Path):
    """``(cfg, arrays, result)`` of a run folder holding a cycle, read and checked by
    :func:`birdocp.cli.inputs.read_run_folder`; a :class:`ConfigError` on RUN_DIR otherwise."""
    import numpy as np

    from birdocp.cli.inputs import read_run_folder

    folder, cfg = read_run_folder(run_dir, "RUN_DIR", commands=CYCLE_COMMANDS, kind="a trim or level run folder",
                                  arrays="required")
    arrays, run = folder.arrays, folder.path
    t = arrays.get("trajectory_t_s", arrays.get("trajectory_t"))  # a 6-DOF trim stores trajectory_t
    x = arrays.get("trajectory_x")
    if t is None or x is None or len(t) < 3:
        raise folder.error("arrays.npz", "holds no cycle trajectory (trajectory_t_s, trajectory_x); animate a "
                                         "trim or level run folder")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(t))):
        raise ConfigError("RUN_DIR", f"the trajectory in '{run}' is not finite (a failed solve); nothing to draw")
    return cfg, arrays, folder.result


def cmd_animate(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp animate``.

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
    t_start = time.perf_counter()
    run = Path(args.run_dir)
    cfg, arrays, result = _load_cycle(run)
    from birdocp.io.runs import check_out_file

    # a read-only or special target is refused now, not after drawing every frame
    out = check_out_file(args.out if args.out is not None else run / "animation.gif",
                         "--out" if args.out is not None else "RUN_DIR", (".gif", ".mp4"))
    six = cfg.model.degrees_of_freedom == 6
    if not six and (args.bank_deg is not None or args.wingbeats is not None):
        raise ConfigError("--bank-deg" if args.bank_deg is not None else "--wingbeats",
                          "only for a six-degree-of-freedom run (model.degrees_of_freedom = 6)")
    args.frames = args.frames if args.frames is not None else (DEFAULT_FRAMES_6DOF if six else DEFAULT_FRAMES)
    if not 8 <= args.frames <= MAX_FRAMES:
        raise ConfigError("--frames", f"must lie in 8..{MAX_FRAMES}, got {args.frames}")
    fps = args.fps
    if not (math.isfinite(fps) and FPS_RANGE[0] <= fps <= FPS_RANGE[1]):
        raise ConfigError("--fps", f"must lie in {FPS_RANGE[0]:g}..{FPS_RANGE[1]:g} (a GIF stores each frame's "
                                   f"duration in hundredths of a second), got {args.fps}")
    if not 20 <= args.dpi <= 600:
        raise ConfigError("--dpi", f"must lie in 20..600, got {args.dpi}")
    if result.get("success") is False:  # drawn all the same (it may be what the user wants to see), but said
        print(f"{cli.PROG}: warning: the run in '{run}' did not converge (status: {result.get('status')}): the "
              "animation shows its last iterate, not a periodic flight", file=sys.stderr)
    from birdocp.plots.animation import animation_writer

    try:
        animation_writer(out, fps)
    except (RuntimeError, ValueError) as exc:
        raise ConfigError("--out", cli.one_line(exc)) from None

    if six:
        return _animate_lateral(args, cfg, arrays, result, out, fps, t_start)
    import numpy as np

    from birdocp.bird.snapshots import earth_path, interpolate_states, motion
    from birdocp.io.progress import progress_bar
    from birdocp.plots.animation import save_animation

    t_s, x = arrays["trajectory_t_s"], arrays["trajectory_x"]
    period = float(t_s[-1] - t_s[0])
    times = t_s[0] + np.arange(args.frames) * period / args.frames
    with cli.stdout_to_stderr():
        mo = motion(cfg, times - t_s[0], interpolate_states(t_s - t_s[0], x, times - t_s[0], period),
                    arrays.get("p"))
        mo["t_s"] = times - t_s[0]
        mo["path_t_s"] = t_s - t_s[0]
        fwd, up = earth_path(t_s, x)
        cmd = (result.get("provenance") or {}).get("command") or "cycle"
        title = (f"birdocp {cmd}: flapping amplitude {cli.fmt_num(result.get('amplitude_deg'), '.2f')} deg, {1 / period:g} Hz, wing root "
                 f"{cfg.wing.root_ahead_m:g} m ahead of G; mean forward speed "
                 f"{cli.fmt_num(result.get('mean_forward_speed_mps'), '.2f')} m/s")
        with progress_bar(args.frames, "animate", quiet=args.quiet, unit="frame") as bar:
            save_animation(mo, fwd, up, out, fps=fps, title=title, dpi=args.dpi, progress=bar.update)
    info = {"success": True, "status": "written", "out": str(out), "frames": int(args.frames), "fps": fps,
            "period_s": period, "bytes": out.stat().st_size, "run_dir": str(run),
            "wall_s": {"total": time.perf_counter() - t_start}}
    if args.json:
        cli.print_json(info, cli.context_of(args))
    else:
        print(f"wrote {out} ({args.frames} frames over one period of {1000 * period:g} ms, {fps:g} fps, "
              f"{info['bytes'] / 1e6:.2f} MB)")
    return cli.EXIT_OK


def _animate_lateral(args, cfg, arrays, result, out, fps, t_start) -> int:
    """A 6-DOF run: the flight from the cycle's start with its bank perturbed, in 3-D
    (:func:`birdocp.plots.animation_lateral.save_lateral_animation`)."""
    import numpy as np

    bank = DEFAULT_BANK_DEG if args.bank_deg is None else args.bank_deg
    beats = DEFAULT_WINGBEATS if args.wingbeats is None else args.wingbeats
    if not (math.isfinite(bank) and abs(bank) <= MAX_BANK_DEG):
        raise ConfigError("--bank-deg", f"must lie in -{MAX_BANK_DEG:g}..{MAX_BANK_DEG:g} deg, got {args.bank_deg}")
    if not 1 <= beats <= MAX_WINGBEATS:
        raise ConfigError("--wingbeats", f"must lie in 1..{MAX_WINGBEATS}, got {args.wingbeats}")
    from birdocp.io.progress import progress_bar
    from birdocp.plots.animation_lateral import save_lateral_animation
    from birdocp.studies.lateral_motion import lateral_motion, perturbed_flight

    per = max(1, math.ceil(96 / args.frames))  # RK4 steps per frame (at least 96 per wingbeat)
    p6 = arrays["p"] if "p" in arrays else np.asarray(result["p"], float)
    with cli.stdout_to_stderr():
        flight = perturbed_flight(cfg, arrays["trajectory_x"][0], p6, bank, beats, steps_per_period=per * args.frames)
        mo = lateral_motion(cfg, flight, np.arange(0, per * args.frames * beats + 1, per), p6)
        title = (f"birdocp trim, 6 DOF: the cycle with its bank disturbed by {bank:+g} deg, {beats} wingbeats "
                 f"(amplitude {cli.fmt_num(result.get('amplitude_deg'), '.2f')} deg, {1 / flight['period_s']:g} Hz)")
        with progress_bar(len(mo["t_s"]), "animate", quiet=args.quiet, unit="frame") as bar:
            save_lateral_animation(mo, flight, out, fps=fps, title=title, dpi=args.dpi, progress=bar.update)
    info = {"success": True, "status": "written", "out": str(out), "frames": int(len(mo["t_s"])), "fps": fps,
            "period_s": flight["period_s"], "bytes": out.stat().st_size, "run_dir": str(args.run_dir),
            "bank_deg": bank, "wingbeats": beats, "wall_s": {"total": time.perf_counter() - t_start}}
    if args.json:
        cli.print_json(info, cli.context_of(args))
    else:
        print(f"wrote {out} ({info['frames']} frames over {beats} wingbeats, {fps:g} fps, {info['bytes'] / 1e6:.2f} MB)")
    return cli.EXIT_OK
