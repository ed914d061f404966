"""Many wingbeats of the six-degree-of-freedom bird: a side gust or a roll perturbation, open or closed
loop (the controller of :func:`birdocp.studies.lateral_control.design_lateral_controller`).

The 9 states are integrated on the trim's RK4 grid, augmented by the inertial position of G (north
= the cycle's initial heading, east = to its right, down) and the time. The air each element meets
is the inertial velocity minus the wind, the wind given in the inertial frame and rotated into the
body axes by the 3-2-1 attitude (psi, theta, phi): the state as the air sees it goes to the loads of
:func:`birdocp.bird.sixdof.body_loads`, the equations of motion keep the inertial velocity.

Side gust (:class:`SideGust`): an east wind (positive from the left, i.e. blowing towards the bird's
right) as a function of time, a ``step`` from its start on, or a ``1 - cos`` ``pulse`` of a given
length (beats; the shape of :func:`birdocp.studies.simulate.gust_shape`). Equivalently a gust frozen in
space along the cycle's path: the length in beats times ``distance_per_beat_m``.

Aerodynamic states (``aero.unsteady = "wagner"``, ``aero.section = "dynamic-stall"``): the lag and
separation states are marched with the body states (after the position and time in the stepper's
state), from the cycle's values (or on their quasi-steady manifold,
:func:`birdocp.studies.lateral_simulate_aero.complete_state6`); with Wagner's added mass the rate of the
wind's body-axis components along the motion enters the accelerations
(:func:`birdocp.bird.sixdof.rhs_expression`'s ``wind_rate``), so a ``step`` side gust (an infinite
rate) is refused with ``wagner`` (:func:`check_lateral_simulation_config`).

A run stops with status ``diverged`` when the state leaves the model's range (non-finite, a speed
above :data:`birdocp.studies.simulate.MAX_SPEED_MPS`, a rate above 1000 rad/s; the histories keep the
states up to the last one in range), with
``left_validity`` when the air-relative forward speed falls below ``validity.min_forward_speed_mps``,
|pitch| exceeds ``validity.max_abs_pitch_deg``, the air meets the body axis at more than
``validity.max_airflow_body_angle_deg`` or, over a beat, more than ``validity.max_stalled_fraction`` of
one wing's span-time area is beyond ``validity.stall_angle_deg`` (the effective angles of attack of
both wings in the asymmetric air-relative flow at every RK4 step end, :func:`birdocp.bird.validity.sixdof_angles`).

Vertical and horizontal gusts and a constant wind (the planar simulation's ``--gust`` and ``--wind``,
:class:`birdocp.studies.simulate.Gust`): the 1 - cos gust frozen in space along the cycle's initial
heading (north), met at the bird's north position; horizontal positive along that heading, vertical
positive up. They add to the side gust.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, ConfigError
from birdocp.bird.sixdof import HEADING, STATE_NAMES, rhs_expression
from birdocp.engine.integrate import RK4Grid, stage_block_index
from birdocp.engine.rk4 import rk4_update
from birdocp.engine.results import result_dict, serial
from birdocp.studies.control import PerModel
from birdocp.studies.lateral_simulate_aero import complete_state6, n_aero_states
from birdocp.studies.simulate import MAX_SPEED_MPS, gust_shape, interval_data, parse_state_values, wind_vector

__all__ = ["SideGust", "LateralSimulation", "simulate_lateral", "parse_side_gust", "parse_lateral_perturbation",
           "LATERAL_STATE_ALIASES"]

LATERAL_STATE_ALIASES = {"u": 0, "v": 1, "w": 2, "p": 3, "q": 4, "r": 5, "phi": 6, "theta": 7, "psi": 8,
                         **{n: i for i, n in enumerate(STATE_NAMES)}}
MAX_RATE_RADPS = 1000.0
"""Largest body rate |p|, |q|, |r| in the model's range."""
SHAPES = ("pulse", "step")


