"""Asymmetric gaits: each wing with its own joint laws (six degrees of freedom only).

The configuration's ``gait.right_offset.<joint>.<field>`` and ``gait.left_offset.<joint>.<field>``
(:class:`birdocp.bird.config.SideOffsets`, deg) are added to the joint law of :class:`Gait` for that
wing alone. Each wing's angles are in its own mirrored frame, so swapping the two offset tables
mirrors the whole bird about its plane of symmetry (``docs/sixdof.md``).

The data of an asymmetric gait is the planar model's data layout (:data:`birdocp.bird.model.DATA_BLOCKS`)
built from two arm-frame wings: ``pre`` evaluated once with the right wing's parameters and once
with the left wing's, then assembled by :func:`birdocp.bird.model.aero_blocks` with a differing
left wing (one lifting line over the full span, its matrices from the asymmetric geometry).
"""

from __future__ import annotations


import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, SIDE_KEYS, Config, get_value
from birdocp.bird.graphs import time_derivative, unsteady_blocks
from birdocp.bird.model import DATA_BLOCKS, N_EL, BirdModel, Structure, aero_blocks
from birdocp.bird.sixdof_inertia import sums_function
from birdocp.bird.sixdof_unsteady import added_mass_data
from birdocp.engine.cache import owned_cache

__all__ = ["SIDE_PARAM_NAMES", "side_vector", "side_parameters", "side_data_functions", "swap_sides"]

SIDE_PARAM_NAMES = SIDE_KEYS
"""The 42 per-side offsets (right wing's 21, then the left wing's) appended to the six-degree-of-freedom
parameter vector of a model with per-side joint laws (:class:`birdocp.bird.sixdof.SixDofModel` with
``sides=True``)."""

_N_SIDE = len(SIDE_PARAM_NAMES) // 2
_BASE_INDEX = [PARAM_NAMES.index(k.replace(".right_offset", "")) for k in SIDE_PARAM_NAMES[:_N_SIDE]]
"""Index in :data:`PARAM_NAMES` of the joint key each right (and left) offset adds to."""


def side_vector(cfg: Config) -> list[float]:
    """The values of :data:`SIDE_PARAM_NAMES` in ``cfg``.

    Parameters
    ----------
    cfg : Config
        Configuration.

    Returns
    -------
    list of float
    """
    return [float(get_value(cfg, k)) for k in SIDE_PARAM_NAMES]


def swap_sides(offsets) -> list[float]:
    """The side vector with the right and left wings' offsets exchanged (the mirrored gait).

    Parameters
    ----------
    offsets : sequence of float
        Side vector (right wing's offsets, then the left's).

    Returns
    -------
    list of float
    """
    o = [float(v) for v in offsets]
    return o[_N_SIDE:] + o[:_N_SIDE]


def side_parameters(p, offsets):
    """(p_right, p_left): the planar parameter vector ``p`` (:data:`PARAM_NAMES`) with the right and
    the left wing's offsets added to the joint keys (CasADi MX/SX or numpy).

    Parameters
    ----------
    p : casadi.MX, SX or ndarray
        Planar parameter vector.
    offsets : casadi.MX, SX or ndarray
        Side vector (:data:`SIDE_PARAM_NAMES`).

    Returns
    -------
    p_right, p_left
    """
    n = len(PARAM_NAMES)
    if isinstance(p, (ca.MX, ca.SX)):
        sel = np.zeros((n, _N_SIDE))
        sel[_BASE_INDEX, np.arange(_N_SIDE)] = 1.0
        S = ca.DM(sel)
        return p + S @ offsets[:_N_SIDE], p + S @ offsets[_N_SIDE:]
    p = np.asarray(p, float)
    o = np.asarray(offsets, float)
    pr, pl = p.copy(), p.copy()
    pr[_BASE_INDEX] += o[:_N_SIDE]
    pl[_BASE_INDEX] += o[_N_SIDE:]
    return pr, pl


def _sides_post(structure: Structure, n_local: int) -> ca.Function:
    """``post2(local_right, local_left, t, p_right, p_left) -> d``: the data of two differing wings."""
    n = len(PARAM_NAMES)
    Lr, Ll = ca.SX.sym("local_right", n_local), ca.SX.sym("local_left", n_local)
    t = ca.SX.sym("t")
    pr, pl = ca.SX.sym("p_right", n), ca.SX.sym("p_left", n)
    blocks = aero_blocks(structure, Lr, t, pr, left=(Ll, pl))
    d = ca.vertcat(*[ca.vec(blocks[name]) for name, _ in DATA_BLOCKS])
    if structure.aero_extra:  # the unsteady data of the two differing wings (stall section, Wagner)
        n_aero = 4 * 3 * N_EL + N_EL
        d = ca.vertcat(d, unsteady_blocks([Lr, Ll], n_aero, n_local - 2 * n_aero, blocks, t))
        if structure.unsteady == "wagner":  # then the 6-DOF added-mass data
            d = ca.vertcat(d, added_mass_data(blocks, time_derivative([Lr, Ll], n_aero, n_local - 2 * n_aero, t)))
    return ca.Function("wing_assemble_sides", [Lr, Ll, t, pr, pl], [d],
                       ["local_right", "local_left", "t", "p_right", "p_left"], ["d"])


def side_data_functions(planar: BirdModel, n_params: int, first_offset: int):
    """``(pre, post, data, pre_params)`` of a model whose parameter vector (``n_params`` values)
    starts with :data:`PARAM_NAMES` and holds :data:`SIDE_PARAM_NAMES` from index ``first_offset``:
    ``pre(t, p)`` stacks the planar ``pre`` of the right and of the left wing, ``post(local, t, p)``
    assembles both (:data:`birdocp.bird.model.DATA_BLOCKS`, then, with wing masses, the 3-D sums
    :data:`birdocp.bird.sixdof_inertia.MASS3_BLOCK` of the two wings); ``pre_params`` adds the offsets of
    the joints ``pre`` depends on (elbow, wrist).

    Parameters
    ----------
    planar : BirdModel
        Planar model.
    n_params : int
        Length of the parameter vector.
    first_offset : int
        Index of the first side offset.

    Returns
    -------
    tuple
        ``(pre, post, data, pre_params)``.
    """
    n = len(PARAM_NAMES)
    nl = planar.pre.size1_out(0)
    post2 = owned_cache(planar).build(("sides_post", nl), lambda: _sides_post(planar.structure, nl))
    tm, pm = ca.MX.sym("t"), ca.MX.sym("p", n_params)
    pr, pl = side_parameters(pm[:n], pm[first_offset:first_offset + 2 * _N_SIDE])
    pre = ca.Function("pre_sides", [tm, pm], [ca.vertcat(planar.pre(tm, pr), planar.pre(tm, pl))], ["t", "p"],
                      ["local"])
    loc = ca.MX.sym("local", 2 * nl)
    d_post = post2(loc[:nl], loc[nl:], tm, pr, pl)
    if planar.structure.wing_mass:  # the 3-D sums of the two differing wings after the aerodynamic blocks
        d_post = ca.vertcat(d_post, sums_function(planar.mass_points, sides=True)(tm, pr, pl))
    post = ca.Function("post_sides", [loc, tm, pm], [d_post], ["local", "t", "p"], ["d"])
    data = ca.Function("data_sides", [tm, pm], [post(pre(tm, pm), tm, pm)], ["t", "p"], ["d"])
    base = set(planar.pre_params)
    extra = [first_offset + i + s * _N_SIDE for s in (0, 1) for i, b in enumerate(_BASE_INDEX) if b in base]
    return pre, post, data, tuple(sorted(base | set(extra)))
