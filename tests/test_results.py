"""The one serialiser of results (birdocp.engine.results): its conventions round-trip through JSON,
and every result type of the package writes its JSON through it."""
from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import json
import math
import pkgutil
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

import birdocp
from birdocp.engine import results
from birdocp.engine.results import result_dict, serial, to_jsonable


@dataclass
class _Inner:
    period_s: float
    multipliers: np.ndarray = field(metadata=serial(complex=True))


@dataclass
class _Outer:
    amplitude_deg: float
    speed_mps: float
    x0: np.ndarray
    modes: np.ndarray = field(metadata=serial(complex=True, columns=True))
    inner: _Inner
    inners: list
    history: np.ndarray = field(metadata=serial(skip=True))
    measures: dict = field(default_factory=dict, metadata=serial(flatten=True))
    wall: float = field(default=0.0, metadata=serial(key="wall_s"))

    @property
    def speed_kmph(self) -> float:
        return self.speed_mps * 3.6


def _json_roundtrip(d):
    return json.loads(json.dumps(d, allow_nan=False))


def test_conventions_round_trip_through_json():
    lam = np.array([1.5 + 0.25j, 1.5 - 0.25j, -0.5, 0.0])  # already largest modulus first
    modes = np.array([[1 + 1j, 2.0], [3.0, 4 - 1j]])
    obj = _Outer(amplitude_deg=42.5, speed_mps=float("nan"), x0=np.array([18.0, np.inf, -1.0]), modes=modes,
                 inner=_Inner(np.float64(0.25), np.array([0.5, 0.25])),  # real values of a complex field
                 inners=[_Inner(1.0, lam)], history=np.zeros(1000),
                 measures={"alpha_max_deg": np.float32(12.5), "stalled_fraction": float("nan")}, wall=np.float64(3.0))
    d = result_dict(obj, derived=("speed_kmph",), extra={"valid": np.bool_(True), "count": np.int64(7)})
    back = _json_roundtrip(d)
    assert back == d  # plain JSON types only: nothing changes through json
    assert list(back)[:5] == ["amplitude_deg", "speed_mps", "x0", "modes", "inner"]  # declaration order
    assert back["amplitude_deg"] == 42.5 and back["speed_mps"] is None and back["speed_kmph"] is None  # NaN -> null
    assert back["x0"] == [18.0, None, -1.0]  # inf -> null
    assert back["modes"] == [[[1.0, 1.0], [3.0, 0.0]], [[2.0, 0.0], [4.0, -1.0]]]  # one list of pairs per column
    assert back["inner"] == {"period_s": 0.25, "multipliers": [[0.5, 0.0], [0.25, 0.0]]}  # pairs even when real
    pairs = back["inners"][0]["multipliers"]
    assert np.array_equal([complex(a, b) for a, b in pairs], lam)  # the order is kept, values exact
    assert "history" not in back and "measures" not in back  # skipped; flattened
    assert back["alpha_max_deg"] == 12.5 and back["stalled_fraction"] is None
    assert back["wall_s"] == 3.0 and "wall" not in back  # renamed
    assert back["valid"] is True and back["count"] == 7 and isinstance(back["count"], int)
    # a nested dataclass without to_dict goes through result_dict; with to_dict, through its to_dict
    assert to_jsonable({"a": _Inner(1.0, [2j])}) == {"a": {"period_s": 1.0, "multipliers": [[0.0, 2.0]]}}
    assert to_jsonable((1 + 2j, np.complex128(-1j), Path("/tmp/x"))) == [[1.0, 2.0], [-0.0, -1.0], "/tmp/x"]
    with pytest.raises(TypeError):
        result_dict({"not": "a dataclass"})


def test_io_and_the_engine_write_json_through_the_same_function():
    from birdocp.engine import floquet
    from birdocp.engine.continuation import branch
    from birdocp.io import files

    assert files.to_jsonable is results.to_jsonable
    assert floquet.complex_pairs is results.complex_pairs
    assert branch.finite_or_none is results.finite_or_none
    assert results.finite_or_none(float("inf")) is None and results.finite_or_none(np.float64(2.5)) == 2.5


