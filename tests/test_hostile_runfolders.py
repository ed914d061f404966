"""Hostile run folders and input files (issue 29, the read side): every command that reads a run
folder (``plot``, ``animate``, ``simulate --controller``) or a CONFIG file checks it before use: a
FIFO, socket, device or folder is refused without opening it (no hang: every special-file case runs
in a subprocess with a timeout), a damaged arrays.npz or arrays of the wrong shape for the stored
configuration, a config.toml that is not the one the result was computed from, a damaged controller:
exit 2 and one line naming the folder, the file and the problem. Resumes (``sweep``, ``continue``)
keep only points computed for their own configuration, also when the index file is damaged."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from birdocp.bird.config import PARAM_NAMES

from birdocp.cli.main import main

FAST = ["--set", "solve.steps_per_period=48", "--set", "solve.points=3"]
ANIMATE = ["--frames", "8", "--dpi", "20"]


def _inproc(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def _subproc(argv, timeout=60):
    """The CLI in a subprocess; a hang fails the test (TimeoutExpired) instead of blocking it."""
    return subprocess.run([sys.executable, "-m", "birdocp", *map(str, argv)], capture_output=True, text=True,
                          timeout=timeout)


def _bad_input(code, err, key, *words):
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith(f"birdocp: error: {key}: "), err
    for w in words:
        assert w in lines[0], lines[0]


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    """A trim run folder and a control run folder of the coarse grid (made once)."""
    base = tmp_path_factory.mktemp("hostile")
    assert main(["trim", *FAST, "--out", str(base / "trim"), "--json", "--quiet"]) == 0
    assert main(["control", *FAST, "--out", str(base / "ctl"), "--json", "--quiet"]) == 0
    return base


def _copy(folders, name, tmp_path):
    dst = tmp_path / name
    shutil.copytree(folders / name, dst)
    return dst


# the commands that read a run folder: argv with the folder at {d}, the key naming it, the folder kind
READERS = {
    "plot": (["plot", "{d}"], "RUN_DIR", "trim"),
    "animate": (["animate", "{d}", *ANIMATE, "--out", "{o}/a.gif"], "RUN_DIR", "trim"),
    "simulate": (["simulate", *FAST, "--beats", "1", "--controller", "{d}", "--out", "{o}/sim"], "--controller", "ctl"),
}


def _argv(cmd, d, o):
    argv, key, _ = READERS[cmd]
    return [a.replace("{d}", str(d)).replace("{o}", str(o)) for a in argv], key


@pytest.mark.parametrize("cmd,file", [("plot", "result.json"), ("plot", "arrays.npz"), ("animate", "result.json"),
                                      ("animate", "config.toml"), ("animate", "arrays.npz"),
                                      ("simulate", "result.json"), ("simulate", "config.toml")])
def test_fifo_in_a_run_folder_is_refused_without_hanging(folders, tmp_path, cmd, file):
    d = _copy(folders, READERS[cmd][2], tmp_path)
    os.unlink(d / file)
    os.mkfifo(d / file)  # nobody writes: an open() for reading would block forever
    argv, key = _argv(cmd, d, tmp_path)
    p = _subproc(argv, timeout=60)
    _bad_input(p.returncode, p.stderr, key, str(d), file, "FIFO")
    assert not (tmp_path / "sim").exists()


@pytest.mark.parametrize("cmd", ["plot", "simulate"])
def test_result_json_linked_to_dev_zero_is_refused(folders, tmp_path, cmd):
    d = _copy(folders, READERS[cmd][2], tmp_path)
    os.unlink(d / "result.json")
    os.symlink("/dev/zero", d / "result.json")  # would read until memory runs out
    argv, key = _argv(cmd, d, tmp_path)
    p = _subproc(argv, timeout=60)
    _bad_input(p.returncode, p.stderr, key, "result.json", "character device")


@pytest.mark.parametrize("what", ["fifo", "dev-zero", "folder"])
def test_config_file_that_is_not_a_regular_file(tmp_path, what):
    path = tmp_path / "c.toml"
    if what == "fifo":
        os.mkfifo(path)
    elif what == "folder":
        path.mkdir()
    else:
        os.symlink("/dev/zero", path)
    p = _subproc(["trim", path, "--out", tmp_path / "run"], timeout=60)
    _bad_input(p.returncode, p.stderr, "CONFIG", str(path), "not a regular file")
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("cmd,file", [("plot", "result.json"), ("animate", "arrays.npz"), ("simulate", "config.toml")])
def test_folder_instead_of_a_file(capsys, folders, tmp_path, cmd, file):
    d = _copy(folders, READERS[cmd][2], tmp_path)
    os.unlink(d / file)
    (d / file).mkdir()
    argv, key = _argv(cmd, d, tmp_path)
    _bad_input(*_inproc(capsys, argv)[::2], key, str(d), file, "is a folder")


def _truncate(path):
    b = path.read_bytes()
    path.write_bytes(b[: len(b) // 2])


def _corrupt(path):
    b = bytearray(path.read_bytes())
    b[200:400] = bytes(200)  # inside the first member: its CRC no longer matches
    path.write_bytes(bytes(b))


def _short_p(path):
    z = dict(np.load(path))
    z["p"] = z["p"][:10]
    np.savez(path, **z)


@pytest.mark.parametrize("cmd", ["plot", "animate"])
@pytest.mark.parametrize("damage,words", [(_truncate, ("cannot be read",)), (_corrupt, ("cannot be read",)),
                                          (_short_p, ("'p' has shape (10,)", f"({len(PARAM_NAMES)},)"))])
def test_damaged_arrays(capsys, folders, tmp_path, cmd, damage, words):
    d = _copy(folders, "trim", tmp_path)
    damage(d / "arrays.npz")
    argv, key = _argv(cmd, d, tmp_path)
    _bad_input(*_inproc(capsys, argv)[::2], key, str(d), "arrays.npz", *words)
    assert not (tmp_path / "a.gif").exists()


def _swap_amplitude(d, new):
    text = (d / "config.toml").read_text()
    assert "amplitude_deg = 42.0" in text
    (d / "config.toml").write_text(text.replace("amplitude_deg = 42.0", f"amplitude_deg = {new}", 1))


def test_swapped_configuration_animate(capsys, folders, tmp_path):
    d = _copy(folders, "trim", tmp_path)
    _swap_amplitude(d, "80.0")  # a 42 deg trajectory beside an 80 deg configuration
    argv, key = _argv("animate", d, tmp_path)
    _bad_input(*_inproc(capsys, argv)[::2], key, str(d), "config.toml", "config_sha256")
    assert not (tmp_path / "a.gif").exists()


def test_swapped_configuration_controller(capsys, folders, tmp_path):
    d = _copy(folders, "ctl", tmp_path)
    _swap_amplitude(d, "43.0")  # its requested_config still says 42
    code, out, err = _inproc(capsys, ["simulate", *FAST, "--amplitude", "43", "--beats", "1", "--controller", d,
                                      "--out", tmp_path / "sim"])
    _bad_input(code, err, "--controller", str(d), "config.toml", "config_sha256")
    assert not (tmp_path / "sim").exists()


def _drop_hash(d):
    r = json.loads((d / "result.json").read_text())
    del r["provenance"]["config_sha256"]
    (d / "result.json").write_text(json.dumps(r))


@pytest.mark.parametrize("cmd", ["plot", "simulate"])
def test_old_folder_without_hash_is_read_with_a_warning(capsys, folders, tmp_path, cmd):
    d = _copy(folders, READERS[cmd][2], tmp_path)
    _drop_hash(d)
    argv, key = _argv(cmd, d, tmp_path)
    code, out, err = _inproc(capsys, argv)
    assert code == 0, err
    warnings = [ln for ln in err.splitlines() if ln.startswith("birdocp: warning:")]
    assert len(warnings) == 1 and "config_sha256" in warnings[0] and str(d) in warnings[0]


@pytest.mark.parametrize("field,value,words", [
    ("controls", ["gait.nothing_deg", "gait.shoulder_flap.amplitude_deg", "gait.shoulder_sweep.offset_deg"],
     ("'controls'", "unknown control")),
    ("gains", [[0.0] * 4] * 3, ("'gains' has shape (3, 4)",)),
    ("updates_per_beat", 7, ("'updates_per_beat' is 7",)),
    ("updates_per_beat", 0, ("'updates_per_beat' is 0",)),
    ("cycle_x0", [None, 0.0, 0.0, 0.0], ("'cycle_x0'", "not finite")),
    ("limits", [[5.0, -5.0], [27.0, 57.0], [-34.0, -4.0]], ("'limits'", "LO < HI")),
])
def test_damaged_controller(capsys, folders, tmp_path, field, value, words):
    d = _copy(folders, "ctl", tmp_path)
    r = json.loads((d / "result.json").read_text())
    r[field] = value
    (d / "result.json").write_text(json.dumps(r))
    argv, key = _argv("simulate", d, tmp_path)
    _bad_input(*_inproc(capsys, argv)[::2], key, str(d), "result.json", *words)


@pytest.mark.parametrize("text,words", [
    ("[body]\nmass_kg = " + "9" * 400 + "\n", ("body.mass_kg", "400 digits")),
    ("x = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n", ("nested too deeply",)),
])
def test_toml_numbers_and_nesting_are_bad_input(capsys, tmp_path, text, words):
    path = tmp_path / "c.toml"
    path.write_text(text)
    code, out, err = _inproc(capsys, ["trim", path, "--out", tmp_path / "run"])
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err
    assert not (tmp_path / "run").exists()


def test_sweep_resume_with_damaged_index_keeps_only_its_own_points(capsys, tmp_path):
    out = tmp_path / "sw"
    argv = ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1", *FAST, "--out", out, "--quiet", "--json"]
    code, first, err = _inproc(capsys, argv)
    assert code == 0, err
    walls = [p["wall_s"] for p in json.loads(first)["points"]]
    (out / "result.json").unlink()  # as if killed before the end, and the index cut short
    (out / "sweep.json").write_text((out / "sweep.json").read_text()[:50])
    code, _, err = _inproc(capsys, [*argv, "--resume", "--set", "body.mass_kg=1.3"])
    _bad_input(code, err, "--resume", "point-0000.json", "another configuration")
    code, again, err = _inproc(capsys, [*argv, "--resume"])  # the same arguments: the points are kept
    assert code == 0, err
    assert [p["wall_s"] for p in json.loads(again)["points"]] == walls  # not solved again


def test_continue_resumes_from_the_points_on_disk(capsys, tmp_path):
    argv = ["continue", "amplitude_deg", "--from", "42", "--to", "43.5", *FAST, "--quiet", "--json"]
    code, whole, err = _inproc(capsys, [*argv, "--out", tmp_path / "whole"])
    assert code == 0, err
    whole = json.loads(whole)
    assert whole["n_points"] >= 4 and whole["resumed_points"] == 0
    # a run killed after its third point: points/ and continue.json, no result
    cut = tmp_path / "cut"
    shutil.copytree(tmp_path / "whole", cut)
    for f in ["result.json", "branch.json", "locus.png", "moduli.png"] + [
            f"points/point-{i:04d}.json" for i in range(3, whole["n_points"])]:
        (cut / f).unlink()
    code, _, err = _inproc(capsys, [*argv, "--out", cut, "--resume", "--set", "body.mass_kg=1.3"])
    _bad_input(code, err, "--resume", "differs in config")  # the index continue.json says so
    (cut / "continue.json").write_text((cut / "continue.json").read_text()[:40])  # and when it is damaged:
    code, _, err = _inproc(capsys, [*argv, "--out", cut, "--resume", "--set", "body.mass_kg=1.3"])
    _bad_input(code, err, "--resume", "point-0000.json", "another configuration")  # each point's own hash
    code, resumed, err = _inproc(capsys, [*argv, "--out", cut, "--resume"])
    assert code == 0, err
    resumed = json.loads(resumed)
    assert resumed["status"] == "reached_to" and resumed["resumed_points"] == 3
    a, b = whole["branch"]["points"], resumed["branch"]["points"]
    assert [p["x0"] for p in b[:3]] == [p["x0"] for p in a[:3]]  # kept as written
    assert b[-1]["parameter"] == pytest.approx(43.5) and np.allclose(b[-1]["x0"], a[-1]["x0"], atol=1e-7)
    assert all(x["arclength"] < y["arclength"] for x, y in zip(b, b[1:]))
    # a finished continuation is not resumed
    code, _, err = _inproc(capsys, [*argv, "--out", cut, "--resume"])
    _bad_input(code, err, "--resume", "finished")


def test_oversized_inputs_are_refused_before_reading(capsys, folders, tmp_path):
    from birdocp.io.inputs import MAX_JSON_BYTES, MAX_TEXT_BYTES

    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:  # sparse: nothing is written, the size is what counts
        fh.truncate(MAX_TEXT_BYTES + 1)
    code, _, err = _inproc(capsys, ["trim", big, "--out", tmp_path / "run"])
    _bad_input(code, err, "CONFIG", str(big), "more than the 16 MiB accepted")
    d = _copy(folders, "trim", tmp_path)
    with open(d / "result.json", "r+b") as fh:
        fh.truncate(MAX_JSON_BYTES + 1)
    _bad_input(*_inproc(capsys, ["plot", d])[::2], "RUN_DIR", "result.json", "accepted")


def test_a_foreign_member_in_arrays_npz(capsys, folders, tmp_path):
    import zipfile

    d = _copy(folders, "trim", tmp_path)
    with zipfile.ZipFile(d / "arrays.npz", "a") as z:
        z.writestr("notes.txt", "not an array")
    _bad_input(*_inproc(capsys, ["plot", d])[::2], "RUN_DIR", "arrays.npz", "'notes.txt' is not a numeric array")
