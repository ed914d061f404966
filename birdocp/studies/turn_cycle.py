"""The level turn of an asymmetric gait as a function of a few gait parameters (reduced space), with
exact gradients: the inner cycle of the gait optimisers in six degrees of freedom when a per-side
offset is set or free.

A gait with per-side offsets (:mod:`birdocp.bird.sides`) flies a steady turn, periodic up to its
heading: the cycle solves the 8 heading-free states of the per-side model
(:attr:`birdocp.bird.sixdof.SixDofModel.ode_no_heading`), as :func:`birdocp.studies.lateral.lateral_trim`
does. For every theta (free keys: symmetric gait keys and per-side offsets
``gait.right_offset.*`` / ``gait.left_offset.*``) Newton solves the state x0 (8) and the flapping
amplitude A from ``Phi(x0; theta, A) = x0`` and ``mean W = climb rate``, and every output's gradient
is exact by the implicit function theorem, as the planar :class:`~birdocp.studies.gait_cycle.ReducedLevelCycle`
(whose Newton, warm starts and speed solve this class inherits). The derivatives come from forward AD
through the RK4 period map (first order along the 8 states, the free keys and A in one pass; the
monodromy's derivative along each free key with x0 and A following, forward over forward), with the
per-time data's forward derivative along each parameter.

Period means (``out_names``): ``vertical_speed_mps`` (W, held), ``forward_speed_mps`` (U, the horizontal
speed along the heading), ``turn_rate_degps`` (the heading rate ``(q sin phi + r cos phi) / cos theta``:
its period mean times the period is the heading change per beat, positive to the right), and with
``valid`` the six-degree-of-freedom smooth validity integrands
(:func:`birdocp.bird.validity_smooth.sixdof_integrands`); with ``power`` first the shoulder powers of
both wings and of each (:data:`birdocp.bird.sixdof_power.CYCLE_POWER_OUTPUTS`: the power objectives of
``optimize-gait`` for a turn).

Stability: the 8 x 8 monodromy couples the longitudinal and lateral states, so its eigenvalues are split
into two groups of four closed under conjugation, the split whose groups lie farthest apart in the
complex plane (:func:`turn_blocks`), and each group's invariant block (4 x 4, exact first derivatives
while the groups stay apart, :func:`birdocp.studies.jury.invariant_block`) carries its own Jury
conditions. A split by the lateral share of the eigenvectors failed here: at the straight optimum the
spiral (1.0304) and the phugoid pair (1.0302 +- 0.0015i) lie 1.5e-3 apart in different blocks, a turn
couples them, and the optimiser met ill-conditioned blocks and groups that switched between iterates.

A turn is optimised by continuation in the turn rate (:func:`turn_stages`): the straight optimum, then
the heading change per beat held at a few fractions of its target, each solve from the last optimum.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, ConfigError, param_vector, with_values
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.bird.sides import SIDE_PARAM_NAMES, side_vector
from birdocp.bird.sixdof import HEADING, LATERAL, STATE_NAMES, LateralInertia, sixdof_model
from birdocp.engine.cache import owned_cache
from birdocp.engine.floquet import sort_multipliers
from birdocp.studies.gait_cycle import ReducedLevelCycle
from birdocp.studies.gait_types import Evaluation
from birdocp.studies.jury import invariant_block

__all__ = ["TurnLevelCycle", "TURN_OUTPUTS", "turn_blocks", "is_turn", "turn_split", "turn_stages"]

TURN_OUTPUTS = ("vertical_speed_mps", "forward_speed_mps", "turn_rate_degps")
"""Period means of a :class:`TurnLevelCycle` (then the smooth validity integrands with ``valid``)."""


def is_turn(cfg: Config, keys=(), turn_deg_per_beat: float | None = None) -> bool:
    """Whether the gait optimisers solve ``cfg`` over the free ``keys`` as a turn (:class:`TurnLevelCycle`):
    six degrees of freedom and a per-side offset set, a per-side key free, or a turn rate held.

    Parameters
    ----------
    cfg : Config
        Configuration.
    keys : sequence of str
        Free keys.
    turn_deg_per_beat : float, optional
        Heading change per wingbeat held [deg].

    Returns
    -------
    bool
    """
    if cfg.model.degrees_of_freedom != 6:
        return False
    return (turn_deg_per_beat is not None or any(k in SIDE_PARAM_NAMES for k in keys)
            or any(float(v) != 0.0 for v in side_vector(cfg)))


def turn_stages(grids, free: dict, turn_deg_per_beat: float | None, turn_steps: int = 0) -> list:
    """The solves of the stability optimiser, ``(RK4 steps, heading change per beat held or None, free
    keys)`` each: one per grid (coarse first); with a turn and ``turn_steps`` > 0, a continuation in
    the turn rate on the first grid: the straight optimum (``free`` without the per-side keys), then the
    turn rate at k / ``turn_steps`` of its target, k = 1 .. ``turn_steps``, then the other grids.

    Parameters
    ----------
    grids : sequence of int
        RK4 steps per period of each stage (coarse first).
    free : dict
        Free keys and bounds.
    turn_deg_per_beat : float or None
        Heading change per wingbeat held at the end [deg].
    turn_steps : int
        Turn-rate steps of the continuation (0: none).

    Returns
    -------
    list of tuple
    """
    stages = [(int(n), turn_deg_per_beat, dict(free)) for n in grids]
    if turn_deg_per_beat is None or int(turn_steps) <= 0:
        return stages
    straight = {k: b for k, b in free.items() if k not in SIDE_PARAM_NAMES}
    n = int(turn_steps)
    return [(stages[0][0], None, straight)] + [(stages[0][0], turn_deg_per_beat * k / n, dict(free))
                                               for k in range(1, n + 1)] + stages[1:]


class _TurnView:
    """The per-side model seen through its heading-free ODE: the owner of the turn cycle's graphs."""

    def __init__(self, six):
        self.six, self.ode, self.data = six, six.ode_no_heading, six.data


