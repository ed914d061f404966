"""The UVLM comparison's birdocp side (scripts/reference_uvlm): planform transfer, held loads, phase rule.

PteraSoftware itself is never imported here (it lives in its own environment); run_uvlm.py's station
builder is numpy only and is imported without it.
"""
from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDER = ROOT / "scripts" / "reference_uvlm"


def _module(name: str):
    sys.path[:0] = [str(ROOT / "scripts"), str(FOLDER)]
    try:
        spec = importlib.util.spec_from_file_location(f"reference_uvlm_{name}", FOLDER / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    finally:
        del sys.path[:2]


@pytest.fixture(scope="module")
def inputs():
    from birdocp.bird.config import Config, to_dict

    mi = _module("make_inputs")
    cfg = Config()
    held = mi.held_state(cfg)
    return {"config": to_dict(cfg), "trim": held, "rigid_gait": mi.rigid_gait(cfg),
            "wing": {"edges": mi.planform(cfg), "shoulder_half_separation_m": cfg.wing.shoulder_half_separation_m,
                     "root_ahead_m": cfg.wing.root_ahead_m}}


def test_uvlm_planform_has_birdocp_area_and_root_chord(inputs):
    """The UVLM's stations (body strip + 12 strips, 2 % of the tip dropped) carry birdocp's wing: the
    area of the rigid wing's lifting line within 2 %, its root chord exactly."""
    st = _module("run_uvlm").stations(inputs, 12)
    y, c = st["y_m"], st["chord_m"]
    area = 2 * float(np.sum(np.diff(y) * 0.5 * (c[1:] + c[:-1])))
    edges = inputs["wing"]["edges"]
    assert area == pytest.approx(edges["lifting_line_area_m2"], rel=0.02)
    root = edges["trailing_edge"]["aft_m"][0] - edges["leading_edge"]["aft_m"][0]
    assert c[0] == c[1] == pytest.approx(root, abs=1e-3)
    assert np.all(np.diff(y) > 0) and np.all(c > 0)


def test_held_gait_lift_balances_weight(inputs):
    """With the body held at the trim state's means, the reference gait's cycle-mean lift is the
    weight and its mean thrust ~0 (the trimmed cycle has no drag to balance): the lift/thrust
    decomposition and the held-state evaluation are right."""
    cmp = _module("compare")
    case = {"name": "gait", "frequency_hz": inputs["config"]["gait"]["frequency_hz"]}
    r = cmp.birdocp_case(inputs, case, "gait", "none", 1)
    weight = inputs["config"]["body"]["mass_kg"] * inputs["config"]["body"]["gravity_mps2"]
    assert r["mean_lift_N"] == pytest.approx(weight, rel=0.01)
    assert abs(r["mean_thrust_N"]) < 0.01 * weight
    rigid = cmp.birdocp_case(inputs, case, "rigid", "none", 1)
    assert rigid["mean_thrust_N"] > 1.0  # a rigid wing that never folds pushes: not the trimmed gait


def test_peak_phase_rule_recovers_a_shifted_cosine():
    cmp = _module("compare")
    for phase in (0.0, 3.3, 47.0, 359.0):
        n = 135
        s = np.arange(n) / n * 2 * math.pi
        v = np.cos(s - math.radians(phase))
        got = cmp.peak_phase_deg(v)
        assert min(abs(got - phase), 360 - abs(got - phase)) < 0.2


def test_wagner_column_is_a_one_line_error_until_the_option_exists(tmp_path):
    cmp = _module("compare")
    if cmp.unsteady_supported():
        pytest.skip("this birdocp has aero.unsteady")
    out = subprocess.run([sys.executable, str(FOLDER / "compare.py"), "--unsteady", "wagner", "--out",
                          str(tmp_path / "o")], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and "aero.unsteady" in out.stderr
    assert not any((tmp_path / "o").iterdir()) if (tmp_path / "o").exists() else True
