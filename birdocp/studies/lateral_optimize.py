"""Gait optimisation in six degrees of freedom: the multipliers that count are the longitudinal and the
lateral ones (the heading's structural 1 left out).

For a symmetric gait the six-degree-of-freedom level cycle is the planar one (v = p = r = phi = 0 along
it) and its monodromy is block diagonal (:mod:`birdocp.studies.lateral`): the planar 4 x 4 monodromy,
the lateral block over (v, p, r, phi) and the heading's 1. So the reduced-space optimisers of
:mod:`birdocp.studies.gait` (``optimize-gait`` and ``optimize-stability``) keep their planar level cycle
and add the lateral block as a second 4 x 4 block whose Jury conditions are constrained as the planar
monodromy's (:meth:`birdocp.studies.gait_cycle.ReducedLevelCycle.stability_blocks`). The lateral block and
its exact derivative along each free parameter (the cycle's change x0(theta), A(theta) included, as the
planar ``dy/dtheta``) come from the second-order variational equations of the 9-state ODE along the
planar cycle: the SX variational equations of :class:`birdocp.engine.variational.PeriodSensitivities`
on the planar cycle's own data and data directions (the 6-DOF data is the planar data; with wing masses,
whose 3-D sums the planar data lacks, forward AD through the 9-state period map of
:class:`birdocp.studies.sensitivity.SecondOrderMaps`).

An asymmetric gait (per-side offsets set or free, or a turn rate held) is a turn, periodic up to its
heading, not the planar cycle: :func:`reduced_level_cycle` gives it the
:class:`~birdocp.studies.turn_cycle.TurnLevelCycle` in the 8 heading-free states (:class:`LateralLevelCycle`
itself refuses it, naming the first non-zero offset).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import Config, ConfigError, asymmetric, get_value
from birdocp.bird.sides import SIDE_PARAM_NAMES
from birdocp.bird.sixdof import LATERAL, LONGITUDINAL, LateralInertia, embed_planar_state, sixdof_model
from birdocp.engine.cache import owned_cache
from birdocp.engine.floquet import matched_distances, sort_multipliers
from birdocp.studies.gait_cycle import ReducedLevelCycle
from birdocp.studies.gait_types import Evaluation

__all__ = ["LateralLevelCycle", "reduced_level_cycle", "multiplier_split", "lateral_check"]


def _pairs(lam) -> list:
    return [[float(complex(z).real), float(complex(z).imag)] for z in np.asarray(lam, complex)]


def multiplier_split(longitudinal_monodromy, lateral_monodromy) -> dict:
    """The JSON split of a symmetric six-degree-of-freedom cycle's multipliers: ``degrees_of_freedom``
    (6), ``longitudinal_multipliers`` and ``lateral_multipliers`` ([re, im] pairs, largest modulus first;
    the heading's 1 is not among them), ``longitudinal_radius`` and ``lateral_radius`` (their largest
    moduli) and ``lateral_stable``.

    Parameters
    ----------
    longitudinal_monodromy, lateral_monodromy : array_like
        The two blocks of the monodromy.

    Returns
    -------
    dict
    """
    lon = sort_multipliers(np.linalg.eigvals(np.asarray(longitudinal_monodromy, float)))
    lat = sort_multipliers(np.linalg.eigvals(np.asarray(lateral_monodromy, float)))
    return {"degrees_of_freedom": 6, "longitudinal_multipliers": _pairs(lon), "lateral_multipliers": _pairs(lat),
            "longitudinal_radius": float(np.max(np.abs(lon))), "lateral_radius": float(np.max(np.abs(lat))),
            "lateral_stable": bool(np.all(np.abs(lat) < 1.0))}


class LateralLevelCycle(ReducedLevelCycle):
    """The planar :class:`~birdocp.studies.gait_cycle.ReducedLevelCycle` of a six-degree-of-freedom
    configuration, whose evaluations also carry the lateral block of the 9-state monodromy (and, with
    the second order, its derivative along the free parameters) in :attr:`Evaluation.blocks`, so that
    ``multipliers`` and the stability constraints count the lateral multipliers (module docstring)."""

    n_blocks = 2

    def __init__(self, cfg: Config, keys, **options):
        if asymmetric(cfg):
            key = next(k for k in SIDE_PARAM_NAMES if get_value(cfg, k) != 0)
            raise ConfigError(key, "LateralLevelCycle takes a symmetric gait (its level cycle is the planar one); "
                                   "a turn is a TurnLevelCycle (reduced_level_cycle chooses it)")
        super().__init__(cfg, keys, **options)
        from birdocp.studies.sensitivity import SecondOrderMaps

        self.six = six = sixdof_model(cfg)
        self.inertia = LateralInertia.of(cfg)
        self._lat = np.ix_(list(LATERAL), list(LATERAL))
        self.shared_data = not six.structure.wing_mass  # the 6-DOF data is the planar data (else 3-D mass sums added)
        if self.shared_data:
            self.sens6 = _variational(six, self.N, self.nt, len(self.vidx), self.second)
        else:
            self.so6 = so = SecondOrderMaps.get(six, self.N, six.flight_outputs()["vertical_speed_mps"])
            self._times6 = ca.DM(so.grid.times(0.0)).reshape((1, -1))

    def _lateral(self, ev: Evaluation, grads: bool):
        """(M, dM): the lateral block of the 9-state monodromy at ``ev`` and, with ``grads``, its
        derivative along each free parameter with x0 and the amplitude following (16 x n_theta): the
        SX variational equations on the planar data and its directions (without wing masses), else
        forward AD through the period map (:meth:`_lateral_wing_masses`)."""
        if not self.shared_data:
            return self._lateral_wing_masses(ev, grads)
        p = self.pfull(ev.theta, ev.amplitude_deg)
        p6 = np.asarray(self.six.params(p, self.inertia), float)
        D, cols = self._data(ca.DM(p))
        x9 = embed_planar_state(np.asarray(ev.x0, float)[:4])
        if not grads:
            return np.asarray(self.sens6["mono"](x9, D, p6)["J"])[self._lat], None
        seeds = np.vstack([self._seeds, np.zeros((len(p6) - len(p), self._seeds.shape[1]))])
        dx0 = np.zeros((9, self.nt))
        dx0[list(LONGITUDINAL)] = ev.dy[:4]
        s = self.sens6["second"](x9, D, p6, dp=seeds, columns=cols, W=np.vstack([np.eye(self.nt), ev.dy[4]]), dx0=dx0)
        dM = np.stack([s["dMon"][:, c].reshape(9, 9, order="F")[self._lat].ravel(order="F") for c in range(self.nt)],
                      axis=1)
        return np.asarray(s["Mon"])[self._lat], dM

    def _lateral_wing_masses(self, ev: Evaluation, grads: bool):
        """:meth:`_lateral` with wing masses (the 6-DOF data has the 3-D mass sums the planar data lacks):
        forward-over-forward AD through the 9-state period map, one direction per free parameter."""
        so, times = self.so6, self._times6
        p6 = np.asarray(self.six.params(self.pfull(ev.theta, ev.amplitude_deg), self.inertia), float)
        Dg = so.grid.data_grid(times, ca.DM(p6))
        D = Dg[:, so.grid.block_index]
        x9 = ca.DM(embed_planar_state(np.asarray(ev.x0, float)[:4]))
        M = np.asarray(so.base(x9, D, ca.DM(p6))[2])[self._lat]
        if not grads:
            return M, None
        dM = np.zeros((16, self.nt))
        for c in range(self.nt):  # along theta_c, with x0 and A moving: dy[:, c]
            dp = np.zeros(len(p6))
            dp[self.idx[c]] = 1.0
            dp[self.ia] += ev.dy[4, c]
            dx = np.zeros(9)
            dx[list(LONGITUDINAL)] = ev.dy[:4, c]
            dDg = so.data_fwd(times, ca.DM(p6), Dg, ca.DM.zeros(1, so.n_times), ca.DM(dp))
            v = np.asarray(so.directional(x9, D, ca.DM(p6), ca.DM(dx), dDg[:, so.grid.block_index], ca.DM(dp))).ravel()
            dM[:, c] = v[10:].reshape(9, 9, order="F")[self._lat].ravel(order="F")
        return M, dM

    def _gradients(self, ev: Evaluation) -> None:
        super()._gradients(ev)
        ev.blocks = [self._lateral(ev, self.second)]

    def fill_monodromy(self, ev: Evaluation) -> None:
        """Set ``ev.monodromy`` and, without them, its lateral blocks.

        Parameters
        ----------
        ev : Evaluation
            Evaluation, changed in place.
        """
        super().fill_monodromy(ev)
        if ev.blocks is None:
            ev.blocks = [self._lateral(ev, False)]

    def multiplier_split(self, ev: Evaluation) -> dict | None:
        """:func:`multiplier_split` of ``ev`` (None without its monodromy).

        Parameters
        ----------
        ev : Evaluation
            Evaluation.

        Returns
        -------
        dict or None
        """
        self.fill_monodromy(ev)
        return multiplier_split(ev.monodromy, ev.blocks[0][0])


def _variational(six, steps: int, n_theta: int, n_data: int, second: bool) -> dict:
    """The 9-state period sensitivities of a :class:`LateralLevelCycle` (built once per model, grid and
    number of free parameters, kept by the model): ``mono`` (the monodromy alone) and, with ``second``, ``second`` (the
    monodromy and its derivative along the combined directions, as the planar cycle's ``sens2``)."""
    from birdocp.engine.variational import PeriodSensitivities

    key = ("lateral_variational", int(steps), int(n_theta), int(n_data), bool(second))
    return owned_cache(six).build(key, lambda: {
        "six": six, "mono": PeriodSensitivities(six.ode, steps, (), 0),
        "second": PeriodSensitivities(six.ode, steps, (), n_theta, True, combined=True, n_data=n_data)
        if second else None})


def lateral_check(cfg_best: Config, x0, multipliers, steps_per_period: int) -> dict:
    """An independent six-degree-of-freedom trim (5-point multiple shooting of the 9-state ODE,
    :func:`birdocp.studies.lateral.lateral_trim`) at the optimal gait ``cfg_best`` from the optimum's
    planar state ``x0``: ``trim_multipliers`` (its eight, the heading's 1 left out),
    ``max_multiplier_difference`` against the optimiser's ``multipliers``, ``trim_heading_multiplier``,
    ``trim_coupling_max`` and ``trim_lateral_modes`` (label, multiplier, wingbeats to double).

    Parameters
    ----------
    cfg_best : Config
        Configuration at the optimal gait.
    x0 : array_like
        The optimum's planar state.
    multipliers : array_like
        The optimiser's multipliers.
    steps_per_period : int
        RK4 steps per period.

    Returns
    -------
    dict
    """
    from birdocp.studies.lateral import lateral_trim

    tr = lateral_trim(cfg_best, x_guess=embed_planar_state(np.asarray(x0, float)[:4]), points=5,
                      steps_per_period=steps_per_period)
    if not tr.success:
        return {"six_dof_trim_success": False}
    lam = sort_multipliers(np.concatenate([tr.longitudinal_multipliers, tr.lateral_multipliers]))
    return {"six_dof_trim_success": True, "trim_multipliers": _pairs(lam),
            "max_multiplier_difference": float(np.max(matched_distances(lam, np.asarray(multipliers, complex)))),
            "trim_heading_multiplier": float(tr.heading_multiplier), "trim_coupling_max": float(tr.coupling_max),
            "trim_lateral_modes": [{"label": m["label"], "multiplier": _pairs([m["multiplier"]])[0],
                                    "beats_to_double": float(m["beats_to_double"])} for m in tr.lateral_modes]}


def reduced_level_cycle(cfg: Config, keys, turn: bool = False, **options) -> ReducedLevelCycle:
    """The :class:`~birdocp.studies.gait_cycle.ReducedLevelCycle` of ``cfg`` over the free ``keys``
    (``options``: its other arguments); with ``model.degrees_of_freedom = 6`` the
    :class:`LateralLevelCycle`, whose multipliers also count the lateral ones, or, for a turn (``turn``,
    or :func:`birdocp.studies.turn_cycle.is_turn`: a per-side offset set or free), the
    :class:`~birdocp.studies.turn_cycle.TurnLevelCycle` in the 8 heading-free states.

    Parameters
    ----------
    cfg : Config
        Configuration.
    keys : sequence of str
        Free keys.
    turn : bool
        Solve the cycle as a turn (six degrees of freedom).
    **options
        Further arguments of the cycle.

    Returns
    -------
    ReducedLevelCycle
    """
    if cfg.model.degrees_of_freedom == 6:
        from birdocp.studies.turn_cycle import TurnLevelCycle, is_turn

        if turn or is_turn(cfg, keys):
            return TurnLevelCycle(cfg, keys, **options)
        return LateralLevelCycle(cfg, keys, **options)
    return ReducedLevelCycle(cfg, keys, **options)