def _graphs(six, cfg: Config, N: int, valid: bool, power: bool = False) -> dict:
    """The CasADi Functions of a :class:`TurnLevelCycle` (built once per grid and validity thresholds,
    kept by the model): the RK4 grid with the outputs, ``base(x0, D, p) -> (x_T, q)``,
    ``mono(x0, D, p) -> Mon`` (8 x 8), their forward derivatives, the data's forward derivative."""
    view = owned_cache(six).build("turn_view", lambda: _TurnView(six))
    v = cfg.validity
    thr = (v.stall_angle_deg, v.min_forward_speed_mps, v.max_abs_pitch_deg, v.max_airflow_body_angle_deg) \
        if valid else None
    return owned_cache(view, "turn_graphs", 4).build((int(N), thr, bool(power)),
                                                     lambda: _build(six, cfg, int(N), valid, bool(power)))


def _build(six, cfg: Config, N: int, valid: bool, power: bool = False) -> dict:
    from birdocp.bird.sixdof_power import power_ode
    from birdocp.engine.integrate import RK4Grid

    ode = power_ode(six) if power else six.ode_no_heading  # with wing masses, each wing's sums in the data
    x, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", ode.nd), ca.SX.sym("p", ode.np)
    fo = six.flight_outputs(HEADING)
    q, r, phi, th = x[4], x[5], x[6], x[7]
    psidot = (q * ca.sin(phi) + r * ca.cos(phi)) / ca.cos(th) * (180.0 / np.pi)
    d0 = d[:six.ode_no_heading.nd]  # the model's data (then, with power and wing masses, the per-wing sums)
    out, names = ca.vertcat(fo["vertical_speed_mps"](x, d0, p), fo["forward_speed_mps"](x, d0, p), psidot), TURN_OUTPUTS
    if power:  # the shoulder powers of the two wings (bird.sixdof_power), on the same RK4 stages
        from birdocp.bird.sixdof_power import CYCLE_POWER_OUTPUTS, cycle_power_outputs
        from birdocp.studies.gait_graphs import POSITIVE_EPS_W

        out, names = ca.vertcat(out, cycle_power_outputs(six, x, d, p, POSITIVE_EPS_W)), names + CYCLE_POWER_OUTPUTS
    if valid:
        from birdocp.bird.validity_smooth import integrand_names, sixdof_integrands

        out = ca.vertcat(out, sixdof_integrands(cfg, ode.nx, d0.shape[0], six.section)(x, d0, p[:len(PARAM_NAMES)]))
        names = names + integrand_names()
    grid = RK4Grid(ode, N, 1, outputs=(ca.Function("turn_outputs", [x, d, p], [out]),))
    x0, D, pm = ca.MX.sym("x0", ode.nx), ca.MX.sym("D", ode.nd, 3 * N), ca.MX.sym("p", ode.np)
    xT, _, qT = grid.period_map(x0, D, pm)
    base = ca.Function("turn_base", [x0, D, pm], [xT, qT])
    mono = ca.Function("turn_mono", [x0, D, pm], [ca.jacobian(xT, x0)])
    return {"grid": grid, "names": names, "base": base, "mono": mono, "fwd": {}, "mono_fwd": {}, "post_dir": {},
            "times": ca.DM(grid.times(0.0)).reshape((1, -1))}


