"""Shared start of the reproduction scripts (``python scripts/<name>.py``; this folder is on sys.path)."""
from __future__ import annotations

import argparse
from pathlib import Path


def script_parser(doc: str, default_out: str, **kwargs) -> argparse.ArgumentParser:
    """The script's options: ``--out DIR`` (default ``default_out``) first; the script adds its own."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0], **kwargs)
    ap.add_argument("--out", default=default_out, help="output folder (default %(default)s)")
    return ap


def parse_with_out(ap: argparse.ArgumentParser, argv=None) -> tuple[argparse.Namespace, Path]:
    """Parse the options and create the ``--out`` folder; (options, folder)."""
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    return args, out
