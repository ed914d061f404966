"""``birdocp plot``: redraw the figures of a run folder."""

from __future__ import annotations

import argparse
import errno
import os
from pathlib import Path

from birdocp.bird.config import ConfigError
from birdocp.cli.common import EXIT_OK, context_of, print_json, solver_noise


PLOTTED = ("trim", "level", "sweep", "continue", "optimize-stability", "optimize-gait")
"""The commands whose run folders ``plot`` draws."""
PLOTTED_HINT = ("plot draws trim, level, sweep (and grid), continue, optimize-stability and optimize-gait run "
                "folders (control and simulate draw their figures as they run)")


def register(sub, common) -> None:
    """Add ``plot`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("plot", help="redraw the figures of a run folder (trim, level, sweep, continue)",
                       description="Read RUN_DIR/result.json (and arrays.npz, sweep.json, branch.json) and write "
                                   "the run's figures into RUN_DIR.")
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on errors")
    p.add_argument("--json", action="store_true", help="print the list of figures as JSON")
    p.add_argument("--verbose", action="store_true", help="show library warnings on the terminal")
    p.add_argument("--quiet", action="store_true", help="accepted as by every command (plot draws no progress bar)")
    p.set_defaults(func=cmd_plot)


def _read_json(path: Path, what: str):
    from birdocp.io.inputs import read_json_file

    return read_json_file(path, "RUN_DIR", what=f"'{path.parent}': {what}")


def cmd_plot(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp plot``.

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
    from birdocp.cli.inputs import read_run_folder

    folder, _ = read_run_folder(args.run_dir, "RUN_DIR", commands=PLOTTED, hint=PLOTTED_HINT)
    run, res = folder.path, folder.result
    command = (res.get("provenance") or {}).get("command")
    from birdocp.io.runs import check_writable

    check_writable(run, "RUN_DIR")  # the figures go into the run folder: refused now if it is read-only
    try:
        with solver_noise(None, getattr(args, "verbose", False)):
            figs = _figures(run, res, command, folder.arrays)
    except ConfigError:
        raise
    except OSError as exc:
        if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC):
            raise ConfigError("RUN_DIR", f"cannot write the figures into '{run}': {exc.strerror}") from None
        raise
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:
        raise ConfigError("RUN_DIR", f"the files of '{run}' are not a complete birdocp {command or ''} run "
                                     f"({type(exc).__name__}: {exc})") from None
    names = [Path(f).name for f in figs]
    if args.json:
        print_json({"run_dir": str(run), "figures": names, "success": True, "status": "plotted"},
                   context_of(args))
    else:
        print(f"wrote {', '.join(names) or 'no figures'} in {run}")
    return EXIT_OK


def _figures(run: Path, res: dict, command, arrays: dict | None) -> list:
    figs = []
    if os.path.lexists(run / "branch.json"):
        from birdocp.engine.continuation import Branch
        from birdocp.plots.branch import plot_branches

        br = Branch.from_dict(_read_json(run / "branch.json", "branch.json"))
        figs = plot_branches({"level flight" if br.settings.get("level") else "branch": br}, run)
    elif os.path.lexists(run / "grid.json"):
        d = _read_json(run / "grid.json", "grid.json")
        figs = [_plot_rows(d.get("points", []), "value", run / "grid.png",
                          f"grid: lines over {d.get('key')}, one per {d.get('row_key')}", d.get("key"))]
    elif os.path.lexists(run / "sweep.json"):
        d = _read_json(run / "sweep.json", "sweep.json")
        figs = [_plot_rows(d.get("points", []), "value", run / "sweep.png", f"sweep of {d.get('key')}", d.get("key"))]
    elif command in ("trim", "level") or "x0" in res:
        from birdocp.plots import figures as plots

        cyc = dict(res, **(arrays or {}))
        if res.get("degrees_of_freedom") == 6 and "trajectory_x" in cyc:  # the states figures: (u, w, q, theta)
            from birdocp.bird.sixdof import LONGITUDINAL

            cyc["trajectory_x"] = [[row[i] for i in LONGITUDINAL] for row in cyc["trajectory_x"]]
        if "trajectory_x" in cyc:
            figs.append(plots.plot_states(cyc, run / "states.png"))
            figs.append(plots.plot_phase_portrait(cyc, run / "phase.png"))
        if cyc.get("multipliers") is not None:
            figs.append(plots.plot_multipliers({command or "cycle": cyc["multipliers"]}, run / "multipliers.png"))
        if cyc.get("residual_history") is not None:
            figs.append(plots.plot_convergence({command or "cycle": cyc["residual_history"]}, run / "convergence.png"))
            if "power_t_s" in cyc:
                from birdocp.plots.energetics import plot_power

                figs.append(plot_power(cyc, run / "power.png"))
        if res.get("degrees_of_freedom") == 6 and res.get("monodromy") is not None and res.get("success"):
            from birdocp.plots.lateral import plot_lateral_run

            figs.extend(plot_lateral_run(res, run))
    else:
        what = f"a '{command}' run" if command else "a result that names no birdocp command"
        raise ConfigError("RUN_DIR", f"do not know how to plot {what}; {PLOTTED_HINT}")
    return figs


def _plot_rows(rows, xkey, path, title, xlabel):
    """|multipliers| and mean vertical speed of sweep or grid rows against ``xkey``."""
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
