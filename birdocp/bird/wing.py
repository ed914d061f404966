"""Wing outline and lifting line as CasADi SX graphs (docs/model.md §4.2-4.6).

The reference implementation makes several discrete, data-dependent choices (segment search in the
arc-length resampling, the corner-smoothing ``while`` loops and passes, nearest-point selection, the
point count of the body section). Each is emulated here with closed forms, ``if_else`` and masked
fixed iteration counts, so the geometry stays one differentiable graph of (t, gait parameters); the
emulation margins are returned as diagnostics (see :data:`DIAGNOSTICS`) and checked in the tests.

Points are lists of 3x1 SX column vectors in the wing frame (m).
"""

from __future__ import annotations

import casadi as ca

N_POINTS = 16
"""Points per resampled edge and per wing line."""

CORNER_HALVINGS = 2
"""Masked halvings per point in a corner sweep (1 is ever needed; 1 of margin)."""
ALIASED_WALK_STEPS = 3
"""Masked segment advances per sample in the aliased resampling walk of the second pass."""

DIAGNOSTICS = (
    "halvings_pass1",       # corner halvings done in the first smoothing pass (both edges)
    "halvings_pass2",       # ... in the second pass: must be 0 (a third pass is not emulated)
    "halving_margin_used",  # points still above the corner threshold after CORNER_HALVINGS: must be 0
    "walk_unfinished",      # aliased walk samples that needed more than ALIASED_WALK_STEPS: must be 0
    "improve_change",       # change measure of the quarter-chord improvement: must be <= 0.1
    "n_mid",                # ceil(2 x_ep / dx): must be 3 (the merged line has 33 points)
)


def _safe_norm(v):
    """Euclidean norm with a finite derivative (0) at exactly zero."""
    s = ca.dot(v, v)
    pos = s > 0
    return ca.if_else(pos, ca.sqrt(ca.if_else(pos, s, 1.0)), 0.0)


def unit(v):
    """``v`` divided by its 2-norm.

    Parameters
    ----------
    v : casadi.SX
        Vector.

    Returns
    -------
    casadi.SX
    """
    return v / ca.norm_2(v)


def _select(points, idx):
    """points[idx] for a symbolic integer-valued idx (one-hot sum)."""
    out = 0
    for k, p in enumerate(points):
        out = out + ca.if_else(idx == k, p, ca.DM.zeros(3, 1))
    return out


def resample(P, carry=(), n_out=N_POINTS):
    """Arc-length resampling of polyline P into n_out points equally spaced in arc length.

    Closed form of the reference walk: sample i lies at arc length i L/(n_out-1) on the segment j
    with cum[j] < s_i <= cum[j+1]; ``carry`` are lists of points carried along with the same segment
    and fraction (the chord end points of the quarter-chord line). The last sample is the last vertex.

    Parameters
    ----------
    P : list
        Polyline points.
    carry : sequence of list
        Points carried along.
    n_out : int
        Number of samples.

    Returns
    -------
    list or tuple
        The samples; with ``carry`` a tuple (samples, carried points...).
    """
    n = len(P)
    seg = [ca.norm_2(P[k + 1] - P[k]) for k in range(n - 1)]
    cum = [0.0]
    for s in seg:
        cum.append(cum[-1] + s)
    length = cum[-1]
    delta = length / (n_out - 1)
    outs = [[P[0]]] + [[C[0]] for C in carry]
    for i in range(1, n_out - 1):
        target = i * delta
        pts = [0] * (1 + len(carry))
        for k in range(n - 1):
            sel = cum[k + 1] >= target
            if k > 0:
                sel = ca.logic_and(sel, cum[k] < target)
            seg_safe = ca.if_else(seg[k] > 0, seg[k], 1.0)
            phi = (cum[k + 1] - target) / seg_safe
            for a, Q in enumerate((P,) + tuple(carry)):
                pts[a] = pts[a] + ca.if_else(sel, (1 - phi) * Q[k + 1] + phi * Q[k], ca.DM.zeros(3, 1))
        for a in range(len(pts)):
            outs[a].append(pts[a])
    outs[0].append(P[-1])
    for a, C in enumerate(carry):
        outs[a + 1].append(C[-1])
    return outs[0] if not carry else tuple(outs)


