"""Bird studies on top of the limit-cycle engine: trimmed flight (limit cycle + Floquet).

``trim(cfg)`` finds the periodic flight of the bird for the gait of ``cfg`` and its Floquet
multipliers; the result adds the flight quantities of the paper to the engine's result:

* ``mean_vertical_speed_mps``: period mean of ``W = u sin(theta) - w cos(theta)`` (inertial vertical
  speed, positive climbing);
* ``mean_forward_speed_mps``: period mean of ``U = u cos(theta) + w sin(theta)`` (inertial horizontal);
* ``flight_path_angle_deg``: ``atan(mean W / mean U)`` (positive climbing).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.bird.config_checks import has_aero_states
from birdocp.bird.flight import flight_outputs, flight_path_angle_deg
from birdocp.bird.model import get_model
from birdocp.bird.validity import CycleValidity, cycle_validity, grid_validity
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_front import solve
from birdocp.engine.orbit_result import JSON_OMITS, OrbitResult
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.results import finite_or_none, result_dict

__all__ = ["TrimResult", "CYCLE_FIELDS", "trim", "method_of", "solver_of", "solver_ode", "BODY_STATE_INDICES"]

def solver_ode(m, compiled: bool = False):
    """The ODE the engine solves for the configured model ``m``: ``m.ode``, or with ``compiled`` its
    twin whose RHS and numeric data Functions are compiled C
    (:func:`birdocp.export.compiled.compiled_ode`, cached; bit-identical numbers). Falls back to
    ``m.ode`` with a warning on stderr if compiling fails.

    Parameters
    ----------
    m : BirdModel
        Configured model.
    compiled : bool
        Use the compiled twin.

    Returns
    -------
    ODE
    """
    if not compiled:
        return m.ode
    from birdocp.export.compiled import compiled_ode

    return compiled_ode(m.ode, key_extra=repr(m.structure)) or m.ode


BODY_STATE_INDICES = (0, 1, 2, 3)
"""The Newton states of the ``"newton-picard"`` solver: u, w, q, theta (the aerodynamic states, strongly
damped, are iterated by Picard)."""


def solver_of(cfg: Config, free: bool = False) -> str:
    """The engine solver of ``cfg.solve.solver``: ``"auto"`` is ``"newton-picard"`` for a model with
    aerodynamic states (trim, and level flight, whose free parameter joins the Newton subspace:
    :mod:`birdocp.engine.newton_picard_free`), ``"ipopt"`` otherwise.

    Parameters
    ----------
    cfg : Config
        Configuration.
    free : bool
        The solve has free parameters held by mean conditions (level flight); the choice is the same.

    Returns
    -------
    str
        ``"ipopt"``, ``"lm"`` or ``"newton-picard"``.
    """
    s = cfg.solve.solver
    if s == "auto":
        return "newton-picard" if has_aero_states(cfg) else "ipopt"
    return s


def method_of(cfg: Config, free: bool = False, **over) -> OrbitMethod:
    """The :class:`~birdocp.engine.method.OrbitMethod` of ``cfg.solve`` (fields overridden by ``over``;
    the solver from :func:`solver_of`; with ``"newton-picard"`` the Newton states are the body's,
    :data:`BODY_STATE_INDICES`, and without free parameters the chord is the exact monodromy,
    ``chord="monodromy"``: its stage Jacobians cost less than the subspace chord's passes for the
    bird's aerodynamic states).

    Parameters
    ----------
    cfg : Config
        Configuration.
    free : bool
        The solve has free parameters (level flight).
    **over
        Fields of :class:`~birdocp.engine.method.OrbitMethod` overridden.

    Returns
    -------
    OrbitMethod
    """
    s = cfg.solve
    kw = dict(points=s.points, steps_per_period=s.steps_per_period, solver=solver_of(cfg, free),
              derivatives=s.derivatives, max_iter=s.max_iter, tol=s.tol if s.tol > 0 else None)
    kw.update(over)
    if kw["solver"] == "newton-picard":
        kw.setdefault("newton_states", BODY_STATE_INDICES)
        if not free:  # the trim: the exact monodromy as the chord (engine.newton_picard_chord)
            kw.setdefault("chord", "monodromy")
    return OrbitMethod(**kw)


def _of_cycle(name: str):
    """A read-only property that reads ``self.cycle.<name>``."""
    return property(lambda self: getattr(self.cycle, name),
                    doc=f"``cycle.{name}`` (:class:`~birdocp.engine.orbit_result.OrbitResult`).")


@dataclass
class TrimResult:
    """A trimmed flight: the engine's :class:`~birdocp.engine.orbit_result.OrbitResult` (``cycle``) plus
    the flight quantities of the paper. The cycle's fields listed in :data:`CYCLE_FIELDS` are also
    readable here (read-only properties); everything else of the cycle is ``result.cycle.<name>``."""

    cycle: OrbitResult
    cfg: Config
    _wing_power: dict | None = field(default=None, repr=False)

    success = _of_cycle("success")
    status = _of_cycle("status")
    message = _of_cycle("message")
    iterations = _of_cycle("iterations")
    residual_history = _of_cycle("residual_history")
    max_residual = _of_cycle("max_residual")
    wall_s = _of_cycle("wall_s")
    period = _of_cycle("period")
    autonomous = _of_cycle("autonomous")
    shooting_times = _of_cycle("shooting_times")
    shooting_points = _of_cycle("shooting_points")
    x0 = _of_cycle("x0")
    p = _of_cycle("p")
    free_values = _of_cycle("free_values")
    trajectory_t = _of_cycle("trajectory_t")
    trajectory_x = _of_cycle("trajectory_x")
    means = _of_cycle("means")
    monodromy = _of_cycle("monodromy")
    multipliers = _of_cycle("multipliers")
    eigenvectors = _of_cycle("eigenvectors")
    floquet_exponents = _of_cycle("floquet_exponents")
    doubling_times_s = _of_cycle("doubling_times_s")
    stable = _of_cycle("stable")
    monodromy_vs_full_period_jacobian = _of_cycle("monodromy_vs_full_period_jacobian")
    method = _of_cycle("method")
    error_estimate = _of_cycle("error_estimate")

    @property
    def validity(self) -> "CycleValidity":
        """Where the model holds on this cycle (:func:`birdocp.bird.validity.grid_validity` on the
        trajectory at the solver's step times, with the solve's stage data; computed on first use,
        thresholds from ``cfg.validity``)."""
        v = self.__dict__.get("_validity")
        if v is None:
            c = self.cycle
            n = int(c.method["steps_per_period"])
            if np.shape(c.trajectory_x)[0] == n + 1:
                v = grid_validity(self.cfg, c.trajectory_x, c.p, float(c.trajectory_t[0]), n)
            else:
                v = cycle_validity(self.cfg, c.trajectory_t, c.trajectory_x, c.p)
            self.__dict__["_validity"] = v
        return v

    @property
    def wing_power(self) -> dict:
        """Powers of the wing masses over the cycle (docs/studies/inertia.md, powers), computed once.

        Keys: ``t_s`` (the trajectory times, one period), the time histories of
        :data:`birdocp.bird.model.WING_POWER_NAMES` and their period means ``mean_<name>``, the
        period means of their positive parts ``mean_positive_<name>`` and ``peak_<name>``
        (maximum). ``inertial_power_W`` is dT_rel/dt of the wings' kinetic energy relative to the
        body (its mean is 0: the cost is its positive part when no energy is recovered);
        ``shoulder_inertial_power_W`` is what the wing joints deliver to the wing masses (add the
        aerodynamic flapping power for the whole shoulder power:
        :func:`birdocp.bird.inertia.total_shoulder_power_W`). Zero for massless wings."""
        if self._wing_power is None:
            t = np.asarray(self.cycle.trajectory_t, float)
            X = np.asarray(self.cycle.trajectory_x, float)
            hist = get_model(self.cfg).model.wing_power_history(t, X, self.cycle.p)
            out = {"t_s": t}
            for k, v in hist.items():
                out[k] = v
                per = v[:-1] if len(v) > 1 else v  # periodic grid: the last point repeats the first
                out[f"mean_{k}"] = float(np.mean(per))
                out[f"mean_positive_{k}"] = float(np.mean(np.maximum(per, 0.0)))
                out[f"peak_{k}"] = float(np.max(per))
            self._wing_power = out
        return self._wing_power

    def wing_power_summary(self) -> dict:
        """JSON part of :attr:`wing_power`: the wing mass, the period means and peaks (W, J) and the
        time histories (lists).

        Returns
        -------
        dict
        """
        from birdocp.bird.model import WING_POWER_NAMES

        wp = self.wing_power if self.cycle.trajectory_x is not None else None
        out = {"wing_mass_kg": float(self.cfg.wing.mass_kg)}
        if wp is None:
            return out
        for k in WING_POWER_NAMES:
            for pre in ("mean_", "mean_positive_", "peak_"):
                out[pre + k] = finite_or_none(wp[pre + k])
        out["wing_power_history"] = {k: [float(v) for v in wp[k]] for k in ("t_s",) + WING_POWER_NAMES}
        return out

    @property
    def mean_vertical_speed_mps(self) -> float:
        return self.cycle.means.get("vertical_speed_mps", float("nan"))

    @property
    def mean_forward_speed_mps(self) -> float:
        return self.cycle.means.get("forward_speed_mps", float("nan"))

    @property
    def flight_path_angle_deg(self) -> float:
        return flight_path_angle_deg(self.mean_vertical_speed_mps, self.mean_forward_speed_mps)

    @property
    def amplitude_deg(self) -> float:
        return float(self.cycle.p[PARAM_NAMES.index("gait.shoulder_flap.amplitude_deg")])

    @property
    def energetics(self) -> dict | None:
        """Power outputs of the cycle (:func:`birdocp.bird.energetics.cycle_energetics`), computed on
        first access (about 0.05-0.5 s); None when the cycle is not finite."""
        if "_energetics" not in self.__dict__:
            self.__dict__["_energetics"] = None
            c = self.cycle
            if np.all(np.isfinite(c.x0)) and np.all(np.isfinite(c.p)):
                from birdocp.bird.energetics import cycle_energetics

                self.__dict__["_energetics"] = cycle_energetics(
                    get_model(self.cfg), c.p, c.x0, int(c.method["steps_per_period"]),
                    float(c.trajectory_t[0]))
        return self.__dict__["_energetics"]

    def energetics_dict(self) -> dict:
        """The scalar power outputs (keys :data:`birdocp.bird.energetics.ENERGETICS_KEYS`) and their
        definitions, JSON-able; computed if needed.

        Returns
        -------
        dict
        """
        from birdocp.bird.energetics import ENERGETICS_KEYS

        e = self.energetics
        if e is None:
            return {}
        out = {k: finite_or_none(e[k]) for k in ENERGETICS_KEYS}
        out["energetics_definitions"] = dict(e["definitions"])
        return out

    def to_dict(self) -> dict:
        """Plain JSON-able dict; complex numbers as [re, im] pairs, multipliers largest first. The
        power outputs are included when they were computed (:attr:`energetics`).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        c = self.cycle
        flight = {"amplitude_deg": self.amplitude_deg,
                  "root_ahead_m": float(c.p[PARAM_NAMES.index("wing.root_ahead_m")]),
                  "moduli": None if c.multipliers is None else np.abs(c.multipliers),
                  "mean_vertical_speed_mps": self.mean_vertical_speed_mps,
                  "mean_forward_speed_mps": self.mean_forward_speed_mps,
                  "flight_path_angle_deg": self.flight_path_angle_deg,
                  "validity": self.validity, **self.wing_power_summary()}
        if self.__dict__.get("_energetics") is not None:
            flight.update(self.energetics_dict())
        if c.error_estimate is not None:  # trim(..., error_estimate=True): the 2N re-solve's estimate
            flight["error_estimate"] = c.error_estimate
        # the engine cycle's fields (the trajectory and p go to arrays.npz), then the flight's
        return result_dict(c, exclude=("p", "trajectory_t", "trajectory_x") + JSON_OMITS[c.formulation], extra=flight,
                           rename={"floquet_exponents": "floquet_exponents_per_s",
                                   "shooting_times": "shooting_times_s"})

    def arrays(self) -> dict:
        """The arrays of the run folder (arrays.npz): trajectory, shooting points, parameters, residual history
        and, when computed, the monodromy and multipliers.

        Returns
        -------
        dict of str to ndarray
        """
        c = self.cycle
        out = {"trajectory_t_s": np.asarray(c.trajectory_t), "trajectory_x": np.asarray(c.trajectory_x),
               "shooting_points": np.asarray(c.shooting_points), "p": np.asarray(c.p),
               "residual_history": np.asarray(c.residual_history)}
        if c.monodromy is not None:
            out.update(monodromy=np.asarray(c.monodromy), multipliers=np.asarray(c.multipliers),
                       eigenvectors=np.asarray(c.eigenvectors))
        e = self.__dict__.get("_energetics")
        if e is not None:
            out.update({f"power_{k}": np.asarray(v) for k, v in e["samples"].items()})
        return out

    def table(self) -> str:
        """Human-readable summary.

        Returns
        -------
        str
        """
        c = self.cycle
        lines = [f"trim: {'converged' if c.success else 'NOT converged'} ({c.status}), "
                 f"{c.iterations} iterations, max residual {c.max_residual:.2e}, {c.wall_s.get('total', 0):.2f} s",
                 f"  amplitude {self.amplitude_deg:.4g} deg, wing root "
                 f"{c.p[PARAM_NAMES.index('wing.root_ahead_m')]:.4g} m ahead of G",
                 "  x0 = (u {:.5f} m/s, w {:.5f} m/s, q {:.5f} rad/s, theta {:.5f} rad)".format(*c.x0)]
        if c.multipliers is not None:
            lines.append("  Floquet multipliers (largest first):")
            lines.append("    {:>24}  {:>9}  {:>22}  {:>14}".format(
                "multiplier", "modulus", "exponent [1/s]", "doubling [s]"))
            for lam, mu, dt in zip(c.multipliers, c.floquet_exponents, c.doubling_times_s):
                kind = "doubling" if dt > 0 else "halving"
                lines.append("    {:>11.6f} {:+10.6f}j  {:9.6f}  {:>9.4f} {:+10.4f}j  {:9.4f} ({})".format(
                    lam.real, lam.imag, abs(lam), mu.real, mu.imag, abs(dt), kind))
            lines.append(f"  verdict: {'STABLE' if c.stable else 'UNSTABLE'} "
                         f"(largest modulus {np.max(np.abs(c.multipliers)):.6f})")
        lines.append(f"  mean forward speed {self.mean_forward_speed_mps:.4f} m/s, mean vertical speed "
                     f"{self.mean_vertical_speed_mps:+.4f} m/s (positive climbing), flight path angle "
                     f"{self.flight_path_angle_deg:+.4f} deg")
        lines.append(f"  model validity: {self.validity.summary()}")
        if self.cfg.wing.mass_kg > 0:
            wp = self.wing_power
            lines.append(f"  wings {self.cfg.wing.mass_kg:.4g} kg each: inertial power dT_rel/dt mean "
                         f"{wp['mean_inertial_power_W']:+.3g} W, positive part {wp['mean_positive_inertial_power_W']:.4g} W, "
                         f"peak {wp['peak_inertial_power_W']:.4g} W; shoulder inertial power mean "
                         f"{wp['mean_shoulder_inertial_power_W']:+.4g} W")
        e = self.__dict__.get("_energetics")
        if e is not None:
            lines.append(f"  mean power: aerodynamic {e['mean_aerodynamic_power_W']:.4g} W, shoulder "
                         f"{e['mean_shoulder_power_W']:.4g} W, positive-work {e['mean_positive_power_W']:.4g} W; "
                         f"cost of transport {e['cost_of_transport']:.4g}, Strouhal {e['strouhal_number']:.4g}")
        if not c.success:
            lines.append(f"  message: {c.message}")
        return "\n".join(lines)


CYCLE_FIELDS = tuple(k for k, v in vars(TrimResult).items() if isinstance(v, property) and v.__doc__
                     and v.__doc__.startswith("``cycle."))
"""The cycle's fields a :class:`TrimResult` forwards (read-only)."""


def trim(cfg: Config | None = None, *, x_guess=None, warm_start=None, method: OrbitMethod | None = None,
         compiled: bool = False, **method_over) -> TrimResult:
    """Trimmed flight of ``cfg`` (default: the paper's reference case).

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case, 42 deg).
    x_guess : array_like, optional
        State (u, w [m/s], q [rad/s], theta [rad]) at t = 0 to start from (default
        ``cfg.solve.initial_guess``; the aerodynamic states of an unsteady or dynamic-stall section
        start on the quasi-steady manifold), or a full state.
    warm_start : TrimResult, optional
        A previous result whose cycle starts the solve.
    method : OrbitMethod, optional
        The shooting method (default from ``cfg.solve``).
    compiled : bool
        Use the state right-hand side and data compiled to C (:func:`solver_ode`; the same numbers,
        faster; compiled once and cached; falls back to the interpreted path with a warning on stderr
        if compilation fails). The CLI's ``--compiled`` (or ``BIRDOCP_COMPILED=1``) sets it.
    **method_over
        Overrides of :class:`~birdocp.engine.method.OrbitMethod`'s fields (``points``,
        ``steps_per_period``, ``solver``, ``tol``, ...).

    Returns
    -------
    TrimResult
        The cycle, its multipliers, speeds, powers and validity; ``success`` means the residual is below
        the tolerance.

    Examples
    --------
    >>> from birdocp import Config, trim
    >>> r = trim(Config(), steps_per_period=60)
    >>> r.success, r.stable, len(r.multipliers)
    (True, False, 4)
    >>> round(float(abs(r.multipliers[0])), 2)   # the expanding multiplier of the reference case
    1.41
    """
    cfg = cfg or Config()
    if x_guess is None and warm_start is None and cfg.aero.section != "linear":
        x_guess = linear_section_start(cfg, compiled, **method_over)
    m = get_model(cfg)
    guess = m.complete_state(cfg.solve.initial_guess if x_guess is None else x_guess, m.p0)
    problem = OrbitProblem(ode=solver_ode(m, compiled), p=m.p0, x_guess=guess,
                           outputs=flight_outputs(m.ode.nd, m.ode.nx))
    method = method or method_of(cfg, **method_over)
    ws = warm_start.cycle if isinstance(warm_start, TrimResult) else warm_start
    return TrimResult(check_physical(solve(problem, method, warm_start=ws)), cfg)


def linear_section_start(cfg: Config, compiled: bool | None = None, **method_over):
    """The start of a stall section's trim (``aero.section = "stall"`` or ``"dynamic-stall"``): the
    body state (u, w, q, theta) at t = 0 of the same model's cycle with the linear section, the first
    step of a continuation from attached to separating flow. From ``cfg.solve.initial_guess`` directly,
    IPOPT's first trial points reach angles where the stall circulation's Newton Jacobian is singular
    (NaN). None when the linear-section trim fails (the configured guess is then used).

    Parameters
    ----------
    cfg : Config
        Configuration with a stall section.
    compiled : bool, optional
        Use the compiled twin of the ODE.
    **method_over
        Fields of the method overridden.

    Returns
    -------
    ndarray or None
        (u, w, q, theta) at t = 0; None when the linear-section trim fails.
    """
    from birdocp.bird.config import with_values

    lin = trim(with_values(cfg, {"aero.section": "linear"}), compiled=compiled, **method_over)
    return np.asarray(lin.cycle.x0, float)[:4] if lin.success else None


def check_physical(cycle: OrbitResult) -> OrbitResult:
    """A converged cycle with u <= 0 somewhere is not a forward flight (the aerodynamic model assumes
    air coming from ahead): mark it failed with status ``non_physical``.

    Parameters
    ----------
    cycle : OrbitResult
        Solved cycle, changed in place.

    Returns
    -------
    OrbitResult
        ``cycle``.
    """
    if cycle.success:
        u = np.asarray(cycle.trajectory_x)[:, 0]
        if not np.all(u > 0):
            cycle.success = False
            cycle.status = "non_physical"
            cycle.message = (f"converged to a cycle with forward speed u <= 0 (min u = {np.min(u):.3g} m/s), "
                             "not a forward flight; start from a better guess (solve.initial_guess)")
    return cycle
