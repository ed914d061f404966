"""The engine's one ODE class: ``x' = rhs(x, d, p)`` with ``d = data(t, p)`` (or ``d = t``), forced or
autonomous.

:class:`ODE` is what every part of the engine integrates (periodic orbits, equilibria and Hopf points,
Lyapunov exponents, continuation). Two ways to build one:

* :meth:`ODE.from_function`: the user writes ``f(x, t, p)`` with operations that work on CasADi symbols
  (``+ - * / **``, ``ca.sin``, ``ca.exp``, ``ca.vertcat`` ...) and the engine builds one SX Function
  from it, once. Whether the system is autonomous is decided from the expression itself (``f`` does not
  depend on ``t``), not from a flag the user could get wrong. :meth:`ODE.from_casadi` wraps an existing
  Function the same way.
* the constructor with a ``data`` Function (the bird) or :meth:`ODE.from_rhs` (``d = t`` made explicit):
  a forced system whose explicit time dependence goes through the data vector ``d(t, p)``, with the
  forcing period. Splitting the time-only part ``d`` from the state right-hand side lets an expensive
  time-only computation be evaluated once per RK4 stage time instead of inside every RHS call (and,
  when no parameter is a decision variable, once per solve as plain numbers).

The ODE selects the shooting strategy of :func:`birdocp.engine.orbit_front.solve`: with a data function,
the forced data-split one (the period is the forcing's; free parameters held by period-mean conditions;
:mod:`birdocp.engine.shooting`); without, the time-scaled one (autonomous: the period is an unknown;
forced: the period is the problem's period guess, e.g. a multiple of the forcing's; :mod:`birdocp.engine.orbits`).

Example::

    import casadi as ca
    from birdocp.engine.ode import ODE

    def rossler(x, t, p):
        a, b, c = p[0], p[1], p[2]
        return ca.vertcat(-x[1] - x[2], x[0] + a * x[1], b + x[2] * (x[0] - c))

    ode = ODE.from_function(rossler, nx=3, params=("a", "b", "c"))
    ode.autonomous   # True
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.engine.cache import owned_cache

__all__ = ["ODE", "check_function"]


def check_function(f, name: str, n_in: int) -> None:
    """ValueError naming ``name`` unless ``f`` is a casadi.Function with ``n_in`` inputs.

    Parameters
    ----------
    f : object
        The object to check.
    name : str
        Name in the error.
    n_in : int
        Number of inputs required.

    Returns
    -------
    None
    """
    if not isinstance(f, ca.Function):
        raise ValueError(f"{name}: expected a casadi.Function, got {type(f).__name__}")
    if f.n_in() != n_in:
        raise ValueError(f"{name}: expected {n_in} inputs, got {f.n_in()}")


@dataclass(frozen=True, eq=False)
class ODE:
    """``x' = rhs(x, d, p)`` with ``d = data(t, p)`` (nd entries), or ``d = t`` when there is no data.

    Attributes
    ----------
    rhs
        Function (x[nx], d[nd], p[np]) -> xdot[nx] (without data: (x, t, p), nd = 1). Build it in SX:
        it is called at every RK4 stage.
    data
        optional Function (t[1], p[np]) -> d[nd] (column). It may be large; the engine evaluates it on
        the RK4 stage-time grid only (numerically when no parameter is free). Given, the system is
        forced with period ``forcing_period`` and solved by the forced, data-split shooting.
    forcing_period
        the period T of the explicit time dependence, in the system's time units (seconds for the
        bird); required with ``data`` (the orbit is sought with this period); without data,
        informative (an orbit's period may be a multiple of it) and set to None when autonomous.
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
    autonomous
        (computed) True when there is no data and rhs does not depend on t: the period of an orbit is
        then an unknown.

    Equality is identity (``eq=False``): the engine caches CasADi graphs per ODE object.
    """

    rhs: ca.Function
    data: ca.Function | None = None
    forcing_period: float | None = None
    state_names: tuple[str, ...] = ()
    param_names: tuple[str, ...] = ()
    pre: ca.Function | None = None
    post: ca.Function | None = None
    pre_params: tuple[int, ...] = ()
    graph_key: str = ""
    numeric: object = None
    autonomous: bool = field(init=False, default=False)

    def __post_init__(self):
        check_function(self.rhs, "ODE.rhs", 3)
        nx, nd, np_ = self.nx, self.nd, self.np
        if self.rhs.size_out(0) != (nx, 1):
            raise ValueError(f"ODE.rhs: output must be a column of size nx={nx}, got {self.rhs.size_out(0)}")
        if self.forcing_period is not None:
            try:
                T = float(self.forcing_period)
            except (TypeError, ValueError):
                T = float("nan")
            if not (np.isfinite(T) and T > 0):
                raise ValueError(f"ODE.forcing_period must be a positive finite number, got {self.forcing_period!r}")
            object.__setattr__(self, "forcing_period", T)
        if self.state_names and len(self.state_names) != nx:
            raise ValueError(f"ODE.state_names: {len(self.state_names)} names for nx={nx} states")
        if self.param_names and len(self.param_names) != np_:
            raise ValueError(f"ODE.param_names: {len(self.param_names)} names for np={np_} parameters")
        object.__setattr__(self, "state_names", tuple(self.state_names))
        object.__setattr__(self, "param_names", tuple(self.param_names))
        if self.data is None:
            if nd != 1 or self.pre is not None or self.post is not None:
                raise ValueError(f"ODE: without data the rhs takes (x, t, p) (nd={nd}) and there is no pre/post")
            x, t, p = ca.SX.sym("x", nx), ca.SX.sym("t"), ca.SX.sym("p", np_)
            autonomous = not ca.depends_on(self.rhs(x, t, p), t)
            object.__setattr__(self, "autonomous", autonomous)
            if autonomous:
                object.__setattr__(self, "forcing_period", None)
            return
        self._check_data(nd, np_)

    def _check_data(self, nd: int, np_: int) -> None:
        """A data-split ODE: data (t, p) -> d[nd], the forcing period, pre and post together."""
        check_function(self.data, "ODE.data", 2)
        if self.forcing_period is None:
            raise ValueError("ODE.forcing_period: required with data (the period of the forcing)")
        if self.data.size1_in(0) * self.data.size2_in(0) != 1:
            raise ValueError("ODE.data: first input (t) must be a scalar")
        if self.data.size_in(1) != (np_, 1) and np_ > 0:
            raise ValueError(f"ODE.data: second input (p) must be {np_}x1, got {self.data.size_in(1)}")
        if self.data.size_out(0) != (nd, 1):
            raise ValueError(f"ODE.data: output must be a column of size nd={nd}, got {self.data.size_out(0)}")
        if (self.pre is None) != (self.post is None):
            raise ValueError("ODE: pre and post go together")
        if self.pre is not None:
            check_function(self.pre, "ODE.pre", 2)
            check_function(self.post, "ODE.post", 3)
            if self.post.size_in(0) != self.pre.size_out(0) or self.post.size_out(0) != (nd, 1):
                raise ValueError("ODE.post: takes pre's output and returns the data vector")

    @property
    def nx(self) -> int:
        """Number of states."""
        return self.rhs.size1_in(0)

    @property
    def np(self) -> int:
        """Number of parameters."""
        return self.rhs.size1_in(2)

    @property
    def nd(self) -> int:
        """Size of the per-time data vector (1 without data: d = t)."""
        return self.rhs.size1_in(1)

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

    @staticmethod
    def from_rhs(f: ca.Function, forcing_period: float, state_names=(), param_names=()) -> "ODE":
        """Wrap a plain ``f(x, t, p)`` as a forced, data-split ODE: the data vector is the time itself
        (``d = t``, nd = 1), so :func:`~birdocp.engine.orbit_front.solve` uses the forced shooting
        (period ``forcing_period``, free parameters with mean conditions, IPOPT by default).

        Parameters
        ----------
        f : casadi.Function
            ``f(x, t, p) -> xdot``.
        forcing_period : float
            Forcing period (the system's time units).
        state_names, param_names : sequence of str
            Names.

        Returns
        -------
        ODE
        """
        check_function(f, "from_rhs f", 3)
        try:
            forcing_period = float(forcing_period)
        except (TypeError, ValueError):
            raise ValueError(f"ODE.from_rhs: forcing_period must be a positive number, got {forcing_period!r}") from None
        nx, np_ = f.size1_in(0), f.size1_in(2)
        x = ca.SX.sym("x", nx)
        d = ca.SX.sym("d", 1)
        p = ca.SX.sym("p", np_)
        t = ca.SX.sym("t", 1)
        rhs = ca.Function("rhs", [x, d, p], [f(x, d, p)], ["x", "d", "p"], ["xdot"])
        data = ca.Function("data", [t, p], [t], ["t", "p"], ["d"])
        return ODE(rhs, data, forcing_period, tuple(state_names), tuple(param_names))

    @staticmethod
    def from_function(f, nx: int, params=0, *, forcing_period: float | None = None,
                      state_names=(), name: str = "f") -> "ODE":
        """Build an ODE (no data: ``d = t``) from ``f(x, t, p) -> xdot`` written with CasADi-compatible
        operations.

        Parameters
        ----------
        f : callable
            ``f(x, t, p)`` with x an SX column (nx), t an SX scalar, p an SX column; returns a
            column (``ca.vertcat(...)``), a list of expressions, or anything ``ca.vertcat`` accepts.
        nx : int
            Number of states.
        params : int or sequence of str
            Number of parameters, or their names (then ``np = len(params)``).
        forcing_period : float, optional
            Period of the forcing of a non-autonomous system (time units of the system; ignored when
            ``f`` does not depend on t).
        state_names : sequence of str, optional
            Names of the states.
        name : str
            Name of the right-hand-side Function.

        Returns
        -------
        ODE
        """
        if isinstance(params, (int, np.integer)):
            n_p, pnames = int(params), ()
            if n_p < 0:
                raise ValueError(f"ODE.from_function: params must be a number >= 0 or names, got {params!r}")
        else:
            pnames = tuple(str(s) for s in params)
            n_p = len(pnames)
        if not (isinstance(nx, (int, np.integer)) and nx >= 1):
            raise ValueError(f"ODE.from_function: nx must be a positive integer, got {nx!r}")
        x = ca.SX.sym("x", int(nx))
        t = ca.SX.sym("t")
        p = ca.SX.sym("p", n_p)
        out = f(x, t, p)
        if isinstance(out, (list, tuple)):
            out = ca.vertcat(*out)
        out = ca.SX(out)
        if out.numel() != nx:
            raise ValueError(f"ODE.from_function: f returned {out.numel()} components for nx={nx}")
        out = ca.reshape(out, nx, 1)
        autonomous = not ca.depends_on(out, t)
        if not autonomous and forcing_period is not None and not (np.isfinite(forcing_period) and forcing_period > 0):
            raise ValueError(f"ODE.from_function: forcing_period must be positive, got {forcing_period!r}")
        if state_names and len(state_names) != nx:
            raise ValueError(f"ODE.from_function: {len(state_names)} state names for nx={nx}")
        rhs = ca.Function(name, [x, t, p], [out], ["x", "t", "p"], ["xdot"])
        return ODE(rhs, None, None if autonomous else forcing_period, tuple(state_names), pnames)

    @staticmethod
    def from_casadi(rhs: ca.Function, *, forcing_period: float | None = None, state_names=(),
                    param_names=()) -> "ODE":
        """Wrap an existing Function ``(x, t, p) -> xdot`` (expanded to SX when it is MX) as an ODE
        without data (:meth:`from_function`).

        Parameters
        ----------
        rhs : casadi.Function
            ``(x, t, p) -> xdot``.
        forcing_period : float, optional
            Period of the forcing (None: autonomous).
        state_names, param_names : sequence of str
            Names (default: indices).

        Returns
        -------
        ODE
        """
        if not isinstance(rhs, ca.Function) or rhs.n_in() != 3:
            raise ValueError("ODE.from_casadi: expected a casadi.Function with inputs (x, t, p)")
        nx, n_p = rhs.size1_in(0), rhs.size1_in(2)
        return ODE.from_function(lambda x, t, p: rhs(x, t, p), nx, tuple(param_names) or n_p,
                                 forcing_period=forcing_period, state_names=state_names)

    def param_index(self, key) -> int:
        """Index of a parameter given by name or index.

        Parameters
        ----------
        key : str or int
            Name or index.

        Returns
        -------
        int
        """
        if isinstance(key, str):
            if key not in self.param_names:
                raise ValueError(f"unknown parameter {key!r}; parameters: {self.param_names}")
            return self.param_names.index(key)
        i = int(key)
        if not 0 <= i < self.np:
            raise ValueError(f"parameter index {i} out of range (np={self.np})")
        return i

    def time_rhs(self, x, t, p):
        """``rhs(x, d(t, p), p)``: the right-hand side as a function of the time (symbols or numbers).

        Parameters
        ----------
        x : casadi.SX, casadi.MX or casadi.DM
            State (nx).
        t : casadi.SX, casadi.MX, casadi.DM or float
            Time.
        p : casadi.SX, casadi.MX or casadi.DM
            Parameters (np).

        Returns
        -------
        casadi.SX, casadi.MX or casadi.DM
            xdot (nx).
        """
        return self.rhs(x, t if self.data is None else self.data(t, p), p)

    def jacobian_function(self) -> ca.Function:
        """``(x, t, p) -> df/dx`` (exact, SX), built on first use.

        Returns
        -------
        casadi.Function
        """
        return owned_cache(self).build("jacobians", self._build_jacobians)

    def _build_jacobians(self) -> ca.Function:
        x, t, p = ca.SX.sym("x", self.nx), ca.SX.sym("t"), ca.SX.sym("p", self.np)
        fx = self.time_rhs(x, t, p)
        return ca.Function("dfdx", [x, t, p], [ca.jacobian(fx, x), ca.jacobian(fx, p)],
                           ["x", "t", "p"], ["dfdx", "dfdp"])

    def evaluate(self, x, t, p) -> np.ndarray:
        """f(x, t, p) as a numpy vector.

        Parameters
        ----------
        x : array_like
            State.
        t : float
            Time.
        p : array_like
            Parameters.

        Returns
        -------
        ndarray
        """
        x, p = np.asarray(x, float).ravel(), np.asarray(p, float).ravel()
        if x.size != self.nx or p.size != self.np:  # CasADi would broadcast a scalar silently
            raise ValueError(f"ODE.evaluate: x has {x.size} entries and p {p.size}; the ODE has nx={self.nx}, "
                             f"np={self.np}")
        return np.asarray(self.time_rhs(ca.DM(x), float(t), ca.DM(p))).ravel()

