"""Lateral-directional stability of the flapping bird: the six-degree-of-freedom cycle
(:mod:`birdocp.bird.sixdof`) and its Floquet multipliers, split into longitudinal, lateral and
heading parts and labelled by their eigenvectors.

For a symmetric gait the periodic orbit has v = p = r = phi = 0 and the monodromy matrix is block
diagonal: the longitudinal block (u, w, q, theta) gives the planar multipliers, the lateral block
(v, p, r, phi, psi) the lateral ones plus the heading's multiplier 1 (nothing depends on psi), which
is reported apart. ``coupling_max`` (the largest entry of the off-diagonal blocks) says how exact
the split is (round-off for a symmetric gait).

Labels of the lateral modes (from the eigenvector, states scaled to comparable units: v by the
mean forward speed, p and r by the wingbeat frequency, phi as is): a complex pair is
``dutch_roll_like``; of the real modes the one with the smallest modulus is ``roll_subsidence``
when its roll-rate share is the largest of the real modes, the one nearest 1 is ``spiral``, others
``lateral_real``. Every mode carries its time to double (positive) or halve (negative) in wingbeats.
Its reported eigenvector (so scaled) is divided by its largest entry, which becomes exactly 1: its sign
and phase do not depend on the eigensolver's round-off.

An asymmetric gait couples the blocks: its 8 x 8 monodromy (the heading left out) is not split.
Each of its modes is then classified by its eigenvector's content (:func:`coupled_modes`): with the
same scaling, its *lateral share* is the fraction of the squared norm in (v, p, r, phi); a mode with a
share of at least :data:`LATERAL_SHARE_MIN` (one half) is lateral and gets a label by the rule above
(the roll share taken over its lateral components), the others are ``longitudinal``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, param_vector
from birdocp.bird.flight import flight_path_angle_deg
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.bird.sides import side_vector
from birdocp.bird.sixdof import HEADING, LATERAL, LONGITUDINAL, STATE_NAMES, LateralInertia, embed_planar_state, \
    sixdof_model
from birdocp.bird.validity import CycleValidity, periodic_validity
from birdocp.engine.floquet import doubling_time_s, multipliers_info, sort_multipliers
from birdocp.engine.problem import MeanCondition, OrbitProblem
from birdocp.engine.results import result_dict, serial
from birdocp.engine.method import OrbitMethod
from birdocp.engine.orbit_front import solve
from birdocp.engine.orbit_result import OrbitResult
from birdocp.studies.lateral_aero import body_share_modes, mirror_basis, mirror_names, split_indices
from birdocp.studies.lateral_options import level_keywords
from birdocp.studies.level import default_bounds
from birdocp.studies.trim import check_physical

__all__ = ["LateralTrimResult", "lateral_trim", "lateral_modes", "coupled_modes", "LATERAL_SHARE_MIN", "beats_to_double",
           "heading_trajectory", "level_keywords", "solve_point", "eigenvector_scales"]


def beats_to_double(multiplier: complex) -> float:
    """Wingbeats for a perturbation along a mode to double (positive, |Lambda| > 1) or halve
    (negative, |Lambda| < 1): ``ln 2 / ln|Lambda|``; inf when |Lambda| = 1, 0 when Lambda = 0.

    Parameters
    ----------
    multiplier : complex
        Floquet multiplier Lambda.

    Returns
    -------
    float
        Wingbeats [-].
    """
    a = abs(complex(multiplier))
    if a == 0.0:
        return 0.0
    la = np.log(a)
    return float("inf") if la == 0 else float(np.log(2.0) / la)


LATERAL_SHARE_MIN = 0.5
"""A mode of a coupled monodromy (an asymmetric gait) is lateral when at least this share of its scaled
eigenvector's squared norm lies in (v, p, r, phi) (:func:`coupled_modes`)."""


