"""The bird's use of Newton-Picard: ``solve.solver = "auto"`` picks it for the trim of a model with
aerodynamic states (body states by Newton), and for its level flight (the free amplitude joins the
Newton subspace), and nothing else changes for the default model; the wagner cycle and its multipliers
are the full Newton's; wagner + stall level flight converges."""
import json
from pathlib import Path

import numpy as np
import pytest

from birdocp.bird.config import Config, with_values
from birdocp.engine.method import OrbitMethod
from birdocp.io.errors import ConfigError
from birdocp.studies.trim import method_of, solver_of, trim

WAGNER = {"aero.unsteady": "wagner"}


def test_auto_is_ipopt_for_the_default_model_and_newton_picard_for_an_aero_trim():
    assert Config().solve.solver == "auto" and solver_of(Config()) == "ipopt"
    # the default model's method object is the one it had before the option existed
    assert method_of(Config()) == OrbitMethod(points=5, steps_per_period=148, solver="ipopt",
                                              derivatives="exact", max_iter=100, tol=None)
    cfg = with_values(Config(), WAGNER)
    assert solver_of(cfg) == "newton-picard" and method_of(cfg).newton_states == (0, 1, 2, 3)
    # the trim's chord is the frozen monodromy (engine/newton_picard_chord.py); level flight's the subspace
    assert method_of(cfg).chord == "monodromy" and method_of(cfg, free=True).chord == "subspace"
    # level flight too: the free amplitude joins the Newton subspace (engine/newton_picard_free.py)
    assert solver_of(cfg, free=True) == "newton-picard" and method_of(cfg, free=True).newton_states == (0, 1, 2, 3)
    assert solver_of(Config(), free=True) == "ipopt"  # the default model's level flight is unchanged
    assert solver_of(with_values(cfg, {"solve.solver": "lm"})) == "lm"


def test_newton_picard_needs_aerodynamic_states():
    with pytest.raises(ConfigError, match="solve.solver"):
        with_values(Config(), {"solve.solver": "newton-picard"})
    with pytest.raises(ConfigError, match="solve.solver"):
        with_values(Config(), {"solve.solver": "newton"})


@pytest.mark.slow
def test_wagner_cycle_is_the_full_newtons():
    cfg = with_values(Config(), {**WAGNER, "solve.steps_per_period": 60})
    np_ = trim(cfg)
    full = trim(with_values(cfg, {"solve.solver": "ipopt"}))
    assert np_.success and full.success, (np_.cycle.message, full.cycle.message)
    assert np_.cycle.method["solver"] == "newton-picard" and full.cycle.method["solver"] == "ipopt"
    assert np.max(np.abs(np_.x0 - full.x0)) < 1e-9
    assert np.max(np.abs(np_.multipliers - full.multipliers)) < 1e-10


@pytest.mark.slow
def test_wagner_stall_level_flight_by_newton_picard(tmp_path, capsys):
    # `birdocp level --set aero.unsteady=wagner --set aero.section=stall --json` from the default guess
    # on a coarse grid: Newton-Picard with the amplitude in its Newton subspace converges, and its
    # amplitude and |Lambda1| are those IPOPT found on the 148-step grid (results/aero, the grid's
    # discretisation error apart: 0.015 deg and 2e-5 measured)
    from birdocp.cli.main import main

    assert main(["level", "--set", "aero.unsteady=wagner", "--set", "aero.section=stall", "--steps", "64",
                 "--json", "--out", str(tmp_path / "run")]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["success"] and d["method"]["solver"] == "newton-picard", d["message"]
    assert "newton-picard: converged" in d["message"] and d["max_residual"] <= 1e-10
    assert abs(d["mean_vertical_speed_mps"]) < 1e-9 and d["validity"]["valid"]
    ref = json.loads((Path(__file__).parents[1] / "results/aero/cases/wagner_stall.json").read_text())["level"]
    assert abs(d["amplitude_deg"] - ref["amplitude_deg"]) < 0.05
    assert abs(d["moduli"][0] - ref["lambda1"]) < 2e-3
