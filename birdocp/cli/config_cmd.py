"""``birdocp config``: the resolved configuration as TOML (or JSON)."""

from __future__ import annotations

import argparse
import sys

from birdocp.bird import config as C
from birdocp.cli.common import EXIT_OK, context_of, print_json, resolve_config


def register(sub, common) -> None:
    p = sub.add_parser("config", parents=[common], help="print the resolved configuration as TOML",
                       description="Print the resolved configuration (defaults <- CONFIG <- --set <- flags) as "
                                   "TOML, e.g. to start a configuration file: birdocp config > bird.toml")
    p.set_defaults(func=cmd_config)


def cmd_config(args: argparse.Namespace, command_line: list[str]) -> int:
    cfg = resolve_config(args)
    if args.json:
        print_json(C.to_dict(cfg), context_of(args))
    else:
        sys.stdout.write("# birdocp configuration (resolved)\n"
                         f"# body alone (without the wings): {C.body_alone_mass_kg(cfg):.6g} kg\n" + C.dumps(cfg))
    return EXIT_OK
