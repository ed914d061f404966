"""Sphinx directive ``.. birdocp-cli::``: the command-line reference generated from the parser.

It calls :func:`birdocp.cli.main.build_parser` at build time and writes one section per subcommand
(its one-line help and the full ``--help`` text), so a new command registered in
``COMMAND_MODULES`` appears in the docs without editing them, and the docs can never disagree with
``birdocp COMMAND --help``.
"""

from __future__ import annotations

import argparse
import os

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective


def _subparsers(parser: argparse.ArgumentParser):
    for action in parser._actions:  # argparse offers no public accessor for the subcommands
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            return [(name, sub, helps.get(name, "")) for name, sub in action.choices.items()]
    return []


class BirdocpCli(SphinxDirective):
    has_content = False

    def run(self):
        from birdocp.cli.main import build_parser

        old = os.environ.get("COLUMNS")
        os.environ["COLUMNS"] = "100"
        try:
            parser = build_parser()
            lines = ["Top level", "---------", "", ".. code-block:: text", ""]
            lines += ["   " + ln for ln in parser.format_help().splitlines()] + [""]
            for name, sub, help_text in _subparsers(parser):
                title = f"birdocp {name}"
                lines += [title, "-" * len(title), ""]
                if help_text:
                    lines += [help_text[0].upper() + help_text[1:] + ".", ""]
                lines += [".. code-block:: text", ""]
                lines += ["   " + ln for ln in sub.format_help().splitlines()] + [""]
        finally:
            if old is None:
                os.environ.pop("COLUMNS", None)
            else:
                os.environ["COLUMNS"] = old
        node = nodes.section()
        node.document = self.state.document
        self.state.nested_parse(StringList(lines, source="birdocp-cli"), self.content_offset, node,
                                match_titles=True)
        return node.children


def setup(app):
    app.add_directive("birdocp-cli", BirdocpCli)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
