"""The span direction of the lifting line's sections (``aero.span_direction``, docs/model.md §5).

``leading_line`` (the paper's definition, the default): every section's span direction is
``tau = up x c_hat`` with ``up = c_hat x t`` and ``t`` the tangent of the relaxed quarter-chord line
through the neighbouring points (docs/model.md §4.5). ``element``: ``tau`` along the element's own
line, node to node (the line its bound vortex and the ends of its trailing filaments follow),
``c_hat`` made normal to it and ``up = c_hat x tau``. Both give right-handed orthonormal frames
(``tau = up x c_hat``); they differ where the wing is swept or bent between the line points.
"""

from __future__ import annotations

SPAN_DIRECTIONS = ("leading_line", "element")
"""The values of ``aero.span_direction``."""


def element_frames(nodes, c_hat):
    """Section frames along the elements: (tau, c_hat, up), each 3 x n, from the element end nodes
    ``nodes`` (3 x (n + 1)) and the chord directions ``c_hat`` (3 x n); code frame. Works on CasADi
    SX/MX/DM and on NumPy arrays (returned as DM).

    ``tau_j = (N_{j+1} - N_j) / |N_{j+1} - N_j|``; ``c_j`` = ``c_hat_j`` without its component along
    ``tau_j``, normalised; ``up_j = c_j x tau_j``.

    Parameters
    ----------
    nodes : casadi.SX, MX, DM or numpy.ndarray
        Element end nodes, code frame [m] (3 x (n + 1)).
    c_hat : casadi.SX, MX, DM or numpy.ndarray
        Chord directions (3 x n).

    Returns
    -------
    tuple
        ``(tau, c_hat, up)``, unit vectors, each 3 x n.
    """
    import casadi as ca  # here: the configuration checks read SPAN_DIRECTIONS without CasADi

    nodes, c_hat = _casadi(nodes), _casadi(c_hat)
    n = c_hat.shape[1]
    d = nodes[:, 1:n + 1] - nodes[:, 0:n]
    tau = d / ca.repmat(ca.sqrt(ca.sum1(d * d)), 3, 1)
    c = c_hat - tau * ca.repmat(ca.sum1(tau * c_hat), 3, 1)
    c = c / ca.repmat(ca.sqrt(ca.sum1(c * c)), 3, 1)
    up = ca.vertcat(c[1, :] * tau[2, :] - c[2, :] * tau[1, :],
                    c[2, :] * tau[0, :] - c[0, :] * tau[2, :],
                    c[0, :] * tau[1, :] - c[1, :] * tau[0, :])
    return tau, c, up


def _casadi(a):
    import casadi as ca

    return a if isinstance(a, (ca.SX, ca.MX, ca.DM)) else ca.DM(a)