def eigenvector_scales(names, period_s: float, speed_mps: float) -> np.ndarray:
    """The eigenvector scaling of the module: velocities by the mean forward speed, rates by the
    period, angles as they are.

    Parameters
    ----------
    names : sequence of str
        State names (:data:`birdocp.bird.sixdof.STATE_NAMES`).
    period_s : float
        Period [s].
    speed_mps : float
        Mean forward speed [m/s].

    Returns
    -------
    ndarray
        One factor per state.
    """
    return np.array([1.0 / max(speed_mps, 1e-9) if k.endswith("_mps") else period_s if k.endswith("_radps")
                     else 1.0 for k in names])


def _mode(lam, vec, names, scale) -> dict:
    """One mode's dict; the scaled eigenvector divided by its largest-modulus entry, which becomes 1
    (real, positive): sign and phase do not depend on the eigensolver's round-off."""
    v = vec * scale
    k = int(np.argmax(np.abs(v)))
    v = v / v[k]
    v[k] = 1.0  # exactly (a complex quotient z / z may round to 1 - 1e-16)
    return {"multiplier": complex(lam), "beats_to_double": beats_to_double(lam),
            "eigenvector": {k: complex(v[j]) for j, k in enumerate(names)},
            "dominant_state": names[int(np.argmax(np.abs(v)))], "label": "lateral_real"}


def _label_lateral(modes: list, roll: list) -> None:
    """The label rule of the module on lateral ``modes`` (``roll``: each one's |p| over its largest
    lateral component): complex pairs ``dutch_roll_like``, the smallest real one ``roll_subsidence``
    when its roll share is the largest of the real ones, the real one nearest 1 of the rest ``spiral``."""
    real = [k for k, m in enumerate(modes) if abs(m["multiplier"].imag) <= 1e-12 * max(1.0, abs(m["multiplier"]))]
    for k, m in enumerate(modes):
        if k not in real:
            m["label"] = "dutch_roll_like"
    if real:
        small = min(real, key=lambda k: abs(modes[k]["multiplier"]))
        if roll[small] >= max(roll[k] for k in real) - 1e-12:
            modes[small]["label"] = "roll_subsidence"
        rest = [modes[k] for k in real if modes[k]["label"] == "lateral_real"]
        if rest:
            min(rest, key=lambda m: abs(abs(m["multiplier"]) - 1.0))["label"] = "spiral"


def lateral_modes(monodromy, period_s: float, speed_mps: float, air_names=()) -> list[dict]:
    """The lateral multipliers of a 9 x 9 monodromy (its (v, p, r, phi) block), each with its label,
    beats to double/halve and its eigenvector over (v, p, r, phi) scaled as the module says.

    With aerodynamic states (``air_names``, the model's names after the 9) the monodromy is in the
    mirror basis (:func:`birdocp.studies.lateral_aero.mirror_basis`) and the lateral block holds the
    antisymmetric aerodynamic states too: of its modes the four whose scaled eigenvectors lie most in
    (v, p, r, phi) are labelled by the rule of the module, the others ``aerodynamic``.

    Parameters
    ----------
    monodromy : array_like, shape (9, 9)
        Monodromy of the 6-DOF cycle.
    period_s : float
        Period [s].
    speed_mps : float
        Mean forward speed [m/s] (scales the eigenvectors).
    air_names : sequence of str
        Names of the aerodynamic states (none by default).

    Returns
    -------
    list of dict
    """
    n_air = len(air_names)
    _, idx = split_indices((), LATERAL, len(STATE_NAMES), n_air)
    names = mirror_names(list(STATE_NAMES) + list(air_names), len(STATE_NAMES))
    names = [names[i] for i in idx]
    lam, vec, _, _, _ = multipliers_info(np.asarray(monodromy)[np.ix_(idx, idx)], period_s)
    scale = eigenvector_scales(names, period_s, speed_mps)
    body = body_share_modes(vec * scale[:, None], len(LATERAL), len(LATERAL), lam) if n_air else range(len(lam))
    modes = [_mode(lam[k], vec[:, k], names, scale) for k in range(len(lam))]
    for k, m in enumerate(modes):
        if n_air:  # the share of the scaled eigenvector's squared norm in (v, p, r, phi)
            w = np.abs(vec[:, k] * scale) ** 2
            m["body_share"] = float(w[:len(LATERAL)].sum() / w.sum())
        if k not in body:
            m["label"] = "aerodynamic"
    lat = [m for m in modes if m["label"] != "aerodynamic"]
    _label_lateral(lat, [abs(m["eigenvector"]["p_radps"]) / max(abs(m["eigenvector"][k]) for k in names[:4])
                         if n_air else abs(m["eigenvector"]["p_radps"]) for m in lat])
    return modes


