"""Where the lifting line's sections see the wake (``aero.collocation``, docs/model.md §5).

``quarter`` (the paper's model, the default): the downwash of every section is the induced velocity of
the straight semi-infinite trailing filaments at the element centre, on the lifting line itself (the
bound vortex at the quarter chord; :func:`birdocp.bird.aero.induced_matrices`).

``three_quarter``: Weissinger's extended lifting line (the one-chordwise-panel vortex lattice). The
flow tangency of section j is evaluated at the three-quarter-chord point of the streamwise section
through its centre,

    P_j = C_j + 1/2 c_j (c_hat_j - T_j c_hat_j1 / T_j1),

(``T_j`` the unit element direction node to node, ``c_hat_j`` the chord direction: P_j lies in the
plane e1 = C_j1, inside the element's strip), and the downwash there is the full three-dimensional
Biot-Savart velocity of every horseshoe (the bound vortex node to node and the two trailing filaments
from the nodes to infinity along e3, the body axis, as the model's wake) along the strip's normal
``n_j = unit((c_hat_j - T_j c_hat_j1 / T_j1) x T_j)``, positive downwards. The velocity of the section's
own bound vortex as an infinite two-dimensional line, ``Gamma_j / (pi c_j)``, is subtracted: it is the
part of the three-quarter-chord normalwash that the section law's ``C_la = 2 pi`` already carries
(thin-aerofoil theory), so that with ``C_la = 2 pi`` the lifting-line equation is exactly the flow
tangency of the one-panel vortex lattice.

Only the circulation equation changes: the forces keep the induced velocity at the bound vortex
(:func:`~birdocp.bird.aero.induced_matrices`' ``Vx``, ``Vy``), and the kinematic normalwash (body rates,
flapping) is still taken at the element centre: the three-quarter-chord pitch-rate term of a pitching
section belongs to ``aero.unsteady = "wagner"`` (its ``pitch_rate_weight``) and is not added here.
Roll and yaw rates move the three-quarter-chord point's normal velocity by nothing (the chord runs along
e3), so the lateral derivatives see the wake term only.
"""

from __future__ import annotations

import math

COLLOCATIONS = ("quarter", "three_quarter")
"""The values of ``aero.collocation``."""

NORMALWASHES = ("angle", "tangency")
"""``aero.normalwash``, the section law's normalwash ``q_j`` of ``Gamma = G q``: ``angle``
``|Vp_j| alpha_j`` (lift linear in the section angle: the paper's model) or ``tangency``
``|Vp_j| sin(alpha_j) = Vp_j . up_j`` (the flow tangency of a flat plate, lift linear in the sine of
the angle: the exact two-dimensional potential-flow lift of a flat plate, and the law a vortex lattice
solves). At a section angle alpha they differ by the lift slope, ``C_la`` against ``C_la cos(alpha)``."""


def _segment(P, A, B):
    """Velocity at P (3-vector) of a unit vortex segment A -> B (Biot-Savart)."""
    import casadi as ca

    r0, r1, r2 = B - A, P - A, P - B
    cr = ca.cross(r1, r2)
    return cr / ca.dot(cr, cr) * ca.dot(r0, r1 / ca.norm_2(r1) - r2 / ca.norm_2(r2)) / (4 * math.pi)


def _trailing(P, N):
    """Velocity at P of a unit semi-infinite filament from N to infinity along e3, with the sign of
    :func:`birdocp.bird.aero.induced_matrices`' tubes (tube strength gamma_m = Gamma_m - Gamma_(m-1))."""
    import casadi as ca

    d = P - N
    h2 = d[0] ** 2 + d[1] ** 2
    f = (1 + d[2] / ca.norm_2(d)) / (4 * math.pi * h2)
    return ca.vertcat(d[1] * f, -d[0] * f, 0)


def three_quarter_downwash(centres, nodes, chord, c_hat):
    """Downwash per unit circulation K (n x n) at the three-quarter-chord points (see the module).

    Parameters
    ----------
    centres : sequence of 3-vectors
        The n element centres on the lifting line (code frame) [m].
    nodes : sequence of 3-vectors
        The n + 1 element end nodes (code frame) [m].
    chord : sequence
        Chords c_j [m].
    c_hat : sequence of 3-vectors
        Chord directions, leading to trailing edge (the wing's geometry, unit vectors).

    Returns
    -------
    casadi.SX or casadi.DM
        ``K[j, m]``: downwash [m/s] at the three-quarter-chord point of section j per unit circulation
        Gamma_m [m^2/s], minus ``1 / (pi c_j)`` on the diagonal.
    """
    import casadi as ca

    n = len(centres)
    rows = []
    for j in range(n):
        T = nodes[j + 1] - nodes[j]
        T = T / ca.norm_2(T)
        a = c_hat[j] - T * c_hat[j][0] / T[0]
        P = centres[j] + 0.5 * chord[j] * a
        normal = ca.cross(a, T)
        normal = normal / ca.norm_2(normal)
        tubes = [ca.dot(normal, _trailing(P, N)) for N in nodes]
        row = []
        for m in range(n):
            v = ca.dot(normal, _segment(P, nodes[m], nodes[m + 1])) + tubes[m] - tubes[m + 1]
            row.append(-v - (1 / (math.pi * chord[j]) if m == j else 0))
        rows.append(ca.horzcat(*row))
    return ca.vertcat(*rows)