# ------------------------------------------------------------------------------------------------
# every result type of the package

def _result_types() -> dict:
    """Dataclasses of birdocp that define ``to_dict`` (public ones: name without a leading _)."""
    found = {}
    for info in pkgutil.walk_packages(birdocp.__path__, "birdocp."):
        if info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        for name, cls in vars(mod).items():
            if (inspect.isclass(cls) and cls.__module__ == mod.__name__ and dataclasses.is_dataclass(cls)
                    and "to_dict" in vars(cls) and not name.startswith("_")):
                found[f"{mod.__name__}.{name}"] = cls
    return found


def _tiny_instances() -> dict:
    """One small instance of each result type (with NaN, complex and array fields where it has them)."""
    from birdocp.bird.config import PARAM_NAMES, Config
    from birdocp.bird.validity import CycleValidity
    from birdocp.engine.continuation.branch import Branch, BranchPoint, SpecialPoint
    from birdocp.engine.equilibria import Equilibrium, EquilibriumBranch, EquilibriumFold, EquilibriumPoint, HopfPoint
    from birdocp.engine.floquet import FloquetResult
    from birdocp.engine.lyapunov import LyapunovResult
    from birdocp.engine.orbit_result import OrbitResult
    from birdocp.export.codegen import ExportInfo
    from birdocp.studies.control import Controller, WingbeatMap
    from birdocp.studies.gait import GaitOptimum
    from birdocp.studies.lateral import LateralTrimResult
    from birdocp.studies.lateral_simulate import LateralSimulation
    from birdocp.studies.optimize import StabilityOptimum
    from birdocp.studies.sensitivity import SensitivityResult
    from birdocp.studies.simulate import SimulationResult
    from birdocp.studies.trim import TrimResult

    nan, lam = float("nan"), np.array([2.0 + 0.0j, 0.5 + 0.1j, 0.5 - 0.1j, 0.01 + 0.0j])
    x4, p = np.array([18.0, 0.5, 0.0, 0.01]), np.zeros(len(PARAM_NAMES))
    validity = CycleValidity(True, [], {"alpha_eff_max_deg": 9.0, "stalled_fraction": nan}, {"stall_deg": 15.0})
    cycle = OrbitResult(True, "converged", "ok", 3, np.array([1.0, 1e-12]), {"total": 0.1},
                        np.array([0.0, 0.125]), np.vstack([x4, x4]), x4, p, {}, np.array([0.0, 0.25]),
                        None, 1e-12, {"vertical_speed_mps": 0.0, "forward_speed_mps": 18.0},
                        monodromy=np.eye(4), multipliers=lam, eigenvectors=np.eye(4, dtype=complex),
                        floquet_exponents=np.log(lam) / 0.25, doubling_times_s=np.array([0.1, -1, -1, np.inf]),
                        stable=False, period=0.125, formulation="data_split")
    trim = TrimResult(cycle, Config())
    trim.__dict__["_validity"] = validity
    point = BranchPoint(0.1, [1.0, 2.0], [[1.0, 2.0]], {}, [[0.5, 0.0]], [0.5], True, {}, 0.0, 1.0, 2, 1e-12,
                        0.0, {"fold": nan})
    special = SpecialPoint("fold", 0.2, [[1.0, 0.0]], [1.0], {}, [1.0, 2.0], 0.1, (0, 1), True, 4, nan)
    wmap = WingbeatMap(["gait.shoulder_flap.amplitude_deg"], 1, 48, x4, p, x4[None, :], 0.5 * np.eye(4)[None],
                       np.ones((1, 4, 1)))
    hopf = HopfPoint(np.zeros(2), np.zeros(3), 0, 1.0, np.array([1.0, 1j]), 1e-14)
    return {
        "birdocp.engine.continuation.branch.BranchPoint": point,
        "birdocp.engine.continuation.branch.SpecialPoint": special,
        "birdocp.engine.continuation.branch.Branch": Branch("mu", [point], [special], "reached_to", "", {}, 1.5),
        "birdocp.bird.validity.CycleValidity": validity,
        "birdocp.engine.floquet.FloquetResult": FloquetResult(
            np.diag([2.0, 1.0]), np.array([2.0 + 0j, 1.0 + 0j]), np.eye(2, dtype=complex),
            np.array([0.69 + 0j, 0j]), np.array([1.0, np.inf]), False, 1e-15, [np.diag([2.0, 1.0])]),
        "birdocp.engine.lyapunov.LyapunovResult": LyapunovResult(
            np.array([0.9]), np.array([0.1]), 20.0, 0.01, 1.0, 10, np.ones((10, 1)), np.arange(3.0),
            np.ones((3, 1)), np.ones(3)),
        "birdocp.engine.equilibria.Equilibrium": Equilibrium(True, "converged", np.zeros(2), np.zeros(3), 0.0, 1,
                                                             np.array([-0.5 + 1j, -0.5 - 1j]), np.eye(2), True),
        "birdocp.engine.equilibria.HopfPoint": hopf,
        "birdocp.engine.equilibria.EquilibriumPoint": EquilibriumPoint(0.5, np.zeros(2), np.array([0.5 + 2j, 0.5 - 2j]),
                                                                       False, 0.1, 1.0),
        "birdocp.engine.equilibria.EquilibriumFold": EquilibriumFold(3, (2, 3), (0.9, 1.1)),
        "birdocp.engine.equilibria.EquilibriumBranch": EquilibriumBranch(
            0, np.array([0.0, 1.0]), np.zeros((2, 2)), np.array([[1j, -1j], [1 + 1j, 1 - 1j]]),
            np.array([True, False]), [hopf], []),
        "birdocp.engine.orbit_result.OrbitResult": cycle,
        "birdocp.export.codegen.ExportInfo": ExportInfo(Path("/tmp/c"), ["a.c"], 48, 0.25, 0.25 / 48, 3, ["x"],
                                                        [1.0], {"y": 2.0}),
        "birdocp.studies.optimize.StabilityOptimum": StabilityOptimum(
            True, "ok", "", 3, {"k": 1.0}, {"k": (1.0, 2.0)}, 40.0, 0.9, lam.real, lam, x4,
            validity=validity.to_dict()),
        "birdocp.studies.gait.GaitOptimum": GaitOptimum(
            True, "ok", "", "power", 3, 1.0, nan, {"k": 1.0}, {"k": (0.0, 2.0)}, {"k": 0.5}, 40.0, x4, lam.real,
            lam, 18.0, None, None, {"flapping_power_W": 2.0}, 1e-9, 0.0),
        "birdocp.studies.sensitivity.SensitivityResult": SensitivityResult(
            ["wing.root_ahead_m"], lam, lam[None, :], np.abs(lam)[None, :], x4[None, :], np.array([0.1]), False,
            None),
        "birdocp.studies.simulate.SimulationResult": SimulationResult(
            True, "ok", "", False, 1, np.arange(3.0), np.tile(x4, (3, 1)), np.arange(3.0), np.zeros(3),
            np.zeros(0), np.zeros((0, 0)), [], np.array([0.01, 0.001]), False, 4.5),
        "birdocp.studies.trim.TrimResult": trim,
        "birdocp.studies.lateral.LateralTrimResult": LateralTrimResult(
            cycle, lam, lam, lam, 1.0, 1e-16, [{"multiplier": 0.5 + 0.1j, "label": "dutch_roll_like",
                                                "beats_to_double": -2.0, "eigenvector": {"v_mps": 1j},
                                                "dominant_state": "v_mps"}],
            {"roll_inertia_kgm2": 0.011}, 42.0, validity),
        "birdocp.studies.lateral_simulate.LateralSimulation": LateralSimulation(
            True, "ok", "", False, 1, np.arange(3.0), np.zeros((3, 9)), np.zeros((3, 3)), np.zeros(0),
            np.zeros((0, 0)), [], np.array([0.01, 0.001]), False, None, [0.0] * 9, 4.5),
        "birdocp.studies.control.Controller": Controller(wmap, np.eye(4), np.eye(1), np.eye(4), np.ones((1, 1, 4)),
                                                         np.array([[-10.0, 10.0]]),
                                                         [{"control": wmap.controls[0], "stabilisable": True}]),
    }