def _resample_aliased(B, n_out=N_POINTS, steps=ALIASED_WALK_STEPS):
    """The reference's second-pass resampling, which reads its input vertices from the buffer it
    is writing into (in place). Literal walk with a symbolic segment counter and masked advances.

    Returns (points, unfinished) where ``unfinished`` counts samples whose walk needed more than
    ``steps`` advances (0 means the emulation is exact).
    """
    buf = list(B)
    n = len(buf)
    length = 0
    for k in range(n - 1):
        length = length + _safe_norm(buf[k + 1] - buf[k])
    delta = length / (n_out - 1)
    j = ca.SX(0)
    unfinished = 0
    for i in range(1, n_out):
        acc = _safe_norm(_select(buf, j + 1) - buf[i - 1])
        for _ in range(steps):
            cond = acc < delta
            jn = j + cond
            within = jn <= n - 2
            seglen = _safe_norm(_select(buf, jn + 1) - _select(buf, jn))
            acc = ca.if_else(cond, ca.if_else(within, acc + seglen, delta + 1), acc)
            j = jn
        unfinished = unfinished + (acc < delta)
        within = j <= n - 2
        seglen = _safe_norm(_select(buf, j + 1) - _select(buf, j))
        phi = (acc - delta) / ca.if_else(seglen > 0, seglen, 1.0)
        inner = (1 - phi) * _select(buf, j + 1) + phi * _select(buf, j)
        buf[i] = ca.if_else(within, inner, buf[n - 1])
    return buf, unfinished


def _corner_sweep(B, radius_m, halvings=CORNER_HALVINGS):
    """Sequential corner smoothing (docs/model.md §4.2 step 2): while the turning angle at B_i exceeds
    |B_i - B_{i-1}| / R_s, move B_i halfway towards the midpoint of its neighbours.

    Returns (points, halvings done, points still above the threshold after ``halvings``).
    """
    B = list(B)
    done = 0
    left_over = 0
    for i in range(1, len(B) - 1):
        active = ca.SX(1)
        for _ in range(halvings + 1):
            a = B[i] - B[i - 1]
            b = B[i + 1] - B[i]
            na = ca.norm_2(a)
            cosang = ca.dot(a, b) / (na * ca.norm_2(b))
            phi = ca.acos(ca.fmax(-1.0, ca.fmin(1.0, cosang)))
            cond = ca.logic_and(active, phi > na / radius_m)
            if _ == halvings:  # the extra evaluation only measures the margin
                left_over = left_over + cond
                break
            B[i] = ca.if_else(cond, 0.5 * B[i] + 0.25 * (B[i - 1] + B[i + 1]), B[i])
            done = done + cond
            active = cond
    return B, done, left_over


def smooth_line(P, radius_m):
    """Resampling with corner smoothing ("smooth_line", docs/model.md §4.2): 16 points.

    Pass 1 resamples the raw polyline and sweeps the corners; if anything moved, pass 2 resamples the
    buffer in place (aliased) and sweeps again. Returns (points, diagnostics dict).

    Parameters
    ----------
    P : list
        Raw polyline.
    radius_m : float
        Smoothing radius R_s [m].

    Returns
    -------
    points : list
    diag : dict
    """
    B1 = resample(P)
    B1c, h1, left1 = _corner_sweep(B1, radius_m)
    modified = h1 > 0
    B2, unfinished = _resample_aliased(B1c)
    B2c, h2, left2 = _corner_sweep(B2, radius_m)
    out = [ca.if_else(modified, b2, b1) for b1, b2 in zip(B1c, B2c)]
    diag = {
        "halvings_pass1": h1,
        "halvings_pass2": ca.if_else(modified, h2, 0),
        "halving_margin_used": left1 + ca.if_else(modified, left2, 0),
        "walk_unfinished": ca.if_else(modified, unfinished, 0),
    }
    return out, diag


def _soft_ramp(x, width_m):
    """C-infinity ramp ``width log(1 + exp(x / width))`` (m): max(x, 0) with its corner rounded over
    ~``width_m``; evaluated as ``max(x, 0) + width log(1 + exp(-|x| / width))`` (no overflow, and the
    two branches are one analytic function)."""
    return ca.fmax(x, 0) + width_m * ca.log1p(ca.exp(-ca.fabs(x) / width_m))


