"""The on-disk store of pre-grid values, the shared stage-data memo and the chunked mapaccum (issue 20).

Each speed-up must leave every number unchanged: the stored arrays are the computed doubles, the
chunked accumulation runs the same steps in the same order, and the validity from the stage data
equals the validity from evaluating the wing again at the trajectory times.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from birdocp.engine import datastore
from birdocp.engine.integrate import RK4Grid, clear_stage_data
from birdocp.engine.rk4 import accumulate, rk4_step


@pytest.fixture
def store_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("BIRDOCP_CACHE", str(tmp_path))
    monkeypatch.delenv("BIRDOCP_GRAPH_CACHE", raising=False)
    return tmp_path


def test_store_round_trip_exact(store_dir):
    a = np.random.default_rng(1).normal(size=(7, 11))
    key = {"pre": "abc", "values": [repr(0.1)]}
    assert datastore.load("k", key) is None
    assert datastore.store("k", key, a) is not None
    b = datastore.load("k", key)
    assert b is not None and b.dtype == float and np.array_equal(a, b)


def test_store_rejects_foreign_and_corrupt(store_dir):
    a = np.arange(12.0).reshape(3, 4)
    key = {"pre": "abc"}
    path = datastore.store("k", key, a)
    # a file renamed to another key's name (foreign): rejected and removed
    other = {"pre": "xyz"}
    path.rename(datastore._path("k", other, None))
    assert datastore.load("k", other) is None
    assert not datastore._path("k", other, None).exists()
    # a truncated file: rejected and removed, then recomputed by the caller
    path = datastore.store("k", key, a)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    assert datastore.load("k", key) is None
    assert not path.exists()
    # values changed behind the checksum's back: rejected
    path = datastore.store("k", key, a)
    with np.load(path) as z:
        parts = {k: z[k] for k in z.files}
    parts["values"] = parts["values"] + 1.0
    np.savez(path.with_suffix(".tmp.npz"), **parts)
    path.with_suffix(".tmp.npz").replace(path)
    assert datastore.load("k", key) is None


def test_store_disabled(store_dir, monkeypatch):
    monkeypatch.setenv("BIRDOCP_GRAPH_CACHE", "0")
    assert datastore.store("k", {"a": 1}, np.zeros(3)) is None
    assert datastore.load("k", {"a": 1}) is None


def test_pre_grid_from_disk_equals_computed(store_dir, default_model):
    """A new process (simulated: memo cleared) reads pre's grid from disk: the same doubles, and
    the stage blocks built from them equal the plain data grid sliced into blocks."""
    m = default_model
    if not m.ode.graph_key:
        pytest.skip("graph cache disabled: no graph_key")
    grid = RK4Grid(m.ode, 148, 4)
    clear_stage_data()
    computed = np.asarray(grid.pre_numeric(0.0, m.p0))
    assert len(list(datastore.folder().glob("pre-grid-*.npz"))) == 1
    clear_stage_data()
    loaded = np.asarray(grid.pre_numeric(0.0, m.p0))
    assert np.array_equal(computed, loaded)
    blocks = np.asarray(grid.blocks_numeric(0.0, m.p0))
    plain = np.asarray(grid.data_grid(ca.DM(grid.times(0.0)), ca.DM(m.p0)))[:, grid.block_index]
    assert np.array_equal(blocks, plain)


@pytest.mark.parametrize("n", [37, 148, 151])
def test_accumulate_is_mapaccum(default_model, n):
    """Chunked accumulation = one mapaccum, bit for bit (148 = 2 x 74 chunks; 151 is prime: one piece)."""
    m = default_model
    step = rk4_step(m.ode)
    x = ca.MX.sym("x", 4)
    D = ca.MX.sym("D", m.ode.nd, 3 * n)
    p = ca.MX.sym("p", m.ode.np)
    h = 1.0 / 4.0 / 148
    ref = ca.Function("ref", [x, D, p], list(step.mapaccum("a", n)(x, D, p, h)))
    new = ca.Function("new", [x, D, p], accumulate(step, n, x, D, p, h))
    grid = RK4Grid(m.ode, 148, 1)
    B = np.asarray(grid.blocks_numeric(0.0, m.p0))
    Dn = ca.DM(np.tile(B, (1, 2))[:, : 3 * n])
    args = (ca.DM([18.0, 0.5, 0.1, 0.01]), Dn, ca.DM(m.p0))
    for a, b in zip(ref(*args), new(*args)):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_grid_validity_equals_cycle_validity(reference_trim):
    """The validity from the solve's stage data equals the one that evaluates the wing again."""
    from birdocp.bird.validity import cycle_validity, grid_validity

    c = reference_trim.cycle
    n = int(c.method["steps_per_period"])
    a = grid_validity(reference_trim.cfg, c.trajectory_x, c.p, float(c.trajectory_t[0]), n).to_dict()
    b = cycle_validity(reference_trim.cfg, c.trajectory_t, c.trajectory_x, c.p).to_dict()
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], float):
            assert a[k] == pytest.approx(b[k], rel=1e-12, abs=1e-12), k
        else:
            assert a[k] == b[k], k
