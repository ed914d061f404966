"""``birdocp animate`` and the geometry it draws (birdocp.bird.snapshots).

The wing must morph as prescribed: tips below the shoulders at the bottom of the downstroke and
above at the top of the upstroke, the wing folded (shorter span) during the upstroke, both wings
mirror images (geometry and circulation).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def run_cli(*argv, cwd=None):
    return subprocess.run([sys.executable, "-m", "birdocp", *map(str, argv)], capture_output=True, text=True,
                          cwd=cwd or REPO, timeout=300)


@pytest.fixture(scope="module")
def trim_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("anim") / "trim"
    p = run_cli("trim", "--points", "3", "--steps", "48", "--out", out, "--json")
    assert p.returncode == 0, p.stderr
    return out


def test_snapshots_wing_morphs(trim_run):
    from birdocp.bird import config as C
    from birdocp.bird.snapshots import interpolate_states, motion

    cfg = C.load(trim_run / "config.toml")
    with np.load(trim_run / "arrays.npz") as z:
        t_s, x, p = z["trajectory_t_s"], z["trajectory_x"], z["p"]
    T = cfg.gait.period_s
    times = np.array([0.0, 0.25, 0.5, 0.75]) * T        # mid-downstroke, bottom, mid-upstroke, top
    mo = motion(cfg, times, interpolate_states(t_s, x, times, T), p)
    shoulder = mo["chain_m"][:, :, 0]
    hand_tip = mo["chain_m"][:, :, 3]
    up = hand_tip[:, 1] - shoulder[:, 1]
    assert up[1] < -0.2 and up[3] > 0.2                   # bottom and top of the stroke [m]
    span = np.abs(mo["leading_edge_m"][:, 0, :]).max(axis=1)
    assert span[2] < span[0] - 0.05                        # folded on the upstroke
    # both wings: the merged lifting line is symmetric (e1 -> -e1)
    line = mo["line_m"]
    np.testing.assert_allclose(line[:, 0, ::-1], -line[:, 0, :], atol=1e-12)
    np.testing.assert_allclose(line[:, 1:, ::-1], line[:, 1:, :], atol=1e-12)
    np.testing.assert_allclose(mo["gamma_m2ps"][:, ::-1], mo["gamma_m2ps"], atol=1e-9)
    # shoulders sit root_ahead_m ahead of G (x' = -e3) and x_ep to the side
    np.testing.assert_allclose(shoulder[:, 2], -cfg.wing.root_ahead_m, atol=1e-12)
    np.testing.assert_allclose(shoulder[:, 0], cfg.wing.shoulder_half_separation_m, atol=1e-12)


def test_interpolation_and_path():
    from birdocp.bird.snapshots import earth_path, interpolate_states

    T = 0.25
    t = np.linspace(0, T, 149)
    x = np.stack([np.sin(2 * np.pi * t / T), np.cos(2 * np.pi * t / T), t * 0, t * 0], axis=1)
    tq = np.random.default_rng(0).uniform(0, 2 * T, 50)
    xi = interpolate_states(t, x, tq, T)
    np.testing.assert_allclose(xi[:, 0], np.sin(2 * np.pi * tq / T), atol=1e-5)
    # straight flight at 10 m/s, pitched 0.1 rad, w = 0: climbs at 10 sin(0.1)
    xs = np.tile([10.0, 0.0, 0.0, 0.1], (len(t), 1))
    fwd, up = earth_path(t, xs)
    np.testing.assert_allclose(fwd[-1], 10 * np.cos(0.1) * T, rtol=1e-12)
    np.testing.assert_allclose(up[-1], 10 * np.sin(0.1) * T, rtol=1e-12)


@pytest.mark.slow
def test_animate_gif(trim_run, tmp_path):
    from PIL import Image

    out = tmp_path / "bird.gif"
    p = run_cli("animate", trim_run, "--out", out, "--frames", "8", "--dpi", "30", "--json",
                "--verbose")  # README: every command takes --verbose and --debug
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert info["success"] and info["frames"] == 8 and Path(info["out"]) == out
    assert p.stderr == ""                                  # stderr is not a terminal: no bar
    with Image.open(out) as im:
        assert im.n_frames == 8
        frames = []
        for k in (0, 4):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB"), dtype=float))
    assert np.abs(frames[0] - frames[1]).mean() > 0.5      # the bird moved


@pytest.mark.parametrize("argv, key", [
    (["animate", "nowhere"], "RUN_DIR"),
    (["animate", "."], "RUN_DIR"),                          # a folder without result.json
    (["animate", "{run}", "--out", "x.avi"], "--out"),
    (["animate", "{run}", "--out", "no/such/dir/x.gif"], "--out"),
    (["animate", "{run}", "--frames", "3"], "--frames"),
    (["animate", "{run}", "--fps", "nan"], "--fps"),
    (["animate", "{run}", "--frames", "100000"], "--frames"),   # was accepted: hours of drawing
    (["animate", "{run}", "--out", ""], "--out"),               # was taken for no --out
])
def test_animate_bad_input(trim_run, tmp_path, argv, key):
    argv = [a.replace("{run}", str(trim_run)) for a in argv]
    p = run_cli(*argv, cwd=tmp_path)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], p.stderr
    assert not list(tmp_path.iterdir())


def test_animate_says_when_the_run_did_not_converge(trim_run, tmp_path):
    """A failed run's last iterate is no periodic flight: drawn, but with one warning line."""
    import shutil

    run = tmp_path / "failed"
    shutil.copytree(trim_run, run)
    res = json.loads((run / "result.json").read_text())
    res.update(success=False, status="Maximum_Iterations_Exceeded")
    (run / "result.json").write_text(json.dumps(res))
    p = run_cli("animate", run, "--out", tmp_path / "a.gif", "--frames", "8", "--dpi", "20", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "did not converge" in lines[0] and "Maximum_Iterations_Exceeded" in lines[0], p.stderr


@pytest.mark.slow
def test_two_animations_of_one_file_at_once(trim_run, tmp_path):
    """Both runs write a whole file (they shared one temporary file: one could rename or delete the
    other's half-written frames)."""
    from PIL import Image

    out = tmp_path / "same.gif"
    argv = [sys.executable, "-m", "birdocp", "animate", str(trim_run), "--out", str(out), "--frames", "8",
            "--dpi", "20"]
    procs = [subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(2)]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    with Image.open(out) as im:
        assert im.n_frames == 8
    assert [f.name for f in tmp_path.iterdir()] == ["same.gif"]  # no temporary file left


def test_animate_mp4_without_ffmpeg(trim_run, tmp_path, monkeypatch):
    from matplotlib import animation

    from birdocp.cli.main import main

    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    out = tmp_path / "bird.mp4"
    assert main(["animate", str(trim_run), "--out", str(out)]) == 2
    assert not out.exists()
