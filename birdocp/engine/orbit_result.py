"""The one result type of the periodic-orbit engine: :class:`OrbitResult` (from
:func:`~birdocp.engine.orbit_front.solve`, continuation starts and Hopf starts)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from birdocp.engine.results import result_dict, serial

__all__ = ["OrbitResult", "FORMULATIONS", "JSON_OMITS"]

FORMULATIONS = ("data_split", "time_scaled")
"""How a result was computed: ``"data_split"`` (an :class:`~birdocp.engine.ode.ODE` with a data
function: forced, period fixed, mean conditions) or ``"time_scaled"`` (an ODE without data: time
scaled by the period, autonomous or forced)."""

JSON_OMITS = {
    "data_split": ("error_estimate", "solver_status", "period", "autonomous", "amplitude", "arc_length",
                   "trivial_multiplier", "trivial_multiplier_error", "nontrivial_multipliers", "accurate",
                   "phase_point", "covers", "reduced_from_period"),
    "time_scaled": ("shooting_times", "means", "eigenvectors", "floquet_exponents", "doubling_times_s",
                    "monodromy_vs_full_period_jacobian"),
}
"""The fields each formulation leaves out of ``to_dict()`` (those it does not compute, and for
``"data_split"`` the error estimate, which callers that compute it add: ``birdocp trim``)."""


def _empty():
    return np.zeros(0)


@dataclass
class OrbitResult:
    """A periodic orbit and its Floquet multipliers. Failures are results (``success=False``).

    Attributes
    ----------
    success : bool
        Converged: the max residual of all equations is finite and at most the tolerance (10 x tol
        for IPOPT on an ODE with data), whatever the solver's status says; finite multipliers; for
        an ODE without data also a true orbit (not an equilibrium) of minimal period.
    status : str
        With data: IPOPT's ``return_status`` (e.g. "Solve_Succeeded") or the LM's "converged",
        "max_iter", "stalled", "nan"; "residual_above_tol" when a status claims convergence but the
        residual exceeds the tolerance. Without data: "converged", "equilibrium", "not_converged", "nan",
        "bad_phase_point", "bad_period", "multiple_cover" (see ``covers``).
    message : str
        What happened, in a sentence (why, for a failure, when known).
    iterations : int
        Solver iterations.
    residual_history : numpy.ndarray
        Max abs residual per iteration (IPOPT: inf_pr as reported, unscaled).
    wall_s : dict
        Seconds by phase (``build``, ``solve``, ``total``, ...; ``all_grids`` when refined).
    shooting_times : numpy.ndarray
        Times of the shooting points (``t0 + k T/(M-1)``).
    shooting_points : numpy.ndarray
        The shooting points, one row per point (the closing point included).
    x0 : numpy.ndarray
        The state at the start of the period.
    p : numpy.ndarray
        The parameters (free ones at their solved values).
    free_values : dict
        The solved free parameters by name.
    trajectory_t, trajectory_x : numpy.ndarray
        The orbit on the integration grid (N+1 times, states one row per time).
    max_residual : float
        Max abs of all equations at the result.
    means : dict
        With data: the period mean of each mean-condition output and extra output (by name).
    monodromy : numpy.ndarray or None
        The monodromy matrix (product of the segment Jacobians).
    multipliers : numpy.ndarray or None
        All Floquet multipliers, largest modulus first (autonomous: the trivial one included).
    eigenvectors, floquet_exponents, doubling_times_s : numpy.ndarray or None
        With data: the multipliers' eigenvectors (one column per mode), ``log(multiplier)/T``
        (1/s) and ``ln 2 / Re(exponent)``, signed (:mod:`birdocp.engine.floquet`).
    stable : bool or None
        All (non-trivial) multipliers inside the unit circle.
    monodromy_vs_full_period_jacobian : float
        With data: max abs difference between the monodromy and the Jacobian of the one-period
        map from x0 (accuracy indicator).
    method : dict
        The method's settings as used.
    error_estimate : dict or None
        ``{"period", "x0", "multipliers", "solver", ...}`` absolute estimates: discretisation error
        (Richardson, from a re-solve with 2N steps) plus the solver-tolerance error, never a bare 0
        (:mod:`birdocp.engine.orbit_checks`); None or empty when not computed
        (``OrbitMethod.error_estimate``).
    solver_status : str
        What the solver said (IPOPT's return status or the LM's), before the residual check that
        decides ``status``.
    period : float
        The period (time units of the system): solved for autonomous orbits, the forcing period
        otherwise.
    autonomous : bool
        Whether the period was an unknown.
    amplitude, arc_length : float
        Without data: max_t of the largest abs(x(t) - x0) component; the polygon length of the orbit.
    trivial_multiplier, trivial_multiplier_error, nontrivial_multipliers
        Without data: the multiplier closest to 1 (autonomous), abs(it - 1), and the others (``stable`` is
        decided on these).
    accurate : bool or None
        Without data: every relative error estimate <= the method's accuracy.
    phase_point : numpy.ndarray or None
        Autonomous ODE: the point of the final Poincare section.
    covers, reduced_from_period
        Without data: k > 1 when the solve converged on a k-fold cover of the orbit and was reduced to the
        minimal period (``reduced_from_period`` holds the converged multiple), or could not be (status
        ``"multiple_cover"``).
    formulation : str
        ``"data_split"`` or ``"time_scaled"`` (:data:`FORMULATIONS`); not in the JSON.
    """

    success: bool = False
    status: str = ""
    message: str = ""
    iterations: int = 0
    residual_history: np.ndarray = field(default_factory=_empty)
    wall_s: dict = field(default_factory=dict)
    shooting_times: np.ndarray = field(default_factory=_empty)
    shooting_points: np.ndarray = field(default_factory=_empty)
    x0: np.ndarray = field(default_factory=_empty)
    p: np.ndarray = field(default_factory=_empty)
    free_values: dict = field(default_factory=dict)
    trajectory_t: np.ndarray = field(default_factory=_empty)
    trajectory_x: np.ndarray | None = field(default_factory=_empty)
    max_residual: float = float("nan")
    means: dict = field(default_factory=dict)
    monodromy: np.ndarray | None = None
    multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    eigenvectors: np.ndarray | None = field(default=None, metadata=serial(complex=True, columns=True))
    floquet_exponents: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    doubling_times_s: np.ndarray | None = None
    stable: bool | None = None
    monodromy_vs_full_period_jacobian: float = float("nan")
    method: dict = field(default_factory=dict)
    error_estimate: dict | None = None
    solver_status: str = ""
    period: float = float("nan")
    autonomous: bool = False
    amplitude: float = float("nan")
    arc_length: float = float("nan")
    trivial_multiplier: complex | None = field(default=None, metadata=serial(complex=True))
    trivial_multiplier_error: float = float("nan")
    nontrivial_multipliers: np.ndarray | None = field(default=None, metadata=serial(complex=True))
    accurate: bool | None = None
    phase_point: np.ndarray | None = None
    covers: int = 1
    reduced_from_period: float | None = None
    formulation: str = field(default="time_scaled", metadata=serial(skip=True))

    def to_dict(self, *, exclude=(), rename=None, extra=None) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): complex numbers as ``[re, im]``
        pairs (``eigenvectors``: one list of pairs per mode), multipliers largest modulus first, NaN
        and inf as null; the fields the formulation does not compute left out (:data:`JSON_OMITS`).

        Parameters
        ----------
        exclude : iterable of str
            Further fields to leave out.
        rename : mapping, optional
            Field name -> JSON key.
        extra : mapping, optional
            Further keys and values, after the fields.

        Returns
        -------
        dict
        """
        omit = tuple(exclude) + JSON_OMITS.get(self.formulation, ())
        return result_dict(self, exclude=omit, rename=rename, extra=extra)
