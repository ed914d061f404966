"""birdocp.io.progress: a tqdm bar on a terminal, nothing otherwise or with --quiet."""

from __future__ import annotations

import io

from birdocp.io.progress import NullBar, progress_bar, progress_callback, progress_enabled


class FakeTTY(io.StringIO):
    def isatty(self):
        return True


def test_no_bar_when_not_a_terminal_or_quiet():
    assert not progress_enabled(False, io.StringIO())
    assert not progress_enabled(True, FakeTTY())
    assert progress_enabled(False, FakeTTY())
    s = io.StringIO()
    with progress_bar(3, "x", stream=s) as bar:
        assert isinstance(bar, NullBar)
        bar.update()
    assert s.getvalue() == ""
    t = FakeTTY()
    with progress_bar(3, "x", quiet=True, stream=t) as bar:
        bar.update()
    assert t.getvalue() == ""


def test_bar_on_a_terminal():
    t = FakeTTY()
    with progress_bar(4, "sweep amplitude", stream=t) as bar:
        for _ in range(4):
            bar.update()
            bar.set_postfix_str("solving 42")
    text = t.getvalue()
    assert "sweep amplitude" in text and "4/4" in text and "solving 42" in text


def test_callback_counts_and_shows_text():
    t = FakeTTY()
    say, bar = progress_callback("continue root_ahead_m", stream=t)
    with bar:
        say("root_ahead_m = 0.05: start")
        say("root_ahead_m = 0.051: 3 it")
    assert bar.n == 2
    assert "0.051: 3 it" in t.getvalue()
