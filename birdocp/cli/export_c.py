"""``birdocp export-c``: the model as a self-contained C folder, written whole: into a temporary
sibling folder that takes the place of ``--out`` in one step (:func:`birdocp.io.files.atomic_folder`),
so an interrupt or a full disk leaves an earlier export complete."""

from __future__ import annotations

import argparse

from birdocp.bird.config import ConfigError
from birdocp.cli.common import EXIT_OK, context_of, print_json, resolve_config, solver_noise


def register(sub, common) -> None:
    """Add ``export-c`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("export-c", parents=[common], help="export the model as a self-contained C folder",
                       description="Write C code for the configured gait: the state equations and their "
                                   "Jacobian, one RK4 step, the period map with its monodromy, the wing data "
                                   "on the RK4 stage grid as a table, bird.h (documented), a Makefile and an "
                                   "example main.c. Build with: make -C DIR && DIR/bird_period U W Q THETA")
    p.add_argument("--out", metavar="DIR", required=True, help="folder to write (new, empty, or an earlier export)")
    p.add_argument("--steps", type=int, metavar="N", help="RK4 steps per period (solve.steps_per_period)")
    p.set_defaults(func=cmd_export_c)


def cmd_export_c(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp export-c``.

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
    from birdocp.io.runs import check_out_path, lock_folder

    cfg = resolve_config(args)
    out = check_out_path(args.out)
    if out.is_dir() and any(p.name != ".birdocp.lock" for p in out.iterdir()) and not (out / "bird.h").exists():
        raise ConfigError("--out", f"{out} is not empty and holds no earlier export (no bird.h); choose a new folder")
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError("--out", f"cannot create folder '{out}': {exc.strerror or exc}") from None
    lock = lock_folder(out, "--out", created)  # two exports never write one folder at once
    try:
        with solver_noise(None, getattr(args, "verbose", False)):
            from birdocp.export.codegen import export_c

            info = export_c(cfg, out)
    except BaseException:
        import contextlib

        from birdocp.io.files import signals_deferred

        with signals_deferred():  # a second Ctrl-C waits for the clean-up
            lock.release()
            if created:
                with contextlib.suppress(OSError):
                    out.rmdir()  # only if nothing was written
        raise
    lock.release()
    if args.json:
        print_json(dict(info.to_dict(), success=True, status="written"), context_of(args))
    else:
        print(f"wrote {out}/: {', '.join(info.files)}")
        print(f"  {info.steps_per_period} RK4 steps of {info.step_s:.6g} s per period {info.period_s:.6g} s; "
              f"data table {2 * info.steps_per_period + 1} x {info.n_data}")
        print(f"  runtime parameters p[]: {', '.join(info.runtime_params)} (everything else is baked in)")
        print(f"  build and run: make -C {out} && {out / 'bird_period'} 18 0.5 0.1 0.01")
    return EXIT_OK
