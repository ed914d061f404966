"""Problem definitions for the model-agnostic limit-cycle engine.

Nothing here knows what system is being integrated: a :class:`PeriodicODE` is any CasADi ODE
``x' = f(x, d(t, p), p)`` with a known period, where all explicit time dependence goes through a
data vector ``d(t, p)``.  Splitting the time-only part ``d`` from the state right-hand side lets an
expensive time-only computation be evaluated once per RK4 stage time instead of inside every RHS
call (and, when no parameter is a decision variable, once per solve as plain numbers).

An :class:`OrbitProblem` says *what* is wanted (a periodic orbit of an ODE -- a :class:`PeriodicODE`
or any :class:`~birdocp.engine.ode.ODE`, forced or autonomous -- optionally with some parameters
free and as many period-mean conditions); the *how* lives in
:class:`birdocp.engine.method.OrbitMethod`, the front is :func:`birdocp.engine.orbit_front.solve`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

__all__ = ["RhsDimensions", "PeriodicODE", "MeanCondition", "OrbitProblem", "finite_vector"]


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


def _check_function(f, name: str, n_in: int) -> None:
    if not isinstance(f, ca.Function):
        raise ValueError(f"{name}: expected a casadi.Function, got {type(f).__name__}")
    if f.n_in() != n_in:
        raise ValueError(f"{name}: expected {n_in} inputs, got {f.n_in()}")


class RhsDimensions:
    """``nx`` and ``np`` of an ODE whose ``rhs`` takes the state first and the parameters third."""

    @property
    def nx(self) -> int:
        """Number of states."""
        return self.rhs.size1_in(0)

    @property
    def np(self) -> int:
        """Number of parameters."""
        return self.rhs.size1_in(2)


@dataclass(frozen=True, eq=False)
class PeriodicODE(RhsDimensions):
    """``x' = rhs(x, d, p)`` with ``d = data(t, p)``, periodic in ``t`` with period ``period_s``.

    Attributes
    ----------
    rhs
        Function (x[nx], d[nd], p[np]) -> xdot[nx]. Build it in SX: it is called at every RK4 stage.
    data
        Function (t[1], p[np]) -> d[nd] (column). It may be large; the engine evaluates it on the
        RK4 stage-time grid only (numerically when no parameter is free).
    period_s
        the period T of the forcing in seconds (the orbit is sought with this period).
    state_names, param_names
        names of the states and of the parameters (optional; parameters can then be named, e.g. as
        free parameters or continuation parameters).
    pre, post, pre_params
        a factorisation ``data(t, p) = post(pre(t, p), t, p)`` where
        ``pre`` depends only on the parameters ``pre_params``. When no free parameter of a problem
        is in ``pre_params``, the engine evaluates ``pre`` numerically once per solve and keeps only
        ``post`` symbolic (e.g. the bird: the wing shape in the arm's frame is numeric, the
        shoulder rotation, merge and lifting-line matrices are symbolic in the amplitude).
    graph_key
        optional identifier of the ODE's graphs (``rhs``, ``data``, ``pre``, ``post``; e.g. a hash of
        the code that built them and of every structural setting): two ODEs with the same key must
        have the same graphs. When set, pre's values on a stage-time grid are kept on disk
        (:mod:`birdocp.engine.datastore`, in the graph-cache folder) and read back by later processes
        instead of evaluating ``pre`` again, and compiled twins of the Functions are found in the
        cache by it.
    numeric
        optional ``(Function, key) -> Function``: given a Function the engine builds from ``post`` (or
        ``data``) only to evaluate numbers, never to differentiate (post mapped on the stage grid,
        post with its directional derivatives along free parameters), returns an equivalent one that
        evaluates faster, e.g. compiled C (:func:`birdocp.export.compiled.compiled_ode`). None: the
        Function itself. It must return the same numbers (CasADi's generated C does, bit for bit).

    Equality is identity (``eq=False``): the engine caches CasADi graphs per ODE object.
    """

    rhs: ca.Function
    data: ca.Function
    period_s: float
    state_names: tuple[str, ...] = ()
    param_names: tuple[str, ...] = ()
    pre: ca.Function | None = None
    post: ca.Function | None = None
    pre_params: tuple[int, ...] = ()
    graph_key: str = ""
    numeric: object = None

    def __post_init__(self):
        _check_function(self.rhs, "PeriodicODE.rhs", 3)
        _check_function(self.data, "PeriodicODE.data", 2)
        if not (np.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"PeriodicODE.period_s must be a positive finite number, got {self.period_s}")
        nx, nd, np_ = self.nx, self.nd, self.np
        if self.rhs.size_out(0) != (nx, 1):
            raise ValueError(f"PeriodicODE.rhs: output must be a column of size nx={nx}, got {self.rhs.size_out(0)}")
        if self.data.size1_in(0) * self.data.size2_in(0) != 1:
            raise ValueError("PeriodicODE.data: first input (t) must be a scalar")
        if self.data.size_in(1) != (np_, 1) and np_ > 0:
            raise ValueError(f"PeriodicODE.data: second input (p) must be {np_}x1, got {self.data.size_in(1)}")
        if self.data.size_out(0) != (nd, 1):
            raise ValueError(f"PeriodicODE.data: output must be a column of size nd={nd}, got {self.data.size_out(0)}")
        if self.state_names and len(self.state_names) != nx:
            raise ValueError(f"PeriodicODE.state_names: {len(self.state_names)} names for nx={nx} states")
        if (self.pre is None) != (self.post is None):
            raise ValueError("PeriodicODE: pre and post go together")
        if self.pre is not None:
            _check_function(self.pre, "PeriodicODE.pre", 2)
            _check_function(self.post, "PeriodicODE.post", 3)
            if self.post.size_in(0) != self.pre.size_out(0) or self.post.size_out(0) != (nd, 1):
                raise ValueError("PeriodicODE.post: takes pre's output and returns the data vector")
        if self.param_names and len(self.param_names) != np_:
            raise ValueError(f"PeriodicODE.param_names: {len(self.param_names)} names for np={np_} parameters")

    def fast(self, f: ca.Function, what: str) -> ca.Function:
        """``numeric(f, key)`` when set (a faster Function for numbers only), else ``f``. ``what`` names
        how the engine built ``f`` from this ODE's Functions (e.g. ``"post"``, ``"post_dpf 3,40"``);
        with ``graph_key`` set, ``key`` = graph_key + what identifies ``f``'s graph (else "").

        Parameters
        ----------
        f : casadi.Function
            Function built from this ODE's Functions.
        what : str
            How it was built.

        Returns
        -------
        casadi.Function
        """
        if self.numeric is None:
            return f
        return self.numeric(f, f"{self.graph_key}:{what}" if self.graph_key else "")

    @property
    def autonomous(self) -> bool:
        """``False``: a PeriodicODE is forced (its period is the forcing's)."""
        return False

    @property
    def forcing_period(self) -> float:
        """The period of the forcing, ``period_s`` (the name :class:`~birdocp.engine.ode.ODE` uses)."""
        return self.period_s

    @property
    def nd(self) -> int:
        """Size of the per-time data vector."""
        return self.rhs.size1_in(1)

    @staticmethod
    def from_rhs(f: ca.Function, period_s: float, state_names=(), param_names=()) -> "PeriodicODE":
        """Wrap a plain ``f(x, t, p)``: the data vector is the time itself (``d = t``, nd = 1).

        Parameters
        ----------
        f : casadi.Function
            ``f(x, t, p) -> xdot``.
        period_s : float
            Forcing period [s].
        state_names, param_names : sequence of str
            Names.

        Returns
        -------
        PeriodicODE
        """
        _check_function(f, "from_rhs f", 3)
        try:
            period_s = float(period_s)
        except (TypeError, ValueError):
            raise ValueError(f"PeriodicODE.from_rhs: period_s must be a positive number, got {period_s!r}") from None
        nx, np_ = f.size1_in(0), f.size1_in(2)
        x = ca.SX.sym("x", nx)
        d = ca.SX.sym("d", 1)
        p = ca.SX.sym("p", np_)
        t = ca.SX.sym("t", 1)
        rhs = ca.Function("rhs", [x, d, p], [f(x, d, p)], ["x", "d", "p"], ["xdot"])
        data = ca.Function("data", [t, p], [t], ["t", "p"], ["d"])
        return PeriodicODE(rhs, data, float(period_s), tuple(state_names), tuple(param_names))


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
        _check_function(self.output, f"MeanCondition({self.name!r}).output", 3)
        if self.output.numel_out(0) != 1:
            raise ValueError(f"MeanCondition({self.name!r}).output must return a scalar")


@dataclass(eq=False)
class OrbitProblem:
    """A periodic orbit of ``ode`` at parameters ``p``: the one problem type of the engine.

    The ODE decides the formulation (:func:`birdocp.engine.orbit_front.solve`):

    * a :class:`PeriodicODE` (forced, data-split ``x' = f(x, d(t, p), p)``): the period is the
      forcing's, free parameters each held by a period-mean condition, extra period-mean outputs;
    * an :class:`~birdocp.engine.ode.ODE`, autonomous (the period is an unknown, a phase condition
      fixes the time origin) or forced (the period is ``period_guess``, by default the forcing's; a
      multiple for subharmonic orbits). Free parameters and mean conditions need a PeriodicODE
      (:meth:`birdocp.engine.ode.ODE.to_periodic_ode`).

    Attributes
    ----------
    ode
        The system: :class:`PeriodicODE` or :class:`~birdocp.engine.ode.ODE`.
    p
        Full parameter vector (np,) (initial values of the free ones).
    x_guess
        A point near the orbit at ``t0`` (nx,), or (an ``ODE``) guesses of the shooting points
        (M or M-1, nx).
    period_guess
        ``ODE``: the period guess (autonomous: an unknown; forced: the period itself, default
        ``ode.forcing_period``). ``PeriodicODE``: the forcing period ``period_s`` (set from it).
    t0
        The start time of the period (forced systems: it fixes the phase).
    free
        Free parameters, by index or name -> (lower, upper) bounds (``PeriodicODE``).
    means
        Period-mean conditions (:class:`MeanCondition`), one per free parameter (the shooting system
        is square: with fewer the free values would be whatever the solver stops at, with more there
        is generically no solution; both are refused).
    outputs
        Extra scalar outputs ``(x, d, p) -> scalar`` whose period means are reported in
        ``result.means`` (no condition imposed; ``PeriodicODE``).
    phase_point
        ``ODE``, autonomous: the point a *fixed* Poincare section passes through (orthogonal to f
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
        if not isinstance(ode, PeriodicODE) and not hasattr(ode, "autonomous"):
            raise ValueError(f"OrbitProblem.ode: expected a PeriodicODE or an ODE, got {type(ode).__name__}")
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
        """Whether the ODE is a :class:`PeriodicODE` (the forced, data-split formulation)."""
        return isinstance(self.ode, PeriodicODE)

    @property
    def autonomous(self) -> bool:
        """Whether the period is an unknown (the ODE does not depend on time)."""
        return bool(self.ode.autonomous)

    def _check_forced(self) -> None:
        """A PeriodicODE problem: the guess point, the free parameters, one mean condition each."""
        ode = self.ode
        self.x_guess = finite_vector(self.x_guess, "OrbitProblem.x_guess", ode.nx, f"the ODE has nx={ode.nx}")
        if self.period_guess is not None and float(self.period_guess) != ode.period_s:
            raise ValueError(f"OrbitProblem.period_guess: a PeriodicODE's period is its period_s={ode.period_s}; "
                             f"leave period_guess out (got {self.period_guess!r})")
        self.period_guess = float(ode.period_s)
        for m in self.means:
            if not isinstance(m, MeanCondition):
                raise ValueError("OrbitProblem.means: items must be MeanCondition")
        for k, g in self.outputs.items():
            _check_function(g, f"OrbitProblem.outputs[{k!r}]", 3)
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
        """An ODE problem: the guess point(s) and the period guess; no free parameters or means."""
        ode = self.ode
        if self.free or self.means or self.outputs:
            raise ValueError("OrbitProblem.free/means/outputs need a PeriodicODE (ODE.to_periodic_ode(period_s))")
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