def coupled_modes(monodromy, period_s: float, speed_mps: float, air_names=()) -> list[dict]:
    """Every mode of a monodromy whose longitudinal and lateral blocks couple (an asymmetric gait: the
    8 states without the heading, or all 9), labelled by its eigenvector's content.

    The eigenvector over all states is scaled as the module says; ``lateral_share`` is the share of its
    squared norm in (v, p, r, phi). Modes with ``lateral_share >= LATERAL_SHARE_MIN`` are lateral and
    labelled by the rule of :func:`lateral_modes` (the roll share taken over their lateral components);
    the others are ``longitudinal``. For a symmetric cycle the shares are exactly 0 or 1 and the labels
    are those of the split monodromy.

    Parameters
    ----------
    monodromy : array_like
        Monodromy (8 x 8 or 9 x 9).
    period_s : float
        Period [s].
    speed_mps : float
        Mean forward speed [m/s].
    air_names : sequence of str
        Names of the aerodynamic states after the body states: the modes beyond the body states' count
        whose scaled eigenvectors lie least in the body states are ``aerodynamic``, the shares of the
        others taken over their body components.

    Returns
    -------
    list of dict
    """
    M = np.asarray(monodromy)
    nb = M.shape[0] - len(air_names)
    names = list(STATE_NAMES[:nb]) + list(air_names)
    lam, vec, _, _, _ = multipliers_info(M, period_s)
    scale = eigenvector_scales(names, period_s, speed_mps)
    body = body_share_modes(vec * scale[:, None], nb, nb, lam) if len(air_names) else range(len(lam))
    modes, lat = [], [i for i, k in enumerate(names[:nb]) if STATE_NAMES.index(k) in LATERAL]
    roll = []
    for k in range(len(lam)):
        m = _mode(lam[k], vec[:, k], names, scale)
        v = np.array(list(m["eigenvector"].values()))[:nb]
        w2 = np.abs(v) ** 2
        # no lateral component (a block-diagonal monodromy: no coupling) is a share of exactly 0, and a
        # mode with no body component (an aerodynamic one) has none: no 0/0
        m["lateral_share"] = float(np.sum(w2[lat]) / np.sum(w2)) if np.any(w2[lat]) else 0.0
        m["label"] = "lateral_real" if m["lateral_share"] >= LATERAL_SHARE_MIN else "longitudinal"
        if k not in body:
            m["label"] = "aerodynamic"
        if m["label"] == "lateral_real":  # its roll share: |p| over its largest lateral component (> 0)
            roll.append(float(abs(v[names.index("p_radps")]) / np.max(np.abs(v[lat]))))
        modes.append(m)
    _label_lateral([m for m in modes if m["label"] == "lateral_real"], roll)
    return modes