def test_every_result_type_serialises_through_the_one_function(monkeypatch):
    types = _result_types()
    tiny = _tiny_instances()
    assert set(types) == set(tiny), f"add a tiny instance of each new result type: {sorted(set(types) ^ set(tiny))}"
    calls = []
    real = results.to_jsonable
    monkeypatch.setattr(results, "to_jsonable", lambda v: calls.append(1) or real(v))
    for name, cls in types.items():
        # statically: to_dict returns result_dict(...) (of itself, or of the result it wraps)
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls.to_dict)))
        returns = [n.value for n in ast.walk(tree) if isinstance(n, ast.Return)]
        assert returns and all(isinstance(r, ast.Call) and getattr(r.func, "id", None) == "result_dict"
                               for r in returns), name
        # and in fact: the output of a tiny instance is plain JSON made by the serialiser
        calls.clear()
        d = tiny[name].to_dict()
        assert calls, f"{name}.to_dict did not call the serialiser"
        assert json.loads(json.dumps(d, allow_nan=False)) == d, name
    # the conventions, on the results themselves
    trim = tiny["birdocp.studies.trim.TrimResult"].to_dict()
    assert trim["multipliers"][0] == [2.0, 0.0] and trim["moduli"][0] == 2.0
    assert trim["eigenvectors"][1] == [[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 0.0]]  # mode 1
    assert trim["doubling_times_s"][-1] is None and trim["validity"]["stalled_fraction"] is None
    assert {"floquet_exponents_per_s", "shooting_times_s", "amplitude_deg"} <= set(trim)
    assert not {"trajectory_t", "trajectory_x"} & set(trim)
    opt = tiny["birdocp.studies.optimize.StabilityOptimum"].to_dict()
    assert opt["multipliers"][1] == [0.5, 0.0] and opt["bounds"] == {"k": [1.0, 2.0]}  # real values stay pairs
    assert opt["active_bounds"] == ["k"] and opt["stable"] is False and "cfg" not in opt
    sim = tiny["birdocp.studies.simulate.SimulationResult"].to_dict()
    assert sim["distance_per_beat_m"] == 4.5 and sim["max_airflow_body_angle_deg"] is None and "t_s" not in sim
    assert sim["final_deviation"] == 0.001 and sim["beats_simulated"] == 1 and sim["controls"] == []
    branch = tiny["birdocp.engine.continuation.branch.Branch"].to_dict()
    assert branch["wall_s"] == {"total": 1.5} and branch["points"][0]["tests"] == {"fold": None}
    assert branch["special_points"][0]["between"] == [0, 1] and branch["special_points"][0]["test_value"] is None
    fl = tiny["birdocp.engine.floquet.FloquetResult"].to_dict()
    assert fl["multipliers"] == [[2.0, 0.0], [1.0, 0.0]] and fl["doubling_times_s"] == [1.0, None]
    assert fl["monodromy"] == [[2.0, 0.0], [0.0, 1.0]] and fl["stable"] is False
    ly = tiny["birdocp.engine.lyapunov.LyapunovResult"].to_dict()
    assert ly["lyapunov_exponents"] == [0.9] and ly["kaplan_yorke_dimension"] is None and "history" not in ly
    assert math.isclose(ly["sum"], 0.9)
