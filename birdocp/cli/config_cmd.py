"""``birdocp config``: the resolved configuration as TOML (or JSON)."""

from __future__ import annotations

import argparse
import sys

from birdocp.bird import config as C
from birdocp.cli.common import EXIT_OK, context_of, print_json, resolve_config


def register(sub, common) -> None:
    """Add ``config`` to the CLI's subparsers.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        Subparsers of the ``birdocp`` parser.
    common : argparse.ArgumentParser
        Parent parser of the common options.
    """
    p = sub.add_parser("config", parents=[common], help="print the resolved configuration as TOML",
                       description="Print the resolved configuration (defaults <- CONFIG <- --set <- flags) as "
                                   "TOML, e.g. to start a configuration file: birdocp config > bird.toml")
    p.set_defaults(func=cmd_config)


def cmd_config(args: argparse.Namespace, command_line: list[str]) -> int:
    """Run ``birdocp config``.

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
    cfg = resolve_config(args)
    if args.json:
        print_json(C.to_dict(cfg), context_of(args))
    else:
        sys.stdout.write("# birdocp configuration (resolved)\n"
                         f"# body alone (without the wings): {C.body_alone_mass_kg(cfg):.6g} kg\n" + C.dumps(cfg))
    return EXIT_OK
