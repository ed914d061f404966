"""Nonlinear simulation of many wingbeats: perturbations, gusts, open or closed loop.

The full model (the same RK4 grid as the trim) is integrated from the cycle's state at the beat start,
with the state augmented by the inertial position of G: ``X' = u cos(theta) + w sin(theta)``
(forward), ``Z' = -u sin(theta) + w cos(theta)`` (down). Wind enters the air velocity of every wing
element and of the tail through :func:`birdocp.bird.model.air_state` (uniform over the bird, taken at
G's position):

* a constant wind (horizontal positive along the flight direction, vertical positive upwards, m/s);
* the aeronautical "1 - cos" discrete gust, frozen in space: ``w_g(X) = A/2 (1 - cos(2 pi (X - X_s) /
  L))`` for ``X_s <= X <= X_s + L`` (A the peak, m/s; L the length in metres, or in wingbeats times
  the distance the cycle flies per beat; X_s its start, by default one beat ahead).

With ``aero.unsteady = "wagner"`` the added mass reacts to the air-relative acceleration: the model
gets the wind's rate along the path, ``dW/dX' X'`` (the gusts are frozen in the air: no own time rate;
a constant wind has none), and turns it into the body frame with the pitch rate
(:func:`birdocp.bird.layout.air_wind_rate`).

Closed loop: at the start of each of the N intervals of a beat the controller's gait corrections
``du = -K_i (x - x_i)`` are applied (held over the interval), saturated at the joint limits.

Validity (:mod:`birdocp.bird.validity`'s thresholds, ``[validity]`` of the configuration, applied to
the air-relative state, since a gust changes the airflow, not the bird's inertial velocity): the
simulation stops (status ``left_validity``) when the air-relative forward speed falls below
``min_forward_speed_mps``, |pitch| exceeds ``max_abs_pitch_deg``, the airflow meets the body axis at
more than ``max_airflow_body_angle_deg``, or, over a beat, more than ``max_stalled_fraction`` of the
span-time area is beyond ``stall_angle_deg`` (effective angles of attack of the 16 elements at every
RK4 step). A state that leaves the model's range (non-finite, a speed above :data:`MAX_SPEED_MPS`
or a pitch rate above :data:`MAX_PITCH_RATE_RADPS`) stops the run with status ``diverged`` and the
beat in ``diverged_beat``; the histories keep the states up to the last one in range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import SimpleNamespace

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, ConfigError
from birdocp.bird.model import air_state, get_model
from birdocp.bird.validity import effective_angles
from birdocp.engine.integrate import RK4Grid, stage_block_index
from birdocp.engine.rk4 import rk4_update
from birdocp.engine.problem import finite_vector
from birdocp.engine.results import result_dict, serial
from birdocp.studies.control import PerModel
from birdocp.studies.simulate_inputs import (  # noqa: F401
    DIRECTIONS, GUST_LENGTH_BEATS, GUST_LENGTH_M, Gust, MAX_GUST_START_BEATS,
    MAX_PITCH_PERTURBATION_RAD, MAX_PITCH_RATE_RADPS, MAX_SPEED_MPS, STATE_ALIASES,
    check_speed, parse_gust, parse_perturbation, parse_state_values)

__all__ = ["Gust", "SimulationResult", "simulate", "gust_envelope", "nonlinear_beat_map", "STATE_ALIASES",
           "parse_perturbation", "parse_gust"]


def _in_range(z: np.ndarray) -> np.ndarray:
    """Per row of states (u, w, q, theta, ...): finite and within the model's range."""
    z = np.asarray(z, float)
    with np.errstate(invalid="ignore", over="ignore"):
        return (np.all(np.isfinite(z), axis=1) & (np.hypot(z[:, 0], z[:, 1]) <= MAX_SPEED_MPS)
                & (np.abs(z[:, 2]) <= MAX_PITCH_RATE_RADPS))