@dataclass
class LateralTrimResult:
    """The six-degree-of-freedom trim of one gait: the engine's cycle (9 states), every multiplier
    (largest modulus first), the longitudinal (u, w, q, theta) and lateral (v, p, r, phi) ones, the
    heading multiplier (1), the largest coupling entry of the monodromy between the blocks, the
    labelled lateral modes, the inertia used, the validity of the cycle (of its planar part: the
    cycle is symmetric) and, in level flight, the solved flapping amplitude.

    An asymmetric gait (per-side offsets, :mod:`birdocp.bird.sides`; ``symmetric`` False) flies a
    cycle periodic up to its heading: ``cycle`` then has the 8 states without psi, ``heading_change_deg``
    is psi(T) - psi(0) over one beat, ``multipliers`` are its 8 and the heading's 1. The blocks couple
    (``coupling_max`` says how much), so the modes are classified by their eigenvectors
    (:func:`coupled_modes`): ``lateral_modes`` are those with a lateral share of at least
    :data:`LATERAL_SHARE_MIN` (labelled, each with its ``lateral_share``), ``lateral_multipliers`` their
    multipliers and ``longitudinal_multipliers`` the others'. ``validity`` is the 6-DOF check over both
    wings (:func:`birdocp.bird.validity.grid_validity` with the 6-DOF ODE: stall per wing, sideslip)."""

    cycle: OrbitResult = field(metadata=serial(skip=True))
    multipliers: np.ndarray = field(metadata=serial(complex=True))
    longitudinal_multipliers: np.ndarray = field(metadata=serial(complex=True))
    lateral_multipliers: np.ndarray = field(metadata=serial(complex=True))
    heading_multiplier: float
    coupling_max: float
    lateral_modes: list
    inertia: dict
    amplitude_deg: float
    validity: CycleValidity | None = None
    symmetric: bool = True
    heading_change_deg: float = 0.0

    @property
    def success(self) -> bool:
        """The cycle converged (residual below the tolerance)."""
        return bool(self.cycle.success)

    @property
    def lateral_stable(self) -> bool | None:
        """Every lateral multiplier inside the unit circle (the heading's 1 excluded)."""
        return None if not len(self.lateral_multipliers) else bool(np.all(np.abs(self.lateral_multipliers) < 1.0))

    @property
    def stable(self) -> bool | None:
        """Every multiplier but the heading's inside the unit circle."""
        if not self.symmetric and len(self.multipliers) and np.all(np.isfinite(self.multipliers)):
            rest = sorted(self.multipliers, key=lambda z: abs(z - 1.0))[1:]  # the heading's 1 left out
            return bool(np.all(np.abs(rest) < 1.0))
        if not len(self.lateral_multipliers):
            return None
        return bool(self.lateral_stable and np.all(np.abs(self.longitudinal_multipliers) < 1.0))

    def to_dict(self) -> dict:
        """JSON of the result: the engine cycle's keys (status, residuals, x0 of 9 states, ...) with
        ``multipliers`` (all nine) and ``stable`` (the heading's 1 excluded), then this result's
        fields, ``state_names``, ``moduli`` (of ``multipliers``), ``lateral_stable`` and the period means ``mean_vertical_speed_mps``
        and ``mean_forward_speed_mps``.

        Returns
        -------
        dict
            Plain JSON types only.
        """
        own = {f.name for f in fields(self)} | {"success", "stable", "lateral_stable"}
        extra = {k: v for k, v in self.cycle.to_dict().items() if k not in own}
        if not self.symmetric and len(self.multipliers):  # the exponents of the nine, the heading's 1 included
            with np.errstate(divide="ignore"):
                mu = np.log(np.asarray(self.multipliers, complex)) / self.cycle.period
            extra["floquet_exponents"] = [[float(z.real), float(z.imag)] for z in mu]
            extra["doubling_times_s"] = [float(v) for v in np.atleast_1d(doubling_time_s(mu.real))]
        extra.update({
            "state_names": list(STATE_NAMES if self.symmetric else STATE_NAMES[:HEADING]), "degrees_of_freedom": 6,
            "moduli": [float(abs(z)) for z in self.multipliers],
            "mean_vertical_speed_mps": self.mean_vertical_speed_mps,
            "mean_forward_speed_mps": self.mean_forward_speed_mps,
            "flight_path_angle_deg": flight_path_angle_deg(self.mean_vertical_speed_mps, self.mean_forward_speed_mps)})
        return result_dict(self, derived=("success", "stable", "lateral_stable"), extra=extra)

    @property
    def mean_vertical_speed_mps(self) -> float:
        """Period mean of the inertial climb rate W [m/s] (the level condition's target when solved)."""
        return float(self.cycle.means.get("vertical_speed_mps", np.nan))

    @property
    def mean_forward_speed_mps(self) -> float:
        """Period mean of the horizontal speed along the heading U [m/s]."""
        return float(self.cycle.means.get("forward_speed_mps", np.nan))