@dataclass(frozen=True)
class SideGust:
    """An east (side) wind: ``amplitude_mps`` (positive: blowing towards the bird's right), ``shape``
    'pulse' (``A/2 (1 - cos(2 pi (t - t_s)/L))`` for t_s <= t <= t_s + L) or 'step' (A from t_s on),
    ``length_beats`` L and ``start_beats`` t_s in wingbeats."""

    amplitude_mps: float
    length_beats: float = 1.0
    start_beats: float = 1.0
    shape: str = "pulse"

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise ConfigError("--side-gust", f"shape must be pulse or step, got '{self.shape}'")
        if not (math.isfinite(self.amplitude_mps) and abs(self.amplitude_mps) <= MAX_SPEED_MPS):
            raise ConfigError("--side-gust", f"the amplitude must lie within +-{MAX_SPEED_MPS:g} m/s, got "
                                             f"{self.amplitude_mps}")
        if not (math.isfinite(self.length_beats) and 0.01 <= self.length_beats <= 1e4):
            raise ConfigError("--side-gust", f"the length must lie in 0.01..10000 beats, got {self.length_beats}")
        if not (math.isfinite(self.start_beats) and 0 <= self.start_beats <= 1e4):
            raise ConfigError("--side-gust", f"the start must lie in 0..10000 beats, got {self.start_beats}")

    def vector(self, period_s: float) -> np.ndarray:
        """(A, t_s [s], L [s], step flag) for the stepper.

        Parameters
        ----------
        period_s : float
            Wingbeat period [s].

        Returns
        -------
        ndarray, shape (4,)
        """
        return np.array([self.amplitude_mps, self.start_beats * period_s, self.length_beats * period_s,
                         1.0 if self.shape == "step" else 0.0])


def parse_side_gust(text: str, start_beats: float = 1.0) -> SideGust:
    """``pulse|step=MPS[:BEATS]`` (BEATS the pulse length, default 1).

    Parameters
    ----------
    text : str
        The gust's text.
    start_beats : float
        Start of the gust [beats].

    Returns
    -------
    SideGust
    """
    try:
        shape, rest = text.split("=", 1)
        amp, _, length = rest.partition(":")
        return SideGust(float(amp), float(length) if length else 1.0, start_beats, shape.strip())
    except ValueError as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError("--side-gust", f"expected pulse|step=MPS[:BEATS], got '{text}'") from None


def _check_lateral_deviation(key: str, i: int, v: float, val: str) -> None:
    top = MAX_SPEED_MPS if i < 3 else MAX_RATE_RADPS if i < 6 else math.pi
    if not (math.isfinite(v) and abs(v) <= top):
        raise ConfigError("--perturb", f"'{key}' must lie within +-{top:g} (m/s, rad/s or rad), got {val}")


def parse_lateral_perturbation(items) -> np.ndarray:
    """``KEY=VALUE`` deviations of the 9 states (u, v, w [m/s], p, q, r [rad/s], phi, theta, psi [rad]).

    Parameters
    ----------
    items : sequence of str
        ``KEY=VALUE`` texts (``--perturb``).

    Returns
    -------
    ndarray, shape (9,)
    """
    return parse_state_values(items, LATERAL_STATE_ALIASES, 9,
                              "six degrees of freedom: u, v, w, p, q, r, phi, theta, psi", _check_lateral_deviation)


def _dcm(phi, th, psi):
    """Inertial (north, east, down) -> body rotation of the 3-2-1 angles."""
    cf, sf, ct, st, cp, sp = ca.cos(phi), ca.sin(phi), ca.cos(th), ca.sin(th), ca.cos(psi), ca.sin(psi)
    return ca.vertcat(ca.horzcat(ct * cp, ct * sp, -st),
                      ca.horzcat(sf * st * cp - cf * sp, sf * st * sp + cf * cp, sf * ct),
                      ca.horzcat(cf * st * cp + sf * sp, cf * st * sp - sf * cp, cf * ct))


