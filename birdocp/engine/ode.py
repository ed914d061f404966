"""Any ODE ``x' = f(x, t, p)`` posed from a plain Python function, forced or autonomous.

:class:`ODE` is the entry point of the general engine (periodic orbits with unknown period,
equilibria and Hopf points, Lyapunov exponents): the user writes ``f`` with operations that work on
CasADi symbols (``+ - * / **``, ``ca.sin``, ``ca.exp``, ``ca.vertcat`` ...) and the engine builds one
SX Function from it, once. Whether the system is autonomous is decided from the expression itself
(``f`` does not depend on ``t``), not from a flag the user could get wrong.

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

from dataclasses import dataclass

import casadi as ca
import numpy as np

from birdocp.engine.problem import RhsDimensions

from birdocp.engine.cache import owned_cache

__all__ = ["ODE"]


@dataclass(frozen=True, eq=False)
class ODE(RhsDimensions):
    """``x' = rhs(x, t, p)`` (nx states, np parameters); built by :meth:`from_function`.

    Attributes
    ----------
    rhs
        SX Function (x[nx], t[1], p[np]) -> xdot[nx].
    autonomous
        True when rhs does not depend on t (then the period of an orbit is an unknown).
    forcing_period
        the period of the explicit time dependence, in the system's time units
        (forced systems; informative: an orbit's period may be a multiple of it).
    state_names, param_names
        optional names.


    Equality is identity (``eq=False``): the engine caches CasADi graphs per ODE object.
    """

    rhs: ca.Function
    autonomous: bool
    forcing_period: float | None = None
    state_names: tuple[str, ...] = ()
    param_names: tuple[str, ...] = ()

    @staticmethod
    def from_function(f, nx: int, params=0, *, forcing_period: float | None = None,
                      state_names=(), name: str = "f") -> "ODE":
        """Build an ODE from ``f(x, t, p) -> xdot`` written with CasADi-compatible operations.

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
            Period of the forcing of a non-autonomous system (time units of the system).
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
        return ODE(rhs, bool(autonomous), None if autonomous else forcing_period,
                   tuple(state_names), pnames)

    @staticmethod
    def from_casadi(rhs: ca.Function, *, forcing_period: float | None = None, state_names=(),
                    param_names=()) -> "ODE":
        """Wrap an existing Function ``(x, t, p) -> xdot`` (expanded to SX when it is MX).

        Parameters
        ----------
        rhs : casadi.Function
            ``(x, t, p) -> xdot``.
        forcing_period : float, optional
            Period of the forcing [s] (None: autonomous).
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

    def jacobian_function(self) -> ca.Function:
        """``(x, t, p) -> df/dx`` (exact, SX), built on first use.

        Returns
        -------
        casadi.Function
        """
        return owned_cache(self).build("jacobians", self._build_jacobians)

    def _build_jacobians(self) -> ca.Function:
        x, t, p = ca.SX.sym("x", self.nx), ca.SX.sym("t"), ca.SX.sym("p", self.np)
        fx = self.rhs(x, t, p)
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
        return np.asarray(self.rhs(ca.DM(x), float(t), ca.DM(p))).ravel()

    def to_periodic_ode(self, period_s: float):
        """The same forced system as a :class:`~birdocp.engine.problem.PeriodicODE` (for the bird-style
        shooting of :mod:`birdocp.engine.shooting`).

        Parameters
        ----------
        period_s : float
            Forcing period [s].

        Returns
        -------
        PeriodicODE
        """
        from birdocp.engine.problem import PeriodicODE

        return PeriodicODE.from_rhs(self.rhs, period_s, self.state_names, self.param_names)