def _soft_resample(P, width_m, carry=(), n_out=N_POINTS):
    """Arc-length resampling of polyline P on its corner-rounded curve (``wing.smooth_geometry``).

    The polyline as a function of arc length s is P_0 + sum_k u_k (ramp(s - cum_k) - ramp(s - cum_{k+1}))
    with u_k = (P_{k+1} - P_k) / |P_{k+1} - P_k|; replacing ramp = max(., 0) by :func:`_soft_ramp`
    rounds every corner over ~``width_m`` and makes the samples at s_i = i L / (n_out - 1) C-infinity
    functions of the vertices: no segment search, no switch. ``carry`` are carried with the same
    weights (the chord end points). The end samples are the end vertices.
    """
    n = len(P)
    seg = [ca.norm_2(P[k + 1] - P[k]) for k in range(n - 1)]
    cum = [0.0]
    for s in seg:
        cum.append(cum[-1] + s)
    delta = cum[-1] / (n_out - 1)
    outs = [[P[0]]] + [[C[0]] for C in carry]
    for i in range(1, n_out - 1):
        target = i * delta
        w = [(_soft_ramp(target - cum[k], width_m) - _soft_ramp(target - cum[k + 1], width_m))
             / ca.if_else(seg[k] > 0, seg[k], 1.0) for k in range(n - 1)]  # a 0-length segment adds 0
        for a, Q in enumerate((P,) + tuple(carry)):
            outs[a].append(Q[0] + sum(w[k] * (Q[k + 1] - Q[k]) for k in range(n - 1)))
    outs[0].append(P[-1])
    for a, C in enumerate(carry):
        outs[a + 1].append(C[-1])
    return outs[0] if not carry else tuple(outs)


def smooth_geometry(LE, TE, radius_m):
    """The switch-free wing (``wing.smooth_geometry = true``, docs/model.md §4.8): both edges resampled
    on their corner-rounded curves (rounding width R_s / 4), the quarter-chord line resampled the same
    way with its chord end points, no corner sweep and no improvement step. Every output is a
    C-infinity function of the joint angles, hence of t. Returns (LEs, TEs, P, E, T, diagnostics);
    the diagnostics are 0 (nothing is emulated).

    Parameters
    ----------
    LE, TE : list
        Raw leading and trailing edges.
    radius_m : float
        Smoothing radius R_s [m].

    Returns
    -------
    tuple
    """
    width = 0.25 * radius_m
    LEs = _soft_resample(LE, width)
    TEs = _soft_resample(TE, width)
    L0 = [0.75 * e + 0.25 * t for e, t in zip(LEs, TEs)]
    P, E, T = _soft_resample(L0, width, carry=(LEs, TEs))
    diag = {k: ca.SX(0) for k in DIAGNOSTICS if k not in ("improve_change", "n_mid")}
    return LEs, TEs, P, E, T, diag


def _nearest_two(points, origin, direction):
    """The nearest and second-nearest of ``points`` to the infinite line {origin + s direction}
    (ties keep the lower index, as a stable argsort)."""
    best = [None, None]
    dist = [None, None]
    for k, P in enumerate(points):
        r = P - origin
        perp = r - ca.dot(r, direction) * direction
        d = ca.dot(perp, perp)  # squared distance: same ordering as the distance
        if k == 0:
            best[0], dist[0] = P, d
            continue
        if k == 1:
            first = d < dist[0]
            best = [ca.if_else(first, P, best[0]), ca.if_else(first, best[0], P)]
            dist = [ca.if_else(first, d, dist[0]), ca.if_else(first, dist[0], d)]
            continue
        first = d < dist[0]
        second = ca.logic_and(ca.logic_not(first), d < dist[1])
        new_b1 = ca.if_else(first, best[0], ca.if_else(second, P, best[1]))
        new_d1 = ca.if_else(first, dist[0], ca.if_else(second, d, dist[1]))
        best[0] = ca.if_else(first, P, best[0])
        dist[0] = ca.if_else(first, d, dist[0])
        best[1], dist[1] = new_b1, new_d1
    return best[0], best[1]


def _closest_on_edge(edge, L, c_hat):
    """Point of the edge line through its two points nearest to {L + s c_hat}, closest to that line."""
    A1, A2 = _nearest_two(edge, L, c_hat)
    e = unit(A2 - A1)
    ec = ca.dot(e, c_hat)
    s = (ca.dot(L, e) - ca.dot(A1, e) + ca.dot(A1, c_hat) * ec - ca.dot(L, c_hat) * ec) / (1 - ec ** 2)
    return A1 + s * e


