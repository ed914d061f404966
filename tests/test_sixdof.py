"""The six-degree-of-freedom bird (birdocp.bird.sixdof) against the planar model and exact properties:
a symmetric cycle is the planar cycle, its monodromy splits into longitudinal and lateral blocks,
the heading adds a multiplier 1, the equations are mirror-symmetric, and for a frozen wing the
cycle's multipliers are the exponentials of the steady glide's eigenvalues."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from birdocp.bird.config import Config, param_vector
from birdocp.bird.sixdof import (HEADING, LATERAL, LONGITUDINAL, LateralInertia, embed_planar_state,
                                 sixdof_model)
from birdocp.engine.problem import OrbitProblem
from birdocp.engine import OrbitMethod, solve
from birdocp.engine.shooting import floquet
from birdocp.studies.lateral import lateral_trim

LON, LAT = list(LONGITUDINAL), list(LATERAL) + [HEADING]
MIRROR = np.diag([1, -1, 1, -1, 1, -1, -1, 1, -1.0])  # (v, p, r, phi, psi) change sign


@pytest.fixture(scope="module")
def six(default_config):
    return sixdof_model(default_config)


def test_rhs_at_a_symmetric_state_is_the_planar_rhs(six, default_model, default_config):
    p = param_vector(default_config)
    for t in (0.0, 0.031, 0.17):
        d = default_model.data(t, p)
        x4 = [18.1, -1.3, 0.4, -0.1]
        f6 = np.array(six.rhs(embed_planar_state(x4), d, six.params(p))).ravel()
        f4 = np.array(default_model.rhs(x4, d, p)).ravel()
        np.testing.assert_allclose(f6[LON], f4, rtol=0, atol=1e-12)
        assert np.abs(f6[LAT]).max() < 1e-10  # F1 and the roll/yaw moments cancel to round-off


def test_mirror_symmetry_of_the_equations(six, default_model, default_config):
    """A symmetric gait: flipping (v, p, r, phi, psi) flips their derivatives (left and right swap)."""
    p = param_vector(default_config)
    rng = np.random.default_rng(3)
    for t in (0.02, 0.11):
        d = default_model.data(t, p)
        x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7]) + 0.1 * rng.standard_normal(9)
        f = np.array(six.rhs(x, d, six.params(p))).ravel()
        fm = np.array(six.rhs(MIRROR @ x, d, six.params(p))).ravel()
        np.testing.assert_allclose(fm, MIRROR @ f, rtol=1e-12, atol=1e-11)
        assert np.abs(f[LATERAL[0]]) > 1e-3  # sideslip does load the bird


def test_symmetric_cycle_is_the_planar_cycle_and_its_monodromy_splits(default_config, reference_trim):
    res = lateral_trim(default_config)
    assert res.success, res.cycle.message
    np.testing.assert_allclose(res.cycle.x0[LON], reference_trim.x0, rtol=0, atol=1e-9)
    assert np.abs(res.cycle.x0[LAT]).max() < 1e-9
    assert res.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers),
                               np.sort_complex(reference_trim.multipliers), rtol=0, atol=1e-9)
    assert abs(res.heading_multiplier - 1) < 1e-12
    assert len(res.lateral_multipliers) == 4 and len(res.multipliers) == 9
    d = res.to_dict()
    assert {"longitudinal_multipliers", "lateral_multipliers", "heading_multiplier", "lateral_modes"} <= set(d)


def test_frozen_wing_multipliers_are_the_glide_eigenvalues(default_config):
    """Amplitudes 0: the model is autonomous, the cycle is a steady glide and ln(Lambda)/T are the
    eigenvalues of the linearised glide (computed apart, by CasADi's Jacobian of the state equations)."""
    from birdocp.bird.config import with_values

    frozen = with_values(default_config, {f"gait.{j}.amplitude_deg": 0.0 for j in (
        "shoulder_incidence", "shoulder_flap", "shoulder_sweep", "elbow_flex", "hand_twist", "wrist_flex",
        "wrist_spread")})
    six = sixdof_model(frozen)
    p6 = six.params(param_vector(frozen), LateralInertia(roll_inertia_kgm2=0.02))
    d0 = six.planar.data(0.0, param_vector(frozen))
    x = ca.SX.sym("x", 8)
    f8 = six.rhs(ca.vertcat(x, 0), d0, p6)[:8]
    F = ca.Function("f8", [x], [f8, ca.jacobian(f8, x)])
    xe = np.array(embed_planar_state([15.0, 1.0, 0.0, -0.1]))[:8]
    for _ in range(30):  # Newton on the glide (psi drops out: nothing depends on it)
        fv, J = (np.array(v) for v in F(xe))
        xe = xe - np.linalg.solve(J, fv.ravel())
    fv, J = (np.array(v) for v in F(xe))
    assert np.abs(fv).max() < 1e-10
    lam = np.sort_complex(np.append(np.linalg.eigvals(J), 0.0))
    T = six.ode.forcing_period
    fl = floquet(six.ode, np.append(xe, 0.0), p6, OrbitMethod(points=3, steps_per_period=600))
    ln = np.sort_complex(np.log(fl.multipliers.astype(complex)) / T)
    np.testing.assert_allclose(ln.real, lam.real, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(np.abs(ln.imag), np.abs(lam.imag), rtol=1e-6, atol=1e-6)


def test_planar_terms_not_in_3d_are_refused():
    from birdocp.bird.config import with_values

    with pytest.raises(ValueError, match="aero.unsteady"):  # Wagner's added mass with wing masses: neither in 4 DOF
        with_values(Config(), {"model.degrees_of_freedom": 6, "aero.unsteady": "wagner", "wing.mass_kg": 0.1})
    with pytest.raises(ValueError, match="roll_inertia_kgm2"):
        LateralInertia(roll_inertia_kgm2=0.0)


def test_solve_from_an_asymmetric_start_returns_to_the_symmetric_cycle(six, default_config):
    p6 = six.params(param_vector(default_config))
    guess = np.array(embed_planar_state(default_config.solve.initial_guess))
    guess[LATERAL[0]] = 0.3  # a sideslipping start: the periodic orbit is still the symmetric one
    res = solve(OrbitProblem(ode=six.ode, p=p6, x_guess=guess), OrbitMethod(points=5, steps_per_period=148))
    assert res.success
    assert np.abs(res.x0[list(LATERAL)]).max() < 1e-8


def test_level_flight_in_six_dof_is_the_planar_level_flight(default_config, coarse):
    from birdocp.studies.level import level

    method = OrbitMethod(**coarse)
    six = lateral_trim(default_config, level=True, method=method)
    planar = level(default_config, **coarse)
    assert six.success and planar.success
    assert abs(six.amplitude_deg - planar.amplitude_deg) < 1e-8
    assert abs(six.mean_vertical_speed_mps) < 1e-9
    np.testing.assert_allclose(np.sort_complex(six.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-8)


def test_trim_cli_with_six_degrees_of_freedom(tmp_path):
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", "trim", "--set", "model.degrees_of_freedom=6",
                           "--points", "3", "--steps", "48", "--json", "--out", str(tmp_path / "run")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["degrees_of_freedom"] == 6 and len(r["x0"]) == 9 and len(r["multipliers"]) == 9
    assert len(r["lateral_multipliers"]) == 4 and len(r["longitudinal_multipliers"]) == 4
    assert r["state_names"][1] == "v_mps" and r["validity"]["valid"] in (True, False)
    assert {m["label"] for m in r["lateral_modes"]} <= {"spiral", "dutch_roll_like", "roll_subsidence", "lateral_real"}
    assert json.loads((tmp_path / "run" / "result.json").read_text())["heading_multiplier"] == r["heading_multiplier"]
    assert {"states.png", "multipliers.png"} <= set(_plot(tmp_path / "run"))


@pytest.mark.slow
def test_lateral_sensitivity_against_central_differences(mass_tail_config, coarse):
    """The exact derivatives of the spiral multiplier's modulus along the shoulder elevation (dihedral)
    and the tail opening, with wing masses and the tail, against central differences of re-solved
    cycles."""
    from birdocp.bird.config import get_value, with_values
    from birdocp.studies.lateral_sensitivity import lateral_sensitivities

    method = OrbitMethod(**coarse)
    keys = ["gait.shoulder_flap.offset_deg", "tail.opening_angle_deg"]
    res = lateral_trim(mass_tail_config, method=method)
    rows = lateral_sensitivities(res, mass_tail_config, keys)
    spiral = [i for i, lab in enumerate(rows[0]["labels"]) if lab == "spiral"]
    assert len(spiral) == 1 and rows[0]["labels"].count("heading") == 1

    def modulus(key, v):
        r = lateral_trim(with_values(mass_tail_config, {key: v}), method=method)
        return abs(next(m["multiplier"] for m in r.lateral_modes if m["label"] == "spiral"))

    h = 0.01
    for key, row in zip(keys, rows):
        v0 = get_value(mass_tail_config, key)
        fd = (modulus(key, v0 + h) - modulus(key, v0 - h)) / (2 * h)
        assert abs(fd) > 1e-4  # both move the spiral mode
        assert abs(row["d_moduli"][spiral[0]] - fd) < 1e-6 * max(1.0, abs(fd)), (key, row["d_moduli"][spiral[0]], fd)
        assert row["d_moduli"][row["labels"].index("heading")] == pytest.approx(0.0, abs=1e-12)


# --- wing masses and the tail in six degrees of freedom --------------------------------------------

MASS_TAIL = {"wing.mass_kg": 0.086, "tail.opening_angle_deg": 20.0}


@pytest.fixture(scope="module")
def mass_tail_config():
    from birdocp.bird.config import with_values

    return with_values(Config(), MASS_TAIL)


def test_wing_masses_and_tail_off_by_their_parameters_are_the_massless_model_bit_for_bit(mass_tail_config, six,
                                                                                          default_config):
    """The structure with wing masses and tail at wing.mass_kg = 0 and opening 0: the right-hand side
    of the massless, tailless 6-DOF model, every bit (the wing correction is an exact zero)."""
    from birdocp.bird.config import PARAM_NAMES

    heavy = sixdof_model(mass_tail_config)
    p = np.array(param_vector(mass_tail_config))
    p[[PARAM_NAMES.index("wing.mass_kg"), PARAM_NAMES.index("tail.opening_angle_deg")]] = 0.0
    x = [17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7]
    for t in (0.02, 0.13):
        d0 = six.data(t, six.params(param_vector(default_config)))
        f0 = np.array(six.rhs(x, d0, six.params(param_vector(default_config)))).ravel()
        f1 = np.array(heavy.rhs(x, heavy.data(t, heavy.params(p)), heavy.params(p))).ravel()
        assert np.array_equal(f0, f1)


def test_mirror_symmetry_with_wing_masses_and_tail(mass_tail_config):
    heavy = sixdof_model(mass_tail_config)
    p6 = heavy.params(param_vector(mass_tail_config))
    x = np.array([17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7])
    d = heavy.data(0.07, p6)
    f = np.array(heavy.rhs(x, d, p6)).ravel()
    np.testing.assert_allclose(np.array(heavy.rhs(MIRROR @ x, d, p6)).ravel(), MIRROR @ f, rtol=1e-12, atol=1e-11)


def test_one_heavy_wing_in_vacuum_conserves_momentum_and_angular_momentum(mass_tail_config):
    """No air, no gravity, only the right wing has mass (asymmetric wing motion: roll, yaw and the
    products of inertia are loaded), a tumbling start: the inertial momentum and the angular momentum
    about a fixed point of body plus wings stay constant along a wingbeat, to RK4 accuracy (the drift
    falls ~16x per halving of the step). Dropping any wing term of the equations breaks this."""
    from birdocp.studies.lateral_checks import vacuum_drift

    r = vacuum_drift(mass_tail_config, (50, 100, 200))
    assert np.abs(r["initial"][3:]).max() > 0.03  # a real angular momentum
    assert abs(r["final_state"][-1][6]) > 0.5  # the body did roll (the wing's reaction), yet H is conserved
    assert r["drift"][-1] < 5e-9
    assert all(12.0 < q < 20.0 for q in r["ratios"]), r["drift"]


def test_symmetric_cycle_with_wing_masses_and_tail_is_the_planar_cycle(mass_tail_config, coarse):
    from birdocp.studies.trim import trim

    res = lateral_trim(mass_tail_config, method=OrbitMethod(**coarse))
    planar = trim(mass_tail_config, **coarse)
    assert res.success and planar.success
    assert res.coupling_max < 1e-12
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers), np.sort_complex(planar.multipliers),
                               rtol=0, atol=1e-9)


# --- the other commands with model.degrees_of_freedom = 6 (coarse grids) ---------------------------

SIX_CLI = ["--set", "model.degrees_of_freedom=6", "--set", "solve.points=3", "--set", "solve.steps_per_period=48"]


def _cli(*args, timeout=300, six=True):
    import json
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", *args, *(SIX_CLI if six else []), "--json"],
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def _plot(folder) -> list:
    return _cli("plot", str(folder), six=False)["figures"]


def test_sweep_cli_with_six_degrees_of_freedom(tmp_path):
    import csv

    r = _cli("sweep", "root_ahead_m", "--from", "0.05", "--to", "0.045", "--step", "0.005", "--out",
             str(tmp_path / "s"))
    assert r["success"] and len(r["points"]) == 2
    for row in r["points"]:
        assert len(row["multipliers"]) == 9 and len(row["lateral_multipliers"]) == 4
        assert len(row["longitudinal_multipliers"]) == 4 and row["valid"] in (True, False)
        assert abs(row["heading_multiplier"] - 1) < 1e-9 and row["coupling_max"] < 1e-12
        assert row["lateral_modulus0"] == pytest.approx(abs(complex(*row["lateral_multipliers"][0])))
    # the warm-started second point moved: the spiral mode grows as the root moves back (Experiment 3)
    assert r["points"][1]["spiral_modulus"] > r["points"][0]["spiral_modulus"]
    with open(tmp_path / "s" / "sweep.csv") as f:
        rows = list(csv.DictReader(f))
    assert "lateral_modulus0" in rows[0] and rows[1]["valid"] in ("True", "False")
    assert _plot(tmp_path / "s") == ["sweep.png"]


def test_continue_cli_with_six_degrees_of_freedom(tmp_path):
    """The branch of the heading-free ODE: 8 multipliers per point (no structural 1 for the fold
    tests), the per-point split, and the 6-DOF trim's multipliers at the start."""
    r = _cli("continue", "root_ahead_m", "--from", "0.05", "--to", "0.048", "--out", str(tmp_path / "c"))
    assert r["success"] and r["degrees_of_freedom"] == 6
    pts = r["branch"]["points"]
    assert len(pts[0]["x0"]) == 8 and len(pts[0]["multipliers"]) == 8
    assert len(r["lateral_multipliers"]) == len(pts) == len(r["longitudinal_multipliers"])
    assert max(r["branch"]["settings"]["coupling_max"]) < 1e-12
    assert all(abs(abs(complex(*m)) - 1.0) > 1e-3 for m in pts[0]["multipliers"])
    trim6 = lateral_trim(Config(), method=OrbitMethod(points=3, steps_per_period=48))
    np.testing.assert_allclose(sorted(abs(complex(*m)) for m in r["lateral_multipliers"][0]),
                               sorted(np.abs(trim6.lateral_multipliers)), rtol=0, atol=1e-8)
    assert set(_plot(tmp_path / "c")) == {"locus.png", "moduli.png"}


@pytest.mark.slow
def test_sensitivity_cli_with_six_degrees_of_freedom(tmp_path):
    """The lateral inertia and the per-side offsets of a symmetric gait through the CLI: a right
    offset's derivatives equal the left one's (mirror symmetry) and sum to the symmetric key's (the
    symmetric offset adds to both wings: the chain rule)."""
    side = [f"gait.{s}_offset.shoulder_sweep.offset_deg" for s in ("right", "left")]
    r = _cli("sensitivity", "--param", "model.roll_inertia_kgm2", "--param", side[0], "--param", side[1],
             "--param", "gait.shoulder_sweep.offset_deg", "--out", str(tmp_path / "s"))
    assert r["success"] and len(r["multipliers"]) == 9 and len(r["lateral_multipliers"]) == 4
    row, right, left, both = r["sensitivities"]
    assert row["parameter"] == "model.roll_inertia_kgm2" and len(row["d_moduli"]) == 9
    # a roll inertia moves only the lateral modes (the longitudinal block does not contain it)
    assert abs(row["d_modulus_by_mode"]["longitudinal"]) < 1e-12 < abs(row["d_modulus_by_mode"]["spiral"])
    assert (right["parameter"], left["parameter"]) == tuple(side)
    np.testing.assert_allclose(right["d_moduli"], left["d_moduli"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.add(right["d_moduli"], left["d_moduli"]), both["d_moduli"], rtol=0, atol=1e-12)
    assert np.abs(both["d_moduli"]).max() > 1e-2


def test_sensitivity_cli_names_a_misspelt_per_side_key(tmp_path):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "birdocp", "sensitivity", "--param",
                           "gait.right_offset.shoulder_sweep.ofset_deg", *SIX_CLI, "--out", str(tmp_path / "s")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and not (tmp_path / "s").exists()
    assert "--param" in proc.stderr and "gait.right_offset.shoulder_sweep.offset_deg" in proc.stderr


def _export_six(d):
    r = _cli("export-c", "--steps", "48", "--out", str(d))
    assert "model.roll_inertia_kgm2" in r["runtime_params"] and "model.product_inertia_xz_kgm2" in r["runtime_params"]
    return r


def test_export_c_with_six_degrees_of_freedom_writes_the_9_state_model(tmp_path):
    """The exported table is the 6-DOF model's data on the RK4 stage grid, the header says 9 states."""
    import re

    r = _export_six(tmp_path / "c6")
    head = (tmp_path / "c6" / "bird.h").read_text()
    assert re.search(r"#define BIRD_NX 9\b", head) and "x[3] = p, x[4] = q, x[5] = r" in head
    cfg = Config()
    six = sixdof_model(cfg)
    assert r["n_data"] == six.rhs.size1_in(1)
    table = (tmp_path / "c6" / "bird_data.c").read_text()
    first = [float(v) for v in re.search(r"bird_data_table\[[^]]*\] = \{\s*([^}]*)", table).group(1).split(",")[:6]]
    np.testing.assert_array_equal(first, np.asarray(six.data(0.0, six.params(param_vector(cfg)))).ravel()[:6])


@pytest.mark.skipif(not __import__("os").environ.get("BIRDOCP_TEST_C6"),
                    reason="compiles the 9-state C export (about 1-2 min): set BIRDOCP_TEST_C6=1")
def test_export_c_with_six_degrees_of_freedom_matches_python(tmp_path):
    """The compiled period map and monodromy of the 9-state export against the Python RK4 map, at a
    sideslipping, rolling state (1e-10)."""
    import os
    import shutil
    import subprocess

    import casadi as ca

    from birdocp.engine.integrate import RK4Grid
    from birdocp.export.compiled import find_compiler

    cc = find_compiler()
    if cc is None:
        pytest.skip("no C compiler")
    d = tmp_path / "c6"
    _export_six(d)
    make = shutil.which("make")
    if make:
        subprocess.run([make, "-j2", "bird_period"], cwd=d, check=True, capture_output=True,
                       env=dict(os.environ, CC=" ".join(cc)))
    else:
        subprocess.run(cc + ["-O1", "-o", "bird_period", "main.c", "bird.c", "bird_casadi.c", "bird_data.c", "-lm"],
                       cwd=d, check=True, capture_output=True)
    x0 = [18.0, 0.4, -1.0, 0.2, 0.1, -0.1, 0.05, -0.1, 0.3]  # a sideslipping, rolling state
    out = subprocess.run([str(d / "bird_period"), *map(repr, x0)], capture_output=True, text=True, check=True).stdout
    rows = [np.array(line.split(), float) for line in out.splitlines() if line.strip()]
    assert len(rows) == 10 and rows[0].size == 9
    cfg = Config()
    six = sixdof_model(cfg)
    p6 = ca.DM(six.params(param_vector(cfg)))
    grid = RK4Grid(six.ode, 48, 1)
    xT, J = grid.period_jacobian(ca.DM(x0), grid.blocks_numeric(0.0, np.asarray(p6).ravel()), p6)
    assert np.max(np.abs(rows[0] - np.asarray(xT).ravel())) < 1e-10
    assert np.max(np.abs(np.vstack(rows[1:]) - np.asarray(J))) < 1e-10


def test_six_dof_validity_and_coupled_labels_of_a_symmetric_cycle_are_the_split_ones(default_config, coarse):
    """Two independent routes on a symmetric cycle: the 6-DOF validity (both wings in 3-D flow) equals
    the planar validity of its (u, w, q, theta) part, and the eigenvector-content labels of the
    unsplit 8 x 8 monodromy (lateral share exactly 0 or 1) are the split monodromy's labels."""
    from birdocp.bird.config import with_values
    from birdocp.bird.validity import periodic_validity
    from birdocp.studies.lateral import coupled_modes

    cfg = with_values(default_config, {"model.degrees_of_freedom": 6})
    res = lateral_trim(cfg, **coarse)
    six = sixdof_model(cfg)
    v6 = periodic_validity(cfg, res.cycle.x0, p=res.cycle.p, steps_per_period=coarse["steps_per_period"],
                           ode=six.ode).to_dict()
    v4 = res.validity.to_dict()
    for k, v in v4.items():
        if isinstance(v, float):
            assert abs(v6[k] - v) < 1e-9 * max(1.0, abs(v)), k
    assert v6["stalled_fraction_left"] == pytest.approx(v6["stalled_fraction_right"], abs=1e-14)
    M8 = np.asarray(res.cycle.monodromy)[:HEADING, :HEADING]
    modes = coupled_modes(M8, six.period_s, float(np.mean(res.cycle.trajectory_x[:, 0])))
    lat = [m for m in modes if m["label"] != "longitudinal"]
    assert all(m["lateral_share"] > 1 - 1e-12 or m["lateral_share"] < 1e-12 for m in modes)
    assert sorted((m["label"], round(m["multiplier"].real, 9)) for m in lat) == \
        sorted((m["label"], round(m["multiplier"].real, 9)) for m in res.lateral_modes)


DRAG = {"drag.body_drag_coefficient": 0.1, "drag.profile_drag_coefficient": 0.014}


def test_drag_in_six_dof_at_a_symmetric_state_is_the_planar_drag(default_config):
    """Body and profile drag on: the 6-DOF right-hand side at a symmetric state (v = p = r = phi = 0)
    is the planar model's with drag, and the lateral rates vanish; drag coefficients 0 give the
    drag-free 6-DOF model bit for bit."""
    from birdocp.bird.config import PARAM_NAMES, with_values
    from birdocp.bird.model import get_model

    cfg = with_values(default_config, DRAG)
    six, planar = sixdof_model(cfg), get_model(cfg)
    assert six.structure.drag
    p = param_vector(cfg)
    for t in (0.0, 0.031, 0.17):
        d = planar.data(t, p)
        x4 = [17.8, -1.9, -0.1, -0.11]
        f4 = np.asarray(planar.rhs(x4, d, p)).ravel()
        f9 = np.asarray(six.rhs(embed_planar_state(x4), d, six.params(p))).ravel()
        np.testing.assert_allclose(f9[LON], f4, rtol=0, atol=1e-12)
        assert np.abs(f9[LAT]).max() < 1e-10
    p0 = np.array(p)
    p0[[PARAM_NAMES.index(k) for k in DRAG]] = 0.0
    plain = sixdof_model(default_config)
    x = [17.5, 0.8, -1.0, 0.3, 0.2, -0.4, 0.15, -0.1, 0.7]
    f_drag0 = np.asarray(six.rhs(x, six.data(0.07, six.params(p0)), six.params(p0))).ravel()
    f_plain = np.asarray(plain.rhs(x, plain.data(0.07, plain.params(p0)), plain.params(p0))).ravel()
    assert np.array_equal(f_drag0, f_plain)
    f_drag = np.asarray(six.rhs(x, six.data(0.07, six.params(p)), six.params(p))).ravel()
    assert np.abs(f_drag - f_plain).max() > 1e-3  # the drag does act
    np.testing.assert_allclose(np.asarray(six.rhs(MIRROR @ x, six.data(0.07, six.params(p)), six.params(p))).ravel(),
                               MIRROR @ f_drag, rtol=1e-12, atol=1e-11)


def test_symmetric_cycle_with_drag_is_the_planar_cycle_with_drag(default_config, coarse):
    from birdocp.bird.config import with_values
    from birdocp.studies.trim import trim

    cfg = with_values(default_config, DRAG)
    res = lateral_trim(with_values(cfg, {"model.degrees_of_freedom": 6}), method=OrbitMethod(**coarse))
    ref = trim(cfg, **coarse)
    assert res.success and ref.success and res.coupling_max < 1e-12
    np.testing.assert_allclose(np.asarray(res.cycle.x0)[LON], ref.cycle.x0, rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.sort_complex(res.longitudinal_multipliers), np.sort_complex(ref.multipliers),
                               rtol=0, atol=1e-8)
    assert res.validity.valid == ref.validity.valid