def _wind_terms(z, g, C, x, wagner: bool):
    """``(wind_b, wind_rate_b)``: the wind in body axes at G [m/s] (the side gust, a function of the time
    ``z[12]``, and the planar winds and gusts frozen in space along the initial heading, met at the
    north position ``z[9]``) and, for Wagner's added mass, the rate of its body-axis components along
    the motion [m/s^2], ``C dW/dt - omega x (C W)`` (``dW/dt = dW/dt_side + dW/dN N'``; None otherwise)."""
    t, north = z[12], z[9]
    w8 = g[4:]  # the planar wind layout of birdocp.studies.simulate.wind_vector
    east = g[0] * ca.if_else(g[3] > 0, ca.if_else(t >= g[1], 1, 0), gust_shape(t, g[1], g[2]))
    forward = w8[0] + w8[2] * gust_shape(north, w8[4], w8[5])
    up = w8[1] + w8[3] * gust_shape(north, w8[6], w8[7])
    W = ca.vertcat(forward, east, -up)
    wind_b = C @ W
    if not wagner:
        return wind_b, None
    W_dot = ca.jtimes(W, ca.vertcat(north, t), ca.vertcat((C.T @ x[:3])[0], 1))
    return wind_b, C @ W_dot - ca.cross(x[3:6], wind_b)


class _SixStepper(PerModel):
    """RK4 of z = (9 states, position N, E, D, time, aerodynamic states) with a side wind and the planar
    winds and gusts (along the initial heading and vertical), for (model, steps, N)."""

    def __init__(self, six, steps: int, n_intervals: int):
        self.model = six
        self.grid = grid = RK4Grid(six.ode, steps, n_intervals)
        n, nd, np_ = grid.n, six.ode.nd, six.ode.np
        n_a = n_aero_states(six)
        z = ca.SX.sym("z", 13 + n_a)
        # g: the side gust (A, t_s, L, step flag) then the planar wind layout of
        # birdocp.studies.simulate (constant horizontal, vertical; gust amplitudes; start/length of each)
        d, p, g = ca.SX.sym("d", nd), ca.SX.sym("p", np_), ca.SX.sym("g", 4 + 8)
        x = ca.vertcat(z[:9], z[13:])
        C = _dcm(x[6], x[7], x[8])
        wagner = six.section is not None and six.section.unsteady == "wagner"
        wind_b, wind_rate = _wind_terms(z, g, C, x, wagner)
        x_air = ca.vertcat(x[:3] - wind_b, x[3:])
        xdot = rhs_expression(x, d, p, x_air, structure=six.structure, section=six.section, wind_rate=wind_rate)
        zdot = ca.vertcat(xdot[:9], C.T @ x[:3], 1, xdot[9:])
        f = ca.Function("f_sim6", [z, d, p, g], [zdot])
        D3 = ca.SX.sym("D3", nd, 3)
        step = ca.Function("sim6_step", [z, D3, p, g], [rk4_update(f, z, D3, grid.h, p, g)[0]])
        self.interval = step.mapaccum("sim6_interval", n)
        self.air = ca.Function("air6", [z, g], [x_air[:3]]).map(n)
        self.post_interval = six.ode.post.map(2 * n + 1)
        self.blocks = stage_block_index(n)
        self.times = grid.times(0.0)

    def data(self, i: int, p) -> ca.DM:
        return interval_data(self, i, p)


