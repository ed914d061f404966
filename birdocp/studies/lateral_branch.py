"""Continuation of six-degree-of-freedom cycles (:func:`birdocp.studies.branch.bird_branch` with
``model.degrees_of_freedom = 6``): the heading-free problem, the validity of a branch point and the
split of its multipliers.

Split from :mod:`birdocp.studies.lateral` to keep modules small.
"""

from __future__ import annotations


import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config, asymmetric, param_vector
from birdocp.bird.keys import AMPLITUDE_KEY
from birdocp.bird.sides import SIDE_PARAM_NAMES, side_vector
from birdocp.bird.sixdof import HEADING, LATERAL, LONGITUDINAL, LateralInertia, embed_planar_state, \
    sixdof_model
from birdocp.engine.floquet import sort_multipliers
from birdocp.engine.problem import MeanCondition, OrbitProblem
from birdocp.engine.method import OrbitMethod
from birdocp.studies.level import default_bounds

from birdocp.studies.lateral import coupled_modes

__all__ = ["branch_problem", "planar_point", "validity_point", "add_lateral_split"]


# ----------------------------------------------------------------------------------------------
# Continuation in six degrees of freedom: the heading dropped (nothing depends on it)

def branch_problem(cfg: Config, model_key: str, level: bool, climb_rate_mps: float, bounds):
    """``(ode, problem)`` of a 6-DOF continuation of ``cfg`` (:func:`birdocp.studies.branch.bird_branch`):
    the heading-free ODE ``ode_no_heading`` (8 states; nothing depends on psi, whose multiplier 1 would
    sit on every fold and branch-point test), at fixed gait or (``level``) with the amplitude free and
    the mean vertical speed held at ``climb_rate_mps``. An asymmetric gait, or a continuation in a
    per-side offset (``gait.right_offset.*``, ``gait.left_offset.*``), uses the model with per-side
    joint laws: its cycles are turns, periodic up to the heading, which the 8 states leave out.

    Parameters
    ----------
    cfg : Config
        Six-degree-of-freedom configuration.
    model_key : str
        Dotted key of the continuation parameter.
    level : bool
        Amplitude free, mean vertical speed held.
    climb_rate_mps : float
        Mean vertical speed held with ``level`` [m/s].
    bounds : (float, float)
        Amplitude bounds [deg] with ``level``.

    Returns
    -------
    ode : ODE
    problem : OrbitProblem
    """
    six = sixdof_model(cfg, sides=asymmetric(cfg) or model_key in SIDE_PARAM_NAMES)
    ode, outs = six.ode_no_heading, six.flight_outputs(HEADING)
    p6 = np.asarray(six.params(param_vector(cfg), LateralInertia.of(cfg), side_vector(cfg) if six.sides else None),
                    float)
    guess = np.array(embed_planar_state(cfg.solve.initial_guess)[:HEADING])
    if not level:
        return ode, OrbitProblem(ode, p6, guess, outputs=outs)
    if model_key == AMPLITUDE_KEY:
        raise ValueError("with level flight held the amplitude is solved for: continue another parameter")
    lo, hi = bounds if bounds is not None else default_bounds(cfg, AMPLITUDE_KEY)
    cond = MeanCondition(outs["vertical_speed_mps"], float(climb_rate_mps), "vertical_speed_mps")
    return ode, OrbitProblem(ode, p6, guess, free={AMPLITUDE_KEY: (float(lo), float(hi))}, means=[cond],
                             outputs={"forward_speed_mps": outs["forward_speed_mps"]})


def planar_point(x0, p):
    """The planar (u, w, q, theta) state and parameter vector of a 6-DOF point (its validity is the
    planar cycle's: a symmetric cycle has v = p = r = phi = 0).

    Parameters
    ----------
    x0 : array_like
        6-DOF state.
    p : array_like or None
        6-DOF parameter vector.

    Returns
    -------
    x4 : ndarray
        (u, w, q, theta).
    p_planar : ndarray or None
        The first ``len(PARAM_NAMES)`` parameters.
    """
    x0 = np.asarray(x0, float)
    return x0[list(LONGITUDINAL)], (np.asarray(p, float)[:len(PARAM_NAMES)] if p is not None and len(p) else None)


def validity_point(x0, p, ode):
    """``(x0, p, ode)`` for the validity of a 6-DOF branch point on the heading-free ``ode``: with
    per-side joint laws (an asymmetric gait, a per-side offset continued) the 6-DOF check over both
    wings on ``ode`` itself; otherwise the planar cycle's (:func:`planar_point`, ode None).

    Parameters
    ----------
    x0, p : array_like
        State and parameter vector of the point.
    ode : ODE
        Heading-free ODE of the branch.

    Returns
    -------
    tuple
        ``(x0, p, ode)``.
    """
    if ode is not None and SIDE_PARAM_NAMES[0] in ode.param_names:
        return np.asarray(x0, float), np.asarray(p, float), ode
    return (*planar_point(x0, p), None)


def add_lateral_split(cfg: Config, branch, steps_per_period: int, points: int, ode=None) -> None:
    """Give every point of a 6-DOF branch its split multipliers, in ``branch.settings``: the lists
    ``longitudinal_multipliers`` and ``lateral_multipliers`` ([re, im] pairs, largest modulus first),
    ``lateral_stable`` and ``coupling_max`` per point, from the point's monodromy (one variational
    period of the heading-free ODE ``ode``, default ``cfg``'s; the heading's multiplier 1 is not part
    of the branch). With per-side joint laws the blocks couple and the multipliers are split by
    eigenvector content (:func:`coupled_modes`).

    Parameters
    ----------
    cfg : Config
        Six-degree-of-freedom configuration.
    branch : Branch
        Branch, changed in place.
    steps_per_period : int
        RK4 steps of the variational period.
    points : int
        Shooting points of the branch.
    ode : ODE, optional
        The heading-free ODE (default: ``cfg``'s).
    """
    from birdocp.engine.shooting import floquet

    ode = sixdof_model(cfg).ode_no_heading if ode is None else ode
    sides = SIDE_PARAM_NAMES[0] in ode.param_names
    lon, lat = list(LONGITUDINAL), list(LATERAL)
    rows = {"longitudinal_multipliers": [], "lateral_multipliers": [], "lateral_stable": [], "coupling_max": []}
    method = OrbitMethod(points=points, steps_per_period=steps_per_period)
    for pt in branch.points:
        M = np.asarray(floquet(ode, pt.x0, pt.p, method).monodromy)
        if sides:
            modes = coupled_modes(M, ode.forcing_period, float(pt.x0[0]))
            L = {"longitudinal": sort_multipliers([m["multiplier"] for m in modes if m["label"] == "longitudinal"]),
                 "lateral": sort_multipliers([m["multiplier"] for m in modes if m["label"] != "longitudinal"])}
        else:
            L = {"longitudinal": sort_multipliers(np.linalg.eigvals(M[np.ix_(lon, lon)])),
                 "lateral": sort_multipliers(np.linalg.eigvals(M[np.ix_(lat, lat)]))}
        for k, v in L.items():
            rows[f"{k}_multipliers"].append([[float(z.real), float(z.imag)] for z in np.asarray(v, complex)])
        rows["lateral_stable"].append(bool(np.all(np.abs(L["lateral"]) < 1.0)))
        rows["coupling_max"].append(float(max(np.abs(M[np.ix_(lon, lat)]).max(), np.abs(M[np.ix_(lat, lon)]).max())))
    branch.settings.update(rows)
    branch.settings["degrees_of_freedom"] = 6
