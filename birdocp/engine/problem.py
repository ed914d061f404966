"""Problem definitions for the model-agnostic limit-cycle engine.

Nothing here knows what system is being integrated: the system is an
:class:`~birdocp.engine.ode.ODE` (forced or autonomous, with or without a per-time data function).
An :class:`OrbitProblem` says *what* is wanted (a periodic orbit of the ODE, optionally with some
parameters free and as many period-mean conditions); the *how* lives in
:class:`birdocp.engine.method.OrbitMethod`, the front is :func:`birdocp.engine.orbit_front.solve`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.engine.ode import ODE, check_function

__all__ = ["MeanCondition", "OrbitProblem", "finite_vector"]


def finite_vector(value, name: str, size: int | None = None, what: str = "") -> np.ndarray:
    """``value`` as a flat float array; ValueError naming ``name`` unless every entry is a finite
    number and (``size`` given) there are ``size`` of them (``what`` says where the size comes from,
    e.g. ``"the ODE has nx=2"``).

    Parameters
    ----------
    value : array_like
        Numbers to check.
    name : str
        Name in the error.
    size : int, optional
        Number of entries required.
    what : str
        Where the size comes from, for the error.

    Returns
    -------
    ndarray
    """
    try:
        v = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers, got {value!r}") from None
    if size is not None and v.size != size:
        raise ValueError(f"{name}: size {v.size}, {what or f'expected {size}'}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite (no NaN or inf), got {v}")
    return v


@dataclass(frozen=True, eq=False)
class MeanCondition:
    """The period mean of ``output(x, d, p)`` (a scalar) must equal ``target``.

    Attributes
    ----------
    output
        Function (x[nx], d[nd], p[np]) -> scalar.
    target
        the period mean it must have (the output's units).
    name
        a name for messages and for ``result.means``.
    """

    output: ca.Function
    target: float = 0.0
    name: str = ""

    def __post_init__(self):
        check_function(self.output, f"MeanCondition({self.name!r}).output", 3)
        if self.output.numel_out(0) != 1:
            raise ValueError(f"MeanCondition({self.name!r}).output must return a scalar")


@dataclass(eq=False)
class OrbitProblem:
    """A periodic orbit of ``ode`` at parameters ``p``: the one problem type of the engine.

    The ODE decides the formulation (:func:`birdocp.engine.orbit_front.solve`):

    * an ODE with a data function (forced, data-split ``x' = f(x, d(t, p), p)``, e.g. the bird or
      :meth:`~birdocp.engine.ode.ODE.from_rhs`): the period is the forcing's, free parameters each
      held by a period-mean condition, extra period-mean outputs;
    * an ODE without data (:meth:`~birdocp.engine.ode.ODE.from_function`), autonomous (the period is
      an unknown, a phase condition fixes the time origin) or forced (the period is ``period_guess``,
      by default the forcing's; a multiple for subharmonic orbits). Free parameters and mean
      conditions need a data function (``ODE.from_rhs(ode.rhs, forcing_period)``).

    Attributes
    ----------
    ode
        The system, an :class:`~birdocp.engine.ode.ODE`.
    p
        Full parameter vector (np,) (initial values of the free ones).
    x_guess
        A point near the orbit at ``t0`` (nx,), or (an ODE without data) guesses of the shooting
        points (M or M-1, nx).
    period_guess
        Without data: the period guess (autonomous: an unknown; forced: the period itself, default
        ``ode.forcing_period``). With data: the forcing period ``ode.forcing_period`` (set from it).
    t0
        The start time of the period (forced systems: it fixes the phase).
    free
        Free parameters, by index or name -> (lower, upper) bounds (an ODE with data).
    means
        Period-mean conditions (:class:`MeanCondition`), one per free parameter (the shooting system
        is square: with fewer the free values would be whatever the solver stops at, with more there
        is generically no solution; both are refused).
    outputs
        Extra scalar outputs ``(x, d, p) -> scalar`` whose period means are reported in
        ``result.means`` (no condition imposed; an ODE with data).
    phase_point
        Autonomous ODE: the point a *fixed* Poincare section passes through (orthogonal to f
        there) for the whole solve; None: the section moves with the iterate (``OrbitMethod.phase``).
    """

    ode: object
    p: np.ndarray
    x_guess: np.ndarray
    period_guess: float | None = None
    t0: float = 0.0
    free: dict = field(default_factory=dict)
    means: list = field(default_factory=list)
    outputs: dict = field(default_factory=dict)
    phase_point: np.ndarray | None = None

    def __post_init__(self):
        ode = self.ode
        if not isinstance(ode, ODE):
            raise ValueError(f"OrbitProblem.ode: expected an ODE, got {type(ode).__name__}")
        self.p = finite_vector(self.p, "OrbitProblem.p", ode.np, f"the ODE has np={ode.np}")
        self.t0 = float(finite_vector(self.t0, "OrbitProblem.t0", 1)[0])
        if self.phase_point is not None:
            self.phase_point = finite_vector(self.phase_point, "OrbitProblem.phase_point", ode.nx,
                                             f"the ODE has nx={ode.nx}")
        if self.data_split:
            self._check_forced()
        else:
            self._check_ode()

    @property
    def data_split(self) -> bool:
        """Whether the ODE has a data function (the forced, data-split formulation)."""
        return self.ode.data is not None

    @property
    def autonomous(self) -> bool:
        """Whether the period is an unknown (the ODE does not depend on time)."""
        return bool(self.ode.autonomous)

    def _check_forced(self) -> None:
        """A data-split problem: the guess point, the free parameters, one mean condition each."""
        ode = self.ode
        self.x_guess = finite_vector(self.x_guess, "OrbitProblem.x_guess", ode.nx, f"the ODE has nx={ode.nx}")
        if self.period_guess is not None and float(self.period_guess) != ode.forcing_period:
            raise ValueError(f"OrbitProblem.period_guess: the period of an ODE with data is its forcing_period="
                             f"{ode.forcing_period}; leave period_guess out (got {self.period_guess!r})")
        self.period_guess = float(ode.forcing_period)
        for m in self.means:
            if not isinstance(m, MeanCondition):
                raise ValueError("OrbitProblem.means: items must be MeanCondition")
        for k, g in self.outputs.items():
            check_function(g, f"OrbitProblem.outputs[{k!r}]", 3)
            if g.numel_out(0) != 1:
                raise ValueError(f"OrbitProblem.outputs[{k!r}] must return a scalar")
        self.free_indices()  # validates
        for key, b in self.free.items():
            try:
                lo, hi = (float(v) for v in b)
            except (TypeError, ValueError):
                raise ValueError(f"OrbitProblem.free[{key!r}]: expected (lower, upper) bounds, got {b!r}") from None
            if not lo <= hi:  # also False for NaN
                raise ValueError(f"OrbitProblem.free[{key!r}]: lower bound {lo} above upper bound {hi} (or NaN)")
        if len(self.means) != len(self.free):
            raise ValueError(f"OrbitProblem.means: {len(self.means)} mean condition(s) for {len(self.free)} free "
                             "parameter(s); give one condition per free parameter (report other means as outputs)")

    def _check_ode(self) -> None:
        """A problem of an ODE without data: the guess point(s) and the period guess; no free parameters or means."""
        ode = self.ode
        if self.free or self.means or self.outputs:
            raise ValueError("OrbitProblem.free/means/outputs need an ODE with data (ODE.from_rhs(ode.rhs, "
                             "forcing_period))")
        self.x_guess = np.asarray(self.x_guess, float)
        if self.x_guess.shape[-1:] != (ode.nx,) or self.x_guess.ndim > 2:
            raise ValueError(f"OrbitProblem.x_guess: shape {self.x_guess.shape}, expected ({ode.nx},) or (M, {ode.nx})")
        finite_vector(self.x_guess, "OrbitProblem.x_guess")
        if self.period_guess is None:
            if ode.autonomous or ode.forcing_period is None:
                raise ValueError("OrbitProblem.period_guess is required (autonomous system or no forcing_period)")
            self.period_guess = float(ode.forcing_period)
        if not (np.isfinite(self.period_guess) and self.period_guess > 0):
            raise ValueError(f"OrbitProblem.period_guess must be positive, got {self.period_guess!r}")

    def free_indices(self) -> tuple[int, ...]:
        """Indices of the free parameters, in the order of ``free``.

        Returns
        -------
        tuple of int
        """
        out = []
        for key in self.free:
            if isinstance(key, str):
                if key not in self.ode.param_names:
                    raise ValueError(f"OrbitProblem.free: unknown parameter name {key!r}")
                i = self.ode.param_names.index(key)
            else:
                i = int(key)
                if not 0 <= i < self.ode.np:
                    raise ValueError(f"OrbitProblem.free: index {i} out of range (np={self.ode.np})")
            if i in out:
                raise ValueError(f"OrbitProblem.free: parameter {key!r} given twice")
            out.append(i)
        return tuple(out)

    def free_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) bounds of the free parameters, in the order of ``free``.

        Returns
        -------
        lower, upper : ndarray
        """
        lo = np.array([float(b[0]) for b in self.free.values()])
        hi = np.array([float(b[1]) for b in self.free.values()])
        return lo, hi

    def free_name(self, i: int) -> str:
        """The name of parameter ``i`` (``p<i>`` when the ODE has no names).

        Parameters
        ----------
        i : int
            Parameter index.

        Returns
        -------
        str
        """
        return self.ode.param_names[i] if self.ode.param_names else f"p{i}"

    def mean_names(self) -> list[str]:
        """Names of the period means a result reports: the conditions', then the outputs'.

        Returns
        -------
        list of str
        """
        names = [m.name or f"mean{k}" for k, m in enumerate(self.means)]
        return names + [str(k) for k in self.outputs]