@dataclass
class LateralSimulation:
    """Time histories and per-beat deviations of a 6-DOF simulation (:func:`simulate_lateral`)."""

    success: bool
    status: str
    message: str
    closed_loop: bool
    beats: int
    t_s: np.ndarray = field(metadata=serial(skip=True))  # (n,) times of the RK4 steps
    states: np.ndarray = field(metadata=serial(skip=True))  # (n, 9) the state (STATE_NAMES)
    position_m: np.ndarray = field(metadata=serial(skip=True))  # (n, 3) north, east, down of G
    control_t_s: np.ndarray = field(metadata=serial(skip=True))
    controls: np.ndarray = field(metadata=serial(skip=True))  # (k, m) applied values (absolute, deg)
    control_keys: list = field(metadata=serial(key="controls"))
    deviation_per_beat: np.ndarray  # (K+1,) 2-norm of the 8 states (heading excluded) minus the cycle's
    saturated: bool
    side_gust: dict | None
    perturbation: list
    distance_per_beat_m: float
    min_air_forward_speed_mps: float = float("nan")
    max_airflow_body_angle_deg: float = float("nan")
    diverged_beat: int | None = None
    control_cycle: np.ndarray = field(default_factory=lambda: np.zeros(0), metadata=serial(skip=True))
    gusts: list = field(default_factory=list)  # the vertical/horizontal gusts met (start_m, length_m, ...)
    wind_mps: list = field(default_factory=lambda: [0.0, 0.0])  # constant (horizontal, vertical up)
    # largest stalled share of one wing's span-time area over a beat (checked every beat)
    max_stalled_fraction: float = field(default=0.0, metadata=serial(key="max_stalled_fraction_per_beat"))
    # (n, n_a) the lag and separation states (aero.unsteady = "wagner", aero.section = "dynamic-stall")
    aero_states: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), metadata=serial(skip=True))
    aero_state_names: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready dict: the fields but the histories, with the peak bank and the final heading [deg],
        the largest sideways drift [m] and the beats to recover (deviation back to 1/100 of its peak).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        dev = np.asarray(self.deviation_per_beat, float)
        k = int(np.nanargmax(dev)) if np.any(np.isfinite(dev)) else 0
        later = np.nonzero(dev[k:] <= dev[k] / 100.0)[0]
        some = len(self.states) > 0
        return result_dict(self, extra={
            "state_names": list(STATE_NAMES), "degrees_of_freedom": 6,
            "peak_deviation": dev[k], "peak_beat": k, "final_deviation": dev[-1],
            "beats_to_recover": int(later[0]) if later.size and self.success else None,
            "max_abs_bank_deg": np.degrees(np.max(np.abs(self.states[:, 6]))) if some else None,
            "final_heading_deg": np.degrees(self.states[-1, HEADING]) if some else None,
            "max_abs_east_drift_m": np.max(np.abs(self.position_m[:, 1])) if some else None,
            "control_range": [[np.min(c), np.max(c)] for c in self.controls.T] if self.controls.size else [],
            "stall_fraction_checked": True})

    def arrays(self) -> dict:
        """The histories (arrays.npz).

        Returns
        -------
        dict of str to ndarray
        """
        return {"t_s": self.t_s, "states": self.states, "position_m": self.position_m,
                "control_t_s": self.control_t_s, "controls": self.controls, "control_cycle": self.control_cycle,
                "deviation_per_beat": self.deviation_per_beat,
                **({"aero_states": self.aero_states} if self.aero_states.size else {})}


def _in_range(z) -> np.ndarray:
    """Per row of the stepper's z: finite, speed and body rates within the model's range."""
    with np.errstate(invalid="ignore", over="ignore"):
        return (np.all(np.isfinite(z), axis=1) & (np.linalg.norm(z[:, :3], axis=1) <= MAX_SPEED_MPS)
                & np.all(np.abs(z[:, 3:6]) <= MAX_RATE_RADPS, axis=1))