def _forward(g: dict, name: str, k: int):
    """``g[name]``'s forward derivative Function along k directions (built once per k)."""
    cache = g["fwd" if name == "base" else "mono_fwd"]
    if k not in cache:
        cache[k] = g[name].forward(k)
    return cache[k]


class TurnLevelCycle(ReducedLevelCycle):
    """The level turn of a six-degree-of-freedom gait with per-side offsets over the free ``keys``
    (module docstring); the other arguments are :class:`~birdocp.studies.gait_cycle.ReducedLevelCycle`'s.
    ``y = (x0 (8 heading-free states), A)``; the monodromy is the 8 x 8 heading-free one. ``power``: the
    period means also hold the shoulder powers (:data:`birdocp.bird.sixdof_power.CYCLE_POWER_OUTPUTS`)."""

    n_blocks = 2

    def __init__(self, cfg: Config, keys, steps_per_period: int | None = None, climb_rate_mps: float = 0.0,
                 second_order: bool = False, amplitude_start_deg: float | None = None, valid: bool = False,
                 amplitude_range_deg: tuple[float, float] = (0.0, 90.0), power: bool = False):
        import threading

        self.cfg = cfg
        self.six = six = sixdof_model(cfg, sides=True)
        self.keys = list(keys)
        names = list(six.ode.param_names)
        for k in self.keys:
            if names.index(k) in six.ode.pre_params:
                raise ConfigError(k, "changes a wing's shape in the arm frame (elbow, wrist): free shoulder "
                                     "joints' offsets (symmetric or per side), wing.root_ahead_m or body keys")
        self.N = N = int(steps_per_period or cfg.solve.steps_per_period)
        self.climb = float(climb_rate_mps)
        self.idx = [names.index(k) for k in self.keys]
        self.ia = names.index(AMPLITUDE_KEY)
        self.nt = len(self.idx)
        self.p0 = np.asarray(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg)), float)
        self.T = six.period_s
        self.valid, self.second = bool(valid), bool(second_order)
        self.nx = six.ode_no_heading.nx
        self.g = _graphs(six, cfg, N, self.valid, power)
        self.out_names, self.grid = self.g["names"], self.g["grid"]
        x0 = [float(v) for v in cfg.solve.initial_guess]
        self._y = np.array([x0[0], 0.0, x0[1], 0.0, x0[2], 0.0, 0.0, x0[3]]
                           + [0.0] * (self.nx - HEADING)
                           + [float(amplitude_start_deg if amplitude_start_deg is not None else self.p0[self.ia])])
        self._theta = self._dy = self._Ry = self._anchor = None
        self._started = False
        self._cache: dict = {}
        self.amplitude_range_deg = tuple(map(float, amplitude_range_deg))
        self.n_full = self.n_resid = 0
        self._count_lock = threading.Lock()

    # -- pieces ----------------------------------------------------------------------------------
    def _D(self, p):
        return self.grid.blocks_numeric(0.0, p)

    def _dD(self, p, cols) -> np.ndarray:
        """Stage blocks of the data's derivative along each parameter direction (columns of ``cols``,
        np x k; none of them in the wing's arm-frame shape, so ``post`` alone moves):
        nd x 3N x k."""
        g, k = self.g, cols.shape[1]
        if k not in g["post_dir"]:
            ode = self.grid.ode
            L, t = ca.MX.sym("L", ode.pre.size1_out(0)), ca.MX.sym("t")
            pm, dp = ca.MX.sym("p", ode.np), ca.MX.sym("dp", ode.np, k)
            f = ca.Function("post_dir", [L, t, pm, dp], [ca.jtimes(ode.post(L, t, pm), pm, dp)])
            g["post_dir"][k] = f.map(2 * self.N + 1)
        out = np.asarray(g["post_dir"][k](self.grid.pre_numeric(0.0, ca.DM(p)), g["times"], ca.DM(p), ca.DM(cols)))
        return np.stack([out[:, c::k][:, self.grid.block_index] for c in range(k)], axis=2)

    def residual(self, y, theta):
        """(R, means): the turn's residual (x_T - x0 over the 8 states, mean W - climb) and the period means.

        Parameters
        ----------
        y : ndarray
            The unknowns (x0 (8 states), A [deg]).
        theta : array_like
            The free parameters (n_theta,), in the units of their keys.

        Returns
        -------
        R : ndarray
            (nx + 1,).
        means : ndarray
            Period mean of each output (``out_names``).
        """
        p = self.pfull(theta, y[self.nx])
        xT, q = self.g["base"](ca.DM(y[:self.nx]), self._D(p), ca.DM(p))
        with self._count_lock:
            self.n_resid += 1
        means = np.asarray(q).ravel() / self.T
        return np.concatenate([np.asarray(xT).ravel() - y[:self.nx], [means[0] - self.climb]]), means

    def _full(self, y, theta, with_theta: bool = False):
        """First-order derivatives at (y, theta) along the 8 states and A (and, ``with_theta``, the free
        keys), in one forward pass: the layout of :meth:`ReducedLevelCycle._full` (Rt None without
        ``with_theta``: a Newton step needs R_y only); the last item is (D, the parameter directions
        (np x (nt + 1): the free keys, then A), their data directions (nd x 3N x (nt + 1)), p)."""
        with self._count_lock:
            self.n_full += 1
        nx, nt = self.nx, self.nt
        p = self.pfull(theta, y[nx])
        D = self._D(p)
        cols = np.zeros((len(p), nt + 1))
        for c, j in enumerate(self.idx + [self.ia]):
            cols[j, c] = 1.0
        if not with_theta:
            cols = cols[:, nt:]
        dDp = self._dD(p, cols)
        k = nx + cols.shape[1]
        dX = np.hstack([np.eye(nx), np.zeros((nx, cols.shape[1]))])
        dP = np.hstack([np.zeros((len(p), nx)), cols])
        dD = np.hstack([np.zeros((D.shape[0], D.shape[1] * nx))] + [dDp[:, :, c] for c in range(cols.shape[1])])
        x0 = ca.DM(y[:nx])
        xT, q = self.g["base"](x0, D, ca.DM(p))
        dxT, dq = _forward(self.g, "base", k)(x0, D, ca.DM(p), xT, q, ca.DM(dX), ca.DM(dD), ca.DM(dP))
        J, Jq = np.asarray(dxT), np.asarray(dq) / self.T
        xT, q = np.asarray(xT).ravel(), np.asarray(q).ravel()
        cy, ct = list(range(nx)) + [k - 1], list(range(nx, k - 1))
        R = np.concatenate([xT - y[:nx], [q[0] / self.T - self.climb]])
        Ry = np.vstack([J[:, cy] - np.eye(nx + 1)[:nx], Jq[0, cy]])
        Rt = np.vstack([J[:, ct], Jq[0, ct]]) if with_theta else None
        return {"J": J, "Jq": Jq}, R, Ry, Rt, Jq, cy, ct, (D, cols, dDp, p)

    def _gradients(self, ev: Evaluation) -> None:
        """Fill ``ev``'s exact gradients, 8 x 8 monodromy (and, second order, its derivatives), ``dy``, ``Ry``."""
        s, R, Ry, Rt, Jq, cy, ct, (D, cols, dDp, p) = self._full(ev.y, ev.theta, with_theta=True)
        try:
            dy = -np.linalg.solve(Ry, Rt)
        except np.linalg.LinAlgError:
            raise RuntimeError("singular turn Jacobian (a fold of cycles)") from None
        nx, nt = self.nx, self.nt
        ev.grads = {n: Jq[i, ct] + Jq[i, cy] @ dy for i, n in enumerate(self.out_names)}
        ev.grads["amplitude_deg"] = dy[nx]
        ev.monodromy = np.asarray(s["J"][:, :nx])
        if self.second:  # along theta_c with x0 and A following: dp = e_c + dA_c e_A
            dP = cols[:, :nt] + np.outer(cols[:, nt], dy[nx])
            dD = np.hstack([dDp[:, :, c] + dy[nx, c] * dDp[:, :, nt] for c in range(nt)])
            x0 = ca.DM(ev.x0)
            M = self.g["mono"](x0, D, ca.DM(p))
            dM = np.asarray(_forward(self.g, "mono", nt)(x0, D, ca.DM(p), M, ca.DM(dy[:nx]), ca.DM(dD), ca.DM(dP)))
            ev.d_monodromy = np.column_stack([dM[:, c * nx:(c + 1) * nx].ravel(order="F") for c in range(nt)])
        ev.dy, ev.Ry = dy, Ry

    def fill_monodromy(self, ev: Evaluation) -> None:
        """Set ``ev.monodromy`` (8 x 8) if it has none.

        Parameters
        ----------
        ev : Evaluation
            A cycle, filled in place.

        Returns
        -------
        None
        """
        if ev.monodromy is None:
            p = self.pfull(ev.theta, ev.amplitude_deg)
            ev.monodromy = np.asarray(self.g["mono"](ca.DM(ev.x0), self._D(p), ca.DM(p)))

    def set_guess(self, x0) -> None:
        """Start the first Newton solve from the state ``x0`` (8 heading-free states, or a planar
        (u, w, q, theta) embedded with zero lateral states).

        Parameters
        ----------
        x0 : array_like
            State at t = 0.

        Returns
        -------
        None
        """
        x = np.asarray(x0, float).ravel()
        if x.size == 4:
            x = np.array([x[0], 0.0, x[1], 0.0, x[2], 0.0, 0.0, x[3]])
        self._y[:x.size] = x
        self._started = True

    def _first_guess(self, theta):
        """x0 from a 6-DOF trim (multiple shooting) of the gait theta at the configured amplitude."""
        from birdocp.studies.lateral import lateral_trim

        y = self._y.copy()
        tr = lateral_trim(with_values(self.cfg, dict(zip(self.keys, map(float, theta)))), steps_per_period=self.N)
        if tr.success:
            y[:self.nx] = np.asarray(tr.cycle.x0, float)[:self.nx]
        return y

    def stability_blocks(self, ev: Evaluation) -> list:
        """The two 4 x 4 invariant blocks of the 8 x 8 monodromy (:func:`turn_blocks`) and their
        derivatives (16 x n_theta, None without the second order).

        Parameters
        ----------
        ev : Evaluation
            A cycle.

        Returns
        -------
        list of (ndarray, ndarray or None)
        """
        return turn_blocks(ev.monodromy, ev.d_monodromy, self.T, ev.means["forward_speed_mps"])

    def multiplier_split(self, ev: Evaluation) -> dict:
        """:func:`turn_split` of ``ev``.

        Parameters
        ----------
        ev : Evaluation
            A cycle.

        Returns
        -------
        dict
        """
        self.fill_monodromy(ev)
        return turn_split(ev.monodromy, self.T, ev.means)

    def exact_validity(self, cfg_best: Config, x0) -> dict:
        """The exact six-degree-of-freedom validity of the turn through ``x0`` at the gait ``cfg_best``
        (both wings, sideslip; :func:`birdocp.bird.validity.periodic_validity` on the heading-free ODE).

        Parameters
        ----------
        cfg_best : Config
            Configuration of the gait (free values and amplitude in it).
        x0 : array_like
            The 8 heading-free states at t = 0.

        Returns
        -------
        dict
        """
        from birdocp.bird.validity import periodic_validity

        p6 = self.six.params(param_vector(cfg_best), LateralInertia.of(cfg_best), side_vector(cfg_best))
        return periodic_validity(cfg_best, np.asarray(x0, float), p=p6, steps_per_period=self.N,
                                 ode=self.six.ode_no_heading).to_dict()


