"""What the reduced level cycle (:class:`~birdocp.studies.gait_cycle.ReducedLevelCycle`) takes and
gives: the checks of its free keys, where its Newton solve starts (:class:`WarmStart`), the cycle and
its exact gradients at one point (:class:`Evaluation`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from birdocp.bird.config import PARAM_NAMES, SIDE_KEYS, ConfigError, get_value, suggest, with_values
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.engine.floquet import sort_multipliers

__all__ = ["check_free_bounds", "check_free_keys", "WarmStart", "Evaluation"]


def check_free_bounds(cfg, free: dict) -> None:
    """ConfigError unless every free key is a known parameter other than the amplitude (in six degrees
    of freedom also a per-side offset, :data:`birdocp.bird.sides.SIDE_PARAM_NAMES`), with finite
    bounds lower < upper that hold the configured value and lie in the key's physical range (each
    bound is a valid configuration value). Needs no model: callers check this before building one.

    Parameters
    ----------
    cfg : Config
        Configuration.
    free : dict of str to (float, float)
        Free key to (lower, upper) bound.
    """
    six = cfg.model.degrees_of_freedom == 6
    for k, (lo, hi) in free.items():
        if k in SIDE_KEYS and not six:
            raise ConfigError(k, "a per-side offset needs six degrees of freedom: add --set model.degrees_of_freedom=6")
        if k not in PARAM_NAMES and k not in SIDE_KEYS:
            raise ConfigError(k, "unknown parameter for --free" + suggest(k, PARAM_NAMES))
        if k == AMPLITUDE_KEY:
            raise ConfigError(k, "the flapping amplitude is solved for level flight; free other keys")
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ConfigError(k, f"bounds must be finite with lower < upper, got ({lo}, {hi})")
        v = float(get_value(cfg, k))
        if not lo <= v <= hi:
            raise ConfigError(k, f"configured value {v:g} lies outside its bounds ({lo:g}, {hi:g}); "
                                 f"widen --bounds {k}=LO:HI")
        for end, value in (("lower", lo), ("upper", hi)):
            try:
                with_values(cfg, {k: float(value)})
            except ConfigError as exc:
                raise ConfigError(k, f"the {end} bound {value:g} is not a valid value ({exc}); "
                                     f"narrow --bounds {k}=LO:HI") from None


def check_free_keys(m, cfg, free: dict) -> None:
    """ConfigError unless every free key can be a reduced variable (:func:`check_free_bounds`, and
    not reshaping the wing in the arm frame, which the model ``m`` tells).

    Parameters
    ----------
    m : BirdModel
        Model of ``cfg``.
    cfg : Config
        Configuration.
    free : dict of str to (float, float)
        Free key to (lower, upper) bound.
    """
    check_free_bounds(cfg, free)
    for k in free:  # (a per-side offset: checked by the turn's cycle, on the per-side model)
        if k in PARAM_NAMES and PARAM_NAMES.index(k) in m.pre_params:
            raise ConfigError(k, "changes the wing's shape in the arm frame (elbow, wrist, morphology): "
                                 "free shoulder joints, wing.root_ahead_m or body/aero/drag keys")


@dataclass(frozen=True)
class WarmStart:
    """Where a :class:`ReducedLevelCycle`'s next Newton solve starts: read it with
    :attr:`ReducedLevelCycle.warm_start`, set it with :meth:`ReducedLevelCycle.restart_from`.

    y: the level cycle's unknowns (x0, A) [state units, deg]; theta: the free parameters it was solved
    at (None: not yet solved with gradients); dy: d(x0, A)/d theta there (5 x n_theta), None for no
    first-order prediction (Newton then starts from y itself).
    """

    y: np.ndarray
    theta: np.ndarray | None = None
    dy: np.ndarray | None = None


@dataclass
class Evaluation:
    """The level cycle at one theta and its exact gradients (per unit of each free key)."""

    theta: np.ndarray
    x0: np.ndarray
    amplitude_deg: float
    means: dict            # quadrature output name -> period mean
    grads: dict            # name -> d mean / d theta; also "amplitude_deg"
    monodromy: np.ndarray
    d_monodromy: np.ndarray | None  # dM/dtheta (nx^2 x n_theta, column-major vec), or d(M V)/dtheta (4 nx x n_theta) on the dominant block's V with aerodynamic states; second order only
    residual: float
    newton_iterations: int
    dy: np.ndarray | None = None    # d(x0, A)/d theta (5 x n_theta), with the gradients
    Ry: np.ndarray | None = None    # the level-cycle residual's Jacobian in (x0, A), with the gradients
    blocks: list | None = None      # further 4 x 4 monodromy blocks that count, [(M, dM or None)] (6-DOF: lateral)

    @property
    def y(self) -> np.ndarray:
        """The level cycle's unknowns (x0, A)."""
        return np.append(self.x0, self.amplitude_deg)

    @property
    def multipliers(self) -> np.ndarray:
        """The eigenvalues of the monodromy and of every further block (:attr:`blocks`), largest first."""
        mats = [self.monodromy] + [b[0] for b in self.blocks or []]
        if any(m is None or not np.all(np.isfinite(m)) for m in mats):
            return np.full(4 * len(mats), np.nan, complex)
        return sort_multipliers(np.concatenate([np.linalg.eigvals(m) for m in mats]))
