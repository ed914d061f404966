"""The lateral Floquet modes of a six-degree-of-freedom cycle over one wingbeat.

A multiplier ``Lambda`` of the monodromy ``M = Phi(T)`` with eigenvector ``v0`` gives the solution
``dx(t) = Phi(t) v0`` of the linearised equations along the cycle; the periodic Floquet mode is
``q(t) = Phi(t) v0 exp(-mu t)`` with the exponent ``mu = ln(Lambda) / T`` (principal logarithm), so that
``q(T) = q(0) = v0``: the shape the perturbation takes within each wingbeat while it grows or decays
by ``Lambda`` per wingbeat. ``Phi(t)`` is propagated step by step with the exact Jacobian of the very
RK4 step the engine integrates (the product over the period reproduces the cycle's monodromy:
``monodromy_error`` says to what accuracy).

The components (v, p, r, phi) are scaled as :func:`birdocp.studies.lateral.lateral_modes` scales the
eigenvectors (v by the mean forward speed, p and r by the period, phi as is) and normalised so that the
largest modulus over the wingbeat is 1; a complex mode is rotated so that this largest entry is real
and positive.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from birdocp.bird.config import Config
from birdocp.bird.sixdof import LATERAL, LATERAL_PARAM_NAMES, STATE_NAMES, sixdof_model
from birdocp.engine.integrate import RK4Grid

__all__ = ["lateral_mode_histories", "state_transition_history", "track_modes"]


def state_transition_history(ode, x0, p, steps_per_period: int):
    """``(t [N+1], X [N+1, nx], Phi [N+1, nx, nx])``: the RK4 trajectory from ``x0`` over one period
    and the state-transition matrices ``Phi(t_k)`` (exact Jacobians of the RK4 steps, multiplied).

    Parameters
    ----------
    ode : ODE
        The system.
    x0 : array_like
        Start state (on the cycle).
    p : array_like
        Its parameters.
    steps_per_period : int
        RK4 steps (the cycle's).

    Returns
    -------
    t : ndarray, shape (N+1,)
    X : ndarray, shape (N+1, nx)
    Phi : ndarray, shape (N+1, nx, nx)
    """
    grid = RK4Grid(ode, int(steps_per_period), 1)
    D = np.asarray(grid.blocks_numeric(0.0, p))
    xs, D3, ps = ca.SX.sym("x", ode.nx), ca.SX.sym("D3", ode.nd, 3), ca.SX.sym("p", ode.np)
    xn = grid.step(xs, D3, ps, grid.h)[0]
    jstep = ca.Function("rk4_step_jac", [xs, D3, ps], [xn, ca.jacobian(xn, xs)])
    x, Phi, pd = np.asarray(x0, float).ravel(), np.eye(ode.nx), ca.DM(np.asarray(p, float))
    X, P = [x], [Phi]
    for k in range(grid.N):
        xk, Jk = jstep(x, D[:, 3 * k:3 * k + 3], pd)
        x, Phi = np.asarray(xk).ravel(), np.asarray(Jk) @ Phi
        X.append(x)
        P.append(Phi)
    return grid.h * np.arange(grid.N + 1), np.array(X), np.array(P)


def _cycle_fields(res) -> tuple:
    """(success, x0, p, steps, monodromy, modes) of a LateralTrimResult or its JSON (result.json)."""
    if isinstance(res, dict):
        modes = [dict(m, multiplier=complex(*m["multiplier"]) if isinstance(m["multiplier"], list)
                      else complex(m["multiplier"])) for m in res.get("lateral_modes") or []]
        mono = res.get("monodromy")
        return (bool(res.get("success")), res.get("x0"), res.get("p"), (res.get("method") or {}).get("steps_per_period"),
                None if mono is None else np.asarray(mono, float), modes)
    c = res.cycle
    return bool(c.success), c.x0, c.p, c.method.get("steps_per_period"), c.monodromy, res.lateral_modes


def lateral_mode_histories(res, cfg: Config | None = None) -> dict:
    """The periodic Floquet modes of the lateral multipliers of a converged 6-DOF cycle.

    Parameters
    ----------
    res : LateralTrimResult or dict
        A converged :func:`birdocp.studies.lateral.lateral_trim` result, or its JSON (a 6-DOF
        ``birdocp trim`` run's ``result.json``: ``x0``, ``p``, ``method``, ``monodromy``, ``lateral_modes``).
    cfg : Config, optional
        Its configuration (default: the reference case).

    Returns
    -------
    dict
        ``t_s`` (N+1 times over one period), ``period_s``, ``monodromy_error`` (max |Phi(T) - M|),
        ``state_names`` (v, p, r, phi), ``scales`` (the factors applied to them) and ``modes``: per
        lateral mode ``label``, ``multiplier`` (complex), ``beats_to_double`` and ``history`` (complex,
        (N+1) x 4, normalised); ``flap_angle_rad`` (N+1: the shoulder flapping angle, tip up positive).
    """
    cfg = cfg or Config()
    success, x0, p, steps, M, lat = _cycle_fields(res)
    if not success or M is None or x0 is None or len(x0) != 9 or not steps:
        raise ValueError("lateral modes need a converged 6-DOF cycle with its monodromy")
    six = sixdof_model(cfg)
    t, X, Phi = state_transition_history(six.ode, x0, p, int(steps))
    T = six.period_s
    lam, vec = np.linalg.eig(Phi[-1])
    speed = float(np.mean(X[:, 0]))
    idx = list(LATERAL)
    scale = np.array([1.0 / speed, T, T, 1.0])
    modes = []
    for m in lat:
        z = complex(m["multiplier"])
        k = int(np.argmin(np.abs(lam - z)))
        mu = np.log(complex(lam[k])) / T
        q = np.einsum("kij,j->ki", Phi, vec[:, k])[:, idx] * np.exp(-mu * t)[:, None] * scale
        kk = np.unravel_index(np.argmax(np.abs(q)), q.shape)
        q = q / q[kk]
        modes.append({"label": m["label"], "multiplier": z, "beats_to_double": m["beats_to_double"],
                      "history": q})
    return {"t_s": t, "period_s": T, "monodromy_error": float(np.max(np.abs(Phi[-1] - M))),
            "state_names": [STATE_NAMES[i] for i in idx], "scales": scale.tolist(), "modes": modes,
            "flap_angle_rad": _flap_angles(six, t, p)}


def _flap_angles(six, t, p6) -> np.ndarray:
    """The shoulder flapping angle [rad] at the times ``t`` (the gait's joint law)."""
    from birdocp.bird.model import GEOMETRY_OUTPUTS

    k = GEOMETRY_OUTPUTS.index("joint_angles_rad")
    pp = np.asarray(p6, float)[:six.ode.np - len(LATERAL_PARAM_NAMES)]
    return np.array([float(np.asarray(six.planar.geometry(float(tk), pp)[k]).ravel()[1]) for tk in t])


def _complex(z) -> complex:
    """A complex number from a complex, a float or a JSON ``[re, im]`` pair."""
    return complex(*z) if isinstance(z, (list, tuple)) else complex(z)


def _unit_vector(mode: dict) -> np.ndarray:
    v = np.array([_complex(z) for z in mode["eigenvector"].values()])
    return v / np.linalg.norm(v)


def _best_match(prev: list, cur: list) -> tuple:
    """(perm, overlaps): ``cur[perm[k]]`` continues ``prev[k]``; the permutation with the largest
    summed eigenvector overlap ``|<a, b>|`` (unit vectors; a conjugate pair matches either way round),
    ties broken by the smaller summed eigenvalue distance."""
    from itertools import permutations

    A = [_unit_vector(m) for m in prev]
    B = [_unit_vector(m) for m in cur]
    ov = np.array([[abs(np.vdot(a, b)) for b in B] for a in A])
    dl = np.array([[abs(_complex(a["multiplier"]) - _complex(b["multiplier"])) for b in cur] for a in prev])
    best = max(permutations(range(len(cur))),
               key=lambda q: (round(sum(ov[k, j] for k, j in enumerate(q)), 9), -sum(dl[k, j] for k, j in enumerate(q))))
    return best, [float(ov[k, j]) for k, j in enumerate(best)]


def track_modes(mode_lists, start: int) -> list[list[dict]]:
    """The labels of a family's lateral modes carried by continuity from point ``start`` outwards.

    Labelling every point on its own (:func:`birdocp.studies.lateral.lateral_modes`) can swap names
    where modes move past each other (e.g. the real mode nearest 1 changes). Here each point's modes
    are matched to its neighbour's (towards ``start``) by the largest overlap ``|<a, b>|`` of their
    unit eigenvectors (scaled as the labels are; a conjugate pair matches either way round), and
    inherit the neighbour's labels; ``start`` keeps its own. Where a complex pair splits into two real
    modes both keep the pair's label; where two real modes of different labels meet and become a
    complex pair, both members get the two labels joined by '+' (e.g.
    ``dutch_roll_like+roll_subsidence``).

    Parameters
    ----------
    mode_lists : sequence of list of dict
        Per point of the family, in parameter order, its lateral modes (``multiplier``, ``eigenvector``,
        ``label``; complex numbers or JSON ``[re, im]`` pairs); the points must have equally many.
    start : int
        The point whose labels are carried (e.g. the reference gait).

    Returns
    -------
    list of list of dict
        Copies of the modes with ``label`` carried, ``point_label`` (the point's own label) and
        ``tracking_overlap`` (the eigenvector overlap with the matched neighbour mode, 1 at ``start``;
        a low value says the step between the two points was too coarse to follow the mode).
    """
    out = [[dict(m, point_label=m["label"], tracking_overlap=1.0) for m in modes] for modes in mode_lists]
    if any(len(m) != len(out[start]) for m in out):
        raise ValueError("track_modes: every point needs the same number of modes")
    for step in (1, -1):
        i = start + step
        while 0 <= i < len(out):
            perm, ov = _best_match(out[i - step], out[i])
            for k, j in enumerate(perm):
                out[i][j]["label"], out[i][j]["tracking_overlap"] = out[i - step][k]["label"], ov[k]
            _merge_pair_labels(out[i])
            i += step
    return out


def _merge_pair_labels(modes: list) -> None:
    """A complex-conjugate pair whose two members descend from differently labelled modes (two real
    modes met on the real axis and became a pair) gets both labels joined by '+' on both members."""
    for a in modes:
        za = _complex(a["multiplier"])
        if za.imag == 0:
            continue
        for b in modes:
            if b is not a and abs(_complex(b["multiplier"]) - za.conjugate()) <= 1e-9 * max(1.0, abs(za)) \
                    and b["label"] != a["label"]:
                a["label"] = b["label"] = "+".join(sorted(set(a["label"].split("+")) | set(b["label"].split("+"))))