def _units(lam) -> list:
    """The eigenvalue indices of ``lam`` as units closed under conjugation: a real eigenvalue alone, a
    complex one with its conjugate."""
    units, seen = [], set()
    for k in range(len(lam)):
        if k in seen:
            continue
        unit = [k]
        if abs(lam[k].imag) > 1e-12 * max(1.0, abs(lam[k])):  # its conjugate
            j = min((j for j in range(len(lam)) if j != k and j not in seen), key=lambda j: abs(lam[j] - np.conj(lam[k])))
            unit.append(int(j))
        seen.update(unit)
        units.append(unit)
    return units


def _groups(M, period_s: float, speed_mps: float):
    """``(lam, Vc, first, second)``: the eigen-decomposition of the 8 x 8 ``M`` and its two groups of four
    eigenvalue indices (closed under conjugation) farthest apart: of all such splits, the one with the
    largest distance between an eigenvalue of one group and one of the other, ``first`` the group with
    the smaller lateral share (of the scaled eigenvectors in (v, p, r, phi), summed; also the tie-break)."""
    from itertools import combinations

    from birdocp.studies.lateral import eigenvector_scales

    lam, Vc = np.linalg.eig(np.asarray(M, float))
    names = STATE_NAMES[:HEADING]
    Vs = Vc * eigenvector_scales(names, period_s, speed_mps)[:, None]
    lat = [i for i in range(len(names)) if i in LATERAL]
    share = np.sum(np.abs(Vs[lat]) ** 2, axis=0) / np.sum(np.abs(Vs) ** 2, axis=0)
    units = _units(lam)
    best = None
    for pick in (c for n in range(1, len(units)) for c in combinations(range(len(units)), n)):
        first = [k for u in pick for k in units[u]]
        if len(first) != len(lam) // 2:
            continue
        second = [k for k in range(len(lam)) if k not in first]
        gap = float(np.min(np.abs(lam[first][:, None] - lam[second][None, :])))
        key = (round(gap, 12), -float(np.sum(share[first])))
        if best is None or key > best[0]:
            best = (key, first, second)
    return lam, Vc, best[1], best[2]


