"""Spanwise refinement of the lifting line (``aero.span_subdivisions = k``, docs/model.md §5).

The merged line (:func:`birdocp.bird.wing.merge`) has 33 points: even ones the 17 element nodes, odd
ones the 16 element centres. Each element is the polyline node - centre - node. With ``k`` > 1 every
element is cut into ``k`` sub-elements of equal parameter length along that polyline (the centre at
the parameter's middle): the same geometry, ``16 k`` circulations. A sub-element keeps its element's
chord, chord direction and normal (the stepped planform); positions, kinematic velocities and earlier
positions are refined by the same linear map, so the refined kinematic velocity is the exact velocity
of the refined points. ``k = 1`` returns the line unchanged (the model, bit for bit).
"""

from __future__ import annotations

MAX_SUBDIVISIONS = 8
"""The largest ``aero.span_subdivisions``."""


def _point(a, c, b, u):
    """The point at parameter ``u`` in [0, 1) of the polyline a - c - b (c at u = 1/2)."""
    if u == 0:
        return a
    if u == 0.5:
        return c
    return a + 2 * u * (c - a) if u < 0.5 else c + (2 * u - 1) * (b - c)


def refine_points(Q: list, k: int) -> list:
    """The 33-point line ``Q`` (nodes at even, centres at odd indices) as a ``32 k + 1``-point line of
    ``16 k`` sub-elements (same layout). Linear in ``Q``: it refines velocities the same way.

    Parameters
    ----------
    Q : list
        The 33 points (3 x 1 each; positions [m] or velocities [m/s]).
    k : int
        Sub-elements per element.

    Returns
    -------
    list
        The ``32 k + 1`` points.
    """
    if k == 1:
        return list(Q)
    out = []
    for j in range((len(Q) - 1) // 2):
        a, c, b = Q[2 * j], Q[2 * j + 1], Q[2 * j + 2]
        out += [_point(a, c, b, m / (2 * k)) for m in range(2 * k)]
    return out + [Q[-1]]


def repeat_sections(values: list, k: int) -> list:
    """Per-point section values of the 33-point line (chords, directions, normals; the centres' are the
    elements') on the refined line: every sub-element gets its element's, the nodes their neighbour's.

    Parameters
    ----------
    values : list
        The 33 per-point values.
    k : int
        Sub-elements per element.

    Returns
    -------
    list
        The ``32 k + 1`` per-point values.
    """
    if k == 1:
        return list(values)
    out = []
    for j in range((len(values) - 1) // 2):
        out += [values[2 * j + 1]] * (2 * k)
    return out + [values[-1]]
