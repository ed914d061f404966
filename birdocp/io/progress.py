"""Progress bars for long commands, through tqdm, on stderr.

One helper for every command: ``with progress_bar(total, "sweep amplitude", quiet=args.quiet) as bar:``
then ``bar.update()`` per finished item and ``bar.set_postfix_str(text)`` for the current state.
The bar is shown only when stderr is a terminal and ``quiet`` is false; otherwise every call is a
no-op (logs and pipes stay clean, and ``--json`` output on stdout is never touched).

``progress_callback(label, quiet)`` adapts a text callback (``progress(text)``, as the continuation
takes) to a bar that counts the calls and shows the last text. ``text_reporter(progress, label)`` turns
a study's ``progress`` argument (False, True or a callable) into that callback: the one way a study
reports progress (a bar from the command line, one line per step on stderr from Python).
"""

from __future__ import annotations

import sys
from typing import Any, Callable

__all__ = ["progress_enabled", "progress_bar", "progress_callback", "text_reporter", "NullBar"]


def progress_enabled(quiet: bool = False, stream=None) -> bool:
    """True when a bar should be drawn: not ``quiet`` and ``stream`` is a terminal.

    Parameters
    ----------
    quiet : bool
        No bar whatever the stream.
    stream : file-like, optional
        Stream the bar would be drawn on (default: ``sys.stderr``).

    Returns
    -------
    bool
    """
    if quiet:
        return False
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class NullBar:
    """A bar that draws nothing (the interface of tqdm used here: update, set_postfix_str,
    set_description_str, write, close, context manager)."""

    n = 0

    def update(self, n: int = 1) -> None:
        self.n += n

    def set_postfix_str(self, text: str = "", refresh: bool = True) -> None:
        return None

    def set_description_str(self, text: str = "", refresh: bool = True) -> None:
        return None

    def write(self, text: str) -> None:
        return None

    def close(self) -> None:
        return None

    def __enter__(self) -> "NullBar":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def progress_bar(total: int | None, label: str, quiet: bool = False, unit: str = "point", stream=None):
    """A tqdm bar on stderr, or a :class:`NullBar` when quiet or stderr is not a terminal.

    Parameters
    ----------
    total : int or None
        Number of items (None: unknown, the bar counts without a percentage).
    label : str
        Text before the bar, e.g. ``"sweep amplitude"``.
    quiet : bool
        No bar at all (the commands' ``--quiet``).
    unit : str
        Name of one item.
    stream : file, optional
        Where to draw (default ``sys.stderr``).

    Returns
    -------
    tqdm.tqdm or NullBar
        Use as a context manager, or call ``close()``.
    """
    stream = sys.stderr if stream is None else stream
    if not progress_enabled(quiet, stream):
        return NullBar()
    from tqdm import tqdm

    return tqdm(total=total, desc=label, unit=unit, file=stream, dynamic_ncols=True, leave=True,
                bar_format="{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} "
                           "[{elapsed}<{remaining}]{postfix}" if total else None)


def progress_callback(label: str, quiet: bool = False, total: int | None = None,
                      stream=None) -> tuple[Callable[[str], None], Any]:
    """A text callback ``say(text)`` drawing a bar that counts calls and shows the latest text.

    Parameters
    ----------
    label : str
        Text in front of the bar.
    quiet : bool
        No bar (a :class:`NullBar`).
    total : int, optional
        Number of calls expected (None: the bar counts without an end).
    stream : file-like, optional
        Stream of the bar (default: ``sys.stderr``).

    Returns
    -------
    say : callable
        ``say(text)``: one step done, ``text`` shown after the bar.
    bar : tqdm or NullBar
        The bar; close it when done (``bar.close()``).
    """
    bar = progress_bar(total, label, quiet, unit="step", stream=stream)

    def say(text: str) -> None:
        bar.update()
        bar.set_postfix_str(str(text).strip()[:80])

    return say, bar


def text_reporter(progress: Any, label: str) -> Callable[[str], None] | None:
    """The callback a study calls with one line of progress text, from its ``progress`` argument.

    Parameters
    ----------
    progress : bool or callable
        False or None: silent (returns None); a callable ``progress(text)``: itself (e.g.
        :func:`progress_callback`'s ``say``); True: one line ``"label: text"`` per call on stderr.
    label : str
        The prefix of the stderr lines, e.g. ``"optimize-stability"``.

    Returns
    -------
    callable or None
        ``say(text)``, or None when silent.
    """
    if not progress:
        return None
    if callable(progress):
        return progress

    def say(text: str) -> None:
        print(f"{label}: {text}", file=sys.stderr, flush=True)

    return say