def turn_blocks(M, d_monodromy, period_s: float, speed_mps: float) -> list:
    """The 8 x 8 heading-free monodromy of a turn as two 4 x 4 invariant blocks (module docstring) and
    their derivatives: ``[(B, dB), (B2, dB2)]``, ``dB`` the column-major vec of ``P dM V`` per column of
    ``d_monodromy`` (64 x n_theta; None gives None).

    Parameters
    ----------
    M : array_like
        Monodromy (8 x 8).
    d_monodromy : array_like or None
        Its derivatives (column-major vec, 64 x n_theta).
    period_s : float
        Period [s].
    speed_mps : float
        Mean forward speed [m/s] (scales the eigenvectors).

    Returns
    -------
    list of (ndarray, ndarray or None)
    """
    M = np.asarray(M, float)
    if not np.all(np.isfinite(M)):
        nan = np.full((4, 4), np.nan)
        return [(nan, None), (nan, None)]
    lam, Vc, first, second = _groups(M, period_s, speed_mps)
    out = []
    for sel in (first, second):
        B, P, V = invariant_block(M, lam, Vc, sel)
        dB = None
        if d_monodromy is not None:
            dM = np.asarray(d_monodromy, float)
            n = M.shape[0]
            dB = np.column_stack([(P @ dM[:, c].reshape(n, n, order="F") @ V).ravel(order="F")
                                  for c in range(dM.shape[1])])
        out.append((B, dB))
    return out


