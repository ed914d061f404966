"""The reported lateral eigenvectors do not depend on the eigensolver's sign or phase
(birdocp.studies.lateral.lateral_modes, coupled_modes): each is divided by its largest entry."""
import warnings

import numpy as np

from birdocp.bird.sixdof import LATERAL, LONGITUDINAL
from birdocp.studies.lateral import coupled_modes, lateral_modes

T, U = 0.25, 17.0  # period [s], speed [m/s]


def _monodromy(seed):
    """A block-diagonal 9 x 9 monodromy (longitudinal and lateral blocks, heading 1) with a complex pair
    and two real multipliers in its lateral block."""
    rng = np.random.default_rng(seed)
    lam = np.array([[0.9, 0.3], [-0.3, 0.9]])
    D = np.zeros((4, 4))
    D[:2, :2], D[2, 2], D[3, 3] = lam, 0.2, 1.05
    V = rng.normal(size=(4, 4))
    M = np.zeros((9, 9))
    M[np.ix_(LATERAL, LATERAL)] = V @ D @ np.linalg.inv(V)
    M[np.ix_(LONGITUDINAL, LONGITUDINAL)] = np.diag([1.4, 0.5, 0.1, 0.01])
    M[8, 8] = 1.0
    return M


def test_dominant_entry_is_one_and_the_two_solvers_agree():
    """Every mode's largest entry is exactly 1; the lateral modes of the 4 x 4 block and of the 8 x 8
    coupled monodromy (two eigensolver calls, free to return other signs and phases) are the same
    vectors to round-off; a conjugate pair gets conjugate vectors."""
    for seed in range(4):
        M = _monodromy(seed)
        split = lateral_modes(M, T, U)
        coupled = [m for m in coupled_modes(M[:8, :8], T, U) if m["label"] != "longitudinal"]
        assert len(split) == len(coupled) == 4
        for a in split:
            v = np.array(list(a["eigenvector"].values()))
            assert v[np.argmax(np.abs(v))] == 1.0
            b = min(coupled, key=lambda m: abs(m["multiplier"] - a["multiplier"]))
            w = np.array([b["eigenvector"][k] for k in a["eigenvector"]])
            assert np.max(np.abs(v - w)) < 1e-12
        pair = [m for m in split if m["multiplier"].imag != 0]
        assert len(pair) == 2
        v0, v1 = (np.array(list(m["eigenvector"].values())) for m in pair)
        assert np.max(np.abs(v0 - np.conj(v1))) < 1e-12


def test_block_diagonal_monodromy_has_exact_shares_and_no_zero_division():
    """Without coupling (a block-diagonal monodromy, as of a symmetric gait) the longitudinal modes'
    lateral share is exactly 0 and no 0/0 is evaluated (warnings are errors); the lateral modes have a
    share of 1 and the labels of the split monodromy."""
    for seed in range(4):
        M = _monodromy(seed)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            coupled = coupled_modes(M[:8, :8], T, U)
        lon = [m for m in coupled if m["label"] == "longitudinal"]
        lat = [m for m in coupled if m["label"] != "longitudinal"]
        assert len(lon) == len(lat) == 4
        assert all(m["lateral_share"] == 0.0 for m in lon)
        assert all(abs(m["lateral_share"] - 1.0) < 1e-15 for m in lat)
        split = lateral_modes(M, T, U)
        assert sorted((m["label"], round(abs(m["multiplier"]), 12)) for m in lat) == \
            sorted((m["label"], round(abs(m["multiplier"]), 12)) for m in split)