class _Stepper(PerModel):
    """RK4 Functions of the position-augmented model with wind for (model, steps, N); cached."""

    def __init__(self, model, steps: int, n_intervals: int):
        self.model = model.model
        self.grid = grid = RK4Grid(model.ode, steps, n_intervals)
        n, nd, np_ = grid.n, model.ode.nd, model.ode.np
        nx = model.ode.nx  # z = (u, w, q, theta, X, Z, aerodynamic states)
        z = ca.SX.sym("z", nx + 2)
        d = ca.SX.sym("d", nd)
        p = ca.SX.sym("p", np_)
        g = ca.SX.sym("g", 8)  # constant (h, v), amplitudes (h, v), start/length (h), start/length (v)
        u, w, th = z[0], z[1], z[3]
        X_dot = u * ca.cos(th) + w * ca.sin(th)
        wind, wind_rate = planar_wind(z[4], X_dot, g)
        xdot = self.model.rhs_wind(ca.vertcat(z[:4], z[6:]), d, p, wind, wind_rate)
        zdot = ca.vertcat(xdot[:4], X_dot, -u * ca.sin(th) + w * ca.cos(th), xdot[4:])
        f = ca.Function("f_sim", [z, d, p, g], [zdot])
        xa = air_state(z, wind)
        if nx > 4 or self.model.structure.aero_extra:
            from birdocp.bird.validity import model_angles

            ae, _, ds, _, _, _ = model_angles(self.model)(ca.vertcat(xa, z[6:]), d, p)
        else:
            ae, _, ds = effective_angles(nd, self.model.structure.normalwash)(xa, d, p)
        # at each step end: effective angles [deg] and element lengths (16 each), airflow-body angle
        # [deg] and air-relative forward speed [m/s]
        self.validity = ca.Function("beat_validity", [z, d, p, g], [
            ae * 180 / math.pi, ds, ca.atan2(xa[1], xa[0]) * 180 / math.pi, xa[0]]).map(n)
        D3 = ca.SX.sym("D3", nd, 3)
        h = grid.h
        step = ca.Function("sim_step", [z, D3, p, g], [rk4_update(f, z, D3, h, p, g)[0]])
        self.interval = step.mapaccum("sim_interval", n)
        self.post_interval = model.ode.post.map(2 * n + 1)
        self.blocks = stage_block_index(n)
        self.times = grid.times(0.0)

    def data(self, i: int, p) -> ca.DM:
        """Stage blocks of interval i for parameters p (the arm-frame shape ``pre`` memoised)."""
        return interval_data(self, i, p)


def planar_wind(X, X_dot, g):
    """The wind at G and its rate along the path, from the steppers' 8 wind numbers
    (:func:`wind_vector`): ``W = (W_X, W_Z)`` (inertial, X forward, Z down) [m/s], the constant wind
    plus the 1 - cos gusts frozen in the air at G's horizontal position X, and ``dW/dt = dW/dX X'``
    [m/s^2] (exact derivative of the gust shape; the gusts have no own time rate, the constant
    wind none).

    Parameters
    ----------
    X : casadi.SX
        Horizontal inertial position of G (a symbol) [m].
    X_dot : casadi.SX
        Its rate, u cos(theta) + w sin(theta) [m/s].
    g : casadi.SX
        The 8 wind numbers.

    Returns
    -------
    wind : casadi.SX
        (W_X, W_Z) [m/s].
    wind_rate : casadi.SX
        (dW_X/dt, dW_Z/dt) [m/s^2].
    """
    wind = ca.vertcat(g[0] + g[2] * gust_shape(X, g[4], g[5]), -(g[1] + g[3] * gust_shape(X, g[6], g[7])))
    return wind, ca.jtimes(wind, X, X_dot)


def gust_shape(x, start, length):
    """The aeronautical 1 - cos gust shape (0..1): ``(1 - cos(2 pi s)) / 2`` for ``0 < s < 1``,
    ``s = (x - start) / length``, 0 elsewhere; ``x`` a position [m] (a gust frozen in space) or a
    time [s] (the six-degree-of-freedom side gust), ``start`` and ``length`` in its unit. The one
    shape of every simulated gust.

    Parameters
    ----------
    x : casadi.SX
        Position [m] or time [s].
    start : casadi.SX or float
        Where (when) the gust starts.
    length : casadi.SX or float
        Its length (duration), > 0.

    Returns
    -------
    casadi.SX
    """
    s = (x - start) / length
    return ca.if_else(ca.logic_and(s > 0, s < 1), 0.5 * (1 - ca.cos(2 * math.pi * s)), 0)