def lateral_trim(cfg: Config | None = None, inertia: LateralInertia | None = None, *, level: bool = False,
                 climb_rate_mps: float = 0.0, bounds=None, method: OrbitMethod | None = None,
                 x_guess=None, warm_start=None, **method_over) -> LateralTrimResult:
    """Trim ``cfg``'s gait in six degrees of freedom and split its Floquet multipliers.

    Parameters
    ----------
    cfg : Config, optional
        The configuration (default: the paper's reference case). The static stall section, the tail, wing masses and
        the optional drag are taken in 3-D, so are ``dynamic-stall`` and ``wagner`` (their aerodynamic states
        split into symmetric and antisymmetric parts, :mod:`birdocp.studies.lateral_aero`).
    inertia : LateralInertia, optional
        Roll and yaw inertia [kg m^2]; default ``cfg.model``'s.
    level : bool
        Solve the flapping amplitude for a mean climb rate ``climb_rate_mps`` (level flight: 0).
    climb_rate_mps : float
        Target period-mean vertical speed [m/s] with ``level``.
    bounds : (float, float), optional
        Amplitude bounds [deg] with ``level`` (default: the planar level flight's).
    method : OrbitMethod, optional
        Shooting points and RK4 steps (default: ``cfg.solve``'s).
    x_guess : sequence of 9 floats, optional
        Start state (default: the planar guess ``cfg.solve.initial_guess`` with zero lateral states).
    warm_start : OrbitResult, optional
        A previous 6-DOF cycle (its shooting points and, with ``level``, its amplitude) to start from.
    **method_over
        Overrides of the default :class:`~birdocp.engine.method.OrbitMethod` (``points``,
        ``steps_per_period``, ...) when ``method`` is not given.

    Returns
    -------
    LateralTrimResult
    """
    cfg = cfg or Config()
    six = sixdof_model(cfg)
    inertia = inertia or LateralInertia.of(cfg)
    asym = six.sides  # per-side offsets: periodic up to the heading, the 8 states without psi solved
    p6 = six.params(param_vector(cfg), inertia, side_vector(cfg) if asym else None)
    method = method or OrbitMethod(**{"points": cfg.solve.points, "steps_per_period": cfg.solve.steps_per_period,
                                           "max_iter": cfg.solve.max_iter, "tol": cfg.solve.tol or None, **method_over})
    guess = _start_state(cfg, method) if x_guess is None else _with_aero_states(cfg, x_guess)
    outputs = six.flight_outputs(8 if asym else 9)
    free, means = {}, []
    if level:
        free = {AMPLITUDE_KEY: tuple(bounds) if bounds is not None else default_bounds(cfg, AMPLITUDE_KEY)}
        means = [MeanCondition(outputs["vertical_speed_mps"], float(climb_rate_mps), "vertical_speed_mps")]
    problem = OrbitProblem(ode=six.ode_no_heading if asym else six.ode, p=p6,
                           x_guess=list(guess)[:HEADING] + list(guess)[HEADING + 1:] if asym else guess, free=free, means=means,
                           outputs={k: f for k, f in outputs.items() if not (level and k == "vertical_speed_mps")})
    ws = getattr(warm_start, "cycle", warm_start)
    cyc = check_physical(solve(problem, method, warm_start=ws))  # u <= 0 somewhere: not a forward flight, as the planar trim
    amplitude = float(cyc.free_values.get(AMPLITUDE_KEY, cfg.gait.shoulder_flap.amplitude_deg))
    if asym:
        return _split_asymmetric(cfg, six, cyc, method, inertia, amplitude)
    return _split(cfg, cyc, six.ode.forcing_period, method, inertia, amplitude)