def _pairs(lam) -> list:
    return [[float(complex(z).real), float(complex(z).imag)] for z in np.asarray(lam, complex)]


def turn_split(monodromy, period_s: float, means: dict) -> dict:
    """The JSON of a turn's multipliers: ``degrees_of_freedom`` (6), ``symmetric`` (False),
    ``longitudinal_multipliers`` and ``lateral_multipliers`` (by eigenvector content,
    :func:`birdocp.studies.lateral.coupled_modes`; [re, im] pairs, largest modulus first), their radii,
    ``lateral_stable``, ``lateral_modes`` (label, multiplier, lateral share, wingbeats to double), and the
    turn: ``turn_rate_degps`` (period mean of the heading rate [deg/s]) and ``heading_change_deg`` (per
    wingbeat [deg], positive to the right).

    Parameters
    ----------
    monodromy : array_like
        The 8 x 8 heading-free monodromy.
    period_s : float
        Period [s].
    means : dict
        The cycle's period means (``forward_speed_mps``, ``turn_rate_degps``).

    Returns
    -------
    dict
    """
    from birdocp.studies.lateral import coupled_modes

    modes = coupled_modes(np.asarray(monodromy, float), period_s, float(means["forward_speed_mps"]))
    lon = sort_multipliers([m["multiplier"] for m in modes if m["label"] == "longitudinal"])
    lat = sort_multipliers([m["multiplier"] for m in modes if m["label"] != "longitudinal"])
    radius = lambda z: float(np.max(np.abs(z))) if len(z) else float("nan")  # noqa: E731
    rate = float(means["turn_rate_degps"])
    return {"degrees_of_freedom": 6, "symmetric": False, "longitudinal_multipliers": _pairs(lon),
            "lateral_multipliers": _pairs(lat), "longitudinal_radius": radius(lon), "lateral_radius": radius(lat),
            "lateral_stable": bool(np.all(np.abs(lat) < 1.0)),
            "lateral_modes": [{"label": m["label"], "multiplier": _pairs([m["multiplier"]])[0],
                               "lateral_share": m["lateral_share"], "beats_to_double": m["beats_to_double"]}
                              for m in modes if m["label"] != "longitudinal"],
            "turn_rate_degps": rate, "heading_change_deg": rate * period_s}