def interval_data(stepper, i: int, p) -> ca.DM:
    """Stage blocks of interval ``i`` for parameters ``p`` of a stepper with ``grid`` (an
    :class:`~birdocp.engine.integrate.RK4Grid` of N intervals), ``post_interval`` (the ODE's ``post``
    mapped over an interval's 2n + 1 times), ``times`` and ``blocks``; the arm-frame shape ``pre``
    memoised by the grid.

    Parameters
    ----------
    stepper : object
        With ``grid``, ``post_interval``, ``times`` and ``blocks``.
    i : int
        Interval index.
    p : array_like
        Parameter vector.

    Returns
    -------
    casadi.DM
    """
    n = stepper.grid.n
    cols = slice(2 * n * i, 2 * n * (i + 1) + 1)
    L = stepper.grid.pre_numeric(0.0, p)[:, cols]
    G = stepper.post_interval(L, ca.DM(stepper.times[:, cols]), ca.DM(np.asarray(p, float)))
    return G[:, stepper.blocks]


def nonlinear_beat_map(cfg, x0, params_per_interval, steps_per_period: int | None = None) -> np.ndarray:
    """The state one beat after ``x0`` in the full model (no wind), with the parameter vector
    ``params_per_interval[i]`` held over interval i of N = len(params_per_interval) equal intervals
    (the per-time data recomputed for each). The map :func:`birdocp.studies.control.wingbeat_map`
    linearises.

    Parameters
    ----------
    cfg : Config
        Configuration.
    x0 : array_like
        Start state.
    params_per_interval : sequence of array_like
        Parameter vector per interval.
    steps_per_period : int, optional
        RK4 steps per period.

    Returns
    -------
    ndarray
        The state one beat later.
    """
    N = len(params_per_interval)
    m = get_model(cfg)
    st = _Stepper.get(m, int(steps_per_period or cfg.solve.steps_per_period), N)
    x0 = m.complete_state(x0, params_per_interval[0])
    z = np.concatenate([x0[:4], [0.0, 0.0], x0[4:]])
    for i, p in enumerate(params_per_interval):
        z = np.asarray(st.interval(z, st.data(i, p), ca.DM(np.asarray(p, float)), np.zeros(8)))[:, -1]
    return np.concatenate([z[:4], z[6:]])


