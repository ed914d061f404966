"""The engine's one IPOPT front: run a CasADi ``nlpsol`` IPOPT solver once and say what happened.

Both periodic-orbit solvers (:mod:`birdocp.engine.shooting` for the forced, fixed-period problem and
:mod:`birdocp.engine.orbits` for any ODE) build their feasibility NLP with the options of
:func:`birdocp.engine.oracle.ipopt_options` and run it through :func:`run_ipopt`: an evaluation
error inside IPOPT becomes a status (never an exception), a Ctrl-C inside it a ``KeyboardInterrupt``
(never a status), and a non-finite iterate is no success whatever IPOPT's status says.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from birdocp.engine import interrupts

__all__ = ["IpoptOutcome", "run_ipopt"]


class IpoptOutcome(NamedTuple):
    """What :func:`run_ipopt` returns: the last iterate, IPOPT's ``return_status`` (``"error"`` when
    it raised, ``"nan"`` for a non-finite iterate), its ``success`` flag, iterations, the history of
    ``inf_pr`` and a one-line message."""

    z: np.ndarray
    status: str
    success: bool
    iterations: int
    history: np.ndarray
    message: str


def run_ipopt(solver, x0, *, lbx, ubx, p=None) -> IpoptOutcome:
    """Run ``solver`` (a CasADi IPOPT ``nlpsol`` with equality constraints g = 0) from ``x0``.

    Parameters
    ----------
    solver : casadi.Function
        The nlpsol.
    x0 : array
        The start.
    lbx, ubx : array
        Bounds of the unknowns.
    p : array, optional
        The NLP's parameter vector, if it has one.

    Returns
    -------
    IpoptOutcome
    """
    args = {"x0": x0, "lbx": lbx, "ubx": ubx, "lbg": 0, "ubg": 0}
    if p is not None:
        args["p"] = p
    with interrupts.interruptible():  # Ctrl-C inside IPOPT: KeyboardInterrupt, not a status
        try:
            sol = solver(**args)
            z = np.asarray(sol["x"]).ravel()
            st = solver.stats()
            status = str(st.get("return_status", "unknown"))
            success = bool(st.get("success", False))
            iters = int(st.get("iter_count", 0))
            hist = np.asarray(st.get("iterations", {}).get("inf_pr", []), float)
            message = f"IPOPT: {status}"
        except Exception as e:  # CasADi may raise on evaluation errors ...
            interrupts.check_from(e)  # ... or on an interrupt inside a callback
            z, status, success, iters, hist = np.asarray(x0, float), "error", False, 0, np.zeros(0)
            message = f"IPOPT raised: {e}"
    interrupts.check()  # CasADi turns Ctrl-C into a status (NonIpopt_Exception_Thrown): never retry it
    if not np.all(np.isfinite(z)):
        success, status = False, "nan"
        message += " (non-finite iterate)"
    return IpoptOutcome(z, status, success, iters, hist, message)
