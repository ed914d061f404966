"""Stability as constraints: the Jury conditions of a 4 x 4 matrix (all eigenvalues inside the circle of
radius r), their CasADi Function, and the dominant 4 x 4 block of a larger monodromy (a model with
aerodynamic states) on which they act with exact first derivatives."""
from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["jury_conditions", "jury_function", "dominant_block", "invariant_block", "jury_values"]


def jury_conditions(A):
    """The five Jury quantities (each >= 0 <=> all eigenvalues of the 4 x 4 A in the closed unit
    disc, strict > 0 for the open disc).

    Parameters
    ----------
    A : casadi.SX or MX, shape (4, 4)
        Matrix.

    Returns
    -------
    casadi.SX or MX, shape (5, 1)
    """
    t1 = ca.trace(A)
    A2 = A @ A
    t2 = ca.trace(A2)
    t3 = ca.trace(A2 @ A)
    a3 = -t1
    a2 = 0.5 * (t1 ** 2 - t2)
    a1 = -(t1 ** 3 - 3 * t1 * t2 + 2 * t3) / 6
    a0 = ca.det(A)
    a = [a0, a1, a2, a3, 1.0]
    p1 = sum(a)
    pm1 = a0 - a1 + a2 - a3 + 1.0
    b = [a[0] * a[k] - a[4] * a[4 - k] for k in range(4)]
    c = [b[0] * b[k] - b[3] * b[3 - k] for k in range(3)]
    return ca.vertcat(p1, pm1, 1 - a0 ** 2, b[0] ** 2 - b[3] ** 2, c[0] ** 2 - c[2] ** 2)


def jury_function():
    """The Jury conditions of M / r and their Jacobian, as a CasADi Function ``jury(M, r) -> (j, dj/d(vec M, r))``.

    Returns
    -------
    casadi.Function
    """
    M, r = ca.SX.sym("M", 4, 4), ca.SX.sym("r")
    j = jury_conditions(M / r)
    return ca.Function("jury", [M, r], [j, ca.jacobian(j, ca.vertcat(ca.vec(M), r))])


def _real_basis(vectors, values, columns: bool = True):
    """A real basis (columns, or rows with ``columns=False``) of the span of complex eigenvectors
    closed under conjugation: a real eigenvalue's real part, a pair's real and imaginary parts."""
    out = []
    for k, lam in enumerate(values):
        v = vectors[:, k] if columns else vectors[k]
        if abs(lam.imag) <= 1e-12 * max(abs(lam), 1.0):
            out.append(np.real(v))
        elif lam.imag > 0:
            out += [np.real(v), np.imag(v)]
    return np.column_stack(out) if columns else np.vstack(out)


def dominant_block(M, k: int = 4):
    """``(B, P, V)`` with ``B = P M V`` (k x k, real) holding the dominant multipliers of the n x n
    monodromy ``M``: the m <= k largest-modulus eigenvalues, m where the modulus drops most (largest
    ratio |lambda_m| / |lambda_m+1|, never inside a conjugate pair), padded with zeros to k x k. V spans
    their right invariant subspace, P their left one with ``P V = I``. A perturbation dM moves them, to
    first order, as the eigenvalues of ``B + P dM V`` (the coupling to the other eigenvalues enters at
    second order), so a stability constraint on B has exact first derivatives. For n = k:
    ``(M, None, None)``. With aerodynamic states the other multipliers are the lag and separation
    modes and the body mode they damp, all far inside the dominant ones (measured on the ibis: 1.42,
    0.87, 0.87, then 0.15 and below). RuntimeError when no m <= k separates (equal moduli).

    Parameters
    ----------
    M : array_like
        Monodromy (n x n).
    k : int
        Size of the block.

    Returns
    -------
    tuple
        ``(B, P, V)``: k x k, k x n and n x k (P and V None when n = k).
    """
    M = np.asarray(M, float)
    n = M.shape[0]
    if n == k:
        return M, None, None
    lam, Vc = np.linalg.eig(M)
    order = np.argsort(-np.abs(lam), kind="stable")
    mod = np.abs(lam[order])
    ratios = [mod[m - 1] / max(mod[m], 1e-300) for m in range(1, k + 1)]
    m = int(np.argmax(ratios)) + 1
    if not ratios[m - 1] > 1.0 + 1e-9:
        raise RuntimeError(f"no dominant multipliers: the {k + 1} largest have the same modulus {mod[0]:.6g}")
    return invariant_block(M, lam, Vc, order[:m], k)