def _start_state(cfg: Config, method: OrbitMethod) -> list[float]:
    """The 9-state start of a 6-DOF trim: ``cfg.solve.initial_guess`` with zero lateral states; with a
    stall section, the planar linear-section cycle's state at t = 0 (as the planar trim,
    :func:`birdocp.studies.trim.linear_section_start`) and, with ``dynamic-stall``, the separation
    states on the quasi-steady manifold there."""
    x4 = cfg.solve.initial_guess
    if cfg.aero.section == "linear" and cfg.aero.unsteady == "none":
        return embed_planar_state(x4)
    from birdocp.studies.trim import linear_section_start

    if cfg.aero.section != "linear":
        lin = linear_section_start(cfg, points=method.points, steps_per_period=method.steps_per_period)
        x4 = x4 if lin is None else lin
    return _with_aero_states(cfg, embed_planar_state(x4))


def _with_aero_states(cfg: Config, x9) -> list[float]:
    """A 9-state start completed with the aerodynamic states (lag, separation) on the quasi-steady
    manifold of its planar part (the planar model's ``complete_state``; the start is symmetric); a
    start that has them is kept."""
    from birdocp.bird.model import get_model

    x9 = [float(v) for v in x9]
    n_air = len(sixdof_model(cfg).state_names) - len(STATE_NAMES)
    if not n_air or len(x9) != len(STATE_NAMES):
        return x9
    m = get_model(cfg)
    return x9 + [float(v) for v in m.complete_state([x9[i] for i in LONGITUDINAL], m.p0)[4:]]


def solve_point(cfg: Config, *, level: bool = False, level_options: dict | None = None, warm_start=None,
                **method_over) -> LateralTrimResult:
    """One 6-DOF point of a family (a sweep or grid, :mod:`birdocp.studies.sweep`): :func:`lateral_trim`
    at fixed amplitude, or in level flight with the planar level's ``level_options``
    (:func:`level_keywords`).

    Parameters
    ----------
    cfg : Config
        The point's configuration (``model.degrees_of_freedom = 6``).
    level : bool
        Solve the amplitude for the mean vertical speed.
    level_options : dict, optional
        The planar level's options (``free``, ``bounds``, ``climb_rate_mps``, ...).
    warm_start : OrbitResult, optional
        The neighbour's 6-DOF cycle.
    **method_over
        Overrides of the shooting method.

    Returns
    -------
    LateralTrimResult
    """
    kw = level_keywords(level_options) if level else {}
    return lateral_trim(cfg, warm_start=warm_start, **kw, **method_over)


def heading_trajectory(six, cycle, steps_per_period: int | None = None):
    """``(t, X)``: the 9 states over one beat from a cycle's start with psi(0) = 0 (RK4 on the trim's
    grid; the 8-state cycle of an asymmetric gait with its heading, or a 9-state cycle).

    Parameters
    ----------
    six : model
        The six-degree-of-freedom model (its 9-state ``ode``).
    cycle : cycle result
        With ``x0`` and ``p``.
    steps_per_period : int, optional
        RK4 steps (default: the trim's).

    Returns
    -------
    t : ndarray
        Times [s].
    X : ndarray
        States over (u, v, w, p, q, r, phi, theta, psi).
    """
    from birdocp.engine.integrate import simulate as rk4

    x0 = list(np.asarray(cycle.x0, float))
    x0 = x0[:HEADING] + [0.0] + x0[HEADING + (len(x0) == len(six.ode.state_names)):]
    steps = int(steps_per_period or cycle.method["steps_per_period"])
    return rk4(six.ode, x0, cycle.p, steps_per_period=steps)


