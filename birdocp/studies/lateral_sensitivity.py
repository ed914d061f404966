"""Exact sensitivities of the multipliers of a 6-DOF cycle (:func:`lateral_sensitivities`): the
derivatives of every multiplier of a converged cycle of :func:`birdocp.studies.lateral.lateral_trim` with
respect to model and gait parameters, the change of the cycle included."""
from __future__ import annotations

import numpy as np

from birdocp.bird.config import Config
from birdocp.bird.sides import SIDE_PARAM_NAMES
from birdocp.bird.sixdof import HEADING, sixdof_model
from birdocp.engine.cache import owned_cache
from birdocp.studies.lateral import LateralTrimResult

__all__ = ["LATERAL_SENSITIVITY_KEYS", "TAIL_SENSITIVITY_KEY", "lateral_sensitivities"]

LATERAL_SENSITIVITY_KEYS = ("gait.shoulder_flap.offset_deg", "gait.shoulder_sweep.offset_deg",
                            "gait.elbow_flex.offset_deg", "gait.wrist_flex.offset_deg",
                            "gait.shoulder_incidence.offset_deg", "model.roll_inertia_kgm2",
                            "model.yaw_inertia_kgm2")
"""Default parameters of :func:`lateral_sensitivities`: the shoulder elevation (dihedral: the flap
joint's offset), sweep, elbow and wrist offsets, the wing incidence and the lateral inertias (and, for a
configuration with the tail, :data:`TAIL_SENSITIVITY_KEY`)."""

TAIL_SENSITIVITY_KEY = "tail.opening_angle_deg"
"""Added to the default parameters of :func:`lateral_sensitivities` when the configuration has the tail
(at opening 0 the tail's span and every derivative of its loads vanish, so the key says nothing there)."""


def lateral_sensitivities(res: LateralTrimResult, cfg: Config | None = None, parameters=None):
    """Exact derivatives of every multiplier of a converged 6-DOF cycle (fixed amplitude) with respect
    to ``parameters`` (keys of :data:`birdocp.bird.config.PARAM_NAMES` or
    :data:`birdocp.bird.sixdof.LATERAL_PARAM_NAMES`), the change of the cycle included (second-order
    AD through the RK4 period map, :func:`birdocp.studies.sensitivity.cycle_derivatives`; the heading
    is left out of the periodicity condition, its multiplier 1 being structural). An asymmetric gait's
    cycle (a turn) is differentiated in the heading-free 8 states it was solved in. The per-side offsets
    (``gait.right_offset.*``, ``gait.left_offset.*``, :data:`birdocp.bird.sides.SIDE_PARAM_NAMES`) are
    parameters of every 6-DOF cycle: a symmetric cycle is differentiated with the model with per-side
    joint laws at zero offsets (the same right-hand side bit for bit), where mirror symmetry makes a
    right offset's derivative equal the left one's.

    Parameters
    ----------
    res : LateralTrimResult
        A converged fixed-amplitude 6-DOF cycle (:func:`lateral_trim` without ``level``).
    cfg : Config, optional
        Its configuration (default: the reference case).
    parameters : sequence of str, optional
        Parameter keys (default :data:`LATERAL_SENSITIVITY_KEYS`, with :data:`TAIL_SENSITIVITY_KEY`
        when ``cfg`` has the tail); per-side offsets allowed.

    Returns
    -------
    list of dict
        One row per parameter: ``parameter``, ``d_moduli`` (per multiplier, in the order of
        ``res.multipliers``' labels: ``labels``), ``d_multipliers`` ([re, im] pairs), per unit of the
        parameter (deg, kg m^2).
    """
    from birdocp.studies.sensitivity import SecondOrderMaps, cycle_derivatives

    cfg = cfg or Config()
    c = res.cycle
    if not c.success:
        raise ValueError("the 6-DOF trim did not converge: sensitivities need a converged cycle")
    if c.free_values:
        raise ValueError("lateral_sensitivities needs a fixed-amplitude cycle (solve level flight, then trim at "
                         "its amplitude)")
    six = sixdof_model(cfg)
    if parameters is None:
        parameters = LATERAL_SENSITIVITY_KEYS + ((TAIL_SENSITIVITY_KEY,) if six.structure.tail else ())
    p = np.asarray(c.p, float)
    if not six.sides and set(parameters) & set(SIDE_PARAM_NAMES):
        # per-side keys of a symmetric cycle: the model with per-side joint laws at zero offsets (its data
        # is the symmetric model's bit for bit), the parameter vector with the 42 zeros appended
        six = sixdof_model(cfg, sides=True)
        p = np.concatenate([p, np.zeros(len(SIDE_PARAM_NAMES))])
    names = list(six.ode.param_names)
    for k in parameters:
        if k not in names:
            raise ValueError(f"unknown parameter {k!r}")
    steps = int(c.method["steps_per_period"])
    if not res.symmetric:  # an asymmetric gait: the heading-free 8 states the cycle was solved in
        so = SecondOrderMaps.get(_heading_free(six), steps, six.flight_outputs(HEADING)["vertical_speed_mps"])
        states = list(range(HEADING))
    else:
        so = SecondOrderMaps.get(six, steps, six.flight_outputs()["vertical_speed_mps"])
        states = [i for i in range(9) if i != HEADING]
    lam, dL, dmod, _, _ = cycle_derivatives(so, six.period_s, c.x0, p, [names.index(k) for k in parameters], states)
    labels = _labels(lam, res)
    return [{"parameter": k, "labels": labels, "multipliers": lam, "d_moduli": dmod[i], "d_multipliers": dL[i]}
            for i, k in enumerate(parameters)]


class _HeadingFree:
    """A per-side 6-DOF model seen through its heading-free ODE (the model interface of
    :class:`birdocp.studies.sensitivity.SecondOrderMaps`: ``model``, ``ode``, ``data``)."""

    def __init__(self, six):
        self.ode, self.data = six.ode_no_heading, six.data

    @property
    def model(self) -> "_HeadingFree":
        """The identity the maps are cached by."""
        return self


def _heading_free(six) -> _HeadingFree:
    """The heading-free view of ``six`` (one per model, kept by it: the maps are cached by it)."""
    return owned_cache(six).build("heading_free", lambda: _HeadingFree(six))


def _labels(lam, res: LateralTrimResult) -> list[str]:
    """A label per multiplier: the lateral modes' labels, 'heading', or 'longitudinal'."""
    out = []
    for z in lam:
        lab = "longitudinal"
        if res.symmetric and abs(z - res.heading_multiplier) < 1e-9 and abs(z.imag) < 1e-12:
            lab = "heading"
        for m in res.lateral_modes:
            if abs(z - m["multiplier"]) < 1e-9 * max(1.0, abs(z)):
                lab = m["label"]
        out.append(lab)
    return out
