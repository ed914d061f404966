"""Wing-mass studies: cycle quantities of a model with wing masses and the "hold mean centre of mass"
placement of the wing root (docs/studies/inertia.md, frames).

With heavy wings the whole bird's centre of mass C moves over the cycle; its cycle mean sits
``S̄/M`` from G_b (body frame x' forward, z' down). Moving mass into the wings therefore shifts the
mean C as well as adding inertial forces and moments. :func:`hold_mean_com_root` separates the two:
it places the wing root so that the shoulder stays ``root_ahead_ref`` ahead of the *mean* C (along
x'), as in the massless model. The vertical offset of the mean C is reported
(:func:`mean_com_offset_m`), not held: the model's shoulder lies on G_b's horizontal.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, with_values
from birdocp.bird.model import get_model
from birdocp.engine.cache import owned_cache
from birdocp.engine.integrate import RK4Grid

__all__ = ["wing_mass_of_fraction", "mean_com_offset_m", "hold_mean_com_root", "stability_margin_mean_com_percent",
           "cycle_summary", "config_with_wing_mass"]



def wing_mass_of_fraction(fraction: float, total_mass_kg: float) -> float:
    """Mass of ONE wing [kg] for a wing-mass fraction (both wings / whole bird, 0..1).

    Parameters
    ----------
    fraction : float
        Wing-mass fraction [-].
    total_mass_kg : float
        Mass of the whole bird [kg].

    Returns
    -------
    float
    """
    return 0.5 * float(fraction) * float(total_mass_kg)


def _mass_points_map(model, n: int):
    """``mass_points`` mapped over ``n`` times, kept by the model."""
    return owned_cache(model).build(("mass_points_map", n), lambda: model.mass_points.map(n))


def mean_com_offset_m(cfg: Config, p=None, n: int = 64) -> tuple[float, float]:
    """Cycle mean of the whole bird's centre of mass relative to G_b, (x' forward, z' down) in m:
    ``S̄/M`` by the trapezoidal rule on ``n`` uniform times of one period (spectrally accurate for the
    smooth periodic wing motion). ``p``: parameter vector (default the configuration's). (0, 0) for a
    model without wing masses.

    Parameters
    ----------
    cfg : Config
        Configuration.
    p : array_like, optional
        Parameter vector.
    n : int
        Number of sample times.

    Returns
    -------
    x_m, z_m : float
    """
    m = get_model(cfg)
    if m.model.mass_points is None:
        return 0.0, 0.0
    p = np.asarray(m.p0 if p is None else p, float)
    t = np.arange(n) * m.period_s / n
    r, _, _, mm = _mass_points_map(m.model, n)(ca.DM(t).T, ca.repmat(ca.DM(p), 1, n))
    r = np.asarray(r)
    mm = np.asarray(mm)
    k = r.shape[1] // n  # points per time
    Sx = np.mean([mm[:, j] @ r[0, j * k:(j + 1) * k] for j in range(n)])
    Sz = np.mean([mm[:, j] @ r[2, j * k:(j + 1) * k] for j in range(n)])
    M = p[PARAM_NAMES.index("body.mass_kg")]
    return float(Sx / M), float(Sz / M)


def hold_mean_com_root(cfg: Config, root_ahead_ref_m: float, p=None) -> float:
    """The wing-root position ``wing.root_ahead_m`` [m] that puts the shoulder ``root_ahead_ref_m``
    ahead of the cycle-mean centre of mass of the whole bird (docs/studies/inertia.md, frames, x' component):
    ``r' = (M r_ref + sum m_i rhō_x,i) / m_b`` with rho_i the mass points relative to the shoulder.
    The mean C depends on the gait (e.g. the level-flight amplitude): evaluate at the gait of ``p``.

    Parameters
    ----------
    cfg : Config
        Configuration.
    root_ahead_ref_m : float
        Shoulder position ahead of the mean centre of mass wanted [m].
    p : array_like, optional
        Parameter vector (default the configuration's).

    Returns
    -------
    float
    """
    p = np.asarray(get_model(cfg).p0 if p is None else p, float)
    M = p[PARAM_NAMES.index("body.mass_kg")]
    m_w = 2.0 * p[PARAM_NAMES.index("wing.mass_kg")]
    root = p[PARAM_NAMES.index("wing.root_ahead_m")]
    Sx_over_M, _ = mean_com_offset_m(cfg, p)
    rho_sum = Sx_over_M * M - m_w * root           # sum m_i rhō_x,i (mass points relative to the shoulder)
    return float((M * root_ahead_ref_m + rho_sum) / (M - m_w))


def stability_margin_mean_com_percent(root_ahead_m: float, mean_com_x_m: float, chord_m: float) -> float:
    """Stability margin measured from the cycle-mean centre of mass C instead of G_b, in percent:
    ``-(root_ahead_m - x̄_C) / chord``.

    Parameters
    ----------
    root_ahead_m : float
        Wing-root position ahead of G_b [m].
    mean_com_x_m : float
        x' of the cycle-mean centre of mass relative to G_b [m].
    chord_m : float
        Reference chord [m].

    Returns
    -------
    float
    """
    return -100.0 * (float(root_ahead_m) - float(mean_com_x_m)) / float(chord_m)


def cycle_summary(cfg: Config, x0, p, steps_per_period: int = 148) -> dict:
    """Pitch and wing-power figures of the periodic cycle through ``x0`` (state at t = 0) for the
    parameters ``p``: period-mean pitch and half peak-to-peak pitch oscillation [deg], mean and peak
    forward speed, mean centre-of-mass offset [m], the period means of the wing powers [W] and the
    exact ``validity`` of the cycle (:func:`birdocp.bird.validity.grid_validity` on the same RK4
    states; a dict, with ``valid``).

    Parameters
    ----------
    cfg : Config
        Configuration.
    x0 : array_like
        State at t = 0 on the cycle.
    p : array_like
        Parameter vector.
    steps_per_period : int
        RK4 steps of one period.

    Returns
    -------
    dict
    """
    from birdocp.bird.validity import grid_validity

    m = get_model(cfg)
    p = np.asarray(p, float)
    grid = owned_cache(m.ode).build(("plain_rk4_grid", steps_per_period), lambda: RK4Grid(m.ode, steps_per_period, 1))
    D = grid.blocks_numeric(0.0, p)
    X = np.asarray(grid.period_map(ca.DM(np.asarray(x0, float)), D, ca.DM(p))[1]).T
    X = np.vstack([np.asarray(x0, float)[None, :], X])
    t = grid.h * np.arange(X.shape[0])
    th = np.degrees(X[:-1, 3])
    wp = m.model.wing_power_history(t, X, p)
    xc, zc = mean_com_offset_m(cfg, p)
    out = {"mean_pitch_deg": float(np.mean(th)), "pitch_oscillation_amplitude_deg": float(0.5 * (th.max() - th.min())),
           "pitch_rate_amplitude_degps": float(0.5 * np.degrees(X[:-1, 2].max() - X[:-1, 2].min())),
           "mean_com_ahead_of_G_m": xc, "mean_com_below_G_m": zc,
           "closure_error": float(np.max(np.abs(X[-1] - X[0])))}
    v = grid_validity(cfg, X[:-1], p, 0.0, steps_per_period, m.ode).to_dict()
    out.update(validity=v, valid=bool(v["valid"]))
    for k, v in wp.items():
        per = v[:-1]
        out[f"mean_{k}"] = float(np.mean(per))
        out[f"mean_positive_{k}"] = float(np.mean(np.maximum(per, 0.0)))
        out[f"peak_{k}"] = float(np.max(per))
    return out


def config_with_wing_mass(cfg: Config, fraction: float) -> Config:
    """``cfg`` with the wing-mass terms in the graphs and ``wing.mass_kg`` for a wing-mass fraction
    (both wings / whole bird).

    Parameters
    ----------
    cfg : Config
        Configuration.
    fraction : float
        Wing-mass fraction (both wings / whole bird) [-].

    Returns
    -------
    Config
    """
    return with_values(cfg, {"wing.inertial_terms": True,
                             "wing.mass_kg": wing_mass_of_fraction(fraction, cfg.body.mass_kg)})