def _split_asymmetric(cfg, six, cyc, method, inertia, amplitude) -> LateralTrimResult:
    none = np.full(0, np.nan)
    if cyc.monodromy is None:
        return LateralTrimResult(cyc, none, none, none, float("nan"), float("nan"), [], _inertia_dict(inertia),
                                 amplitude, None, symmetric=False, heading_change_deg=float("nan"))
    M = np.asarray(cyc.monodromy)
    lon, lat = list(LONGITUDINAL), list(LATERAL)
    coupling = float(max(np.abs(M[np.ix_(lon, lat)]).max(), np.abs(M[np.ix_(lat, lon)]).max()))
    _, X = heading_trajectory(six, cyc, method.steps_per_period)
    modes = coupled_modes(M, six.period_s, float(np.mean(X[:, 0])), six.state_names[len(STATE_NAMES):])
    modes = [m for m in modes if m["label"] != "aerodynamic"]  # in ``multipliers`` only
    validity = periodic_validity(cfg, cyc.x0, p=cyc.p, steps_per_period=method.steps_per_period,
                                 ode=six.ode_no_heading)
    return LateralTrimResult(
        cycle=cyc, multipliers=sort_multipliers(list(cyc.multipliers) + [1.0]),
        longitudinal_multipliers=sort_multipliers([m["multiplier"] for m in modes if m["label"] == "longitudinal"]),
        lateral_multipliers=sort_multipliers([m["multiplier"] for m in modes if m["label"] != "longitudinal"]),
        heading_multiplier=1.0, coupling_max=coupling, lateral_modes=[m for m in modes if m["label"] != "longitudinal"],
        inertia=_inertia_dict(inertia), amplitude_deg=amplitude, validity=validity, symmetric=False,
        heading_change_deg=float(np.degrees(X[-1, HEADING] - X[0, HEADING])))


def _split(cfg, cyc, T, method, inertia, amplitude) -> LateralTrimResult:
    if cyc.monodromy is None:
        nan = np.full(0, np.nan)
        return LateralTrimResult(cyc, nan, nan, nan, float("nan"), float("nan"), [], _inertia_dict(inertia),
                                 amplitude)
    M = np.asarray(cyc.monodromy)
    air = tuple(sixdof_model(cfg).state_names[len(STATE_NAMES):])
    B = mirror_basis(len(STATE_NAMES), len(air))  # aerodynamic states: symmetric and antisymmetric parts
    M = B @ M @ B.T
    lon, lat = split_indices(LONGITUDINAL, list(LATERAL) + [HEADING], len(STATE_NAMES), len(air))
    coupling = float(max(np.abs(M[np.ix_(lon, lat)]).max(), np.abs(M[np.ix_(lat, lon)]).max()))
    speed = float(np.mean(cyc.trajectory_x[:, 0])) if cyc.trajectory_x is not None else float(cyc.x0[0])
    modes = lateral_modes(M, T, speed, air)
    p = param_vector(cfg)
    p[list(PARAM_NAMES).index(AMPLITUDE_KEY)] = amplitude
    x0 = np.asarray(cyc.x0)
    validity = periodic_validity(cfg, np.concatenate([x0[list(LONGITUDINAL)], x0[len(STATE_NAMES):]]), p=p,
                                 steps_per_period=method.steps_per_period)
    return LateralTrimResult(
        cycle=cyc, multipliers=sort_multipliers(cyc.multipliers),
        longitudinal_multipliers=sort_multipliers(np.linalg.eigvals(M[np.ix_(lon, lon)])),
        lateral_multipliers=sort_multipliers([m["multiplier"] for m in modes]),
        heading_multiplier=float(M[HEADING, HEADING]), coupling_max=coupling, lateral_modes=modes,
        inertia=_inertia_dict(inertia), amplitude_deg=amplitude, validity=validity)


def _inertia_dict(inertia: LateralInertia) -> dict:
    return {"roll_inertia_kgm2": inertia.roll_inertia_kgm2, "yaw_inertia_kgm2": inertia.yaw_inertia_kgm2,
            "product_inertia_xz_kgm2": inertia.product_inertia_xz_kgm2}
