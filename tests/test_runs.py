"""Run folders (unique, atomic) and provenance."""

from __future__ import annotations

import hashlib
import json
import threading

import numpy as np
import pytest

from birdocp.bird import config as C
from birdocp.io import files as bio
from birdocp.io import provenance as P
from birdocp.io import runs
from birdocp.bird.config import ConfigError


def _leftovers(folder):
    return [p.name for p in folder.iterdir() if p.name.endswith(".tmp")]


# ---------------------------------------------------------------------------------------------
# unique folders

def test_new_run_dir_names_and_uniqueness(tmp_path):
    dirs = [runs.new_run_dir(tmp_path / "runs", "trim") for _ in range(50)]
    assert len(set(dirs)) == 50
    for d in dirs:
        assert d.is_dir() and d.parent == tmp_path / "runs"
        date, clock, command, token = d.name.split("-")
        assert len(date) == 8 and len(clock) == 6 and command == "trim" and len(token) == 6


def test_new_run_dir_concurrent(tmp_path):
    out, lock = [], threading.Lock()

    def work():
        for _ in range(20):
            d = runs.new_run_dir(tmp_path, "trim")
            with lock:
                out.append(d)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(out) == 160 and len(set(out)) == 160


def test_new_run_dir_retries_on_collision(tmp_path, monkeypatch):
    tokens = iter(["aaaaaa", "aaaaaa", "bbbbbb"])
    monkeypatch.setattr(runs.secrets, "token_hex", lambda n: next(tokens))
    monkeypatch.setattr(runs.time, "strftime", lambda fmt: "20250101-000000")
    a = runs.new_run_dir(tmp_path, "trim")
    b = runs.new_run_dir(tmp_path, "trim")  # same name first: must not reuse the folder
    assert a.name == "20250101-000000-trim-aaaaaa" and b.name == "20250101-000000-trim-bbbbbb"


def test_new_run_dir_default_base_and_base_is_a_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    d = runs.new_run_dir(None, "trim")
    assert d.parent.resolve() == (tmp_path / "runs").resolve()
    (tmp_path / "file").write_text("x")
    with pytest.raises(ConfigError):
        runs.new_run_dir(tmp_path / "file", "trim")


def test_claim_out_dir(tmp_path):
    assert runs.claim_out_dir(tmp_path / "new" / "deep", "trim").is_dir()
    (tmp_path / "empty").mkdir()
    assert runs.claim_out_dir(tmp_path / "empty", "trim") == tmp_path / "empty"
    (tmp_path / "f").write_text("x")
    with pytest.raises(ConfigError, match="existing file") as e:
        runs.claim_out_dir(tmp_path / "f", "trim")
    assert e.value.key == "--out"
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with pytest.raises(ConfigError, match="not empty"):
        runs.claim_out_dir(tmp_path / "full", "trim")
    prev = tmp_path / "prev"
    runs.write_run(prev, C.Config(), {"success": True}, None, ["birdocp", "trim"], command="trim")
    assert runs.is_run_dir(prev, "trim") and not runs.is_run_dir(prev, "sweep")
    with pytest.raises(ConfigError, match="previous 'trim' run"):
        runs.claim_out_dir(prev, "trim")


# ---------------------------------------------------------------------------------------------
# atomic writes

def test_write_run_round_trip(tmp_path):
    cfg = C.with_values(C.Config(), {"gait.shoulder_flap.amplitude_deg": 30.0})
    arrays = {"t": np.linspace(0, 1, 5), "x": np.arange(20.0).reshape(5, 4)}
    path = runs.write_run(tmp_path, cfg, {"success": True, "wall_s": {"total": 1.5}, "z": [1 + 2j]},
                          arrays, ["birdocp", "trim"], command="trim")
    assert path == tmp_path / "result.json"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(runs.RUN_FILES)
    assert C.load(tmp_path / "config.toml") == cfg
    res = json.loads(path.read_text())
    assert res["z"] == [[1.0, 2.0]] and res["provenance"]["wall_s"] == {"total": 1.5}
    with np.load(tmp_path / "arrays.npz") as z:
        assert np.array_equal(z["x"], arrays["x"])


def test_atomic_file_leaves_nothing_when_the_writer_raises(tmp_path):
    target = tmp_path / "arrays.npz"
    with pytest.raises(RuntimeError):
        with runs.atomic_file(target) as fh:
            fh.write(b"half of the data")
            raise RuntimeError("disk full")
    assert list(tmp_path.iterdir()) == []
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with runs.atomic_file(target) as fh:
            fh.write(b"new, partial")
            raise RuntimeError("disk full")
    assert target.read_bytes() == b"old" and _leftovers(tmp_path) == []


def test_write_run_midway_failure_leaves_no_partial_file(tmp_path, monkeypatch):
    real_savez = np.savez

    def savez_then_fail(fh, **arrays):
        real_savez(fh, **arrays)  # the bytes are in the temp file...
        raise OSError("disk full")  # ...but the write did not finish

    monkeypatch.setattr(np, "savez", savez_then_fail)
    with pytest.raises(OSError):
        runs.write_run(tmp_path, C.Config(), {"success": True}, {"x": np.ones(3)}, ["birdocp"], command="trim")
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == []  # the files appear together or not at all: no config.toml alone, no temp files
    assert not runs.is_run_dir(tmp_path)


def test_json_write_failure_keeps_the_old_file(tmp_path, monkeypatch):
    target = tmp_path / "result.json"
    target.write_text('{"old": true}\n')

    def fsync_fails(fd):
        raise OSError("I/O error")

    from birdocp.engine import atomic

    monkeypatch.setattr(atomic.os, "fsync", fsync_fails)
    with pytest.raises(OSError):
        bio.atomic_write_json(target, {"new": True})
    assert json.loads(target.read_text()) == {"old": True}
    assert _leftovers(tmp_path) == []


# ---------------------------------------------------------------------------------------------
# provenance

FIELDS = {"birdocp_version", "git", "python", "casadi", "numpy", "ipopt_linear_solver", "platform",
          "cpu_count", "config", "config_sha256", "command_line", "timestamp_utc", "wall_s"}


def test_provenance_fields():
    cfg = C.Config()
    prov = P.provenance(cfg, ["birdocp", "trim"], {"total": 2.0})
    assert FIELDS <= set(prov)
    assert prov["ipopt_linear_solver"] == "mumps"
    assert prov["config"] == C.to_dict(cfg)
    assert prov["command_line"] == ["birdocp", "trim"]
    assert prov["birdocp_version"]
    assert prov["numpy"] == np.__version__
    assert prov["timestamp_utc"].endswith("+00:00")
    git = prov["git"]
    assert git is None or (len(git["commit"]) == 40 and isinstance(git["dirty"], bool))
    json.dumps(prov)  # JSON-able as is


def test_git_revision_outside_a_checkout(tmp_path):
    assert P.git_revision(tmp_path) is None


def test_config_hash_is_stable_and_sensitive():
    a = C.Config()
    b = C.from_dict(C.to_dict(C.Config()))
    c = C.loads(C.dumps(a))
    h = P.config_hash(a)
    assert h == P.config_hash(b) == P.config_hash(c)
    assert h == hashlib.sha256(P.canonical_toml(a).encode()).hexdigest()
    assert len(h) == 64
    changed = C.with_values(a, {"body.mass_kg": 1.2000001})
    assert P.config_hash(changed) != h
    assert P.provenance(a, None)["config_sha256"] == h
