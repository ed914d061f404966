"""The lateral Floquet modes over the wingbeat (birdocp.studies.lateral_modes, birdocp.plots.lateral)
and `birdocp plot` of a six-degree-of-freedom trim run."""
from __future__ import annotations

import json
import numpy as np
import pytest

from birdocp.bird.config import Config
from birdocp.engine import OrbitMethod
from birdocp.studies.lateral import lateral_trim
from birdocp.studies.lateral_modes import lateral_mode_histories


@pytest.fixture(scope="module")
def coarse_six():
    cfg = Config()
    res = lateral_trim(cfg, method=OrbitMethod(points=3, steps_per_period=48))
    assert res.success
    return cfg, res


def test_mode_histories_are_periodic_and_start_on_the_eigenvectors(coarse_six):
    cfg, res = coarse_six
    h = lateral_mode_histories(res, cfg)
    assert h["monodromy_error"] < 1e-9  # the stepped Phi(T) is the engine's monodromy
    assert len(h["modes"]) == 4 and len(h["t_s"]) == 49
    for m, ref in zip(h["modes"], res.lateral_modes):
        q = m["history"]
        assert np.abs(q).max() == pytest.approx(1.0)
        np.testing.assert_allclose(q[-1], q[0], rtol=0, atol=1e-7)  # periodic: q(T) = q(0)
        v = np.array([ref["eigenvector"][k] for k in ("v_mps", "p_radps", "r_radps", "phi_rad")])
        c = np.vdot(v, q[0]) / np.vdot(v, v)  # q(0) is the (scaled) eigenvector of the lateral block
        np.testing.assert_allclose(q[0], c * v, rtol=0, atol=1e-8)
        assert abs(c) > 1e-3


def test_plot_draws_the_lateral_modes_of_a_six_dof_trim_run(tmp_path, capsys):
    from birdocp.cli.main import main

    run = tmp_path / "run"
    assert main(["trim", "--set", "model.degrees_of_freedom=6", "--points", "3", "--steps", "48", "--quiet",
                 "--out", str(run)]) == 0
    capsys.readouterr()
    assert main(["plot", str(run), "--json"]) == 0
    figs = json.loads(capsys.readouterr().out)["figures"]
    for label in ("roll_subsidence", "spiral", "dutch_roll_like"):
        assert f"lateral_mode_{label}.png" in figs
        assert (run / f"lateral_mode_{label}.png").stat().st_size > 10_000
    assert main(["animate", str(run), "--bank-deg", "99"]) == 2
    err = capsys.readouterr().err
    assert "--bank-deg" in err and len(err.strip().splitlines()) == 1


def test_perturbed_flight_follows_the_monodromy_and_banks_the_right_wing_down(coarse_six):
    from birdocp.plots.animation_lateral import _world
    from birdocp.studies.lateral_motion import perturbed_flight

    cfg, res = coarse_six
    c = res.cycle
    bank = 0.05  # deg: small, the flight after one wingbeat is the cycle plus M times the perturbation
    fl = perturbed_flight(cfg, c.x0, c.p, bank, 1, steps_per_period=48)
    dx0 = np.zeros(9)
    dx0[6] = np.radians(bank)
    dxT = fl["x"][-1] - c.x0
    np.testing.assert_allclose(dxT, np.asarray(c.monodromy) @ dx0, rtol=0, atol=2e-3 * np.radians(bank))
    east, north, up = _world(0.3, 0.0, 0.0)(np.array([[0.6], [0.0], [0.0]]))  # right wing tip, bank 0.3 rad
    assert up[0] == pytest.approx(-0.6 * np.sin(0.3)) and east[0] > 0
    east, north, up = _world(0.0, 0.0, 0.3)(np.array([[0.0], [0.0], [-1.0]]))  # the nose, heading 0.3 rad
    assert east[0] == pytest.approx(np.sin(0.3)) and north[0] == pytest.approx(np.cos(0.3))