def invariant_block(M, lam, Vc, sel, k: int = 4):
    """``(B, P, V)`` with ``B = P M V`` (k x k, real) holding the eigenvalues ``lam[sel]`` of ``M`` (a set
    closed under conjugation, at most k of them; padded with zeros to k x k): V spans their right
    invariant subspace, P their left one with ``P V = I``. A perturbation dM moves them, to first
    order, as the eigenvalues of ``B + P dM V`` (exact first derivatives while they stay apart from
    the other eigenvalues; only the eigenvalues themselves, not their moduli, must differ).

    Parameters
    ----------
    M : array_like
        Matrix (n x n).
    lam : array_like
        Its eigenvalues (n,).
    Vc : array_like
        Its right eigenvectors (columns, n x n), as :func:`numpy.linalg.eig` gives them.
    sel : sequence of int
        Indices of the eigenvalues of the block.
    k : int
        Size of the block.

    Returns
    -------
    tuple
        ``(B, P, V)``: k x k, k x n and n x k.
    """
    M, lam, Vc = np.asarray(M, float), np.asarray(lam), np.asarray(Vc)
    sel = list(sel)
    n, m = M.shape[0], len(sel)
    V = _real_basis(Vc[:, sel], lam[sel])
    U = _real_basis(np.linalg.inv(Vc)[sel], lam[sel], columns=False)  # rows: the left eigenvectors
    P = np.linalg.solve(U @ V, U)
    P, V = np.vstack([P, np.zeros((k - m, n))]), np.hstack([V, np.zeros((n, k - m))])
    return P @ M @ V, P, V


def jury_values(jury, M, r, d_monodromy=None):
    """``(values (5,), d values / d theta (5 x n_theta) or None, d values / d r (5,))`` of the Jury
    conditions of ``B / r``, B the :func:`dominant_block` of the monodromy ``M`` (M itself for the 4
    body states). ``jury``: :func:`jury_function`'s Function; ``d_monodromy``: dM/dtheta (column-major
    vec, n^2 x n_theta). The radius constrained is therefore the spectral radius of the full
    monodromy as long as the other multipliers (aerodynamic modes) stay inside the 4 dominant ones.

    Parameters
    ----------
    jury : casadi.Function
        :func:`jury_function`'s Function.
    M : array_like
        Monodromy (n x n).
    r : float
        Radius bound R.
    d_monodromy : array_like, optional
        dM/dtheta (column-major vec, n^2 x n_theta), or d(M V)/dtheta (4 n x n_theta) with V the
        :func:`dominant_block`'s of ``M`` (a second-order pass carried on V only).

    Returns
    -------
    tuple
        Values (5,), their theta derivatives (5 x n_theta, or None) and their r derivatives (5,).
    """
    B, P, V = dominant_block(M)
    jv, jj = (np.asarray(v) for v in jury(ca.DM(B), r))
    dB = d_monodromy
    if d_monodromy is not None and P is not None:
        n = np.shape(M)[0]
        dM = np.asarray(d_monodromy, float)
        k = dM.shape[0] // n  # n: dM/dtheta; 4: d(M V)/dtheta on this V already
        dB = np.column_stack([(P @ (dM[:, c].reshape(n, k, order="F") @ V if k == n else
                                    dM[:, c].reshape(n, k, order="F"))).ravel(order="F")
                              for c in range(dM.shape[1])])
    return jv.ravel(), (None if dB is None else jj[:, :16] @ dB), jj[:, 16]