def lifting_line(LEs, TEs):
    """Quarter-chord line with one improvement step and the final resampling (docs/model.md §4.3-4.4).

    Returns (P, E, T, L_relaxed, change): line points, chord end points (leading, trailing), the
    relaxed line before the final resampling (used for tangents) and the change measure.

    Parameters
    ----------
    LEs, TEs : list
        Smoothed leading and trailing edges.

    Returns
    -------
    tuple
    """
    L0 = [0.75 * e + 0.25 * t for e, t in zip(LEs, TEs)]
    L, E, T = resample(L0, carry=(LEs, TEs))
    n = len(L)
    Ln, En, Tn = list(L), list(E), list(T)
    for i in range(1, n - 1):
        t_hat = unit(L[i + 1] - L[i - 1])
        v = T[i] - E[i]
        c_hat = unit(v - ca.dot(v, t_hat) * t_hat)
        En[i] = _closest_on_edge(LEs, L[i], c_hat)
        Tn[i] = _closest_on_edge(TEs, L[i], c_hat)
        Ln[i] = 0.75 * En[i] + 0.25 * Tn[i]
    change = 0
    for i in range(0, n - 1):
        change = change + 0.25 * ca.norm_2(Ln[i] - L[i]) / ca.norm_2(L[max(0, i - 1)] - L[min(16, i + 1)])
    change = change / n
    Lr = [0.25 * a + 0.75 * b for a, b in zip(Ln, L)]
    Er = [0.25 * a + 0.75 * b for a, b in zip(En, E)]
    Tr = [0.25 * a + 0.75 * b for a, b in zip(Tn, T)]
    P, Ef, Tf = resample(Lr, carry=(Er, Tr))
    return P, Ef, Tf, Lr, change


def sections(P, E, T, L_relaxed):
    """Chords (m), chord directions (LE -> TE) and 'up' normals of the 16 line points (docs/model.md §4.5).

    Parameters
    ----------
    P : list
        Line points.
    E, T : list
        Chord end points (leading, trailing).
    L_relaxed : list
        Relaxed line (tangents).

    Returns
    -------
    chord, c_hat, up : list
    """
    n = len(P)
    chord, c_hat, up = [], [], []
    for i in range(n):
        v = T[i] - E[i] + 1e-20
        c = ca.norm_2(v)
        ch = v / c
        if i == 0:
            t = unit(L_relaxed[1] - L_relaxed[0])
        elif i == n - 1:
            t = unit(L_relaxed[n - 1] - L_relaxed[n - 2])
        else:
            t = unit(L_relaxed[i + 1] - L_relaxed[i - 1])
        chord.append(c)
        c_hat.append(ch)
        up.append(ca.cross(ch, t))
    return chord, c_hat, up


def merge(P, chord, c_hat, up, half_separation_m, left=None):
    """Both wings on one line from the left tip to the right tip (docs/model.md §4.5-4.6).

    ``P``, ``chord``, ``c_hat``, ``up``: the right wing's points in the wing frame (the left wing is
    their mirror image); ``left`` = (P, chord, c_hat, up) of a left wing that differs (an asymmetric
    gait, :mod:`birdocp.bird.sides`), given in its own mirrored frame: mirrored here. The middle node
    is then the mean of the two root points (with ``left`` None: the right root's, as before).

    Returns (Q, chord, c_hat, up): 33 points (wing frame shifted to the body centre line) with their
    chords, chord directions and normals. Even indices are element nodes, odd indices centres.

    Parameters
    ----------
    P, chord, c_hat, up : list
        The right wing's points, chords, chord directions and normals.
    half_separation_m : float
        Shift of the wing frame to the body centre line (half the root separation) [m].
    left : tuple, optional
        A differing left wing.

    Returns
    -------
    tuple
    """
    flip = ca.DM([-1.0, 1.0, 1.0])
    shift = ca.DM([half_separation_m, 0, 0]) if not isinstance(half_separation_m, ca.SX) else ca.vertcat(half_separation_m, 0, 0)
    right = [p + shift for p in P]
    Pl, chl, cl, ul = (P, chord, c_hat, up) if left is None else left
    left_pts = [flip * p - shift for p in reversed(Pl)]
    if left is None:
        mid = ca.vertcat(0.5 * (left_pts[-1][0] + right[0][0]), right[0][1], right[0][2])
    else:
        mid = 0.5 * (left_pts[-1] + right[0])
    Q = left_pts + [mid] + right
    ch = list(reversed(chl)) + [chord[0] * 1e-4] + list(chord)
    cd = [flip * c for c in reversed(cl)] + [c_hat[0]] + list(c_hat)
    nu = [flip * u for u in reversed(ul)] + [up[0]] + list(up)
    return Q, ch, cd, nu


def mean_spacing(P):
    """dx of docs/model.md §4.5: mean point spacing of one wing line, used for the body-section point count.

    Parameters
    ----------
    P : list
        Line points.

    Returns
    -------
    casadi.SX or float
        Mean spacing [m].
    """
    n = len(P)
    total = 0
    for i in range(n - 1):
        total = total + ca.norm_2(P[i + 1] - P[i])
    total = total + ca.norm_2(P[n - 1] - P[n - 2])
    return total / n