def _limits_text(status_z, air, lim, stalled=None):
    """The reasons a step range leaves the model's range or validity (empty: none); ``stalled``: the
    beat's stalled share of the span-time area of each wing (left, right)."""
    z = status_z
    if not np.all(_in_range(z)):
        return "diverged", "the state left the model's range (non-finite, speed or rate too large)"
    inflow = np.degrees(np.arctan2(np.hypot(air[1], air[2]), air[0]))
    pitch = np.degrees(np.max(np.abs(z[:, 7])))
    reasons = [t for bad, t in (
        (np.min(air[0]) < lim.min_forward_speed_mps,
         f"air-relative forward speed {np.min(air[0]):.3g} m/s < {lim.min_forward_speed_mps:g} m/s"),
        (pitch > lim.max_abs_pitch_deg, f"|pitch| {pitch:.3g} > {lim.max_abs_pitch_deg:g} deg"),
        (np.max(np.abs(inflow)) > lim.max_airflow_body_angle_deg,
         f"airflow at {np.max(np.abs(inflow)):.3g} deg to the body axis > {lim.max_airflow_body_angle_deg:g} deg"),
    ) + tuple((v > lim.max_stalled_fraction, f"{v:.1%} of the {side} wing's span-time area beyond the stall angle "
                                            f"{lim.stall_angle_deg:g} deg > {lim.max_stalled_fraction:.0%}")
              for side, v in zip(("left", "right"), [] if stalled is None else stalled)) if bad]
    return ("left_validity", ", ".join(reasons)) if reasons else ("ok", "")


def _stalled_shares(st, Zi, air, D, pk, stall_deg: float) -> np.ndarray:
    """(2, n): the stalled share of each wing's span (left, right) at the n step ends of an interval,
    from the effective angles of the air-relative state (:func:`birdocp.bird.validity.sixdof_angles`)."""
    from birdocp.bird.validity import side_elements, sixdof_angles

    n = Zi.shape[0]
    f = sixdof_angles(9 + n_aero_states(st.model), st.model.ode.nd, n, st.model.section,
                      st.model.structure.normalwash)
    X_air = np.vstack([air, Zi[:, 3:9].T, Zi[:, 13:].T])  # then the aerodynamic states
    ae, _, ds = (np.asarray(v) for v in f(ca.DM(X_air), D[:, 2::3], ca.DM(pk[:len(PARAM_NAMES)])))
    stalled = np.degrees(np.abs(ae)) > stall_deg
    return np.array([(stalled[j] * ds[j]).sum(axis=0) / ds[j].sum(axis=0) for j in side_elements(ds.shape[0]).values()])


def _beat(st, z, k, N, p_cyc, idx, u_cyc, controller, gvec, T, stall_deg=None):
    """One beat of :func:`simulate_lateral`: (z, Zs, controls applied, saturated, air velocities,
    stalled shares (2, steps): left and right wing at each step end)."""
    Zs, applied, sat, airs, shares = [], [], False, [], []
    for i in range(N):
        pk = p_cyc
        if controller is not None:
            u = u_cyc - np.asarray(controller.K[i]) @ (z[:HEADING] - np.asarray(controller.x_starts[i]))
            lim = np.asarray(controller.limits)
            uc = np.clip(u, lim[:, 0], lim[:, 1])
            sat = sat or bool(np.any(uc != u))
            pk = p_cyc.copy()
            pk[idx] = uc
            applied.append(((k + i / N) * T, uc))
        D = st.data(i, pk)
        with np.errstate(all="ignore"):
            Zi = np.asarray(st.interval(z, D, ca.DM(pk), ca.DM(gvec))).T
        Zs.append(Zi)
        airs.append(np.asarray(st.air(Zi.T, ca.DM(gvec))))
        if stall_deg is not None and np.all(np.isfinite(Zi)):
            shares.append(_stalled_shares(st, Zi, airs[-1], D, pk, stall_deg))
        z = Zi[-1]
    return z, np.vstack(Zs), applied, sat, np.hstack(airs), (np.hstack(shares) if shares else np.zeros((2, 0)))


def _wind_of(st, x0, N, p_cyc, side_gust, gusts, wind_mps):
    """``(g, beat_m, spans)``: the stepper's wind numbers (side gust, then :func:`wind_vector`'s), the
    distance flown in one calm beat of the cycle [m] (the gusts' beats) and the gusts' spans."""
    T = st.model.period_s
    side = side_gust.vector(T) if side_gust is not None else np.array([0.0, 0.0, 1.0, 0.0])
    calm = np.concatenate([[0.0, 0.0, 1.0, 0.0], wind_vector((), (0.0, 0.0), 1.0)[0]])
    zc = _beat(st, _augmented(x0), 0, N, p_cyc, [], np.zeros(0), None, calm, T)[0]
    beat_m = float(np.hypot(zc[9], zc[10]))
    planar, spans = wind_vector(gusts, wind_mps, beat_m)
    return np.concatenate([side, planar]), beat_m, spans


