"""Ctrl-C that survives CasADi.

CasADi catches a ``KeyboardInterrupt`` raised inside IPOPT (or inside a Python callback that IPOPT
calls) and returns a solver status instead (``NonIpopt_Exception_Thrown``, ``User_Requested_Stop``);
a caller that only looks at the status would then retry or report a failure, and the interrupt is
lost. :func:`interruptible` records every SIGINT in a flag while its body runs; :func:`check`
re-raises the interrupt after any solver call, whatever the solver made of it.

Use::

    with interruptible():
        sol = solver(...)
        check()          # raises KeyboardInterrupt if Ctrl-C came during the call

Outside the main thread, or when SIGINT is ignored or handled by someone else, :func:`interruptible`
installs nothing and :func:`check` sees only interrupts recorded with :func:`note`.
"""
from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator

__all__ = ["interruptible", "install", "check", "check_from", "note", "pending", "INTERRUPT_STATUSES"]

INTERRUPT_STATUSES = frozenset({"User_Requested_Stop", "NonIpopt_Exception_Thrown"})
"""IPOPT statuses CasADi returns when a Python exception (e.g. KeyboardInterrupt) stopped IPOPT."""

_pending = False


def note() -> None:
    """Record an interrupt (called by the SIGINT handler and by callbacks that see one)."""
    global _pending
    _pending = True


def pending() -> bool:
    """Whether an interrupt was recorded and not yet raised by :func:`check`.

    Returns
    -------
    bool
    """
    return _pending


def check() -> None:
    """Raise ``KeyboardInterrupt`` (once) if an interrupt was recorded."""
    global _pending
    if _pending:
        _pending = False
        raise KeyboardInterrupt


def _handler(signum, frame):
    note()
    raise KeyboardInterrupt


def install() -> bool:
    """Record SIGINT for the rest of the process (a command-line program calls this once); returns
    whether the handler was installed (main thread, SIGINT not ignored or handled elsewhere).

    Returns
    -------
    bool
    """
    if threading.current_thread() is not threading.main_thread():
        return False
    with contextlib.suppress(ValueError, TypeError):
        if signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _handler):
            signal.signal(signal.SIGINT, _handler)
            return True
    return False


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Record SIGINT while the body runs (see the module docstring); on leaving, a recorded interrupt
    is raised as ``KeyboardInterrupt``, also when the body ended with another exception (e.g. CasADi's
    ``RuntimeError`` around an interrupted callback).

    Yields
    ------
    None
    """
    installed = False
    if threading.current_thread() is threading.main_thread():
        with contextlib.suppress(ValueError, TypeError):
            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                signal.signal(signal.SIGINT, _handler)
                installed = True
    try:
        yield
    except KeyboardInterrupt:
        global _pending
        _pending = False
        raise
    except BaseException as exc:
        if _pending:
            check_from(exc)
        raise
    finally:
        if installed:
            with contextlib.suppress(ValueError, TypeError):
                signal.signal(signal.SIGINT, signal.default_int_handler)
    check()


def check_from(exc: BaseException) -> None:
    """Raise the recorded interrupt in place of ``exc`` (chained), if there is one.

    Parameters
    ----------
    exc : BaseException
        The exception being handled.
    """
    global _pending
    if _pending:
        _pending = False
        raise KeyboardInterrupt from exc
