"""Wingbeat-to-wingbeat feedback: the linearised wingbeat map with gait controls and its LQR.

At a converged cycle (a trim or a level-flight trim) the beat is split into ``N`` equal intervals
(``updates_per_beat``; N = 1 is wingbeat-to-wingbeat feedback). Over interval ``i`` the chosen gait
parameters (dotted keys of :data:`birdocp.bird.config.PARAM_NAMES`, e.g. a joint offset in deg) are
held at ``u_cycle + du_i``; the state deviation at the interval starts obeys, to first order::

    dx_{i+1} = A_i dx_i + B_i du_i        (i = 0 .. N-1, dx_N = dx at the next beat's start)

``A_i`` (4 x 4) and ``B_i`` (4 x m, per unit of each control's own unit) are exact derivatives of the
RK4 map of the trim's grid: forward AD through the per-time data (wing geometry, lifting-line
matrices) and through every RK4 step. ``M = A_{N-1} ... A_0`` is the monodromy.

Controller: the periodic discrete-time LQR ``du_i = -K_i dx_i`` minimising
``sum_k dx_k' Q dx_k + du_k' R du_k`` over all interval starts. The periodic Riccati equation is
solved with :func:`scipy.linalg.solve_discrete_are` on the cyclic reformulation of the N-periodic
system (Bittanti & Colaneri: the time-invariant system of dimension 4N whose DARE solution is
block-diagonal with the periodic solution ``P_i`` on its diagonal); python-control 0.10 has no
periodic LQR. Default weights by Bryson's rule: acceptable deviations
:data:`ACCEPTABLE_STATE` (u, w in m/s, q in rad/s, theta in rad) and :data:`ACCEPTABLE_CONTROL_DEG`
per control (deg; other units: 5 % of the configured value).

Controllability per control (each alone): stabilisable by the PBH test on the beat map for every
multiplier outside the unit circle, the modal input ``w^H B`` of the expanding mode, the
minimal-energy stabilising gain (the LQR limit Q -> 0 on the unstable modal subsystem: it reflects
each expanding multiplier lambda to 1/conj(lambda) and leaves the others in place) and the LQR gain
with the default weights alone, with their closed-loop spectral radii.

scipy is needed at run time for this module (``pip install 'birdocp[control]'``, also in ``[test]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError
from birdocp.bird.model import get_model
from birdocp.engine.cache import owned_cache
from birdocp.engine.floquet import complex_pairs, multiplier_order
from birdocp.engine.integrate import RK4Grid
from birdocp.studies.control_aero import body_gains, manifold_slopes, pad_weight
from birdocp.studies.control_keys import (ACCEPTABLE_CONTROL_DEG, ACCEPTABLE_STATE, CONTROL_ALIASES,  # noqa: F401
                                         DEFAULT_CONTROLS, DEFAULT_LIMIT_DEG, GAIT_HINT, bryson_weights,
                                         default_limits, resolve_controls)
from birdocp.engine.results import result_dict, serial

__all__ = ["DEFAULT_CONTROLS", "ACCEPTABLE_STATE", "ACCEPTABLE_CONTROL_DEG", "DEFAULT_LIMIT_DEG",
           "WingbeatMap", "Controller", "wingbeat_map", "periodic_lqr", "design_controller",
           "resolve_controls", "bryson_weights", "default_limits", "sorted_eigs", "reference_cycle",
           "closed_loop_monodromy", "body_gains", "CONTROL_ALIASES", "PerModel", "linearise", "controller_on_map"]

def sorted_eigs(Mat):
    """Eigenvalues and right eigenvectors, largest modulus first (:func:`~birdocp.engine.floquet.multiplier_order`).

    Parameters
    ----------
    Mat : array_like, shape (n, n)
        Real matrix.

    Returns
    -------
    lam : ndarray, shape (n,)
    V : ndarray, shape (n, n)
        Eigenvectors as columns, in the order of ``lam``.
    """
    lam, V = np.linalg.eig(np.asarray(Mat, float))
    order = multiplier_order(lam)
    return lam[order], V[:, order]


class PerModel:
    """Base of the classes that hold CasADi Functions built once per (model, settings): ``get``
    returns the instance kept by the model (``model.model``, :func:`birdocp.engine.cache.owned_cache`)."""

    @classmethod
    def get(cls, model, *settings):
        """The instance for (model, settings), built on first use and kept by ``model.model``.

        Parameters
        ----------
        model : object
            Model (``model.model`` keeps the instance).
        *settings
            Further parts of the key.

        Returns
        -------
        PerModel
        """
        return owned_cache(model.model).build((cls, *settings), lambda: cls(model, *settings))


class _Linearisation(PerModel):
    """CasADi Functions of one interval of the beat for (model, steps, N): end state, state Jacobian
    and directional derivatives along the data/parameter directions of the controls. ``model``: any
    object with ``ode`` (a :class:`~birdocp.engine.ode.ODE` of nx states), ``data`` (its
    data Function) and ``model`` (the identity it is cached by)."""

    def __init__(self, model, steps: int, n_intervals: int):
        self.model = model.model
        self.grid = grid = RK4Grid(model.ode, steps, n_intervals)
        nx, nd, np_ = model.ode.nx, model.ode.nd, model.ode.np
        x = ca.MX.sym("x", nx)
        Dn = ca.MX.sym("D", nd, 3 * grid.n)
        p = ca.MX.sym("p", np_)
        dD = ca.MX.sym("dD", nd, 3 * grid.n)
        dp = ca.MX.sym("dp", np_)
        xe = grid.segment(x, Dn, p)[0]
        Jx = ca.jacobian(xe, x)
        Ju = ca.jtimes(xe, ca.vertcat(ca.vec(Dn), p), ca.vertcat(ca.vec(dD), dp))
        self.interval = ca.Function("interval_lin", [x, Dn, p, dD, dp], [xe, Jx, Ju])
        self.n_times = 2 * steps + 1
        self.data_fwd = model.data.forward(1).map(self.n_times)


@dataclass
class WingbeatMap:
    """The linearised wingbeat map with controls, at a cycle.

    controls: the control keys; updates_per_beat: N; x0: the cycle's state at the beat start;
    p: the cycle's parameters; x_starts (N, n): the cycle's state at each interval start;
    A (N, n, n), B (N, n, m): interval maps (B per unit of each control's own unit, e.g. per deg);
    M (n, n): the monodromy A_{N-1}..A_0; B_lifted (n, N m): the response of the state one beat later
    to each interval's control (columns interval-major); cycle_validity: the exact validity of the
    cycle (:meth:`birdocp.bird.validity.CycleValidity.to_dict`; whether the model holds on the
    cycle the controller is designed around); param_names, state_names: the names of ``p`` and
    of the body states (the planar model's 4 by default; the six-degree-of-freedom map of
    :mod:`birdocp.studies.lateral_control` has 8); manifold (N, n - nb, nb), nb the body states:
    with aerodynamic states, the slope of their quasi-steady manifold (the lag and separation states
    that a body state implies, :meth:`birdocp.bird.model.BirdModel.complete_state`) at each interval
    start.

    With aerodynamic states (``aero.unsteady = "wagner"`` or ``aero.section = "dynamic-stall"``) the
    state has n = 4 + 16 n_z components (body first) and A, B, x_starts, x0 are over all of them.
    """

    controls: list
    updates_per_beat: int
    steps_per_period: int
    x0: np.ndarray
    p: np.ndarray
    x_starts: np.ndarray
    A: np.ndarray
    B: np.ndarray
    cycle_validity: dict | None = None
    param_names: tuple = PARAM_NAMES
    state_names: tuple = ("u_mps", "w_mps", "q_radps", "theta_rad")
    manifold: np.ndarray | None = None

    @property
    def n_states(self) -> int:
        return int(self.A.shape[1])

    @property
    def n_body(self) -> int:
        """The number of body (flight) states: :attr:`state_names`; the rest are aerodynamic states."""
        return len(self.state_names)

    @property
    def M(self) -> np.ndarray:
        out = np.eye(self.n_states)
        for Ai in self.A:
            out = Ai @ out
        return out

    @property
    def B_lifted(self) -> np.ndarray:
        N, cols = self.updates_per_beat, []
        for i in range(N):
            T = np.eye(self.n_states)
            for j in range(i + 1, N):
                T = self.A[j] @ T
            cols.append(T @ self.B[i])
        return np.hstack(cols)

    @property
    def multipliers(self) -> np.ndarray:
        return sorted_eigs(self.M)[0]


def wingbeat_map(cycle_result, controls=DEFAULT_CONTROLS, updates_per_beat: int = 1) -> WingbeatMap:
    """Exact linearisation of the wingbeat map with gait controls.

    Parameters
    ----------
    cycle_result : TrimResult
        A converged trim (its grid, ``steps_per_period`` RK4 steps, is linearised).
    controls : sequence of str
        Gait keys (or aliases) held over each interval; derivatives per unit of each key's own unit
        (deg for angles).
    updates_per_beat : int
        N >= 1 intervals; must divide the RK4 steps per period.

    Returns
    -------
    WingbeatMap
        ``A`` (N, 4, 4), ``B`` (N, 4, m), the cycle's states at the interval starts, ``M``,
        ``B_lifted``. State units: u, w [m/s], q [rad/s], theta [rad].
    """
    controls = resolve_controls(controls)
    N = int(updates_per_beat)
    c = cycle_result.cycle
    steps = int(c.method["steps_per_period"])
    if N < 1:
        raise ConfigError("--updates-per-beat", f"must be >= 1, got {N}")
    if steps % N:
        raise ConfigError("--updates-per-beat", f"must divide the RK4 steps per period ({steps}); "
                          "change it or solve.steps_per_period")
    if not c.success:
        raise ValueError("the cycle did not converge: the wingbeat map needs a converged cycle")
    m = get_model(cycle_result.cfg)
    p = np.asarray(c.p, float)
    x0 = m.complete_state(np.asarray(c.x0, float), p)  # with aerodynamic states: the full state
    xs, A, B = linearise(m, x0, p, steps, N, [PARAM_NAMES.index(k) for k in controls])
    v = getattr(cycle_result, "validity", None)
    S = manifold_slopes(m, xs, np.arange(N) * (m.period_s / N), p) if m.ode.nx > 4 else None
    return WingbeatMap(list(controls), N, steps, np.asarray(x0, float), p, xs, A, B,
                       v.to_dict() if v is not None else None, manifold=S)


def linearise(model, x0, p, steps: int, updates_per_beat: int, control_index):
    """The interval maps of the wingbeat map at a cycle, by exact forward AD through the per-time data and
    every RK4 step.

    Parameters
    ----------
    model : object
        With ``ode``, ``data`` and ``model`` (:class:`_Linearisation`).
    x0, p : array_like
        The cycle's start state and parameter vector.
    steps : int
        RK4 steps per period.
    updates_per_beat : int
        N, the intervals over which each control is held.
    control_index : sequence of int
        Indices in ``p`` of the m controls.

    Returns
    -------
    x_starts : ndarray, shape (N, n)
    A : ndarray, shape (N, n, n)
    B : ndarray, shape (N, n, m)
    """
    N = int(updates_per_beat)
    lin = _Linearisation.get(model, steps, N)
    grid = lin.grid
    p = np.asarray(p, float)
    times = ca.DM(grid.times(0.0)).reshape((1, -1))
    Dgrid = grid.data_grid(times, ca.DM(p))
    idx = grid.block_index
    nm, nx = len(control_index), model.ode.nx
    dDs, dps = [], []
    for k in control_index:
        ep = np.zeros(len(p))
        ep[k] = 1.0
        dDs.append(lin.data_fwd(times, ca.DM(p), Dgrid, ca.DM.zeros(1, lin.n_times), ca.DM(ep))[:, idx])
        dps.append(ca.DM(ep))
    width = 3 * grid.n
    x = ca.DM(np.asarray(x0, float))
    xs, A, B = [], np.zeros((N, nx, nx)), np.zeros((N, nx, nm))
    D = Dgrid[:, idx]
    for i in range(N):
        cols = slice(width * i, width * (i + 1))
        xs.append(np.asarray(x).ravel())
        for j in range(nm):
            xe, Jx, Ju = lin.interval(x, D[:, cols], ca.DM(p), dDs[j][:, cols], dps[j])
            B[i, :, j] = np.asarray(Ju).ravel()
        A[i] = np.asarray(Jx)
        x = xe
    return np.array(xs), A, B


def periodic_lqr(A, B, Q, R):
    """Periodic discrete-time LQR of ``x_{i+1} = A_i x_i + B_i u_i`` (i mod N), cost
    ``sum x'Qx + u'Ru``.

    Parameters
    ----------
    A : array (N, n, n)
    B : array (N, n, m)
    Q : array (n, n)
        State weight at every interval start.
    R : array (m, m)
        Control weight of every interval.

    Returns
    -------
    P : array (N, n, n)
        The periodic Riccati solution (cost-to-go from interval i).
    K : array (N, m, n)
        Gains, ``u_i = -K_i x_i``.

    Notes
    -----

    Solved by :func:`scipy.linalg.solve_discrete_are` on the cyclic reformulation (state
    ``(x_0, .., x_{N-1})`` of dimension nN, ``A_i`` in block (i+1, i)), whose stabilising solution is
    ``blockdiag(P_0, .., P_{N-1})``. Raises ``numpy.linalg.LinAlgError`` (from scipy) when no
    stabilising solution exists (not stabilisable)."""
    from scipy.linalg import solve_discrete_are

    A = np.asarray(A, float)
    B = np.asarray(B, float)
    N, n, m = A.shape[0], A.shape[1], B.shape[2]
    if N == 1:
        P = solve_discrete_are(A[0], B[0], Q, R)
        Ps = P[None]
    else:
        Ac = np.zeros((N * n, N * n))
        Bc = np.zeros((N * n, N * m))
        for i in range(N):
            r = (i + 1) % N
            Ac[r * n:(r + 1) * n, i * n:(i + 1) * n] = A[i]
            Bc[r * n:(r + 1) * n, i * m:(i + 1) * m] = B[i]
        Pc = solve_discrete_are(Ac, Bc, np.kron(np.eye(N), Q), np.kron(np.eye(N), R))
        Ps = np.array([Pc[i * n:(i + 1) * n, i * n:(i + 1) * n] for i in range(N)])
        Ps = 0.5 * (Ps + Ps.transpose(0, 2, 1))
    K = np.zeros((N, m, n))
    for i in range(N):
        Pn = Ps[(i + 1) % N]
        K[i] = np.linalg.solve(R + B[i].T @ Pn @ B[i], B[i].T @ Pn @ A[i])
    return Ps, K


def closed_loop_monodromy(A, B, K) -> np.ndarray:
    """``prod_i (A_i - B_i K_i)``: the beat map under periodic state feedback.

    Parameters
    ----------
    A, B : array_like
        Interval maps, (N, n, n) and (N, n, m).
    K : array_like
        Gains (N, m, n) or (N, m, 4): a narrower gain feeds back the first (body) states only.

    Returns
    -------
    ndarray, shape (n, n)
    """
    n = np.asarray(A).shape[1]
    out = np.eye(n)
    for Ai, Bi, Ki in zip(A, B, K):
        Ki = np.asarray(Ki, float)
        if Ki.shape[1] < n:
            Ki = np.hstack([Ki, np.zeros((Ki.shape[0], n - Ki.shape[1]))])
        out = (Ai - Bi @ Ki) @ out
    return out


def _single_control(wm: WingbeatMap, j: int, Q, R) -> dict:
    """Controllability of the cycle through control j alone."""
    lam, V = sorted_eigs(wm.M)
    W = np.linalg.inv(V)
    unstable = np.abs(lam) >= 1.0
    Bl = wm.B_lifted[:, j::len(wm.controls)]  # this control's columns, one per interval
    scale = np.linalg.norm(wm.M, 2) + np.linalg.norm(Bl, 2)
    pbh = [float(np.linalg.svd(np.hstack([lam[i] * np.eye(wm.n_states) - wm.M, Bl]), compute_uv=False)[-1] / scale)
           for i in np.nonzero(unstable)[0]]
    stabilisable = bool(all(s > 1e-9 for s in pbh))
    modal = W[0] @ Bl  # input of the expanding mode (v normalised to unit 2-norm)
    row = {"control": wm.controls[j], "stabilisable": stabilisable,
           "pbh_min_singular_value": min(pbh) if pbh else None,
           "modal_input_per_unit": float(np.linalg.norm(modal)),
           "min_gain": None, "min_gain_norm": None, "min_gain_spectral_radius": None,
           "min_effort_per_unit_mode": None, "lqr_gain": None, "lqr_gain_norm": None,
           "lqr_spectral_radius": None, "lqr_multipliers": None}
    if not stabilisable:
        return row
    from scipy.linalg import solve_discrete_are

    # minimal-energy stabilising gain: the Q -> 0 LQR of the unstable modal subsystem (lifted beat map)
    Wu = W[unstable]
    Au = np.diag(lam[unstable])
    Bu = Wu @ Bl
    Ru = np.eye(Bl.shape[1])
    try:
        Pu = solve_discrete_are(Au, Bu, np.zeros_like(Au), Ru)
        Ku = np.real(np.linalg.solve(Ru + Bu.conj().T @ Pu @ Bu, Bu.conj().T @ Pu @ Au) @ Wu)
        rho = float(np.max(np.abs(np.linalg.eigvals(wm.M - Bl @ Ku))))
        row.update(min_gain=Ku.tolist(), min_gain_norm=float(np.linalg.norm(Ku, 2)),
                   min_gain_spectral_radius=rho,
                   min_effort_per_unit_mode=float(np.linalg.norm(Ku @ np.real_if_close(V[:, 0]))))
    except (np.linalg.LinAlgError, ValueError):
        pass
    try:
        Rj = R[j:j + 1, j:j + 1]
        _, K = periodic_lqr(wm.A, wm.B[:, :, j:j + 1], Q, Rj)
        K = body_gains(wm, K)
        mult = sorted_eigs(closed_loop_monodromy(wm.A, wm.B[:, :, j:j + 1], K))[0]
        row.update(lqr_gain=K[:, 0, :].tolist(), lqr_gain_norm=float(np.max(np.linalg.norm(K[:, 0, :], axis=1))),
                   lqr_spectral_radius=float(np.max(np.abs(mult))), lqr_multipliers=complex_pairs(mult))
    except (np.linalg.LinAlgError, ValueError):
        pass
    return row


@dataclass
class Controller:
    """A periodic state-feedback controller of the wingbeat map and its analysis.

    ``du_i = -K_i (x - x_starts[i])`` at the start of interval i (units: each control's own unit per
    state unit), saturated at ``limits`` (absolute, (m, 2)) by the simulation. ``K`` and ``x_starts``
    are over the 4 body states; with aerodynamic states ``K_full`` holds the full-state LQR gains the
    body gains come from (:func:`body_gains`), and the closed loop is evaluated on the full map.
    """

    map: WingbeatMap = field(metadata=serial(skip=True))  # written through the keys of to_dict
    Q: np.ndarray
    R: np.ndarray
    P: np.ndarray = field(metadata=serial(key="riccati_P"))
    K: np.ndarray = field(metadata=serial(key="gains"))
    limits: np.ndarray
    per_control: list = field(default_factory=list)
    K_full: np.ndarray | None = field(default=None, metadata=serial(skip=True))

    @property
    def controls(self) -> list:
        return self.map.controls

    @property
    def x_starts(self) -> np.ndarray:
        return self.map.x_starts[:, :self.map.n_body]

    @property
    def updates_per_beat(self) -> int:
        return self.map.updates_per_beat

    @property
    def closed_loop_monodromy(self) -> np.ndarray:
        return closed_loop_monodromy(self.map.A, self.map.B, self.K)

    @property
    def closed_loop_multipliers(self) -> np.ndarray:
        return sorted_eigs(self.closed_loop_monodromy)[0]

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.closed_loop_multipliers)))

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`): the design, its verdict and
        the linearised map it was designed on.

        Returns
        -------
        dict
            Plain JSON types only.
        """
        wm = self.map
        ol = wm.multipliers
        rho = self.spectral_radius
        aero, nb = {}, wm.n_body
        if wm.n_states > nb and self.K_full is not None:  # the body-state feedback against full-state LQR
            full = sorted_eigs(closed_loop_monodromy(wm.A, wm.B, self.K_full))[0]
            aero = {"aero_states": wm.n_states - nb, "full_state_gains": self.K_full,
                    "full_state_spectral_radius": np.max(np.abs(full))}
        stable = bool(rho < 1.0)
        return result_dict(self, extra={
            "success": stable, "status": "stabilised" if stable else "not_stabilised",
            "message": (f"closed-loop spectral radius {rho:.4g} < 1" if stable else
                        f"closed-loop spectral radius {rho:.4g} >= 1: the cycle is not stabilisable through "
                        + ", ".join(r["control"] for r in self.per_control if not r["stabilisable"])
                        if any(not r["stabilisable"] for r in self.per_control) else
                        f"closed-loop spectral radius {rho:.4g} >= 1"),
            "controls": wm.controls, "updates_per_beat": wm.updates_per_beat,
            "steps_per_period": wm.steps_per_period,
            "open_loop_multipliers": complex_pairs(ol),
            "closed_loop_multipliers": complex_pairs(self.closed_loop_multipliers),
            "open_loop_spectral_radius": np.max(np.abs(ol)), "closed_loop_spectral_radius": rho,
            "beats_to_reduce_100x": (math.log(100.0) / -math.log(rho)) if 0 < rho < 1 else None,
            "gain": self.K[0],
            "gain_units": ("control unit (deg) per state unit (u, w: m/s; q: rad/s; theta: rad)" if nb == 4 else
                           "control unit (deg) per state unit (u, v, w: m/s; p, q, r: rad/s; phi, theta: rad)"),
            "state_names": list(wm.state_names),
            "controllable": {r["control"]: r["stabilisable"] for r in self.per_control},
            "cycle_x0": wm.x0[:nb], "cycle_controls": [wm.p[list(wm.param_names).index(k)] for k in wm.controls],
            "cycle_amplitude_deg": wm.p[list(wm.param_names).index("gait.shoulder_flap.amplitude_deg")],
            "cycle_validity": wm.cycle_validity,
            "cycle_valid": None if wm.cycle_validity is None else bool(wm.cycle_validity.get("valid")),
            "x_starts": wm.x_starts[:, :nb], "A": wm.A, "B": wm.B, "monodromy": wm.M, "B_lifted": wm.B_lifted,
            **aero})


def design_controller(cycle_result, controls=DEFAULT_CONTROLS, updates_per_beat: int = 1, *,
                      Q=None, R=None, limit_deg: float = DEFAULT_LIMIT_DEG) -> Controller:
    """Linearise the wingbeat map, design the periodic LQR and analyse each control alone.

    Parameters
    ----------
    cycle_result : TrimResult
        A converged trim (or a level-flight cycle re-trimmed at its amplitude: :func:`reference_cycle`).
    controls : sequence of str
        Gait keys or aliases (default :data:`DEFAULT_CONTROLS`).
    updates_per_beat : int
        N corrections per beat (1 = wingbeat to wingbeat).
    Q, R : array, optional
        Weights (default :func:`bryson_weights`: 1 m/s, 1 m/s, 1 rad/s, 5 deg; 5 deg per joint).
    limit_deg : float
        Joint range around the cycle value used by the simulation to saturate [deg].

    Returns
    -------
    Controller
        Gains ``K`` (N, m, 4) in control units (deg) per state unit, multipliers, per-control analysis.

    Raises
    ------
    ConfigError
        Unknown key or bad N.
    numpy.linalg.LinAlgError
        The controls cannot stabilise the cycle (no stabilising Riccati solution); the exception
        carries ``wingbeat_map`` and ``per_control`` (the analysis of each control alone).
    """
    wm = wingbeat_map(cycle_result, controls, updates_per_beat)
    Qd, Rd = bryson_weights(cycle_result.cfg, wm.controls)
    Q = pad_weight(Qd if Q is None else Q, wm.n_states)  # no weight on the aerodynamic states
    R = Rd if R is None else np.asarray(R, float)
    return controller_on_map(wm, Q, R, default_limits(cycle_result.cfg, wm.controls, wm.p, limit_deg))


def controller_on_map(wm: WingbeatMap, Q, R, limits) -> Controller:
    """The periodic LQR of a linearised wingbeat map and the analysis of each control alone.

    Parameters
    ----------
    wm : WingbeatMap
        Linearised wingbeat map (any number of states).
    Q, R : array_like
        State and control weights.
    limits : array_like, shape (m, 2)
        Absolute control limits, kept by the controller.

    Returns
    -------
    Controller
        No stabilising solution: ``numpy.linalg.LinAlgError`` carrying ``wingbeat_map`` and ``per_control``.
    """
    per = [_single_control(wm, j, Q, R) for j in range(len(wm.controls))]
    try:
        P, K_full = periodic_lqr(wm.A, wm.B, Q, R)
    except (np.linalg.LinAlgError, ValueError) as exc:
        # the analysis survives the failure: the wingbeat map and each control alone
        exc.wingbeat_map, exc.per_control = wm, per
        raise
    K = body_gains(wm, K_full)
    return Controller(wm, Q, R, P, K, np.asarray(limits, float), per, K_full if wm.n_states > wm.n_body else None)


def reference_cycle(cfg: Config, level: bool = False):
    """The cycle to control: the trim of ``cfg``, or with ``level`` the level-flight amplitude solved first
    and the cycle re-trimmed at it (its ``cfg`` then holds that amplitude).

    Parameters
    ----------
    cfg : Config
        Configuration.
    level : bool
        Solve the level-flight amplitude first.

    Returns
    -------
    TrimResult or LevelResult
        The trim; the failed level result when the level solve fails.
    """
    from birdocp.bird.config import with_values
    from birdocp.studies.trim import trim

    if not level:
        return trim(cfg)
    from birdocp.bird.keys import AMPLITUDE_KEY
    from birdocp.studies.level import level as solve_level

    lv = solve_level(cfg)
    if not lv.success:
        return lv
    return trim(with_values(cfg, {AMPLITUDE_KEY: lv.amplitude_deg}), warm_start=lv)