@dataclass
class SimulationResult:
    """Time histories and per-beat deviations of a simulation (see :func:`simulate`)."""

    success: bool
    status: str
    message: str
    closed_loop: bool
    beats: int
    # the time histories go to arrays.npz (:meth:`arrays`), not to the JSON
    t_s: np.ndarray = field(metadata=serial(skip=True))  # (n,) times of the RK4 steps
    states: np.ndarray = field(metadata=serial(skip=True))  # (n, 4) u [m/s], w [m/s], q [rad/s], theta [rad]
    X_m: np.ndarray = field(metadata=serial(skip=True))  # (n,) inertial forward position of G
    Z_m: np.ndarray = field(metadata=serial(skip=True))  # (n,) inertial position of G, positive down
    control_t_s: np.ndarray = field(metadata=serial(skip=True))  # (k,) times of the control updates
    controls: np.ndarray = field(metadata=serial(skip=True))  # (k, m) applied values (absolute, own units)
    control_keys: list = field(metadata=serial(key="controls"))
    deviation_per_beat: np.ndarray  # (K+1,) 2-norm of x(kT) - x_cycle, first = the initial perturbation
    saturated: bool
    beat_distance_m: float = field(metadata=serial(key="distance_per_beat_m"))
    gust_spans_m: list = field(default_factory=list)
    # largest |atan2(w_air, u_air)| along the trajectory
    max_inflow_deg: float = field(default=float("nan"), metadata=serial(key="max_airflow_body_angle_deg"))
    # smallest air-relative forward speed u_air of G
    min_airspeed_mps: float = field(default=float("nan"), metadata=serial(key="min_air_forward_speed_mps"))
    control_cycle: np.ndarray = field(default_factory=lambda: np.zeros(0),  # the controls' cycle values
                                      metadata=serial(skip=True))
    # largest stalled share of the span-time area over one beat
    max_stalled_fraction: float = field(default=0.0, metadata=serial(key="max_stalled_fraction_per_beat"))
    # the beat (1-based) in which the state left the model's range (status "diverged"), else None
    diverged_beat: int | None = None

    @property
    def final_deviation(self) -> float:
        return float(self.deviation_per_beat[-1])

    @property
    def peak_deviation(self) -> tuple[float, int]:
        k = int(np.nanargmax(self.deviation_per_beat))
        return float(self.deviation_per_beat[k]), k

    @property
    def beats_to_recover(self) -> int | None:
        """Beats from the peak deviation until it falls to 1/100 of the peak (None if it does not)."""
        peak, k = self.peak_deviation
        later = np.nonzero(self.deviation_per_beat[k:] <= peak / 100.0)[0]
        return int(later[0]) if later.size and self.success else None

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): the fields but the time
        histories, and the per-beat summary derived from them.

        Returns
        -------
        dict
            Plain JSON types only.
        """
        peak, k = self.peak_deviation
        some = len(self.states) > 0
        return result_dict(self, derived=("final_deviation", "beats_to_recover"), extra={
            "beats_simulated": len(self.deviation_per_beat) - 1, "peak_deviation": peak, "peak_beat": k,
            "control_range": [[np.min(c), np.max(c)] for c in self.controls.T] if self.controls.size else [],
            "min_forward_speed_mps": np.min(self.states[:, 0]) if some else None,
            "max_abs_pitch_deg": np.degrees(np.max(np.abs(self.states[:, 3]))) if some else None,
            "final_position_m": [self.X_m[-1], self.Z_m[-1]] if len(self.X_m) else None})

    def arrays(self) -> dict:
        """The histories (arrays.npz): times [s], states, position X, Z [m], pitch [deg], the controls and the
        deviation per beat.

        Returns
        -------
        dict of str to ndarray
        """
        return {"t_s": self.t_s, "states": self.states, "X_m": self.X_m, "Z_m": self.Z_m,
                "pitch_deg": np.degrees(self.states[:, 3]), "control_t_s": self.control_t_s,
                "controls": self.controls, "control_cycle": self.control_cycle,
                "deviation_per_beat": self.deviation_per_beat}


def wind_vector(gusts, wind_mps, beat_m) -> tuple[np.ndarray, list]:
    """``(g, spans)``: the 8 wind numbers of the simulation steppers (constant horizontal and vertical
    wind [m/s], the gusts' amplitudes [m/s] and (start, length) [m] of the horizontal then the vertical
    gust) and one dict per gust, for ``beat_m`` metres flown per beat.

    Parameters
    ----------
    gusts : sequence of Gust
        Gusts.
    wind_mps : sequence of float
        Constant wind (horizontal, vertical) [m/s].
    beat_m : float
        Distance flown per beat [m].

    Returns
    -------
    g : ndarray, shape (8,)
    spans : list of dict
    """
    g = np.array([float(wind_mps[0]), float(wind_mps[1]), 0.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    spans = []
    for gust in gusts:
        start, length = gust.span_m(beat_m)
        j = 0 if gust.direction == "horizontal" else 1
        if g[2 + j] != 0.0:
            raise ConfigError("--gust", f"one {gust.direction} gust at a time")
        g[2 + j] = gust.amplitude_mps
        g[4 + 2 * j], g[5 + 2 * j] = start, length
        spans.append({"direction": gust.direction, "amplitude_mps": gust.amplitude_mps,
                      "start_m": start, "length_m": length})
    return g, spans


def simulate(cfg, x0_cycle, beats: int, *, steps_per_period: int | None = None, perturbation=None,
             gusts=(), wind_mps=(0.0, 0.0), controller=None, p=None,
             stop_when_recovered: bool = False, progress=None) -> SimulationResult:
    """Integrate the bird ``beats`` wingbeats from ``x0_cycle + perturbation``.

    Parameters
    ----------
    cfg : Config
        The configuration of the cycle.
    x0_cycle : array (4,)
        The cycle's state at the beat start (u, w [m/s], q [rad/s], theta [rad]).
    beats : int
        Wingbeats to simulate (>= 1).
    progress : callable, optional
        ``progress(text)`` called at the start of every beat (e.g. a progress bar).
    steps_per_period : int, optional
        RK4 steps per beat (default ``cfg.solve.steps_per_period``; use the cycle's).
    perturbation : array (4,), optional
        State deviation added at t = 0 (same units as the state).
    gusts : sequence of Gust
        At most one per direction.
    wind_mps : (float, float)
        Constant wind: horizontal (positive along the flight), vertical (positive up) [m/s].
    controller : Controller, optional
        A :class:`birdocp.studies.control.Controller` (or any object with ``controls``, ``K``,
        ``x_starts``, ``limits``, ``updates_per_beat``) for the closed loop; None = open loop.
    p : array, optional
        Parameter vector of the cycle (default that of ``cfg``).
    stop_when_recovered : bool
        Stop once every gust is behind the bird and the deviation at a beat start is back to 1/100
        of its peak (the gust envelope's criterion).

    Returns
    -------
    SimulationResult
        ``success`` False with status ``diverged`` (and ``diverged_beat``) or ``left_validity`` when
        the run stopped early.
    """
    if int(beats) < 1:
        raise ConfigError("--beats", f"must be >= 1, got {beats}")
    beats = int(beats)
    r = _setup(cfg, x0_cycle, perturbation, steps_per_period, controller, p)
    # distance flown per beat on the cycle (open loop, no wind): converts gust lengths in beats
    zc = np.concatenate([r.x0_cycle, [0.0, 0.0], r.x_full[4:]])
    for i in range(r.N):
        zc = np.asarray(r.st.interval(zc, r.st.data(i, r.p_cyc), r.pd, np.zeros(8)))[:, -1]
    beat_m = float(zc[4])
    g, spans = wind_vector(gusts, wind_mps, beat_m)
    r.gd = ca.DM(g)
    r.z = np.concatenate([r.x0_cycle + r.dx0, [0.0, 0.0], r.x_full[4:]])
    r.traj, r.dev = [r.z[None, :]], [float(np.linalg.norm(r.dx0))]
    r.status, r.message, r.diverged_beat = "ok", f"{beats} beats simulated", None
    for k in range(beats):
        if progress is not None:
            progress(f"beat {k + 1}/{beats}")
        for i in range(r.N):
            _interval(r, cfg.validity, controller, k, i)
            if r.status != "ok":
                break
        r.dev.append(float(np.linalg.norm(r.z[:4] - r.x0_cycle)) if r.status != "diverged" else float("nan"))
        if r.status != "ok":
            break
        if (stop_when_recovered and max(r.dev) > 0 and r.dev[-1] <= max(r.dev) / 100.0
                and all(r.z[4] > sp["start_m"] + sp["length_m"] for sp in spans)):
            r.message = f"recovered after {k + 1} beats"
            break
    Z = np.vstack(r.traj)
    t = np.arange(Z.shape[0]) * r.st.grid.h
    ctrl_arr = np.array(r.ctrl) if r.ctrl else np.zeros((0, len(r.keys)))
    return SimulationResult(r.status == "ok", r.status, r.message, controller is not None, beats, t, Z[:, :4],
                            Z[:, 4], Z[:, 5], np.array(r.ctrl_t), ctrl_arr, r.keys, np.array(r.dev), r.saturated,
                            beat_m, spans, r.max_inflow, r.min_air, r.u_cyc, r.max_stalled, r.diverged_beat)


def _setup(cfg, x0_cycle, perturbation, steps_per_period, controller, p) -> SimpleNamespace:
    """The checked inputs and the run's accumulators of :func:`simulate`."""
    m = get_model(cfg)
    x0_cycle = np.asarray(x0_cycle, float).ravel()
    x0_cycle = finite_vector(x0_cycle, "simulate x0_cycle", m.ode.nx if x0_cycle.size == m.ode.nx else 4,
                             "the state is (u, w, q, theta), or the model's full state")
    if perturbation is not None:
        perturbation = finite_vector(perturbation, "simulate perturbation", 4, "the state is (u, w, q, theta)")
    steps = int(steps_per_period or cfg.solve.steps_per_period)
    N = int(getattr(controller, "updates_per_beat", 1)) if controller is not None else 1
    p_cyc = np.asarray(m.p0 if p is None else p, float)
    keys = list(controller.controls) if controller is not None else []
    idx = [PARAM_NAMES.index(k) for k in keys]
    x_full = m.complete_state(x0_cycle, p_cyc)  # aerodynamic states on the quasi-steady manifold if not given
    return SimpleNamespace(
        m=m, N=N, st=_Stepper.get(m, steps, N), p_cyc=p_cyc, pd=ca.DM(p_cyc), keys=keys, idx=idx, u_cyc=p_cyc[idx],
        x_full=x_full, x0_cycle=x_full[:4], T=m.period_s,
        dx0=np.zeros(4) if perturbation is None else np.asarray(perturbation, float).ravel(),
        ctrl_t=[], ctrl=[], saturated=False, max_inflow=0.0, min_air=math.inf, max_stalled=0.0, stalled_area=0.0)


def _interval(r: SimpleNamespace, lim, controller, k: int, i: int) -> None:
    """Interval i of beat k of :func:`simulate`: the controls, the RK4 steps, the range and validity
    checks (updates ``r``)."""
    N = r.N
    pk = r.p_cyc
    if controller is not None:
        du = -np.asarray(controller.K[i]) @ (r.z[:4] - np.asarray(controller.x_starts[i]))
        u = r.u_cyc + du
        lo, hi = np.asarray(controller.limits)[:, 0], np.asarray(controller.limits)[:, 1]
        uc = np.clip(u, lo, hi)
        r.saturated = r.saturated or bool(np.any(uc != u))
        pk = r.p_cyc.copy()
        pk[r.idx] = uc
        r.ctrl_t.append((k + i / N) * r.T)
        r.ctrl.append(uc)
    if i == 0:
        r.stalled_area = 0.0  # stalled share of the span-time area over this beat
    D = r.st.data(i, pk)
    with np.errstate(all="ignore"):
        Zi = np.asarray(r.st.interval(r.z, D, r.pd, r.gd)).T
    ok = _in_range(Zi)
    if not np.all(ok):  # keep the states up to the first one out of range (the figure, the arrays)
        Zi = Zi[:int(np.argmin(ok))]
        r.status, r.diverged_beat = "diverged", k + 1
        r.message = (f"diverged in beat {k + 1}: the state left the model's range (non-finite, speed above "
                     f"{MAX_SPEED_MPS:g} m/s or |pitch rate| above {MAX_PITCH_RATE_RADPS:g} rad/s)")
    r.traj.append(Zi)
    r.z = Zi[-1] if len(Zi) else r.z
    if r.status == "ok":
        _check_validity(r, lim, Zi, D, pk, k, i)


def _check_validity(r: SimpleNamespace, lim, Zi, D, pk, k: int, i: int) -> None:
    """The validity thresholds on interval i's steps (updates ``r``: extremes, status, message)."""
    N = r.N
    ae, ds, angle, u_air = (np.asarray(v) for v in r.st.validity(Zi.T, D[:, 2::3], ca.DM(pk), r.gd))
    inflow = float(np.max(np.abs(angle)))
    r.max_inflow = max(r.max_inflow, inflow)
    r.min_air = min(r.min_air, float(np.min(u_air)))
    pitch = float(np.degrees(np.max(np.abs(Zi[:, 3]))))
    r.stalled_area += float(np.mean(((np.abs(ae) > lim.stall_angle_deg) * ds).sum(axis=0) / ds.sum(axis=0))) / N
    reasons = [text for bad, text in (
        (r.min_air < lim.min_forward_speed_mps,
         f"air-relative forward speed {r.min_air:.3g} m/s < {lim.min_forward_speed_mps:g} m/s"),
        (pitch > lim.max_abs_pitch_deg, f"|pitch| {pitch:.3g} > {lim.max_abs_pitch_deg:g} deg"),
        (inflow > lim.max_airflow_body_angle_deg,
         f"airflow at {inflow:.3g} deg to the body axis > {lim.max_airflow_body_angle_deg:g} deg"),
        (i == N - 1 and r.stalled_area > lim.max_stalled_fraction,
         f"{r.stalled_area:.1%} of the span-time area beyond the stall angle "
         f"{lim.stall_angle_deg:g} deg > {lim.max_stalled_fraction:.0%}")) if bad]
    if i == N - 1:
        r.max_stalled = max(r.max_stalled, r.stalled_area)
    if reasons:
        r.status = "left_validity"
        r.message = f"left the model's validity in beat {k + 1}: {', '.join(reasons)}"


def gust_envelope(cfg, x0_cycle, controller, direction: str = "vertical", *, sign: float = 1.0,
                  length_beats: float = 1.0, beats: int = 40, steps_per_period: int | None = None,
                  p=None, start_mps: float = 0.5, max_mps: float = 16.0, tol_mps: float = 0.05) -> dict:
    """The largest 1 - cos gust (peak amplitude, m/s, of sign ``sign``) the closed loop recovers from
    within ``beats`` beats (deviation back to 1/100 of its peak) without saturating a joint and
    without leaving the model's validity; found by doubling from ``start_mps`` then bisection to
    ``tol_mps``. Returns the envelope amplitude, the beats to recover there and every trial.

    Parameters
    ----------
    cfg : Config
        The configuration of the cycle.
    x0_cycle : array_like (4,)
        The cycle's state at the beat start.
    controller : Controller or None
        The feedback (None: open loop).
    direction : {"vertical", "horizontal"}
        The gust's direction.
    sign : float
        +1 or -1: up/tailwind or down/headwind.
    length_beats : float
        Gust length in wingbeats.
    beats : int
        Beats allowed to recover.
    steps_per_period : int, optional
        RK4 steps per beat (default ``cfg.solve.steps_per_period``).
    p : array_like, optional
        Parameter vector of the cycle (default that of ``cfg``).
    start_mps, max_mps, tol_mps : float
        First trial, largest trial and bisection tolerance of the peak amplitude [m/s].

    Returns
    -------
    dict
        The envelope amplitude [m/s], the beats to recover there and every trial.
    """
    trials = []

    def ok(a):
        r = simulate(cfg, x0_cycle, beats, steps_per_period=steps_per_period, controller=controller, p=p,
                     gusts=[Gust(direction, sign * a, length_beats)], stop_when_recovered=True)
        rec = r.beats_to_recover
        good = bool(r.success and not r.saturated and rec is not None)
        trials.append({"amplitude_mps": sign * a, "recovered": good, "status": r.status, "message": r.message,
                       "saturated": r.saturated, "beats_to_recover": rec,
                       "peak_deviation": r.peak_deviation[0],
                       "control_range": r.to_dict()["control_range"]})
        return good, rec

    lo, hi, rec_lo = 0.0, None, None
    a = start_mps
    while a <= max_mps:
        good, rec = ok(a)
        if not good:
            hi = a
            break
        lo, rec_lo = a, rec
        a *= 2
    if hi is not None:
        while hi - lo > tol_mps:
            mid = 0.5 * (lo + hi)
            good, rec = ok(mid)
            if good:
                lo, rec_lo = mid, rec
            else:
                hi = mid
    return {"direction": direction, "sign": sign, "length_beats": length_beats, "envelope_mps": sign * lo,
            "bounded_by_search": hi is None, "beats_to_recover": rec_lo, "first_failure_mps":
            None if hi is None else sign * hi, "trials": trials}