def _augmented(x_full) -> np.ndarray:
    """The stepper's z of a full state (9 body states, then the aerodynamic states): position and time 0."""
    x_full = np.asarray(x_full, float)
    return np.concatenate([x_full[:9], [0.0] * 4, x_full[9:]])


def check_lateral_simulation_config(cfg, side_gust: SideGust | None = None) -> None:
    """Refuse, before anything is built, a 6-DOF simulation the model cannot march.

    Parameters
    ----------
    cfg : birdocp.bird.config.Config
        The 6-DOF configuration to simulate.
    side_gust : SideGust, optional
        The side gust.

    Returns
    -------
    None
        Returns when the simulation can run; raises :class:`~birdocp.bird.config.ConfigError` naming
        ``--side-gust`` for a ``step`` side gust with ``aero.unsteady = 'wagner'`` (the added mass
        reacts to the wind's rate, infinite at the step: its impulse is not modelled).
    """
    if side_gust is not None and side_gust.shape == "step" and cfg.aero.unsteady == "wagner":
        raise ConfigError("--side-gust", "a step has an infinite rate at its start, which Wagner's added mass "
                                         "(aero.unsteady = 'wagner') reacts to: use a pulse (pulse=MPS:BEATS)")


def simulate_lateral(cfg, x0_cycle, p, beats: int, *, steps_per_period: int | None = None, perturbation=None,
                     side_gust: SideGust | None = None, gusts=(), wind_mps=(0.0, 0.0), controller=None,
                     progress=None) -> LateralSimulation:
    """Integrate the 6-DOF bird ``beats`` wingbeats from ``x0_cycle + perturbation``.

    Parameters
    ----------
    cfg : Config
        The configuration (``model.degrees_of_freedom = 6``; its ``[validity]`` thresholds).
    x0_cycle : array
        The cycle's state at the beat start: 8 (psi = 0) or 9 body states, then, with ``aero.unsteady =
        "wagner"`` or ``aero.section = "dynamic-stall"``, the cycle's aerodynamic states (the trim's
        ``cycle.x0``); body states alone get them on the quasi-steady manifold
        (:func:`birdocp.studies.lateral_simulate_aero.complete_state6`).
    p : array
        The per-side model's parameter vector of the cycle
        (:func:`birdocp.studies.lateral_control.sides_parameters`).
    beats : int
        Wingbeats to simulate (>= 1).
    steps_per_period : int, optional
        RK4 steps per beat (default ``cfg.solve.steps_per_period``; use the cycle's).
    perturbation : array (9,) or (9 + aerodynamic states,), optional
        State deviation at t = 0 (:func:`parse_lateral_perturbation`; the aerodynamic states unperturbed
        when 9 are given).
    side_gust : SideGust, optional
        The side wind.
    gusts : sequence of Gust
        Vertical and horizontal 1 - cos gusts (:class:`birdocp.studies.simulate.Gust`, at most one of
        each) frozen in space along the cycle's initial heading, met at the bird's position.
    wind_mps : (float, float)
        Constant wind (horizontal along the initial heading, vertical positive up) [m/s].
    controller : Controller, optional
        A 6-DOF controller (gains (N, m, 8) on the body states, heading excluded); None = open loop.
    progress : callable, optional
        ``progress(text)`` at the start of every beat.

    Returns
    -------
    LateralSimulation
    """
    if int(beats) < 1:
        raise ConfigError("--beats", f"must be >= 1, got {beats}")
    six, x0, dx0 = _start(cfg, x0_cycle, p, perturbation, side_gust)
    N = int(getattr(controller, "updates_per_beat", 1)) if controller is not None else 1
    st = _SixStepper.get(six, int(steps_per_period or cfg.solve.steps_per_period), N)
    p_cyc = np.asarray(p, float)
    keys = list(controller.controls) if controller is not None else []
    idx = [list(six.ode.param_names).index(k) for k in keys]
    gvec, beat_m, spans = _wind_of(st, x0, N, p_cyc, side_gust, gusts, wind_mps)
    z = _augmented(x0 + dx0)
    traj, ctrl, dev = [z[None, :]], [], [float(np.linalg.norm(dx0[:HEADING]))]
    sat, status, message, diverged, airs, stall_max = False, "ok", f"{int(beats)} beats simulated", None, [], 0.0
    for k in range(int(beats)):
        if progress is not None:
            progress(f"beat {k + 1}/{beats}")
        z, Zk, applied, s, air, shares = _beat(st, z, k, N, p_cyc, idx, p_cyc[idx], controller, gvec, six.period_s,
                                               cfg.validity.stall_angle_deg)
        stalled = shares.mean(axis=1) if shares.shape[1] == Zk.shape[0] else np.zeros(0)  # per wing, over the beat
        stall_max = max([stall_max, *stalled])
        status, why = _limits_text(Zk, air, cfg.validity, stalled)
        if status == "diverged":  # the histories keep the states up to the last one in range
            Zk, air = Zk[:int(np.argmin(_in_range(Zk)))], air[:, :int(np.argmin(_in_range(Zk)))]
        sat, ctrl = sat or s, ctrl + applied
        traj.append(Zk)
        airs.append(air)
        dev.append(float(np.linalg.norm(z[:HEADING] - x0[:HEADING])) if status != "diverged" else float("nan"))
        if status != "ok":
            diverged = k + 1 if status == "diverged" else None
            message = f"{'diverged' if diverged else 'left the model validity'} in beat {k + 1}: {why}"
            break
    Z = np.vstack(traj)
    min_air, max_inflow = _air_extremes(airs)
    return LateralSimulation(
        status == "ok", status, message, controller is not None, int(beats), np.asarray(Z[:, 12]), Z[:, :9],
        Z[:, 9:12], np.array([c[0] for c in ctrl]), np.array([c[1] for c in ctrl]) if ctrl else np.zeros((0, len(keys))),
        keys, np.array(dev), sat, None if side_gust is None else asdict(side_gust), dx0.tolist(), beat_m, min_air,
        max_inflow, diverged, p_cyc[idx],
        gusts=spans, wind_mps=[float(v) for v in wind_mps], max_stalled_fraction=stall_max, aero_states=Z[:, 13:],
        aero_state_names=list(six.state_names[9:]))


def _air_extremes(airs) -> tuple[float, float]:
    """(smallest air-relative forward speed [m/s], largest airflow-body angle [deg]) of the air velocities
    (3 x n blocks) met; NaN when no step stayed in range."""
    A = np.hstack(airs) if airs else np.zeros((3, 0))
    if not A.size:
        return float("nan"), float("nan")
    return float(np.nanmin(A[0])), float(np.nanmax(np.degrees(np.arctan2(np.hypot(A[1], A[2]), A[0]))))


def _start(cfg, x0_cycle, p, perturbation, side_gust):
    """``(six, x0, dx0)`` of :func:`simulate_lateral`: the per-side model, the cycle's full state and the
    full perturbation, checked."""
    from birdocp.bird.sixdof import sixdof_model

    check_lateral_simulation_config(cfg, side_gust)
    six = sixdof_model(cfg, sides=True)
    x0 = complete_state6(six, x0_cycle, p)
    dx0 = np.zeros(len(x0))
    if perturbation is not None:
        d = np.asarray(perturbation, float).ravel()
        if d.size not in (9, len(x0)):
            raise ValueError(f"the perturbation has 9 body states or all {len(x0)} states; got {d.size}")
        dx0[:d.size] = d
    return six, x0, dx0