def check_turn(cfg: Config, objective: str, turn_deg_per_beat: float | None, turn: bool) -> None:
    """ConfigError (naming the option) before any computation when a turn cannot be optimised as asked:
    a turn rate without six degrees of freedom, a non-finite one, or a power objective for a turn whose
    per-wing power is not written (:func:`birdocp.bird.sixdof_power.check_power_model`: Wagner's section).

    Parameters
    ----------
    cfg : Config
        Configuration.
    objective : str
        The optimiser's objective.
    turn_deg_per_beat : float or None
        Heading change per wingbeat held [deg].
    turn : bool
        The cycle is a turn (:func:`is_turn`).
    """
    if turn_deg_per_beat is not None:
        if cfg.model.degrees_of_freedom != 6:
            raise ConfigError("--turn-rate", "a turn needs six degrees of freedom: add --set model.degrees_of_freedom=6")
        if not np.isfinite(turn_deg_per_beat):
            raise ConfigError("--turn-rate", f"must be a finite heading change per wingbeat in deg, got {turn_deg_per_beat}")
    if turn and objective != "stability":
        from birdocp.bird.sixdof_power import check_power_model

        check_power_model(cfg, f"--objective {objective} of a turn")


def turn_check(opt, cfg: Config, steps: int) -> dict:
    """An independent six-degree-of-freedom trim at the optimal turning gait: 5-point multiple shooting
    of the 8 heading-free states (:func:`birdocp.studies.lateral.lateral_trim`) from the configured
    initial guess (from scratch; if it fails, from the start gait's cycle), at the optimum's gait and
    amplitude; its multipliers, heading change and state against the optimiser's.

    Parameters
    ----------
    opt : GaitOptimum
        The optimum (``free``, ``amplitude_deg``, ``x0``, ``multipliers``, ``means``, ``start_x0``).
    cfg : Config
        The configuration optimised.
    steps : int
        RK4 steps per period of the optimiser.

    Returns
    -------
    dict
        ``cfg`` (the optimal gait's configuration), ``trim_success``, ``trim_from`` ("scratch" or
        "start cycle"), ``trim_multipliers`` (the 8), ``max_multiplier_difference``,
        ``trim_heading_change_deg``, ``heading_change_difference_deg``, ``trim_x0_difference``,
        ``trim_mean_vertical_speed_mps``, ``trim_lateral_modes``.
    """
    from birdocp.engine.floquet import matched_distances
    from birdocp.studies.lateral import lateral_trim

    cfg_best = with_values(cfg, dict(opt.free) | {AMPLITUDE_KEY: float(opt.amplitude_deg)})
    out = {"cfg": cfg_best, "trim_success": False}
    tr = lateral_trim(cfg_best, points=5, steps_per_period=steps)
    out["trim_from"] = "scratch"
    if not tr.success and opt.start_x0 is not None:
        x = list(np.asarray(opt.start_x0, float)[:HEADING])
        tr = lateral_trim(cfg_best, x_guess=x + [0.0], points=5, steps_per_period=steps)
        out["trim_from"] = "start cycle"
    if not tr.success:
        return out
    lam = sort_multipliers(tr.cycle.multipliers)
    out.update({
        "trim_success": True, "trim_multipliers": _pairs(lam),
        "max_multiplier_difference": float(np.max(matched_distances(lam, np.asarray(opt.multipliers, complex)))),
        "trim_heading_change_deg": float(tr.heading_change_deg),
        "heading_change_difference_deg": float(tr.heading_change_deg - opt.means["turn_rate_degps"] * tr.cycle.period),
        "trim_x0_difference": float(np.max(np.abs(np.asarray(tr.cycle.x0, float)[:HEADING] - np.asarray(opt.x0)[:HEADING]))),
        "trim_mean_vertical_speed_mps": float(tr.mean_vertical_speed_mps),
        "trim_lateral_modes": [{"label": m["label"], "multiplier": _pairs([m["multiplier"]])[0],
                                "beats_to_double": float(m["beats_to_double"])} for m in tr.lateral_modes]})
    return out
