"""The engine's fast paths for the per-time data agree with the general ones.

* ``RK4Grid.blocks_numeric`` evaluates ``post(pre(t, p), t, p)`` with ``pre`` memoised; the general path
  is the composed ``data(t, p)``.
* A free parameter entering the data affinely with a constant coefficient (the wing-root position)
  is handled by ``data(p) = data(p_context) + C (pf - p_context)``; the general path keeps ``post`` in
  the graph. Both residuals and Jacobians must agree, and the parameter column must match central
  differences of the residual.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from birdocp.engine import shooting_graphs
from birdocp.bird.config import Config
from birdocp.engine.integrate import RK4Grid
from birdocp.bird.model import get_model
from birdocp.engine import OrbitMethod
from birdocp.engine.shooting import ShootingGraphs
from birdocp.bird.flight import flight_outputs

ROOT = "wing.root_ahead_m"


@pytest.fixture(scope="module")
def m():
    return get_model(Config())


def test_split_data_blocks_equal_composed_data(m):
    grid = RK4Grid(m.ode, 48, 2)
    p = m.p0.copy()
    for amp in (42.0, 47.5):  # the second reuses the memoised pre (amplitude is not a pre parameter)
        p[m.ode.param_names.index("gait.shoulder_flap.amplitude_deg")] = amp
        fast = np.asarray(grid.blocks_numeric(0.0, p))
        full = np.asarray(grid.data_grid(ca.DM(grid.times(0.0)), ca.DM(p)))[:, grid.block_index]
        assert np.max(np.abs(fast - full)) <= 1e-12 * max(1.0, np.max(np.abs(full)))


def _builder(m, general: bool, monkeypatch):
    if general:
        monkeypatch.setattr(shooting_graphs, "_affine_columns", lambda ode, free_idx: None)
    j = m.ode.param_names.index(ROOT)
    b = ShootingGraphs(m.ode, OrbitMethod(points=3, steps_per_period=48), (j,), (),
                 (flight_outputs()["forward_speed_mps"],))
    b.set_context(b.symbolic_context(0.0, m.p0), m.p0, np.zeros(0))
    return b


def test_affine_free_parameter_path_equals_general_path(m, monkeypatch):
    fast = _builder(m, False, monkeypatch)
    assert fast.affine
    general = _builder(m, True, monkeypatch)
    assert not general.affine
    x = np.array([15.0, 0.5, 0.0, 0.1])
    z = np.concatenate([np.tile(x, 3) + np.linspace(0.0, 0.2, 12), [0.043]])  # root moved 7 mm back
    g1, J1 = fast.evaluate(z)
    g2, J2 = general.evaluate(z)
    assert np.max(np.abs(g1 - g2)) < 1e-10
    assert np.max(np.abs(J1 - J2)) < 1e-9 * np.max(np.abs(J2))
    # the root column against central differences of the residual alone
    h = 1e-6
    zp, zm = z.copy(), z.copy()
    zp[-1] += h
    zm[-1] -= h
    fd = (fast.resid(zp) - fast.resid(zm)) / (2 * h)
    assert np.max(np.abs(fd - J1[:, -1])) < 1e-6 * np.max(np.abs(J1[:, -1]))
    assert np.max(np.abs(J1[:, -1])) > 1.0  # the root position does move the segment ends
