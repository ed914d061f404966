"""Aerodynamic states (``aero.unsteady = "wagner"``, ``aero.section = "dynamic-stall"``) in the
six-degree-of-freedom monodromy: the mirror basis that splits them into symmetric and antisymmetric
parts.

The lag and separation states are per lifting-line element over both wings (left 0..7, right 8..15:
element j's mirror image is element 15 - j). Under the mirror symmetry of a symmetric gait the
combinations ``(z_j + z_(15-j)) / sqrt 2`` are even (they join the longitudinal states u, w, q, theta)
and ``(z_j - z_(15-j)) / sqrt 2`` odd (they join v, p, r, phi, psi). In this orthogonal basis the
monodromy of a symmetric cycle is block diagonal: the longitudinal block is the planar model's
monodromy restricted to its symmetric aerodynamic states, the lateral block holds the lateral modes
and the antisymmetric aerodynamic ones.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mirror_basis", "mirror_names", "split_indices", "body_share_modes", "mirror_state"]


def mirror_basis(n_body: int, n_air: int, n_el: int = 16) -> np.ndarray:
    """The orthogonal matrix T (rows: new states) taking a state (``n_body`` body states, then
    ``n_air`` aerodynamic states in blocks of ``n_el`` elements) to the body states followed, per
    block, by its ``n_el / 2`` symmetric then ``n_el / 2`` antisymmetric combinations.

    Parameters
    ----------
    n_body : int
        Body states (9, or 8 without the heading).
    n_air : int
        Aerodynamic states (a multiple of ``n_el``).
    n_el : int
        Elements per block.

    Returns
    -------
    ndarray, shape (n_body + n_air, n_body + n_air)
    """
    T = np.zeros((n_body + n_air, n_body + n_air))
    T[:n_body, :n_body] = np.eye(n_body)
    h, s = n_el // 2, 1.0 / np.sqrt(2.0)
    for b in range(n_air // n_el):
        k = n_body + b * n_el
        for j in range(h):
            T[k + j, k + j], T[k + j, k + n_el - 1 - j] = s, s
            T[k + h + j, k + j], T[k + h + j, k + n_el - 1 - j] = s, -s
    return T


def mirror_names(names, n_body: int, n_el: int = 16) -> list[str]:
    """State names in the :func:`mirror_basis`: the aerodynamic ``<kind>_<j>`` become
    ``<kind>_sym_<j>`` and ``<kind>_anti_<j>`` (j = 0..n_el/2 - 1, units kept last: ``z1_sym_0_mps``).

    Parameters
    ----------
    names : sequence of str
        State names (body, then aerodynamic).
    n_body : int
        Body states.
    n_el : int
        Elements per block.

    Returns
    -------
    list of str
    """
    out = list(names[:n_body])
    for b in range((len(names) - n_body) // n_el):
        kind = names[n_body + b * n_el].rsplit("_", 1)[0]           # z1_mps, z2_mps, f_sep
        unit = "_mps" if kind.endswith("_mps") else ""
        stem = kind[:-4] if unit else kind
        out += [f"{stem}_{part}_{j}{unit}" for part in ("sym", "anti") for j in range(n_el // 2)]
    return out


def split_indices(longitudinal, lateral, n_body: int, n_air: int, n_el: int = 16) -> tuple[list, list]:
    """Indices, in the :func:`mirror_basis`, of the longitudinal states (``longitudinal`` then the
    symmetric aerodynamic ones) and of the lateral states (``lateral`` then the antisymmetric ones).

    Parameters
    ----------
    longitudinal, lateral : sequence of int
        Body-state indices of each part.
    n_body : int
        Body states.
    n_air : int
        Aerodynamic states.
    n_el : int
        Elements per block.

    Returns
    -------
    tuple of list of int
    """
    h = n_el // 2
    sym = [n_body + b * n_el + j for b in range(n_air // n_el) for j in range(h)]
    return list(longitudinal) + sym, list(lateral) + [i + h for i in sym]


def body_share_modes(vectors, n_body_states: int, n_modes: int, multipliers=None) -> list[int]:
    """Indices of the ``n_modes`` eigenvectors (columns, already scaled) whose squared norm lies most in
    their first ``n_body_states`` components: the body modes among aerodynamic ones. With
    ``multipliers`` a complex pair is taken or left whole (by its larger share), so the pick never
    splits a conjugate pair.

    Parameters
    ----------
    vectors : array_like
        Eigenvectors as columns.
    n_body_states : int
        Leading body components.
    n_modes : int
        Body modes to pick.
    multipliers : array_like, optional
        The eigenvalues of the columns.

    Returns
    -------
    list of int
    """
    v = np.asarray(vectors)
    share = np.sum(np.abs(v[:n_body_states]) ** 2, axis=0) / np.sum(np.abs(v) ** 2, axis=0)
    lam = None if multipliers is None else np.asarray(multipliers, complex)
    picked: list[int] = []
    for k in np.argsort(-share):
        k = int(k)
        if k in picked:
            continue
        group = [k]
        if lam is not None and abs(lam[k].imag) > 1e-12 * max(1.0, abs(lam[k])):
            mates = [j for j in range(len(lam)) if j != k and j not in picked and abs(lam[j] - lam[k].conjugate())
                     <= 1e-9 * max(1.0, abs(lam[k]))]
            group += mates[:1]
        if len(picked) + len(group) <= n_modes:
            picked += group
        if len(picked) == n_modes:
            break
    return sorted(picked)


def mirror_state(x, n_body: int, flip, n_el: int = 16) -> np.ndarray:
    """The mirror image of a state: the body states multiplied by ``flip`` (+1 or -1 each), every
    aerodynamic block's elements reversed (element j to 15 - j).

    Parameters
    ----------
    x : array_like
        State (body, then aerodynamic states).
    n_body : int
        Body states.
    flip : array_like
        Signs of the body states under the mirror (length ``n_body``).
    n_el : int
        Elements per block.

    Returns
    -------
    ndarray
    """
    x = np.asarray(x, float)
    air = x[n_body:].reshape(-1, n_el)[:, ::-1].ravel()
    return np.concatenate([x[:n_body] * np.asarray(flip, float), air])
