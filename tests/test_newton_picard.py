"""Newton-Picard (engine/newton_picard.py) on a forced Duffing oscillator coupled to fast linear lags:
the same cycle and multipliers as the full Newton (also with a free parameter held by a mean
condition), and an honest hand-over to the full Newton when the Picard complement does not contract."""
import casadi as ca
import numpy as np
import pytest

from birdocp.engine import OrbitMethod, solve
from birdocp.engine.ode import ODE
from birdocp.engine.problem import MeanCondition, OrbitProblem

OMEGA = 1.3
T = 2 * np.pi / OMEGA
RATES = (3.0, 5.0, 8.0, 12.0)  # lag rates [1/s]: multipliers exp(-k T) <= 2e-7


def lagged_duffing(rates=RATES, feedback=0.3):
    """x'' + c x' + k x + beta x^3 + feedback * sum(y) = F cos(w t), y_i' = -k_i (y_i - x): the lags
    feed back on the oscillator, so the complement couples to the Newton states both ways."""
    n = len(rates)
    x, t, p = ca.SX.sym("x", 2 + n), ca.SX.sym("t"), ca.SX.sym("p", 4)
    c, k, beta, F = p[0], p[1], p[2], p[3]
    y = x[2:]
    acc = -c * x[1] - k * x[0] - beta * x[0] ** 3 - feedback * ca.sum1(y) + F * ca.cos(OMEGA * t)
    ydot = ca.vertcat(*[-r * (y[i] - x[0]) for i, r in enumerate(rates)])
    f = ca.Function("lagged_duffing", [x, t, p], [ca.vertcat(x[1], acc, ydot)])
    return ODE.from_rhs(f, T)


P = np.array([0.25, 1.0, 0.8, 0.6])
NP_METHOD = OrbitMethod(points=5, steps_per_period=240, solver="newton-picard", newton_states=(0, 1))


def _compare(problem, **np_over):
    full = solve(problem, OrbitMethod(points=5, steps_per_period=240, solver="lm", tol=1e-12))
    np_ = solve(problem, OrbitMethod(points=5, steps_per_period=240, solver="newton-picard",
                                     newton_states=(0, 1), tol=1e-12, **np_over))
    assert full.success and np_.success, (full.message, np_.message)
    return full, np_


def test_same_cycle_and_multipliers_as_the_full_newton():
    ode = lagged_duffing()
    full, np_ = _compare(OrbitProblem(ode, P, np.zeros(ode.nx)))
    assert np.max(np.abs(np_.x0 - full.x0)) < 1e-10
    assert np.max(np.abs(np_.multipliers - full.multipliers)) < 1e-10
    assert np_.max_residual <= 1e-12 and "newton-picard: converged" in np_.message
    assert np.isnan(np_.monodromy_vs_full_period_jacobian)  # the check pass is not run
    # the two oscillator multipliers agree with the full Newton's to round-off too (largest first)
    assert np.max(np.abs(np_.multipliers[:2] - full.multipliers[:2])) < 1e-12


def _energy_problem(ode, target=0.3):
    """The forcing amplitude F free (bounds 0..5), the period mean of an energy that also reads a lag
    state held at ``target`` (so the mean rows see the Picard states too)."""
    x2, d, p = ca.SX.sym("x", ode.nx), ca.SX.sym("d", 1), ca.SX.sym("p", 4)
    e = 0.5 * x2[1] ** 2 + 0.5 * x2[0] ** 2 + 0.2 * x2[0] * x2[2]
    energy = MeanCondition(ca.Function("e", [x2, d, p], [e]), target, "energy")
    return OrbitProblem(ode, P, np.zeros(ode.nx), free={3: (0.0, 5.0)}, means=[energy])


def test_free_parameter_same_cycle_as_lm_and_ipopt():
    # a free parameter held by a mean condition joins the Newton subspace (newton_picard_free): the
    # same cycle, free value and multipliers as the full Newton (LM) and IPOPT, to 1e-10
    ode = lagged_duffing()
    prob = _energy_problem(ode)
    full, np_ = _compare(prob)
    ip = solve(prob, OrbitMethod(points=5, steps_per_period=240, solver="ipopt", tol=1e-12))
    assert ip.success, ip.message
    assert "newton-picard: converged" in np_.message and np_.max_residual <= 1e-12
    for ref in (full, ip):
        assert abs(np_.free_values["p3"] - ref.free_values["p3"]) < 1e-10
        assert np.max(np.abs(np_.x0 - ref.x0)) < 1e-10
        assert np.max(np.abs(np_.multipliers - ref.multipliers)) < 1e-10
    assert abs(np_.means["energy"] - 0.3) < 1e-12
    assert 0.6 != pytest.approx(np_.free_values["p3"], abs=1e-3)  # the free value moved from its start
    assert np_.iterations < 15  # Newton-like: a few iterations, not a Picard crawl


def test_not_contracting_complement_hands_over_to_the_full_newton():
    # a slow lag (rate 0.05/s: multiplier 0.79) named as a Picard state: Newton-Picard says so and the
    # full Newton converges from its last iterate
    ode = lagged_duffing(rates=(0.05, 8.0), feedback=0.3)
    r = solve(OrbitProblem(ode, P, np.zeros(ode.nx)), OrbitMethod(points=5, steps_per_period=240,
                                                               solver="newton-picard", newton_states=(0, 1)))
    assert "not contracting" in r.message and "full Newton (lm)" in r.message, r.message
    assert r.success and r.max_residual <= 1e-10


def test_monodromy_chord_same_cycle_and_multipliers_as_the_full_newton():
    # chord="monodromy" (engine/newton_picard_chord.py): every state by Newton with a frozen monodromy
    # at the start and Broyden updates; the same cycle and multipliers as the full Newton
    ode = lagged_duffing()
    full, mono = _compare(OrbitProblem(ode, P, np.zeros(ode.nx)), chord="monodromy")
    assert "newton-picard: converged" in mono.message and "monodromy chord" in mono.message
    assert np.max(np.abs(mono.x0 - full.x0)) < 1e-10
    assert np.max(np.abs(mono.multipliers - full.multipliers)) < 1e-10
    assert mono.max_residual <= 1e-12 and mono.iterations < 10


def test_monodromy_chord_needs_no_contracting_complement():
    # the slow lag that the subspace chord cannot iterate by Picard (previous test) is a Newton state
    # here: converged by the chord itself, no hand-over
    ode = lagged_duffing(rates=(0.05, 8.0), feedback=0.3)
    prob = OrbitProblem(ode, P, np.zeros(ode.nx))
    r = solve(prob, OrbitMethod(points=5, steps_per_period=240, solver="newton-picard", newton_states=(0, 1),
                                chord="monodromy"))
    assert r.success and "newton-picard: converged" in r.message and "full Newton" not in r.message, r.message
    full = solve(prob, OrbitMethod(points=5, steps_per_period=240, solver="lm", tol=1e-12))
    assert np.max(np.abs(r.multipliers - full.multipliers)) < 1e-9


def test_monodromy_chord_without_state_jacobians_is_the_subspace_chord(monkeypatch):
    # a right-hand side whose SX state Jacobian cannot be built: the subspace chord runs instead
    import birdocp.engine.newton_picard_chord as chord

    def fail(grid):
        raise NotImplementedError("no SX derivatives")

    monkeypatch.setattr(chord, "step_start_jacobians", fail)
    ode = lagged_duffing()
    r = solve(OrbitProblem(ode, P, np.zeros(ode.nx)), OrbitMethod(points=5, steps_per_period=240, solver="newton-picard",
                                                               newton_states=(0, 1), chord="monodromy"))
    assert r.success and "Picard growth" in r.message and "monodromy chord" not in r.message, r.message


def test_monodromy_chord_with_a_free_parameter_is_the_subspace_chord():
    # free parameters: the subspace chord (newton_picard_free), whatever OrbitMethod.chord says
    prob = _energy_problem(lagged_duffing())
    a, b = (solve(prob, OrbitMethod(points=5, steps_per_period=240, solver="newton-picard", newton_states=(0, 1),
                                    tol=1e-12, chord=c)) for c in ("subspace", "monodromy"))
    assert a.success and "monodromy chord" not in b.message and b.iterations == a.iterations
    assert np.array_equal(a.x0, b.x0)


def test_bad_input():
    ode = lagged_duffing()
    prob = OrbitProblem(ode, P, np.zeros(ode.nx))
    with pytest.raises(ValueError, match="newton_states"):
        solve(prob, OrbitMethod(solver="newton-picard"))
    with pytest.raises(ValueError, match="newton_states"):
        solve(prob, OrbitMethod(solver="newton-picard", newton_states=(0, 9)))
    with pytest.raises(ValueError, match="picard_max_rate"):
        OrbitMethod(picard_max_rate=1.5).validate()
    with pytest.raises(ValueError, match="OrbitMethod.chord"):
        OrbitMethod(chord="exact").validate()


def test_compiled_ode_with_a_free_parameter(tmp_path, monkeypatch):
    # Newton-Picard on an ODE whose RHS is compiled C (the CLI's --compiled): the directional passes
    # and the mean rows' gradient are built from its interpreted source; the same cycle as interpreted
    from birdocp.export.compiled import compiled_ode, find_compiler

    if find_compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("BIRDOCP_CACHE", str(tmp_path))
    ode = lagged_duffing()
    code = compiled_ode(ode)
    assert code is not None and code.numeric.source is ode
    method = OrbitMethod(points=5, steps_per_period=240, solver="newton-picard", newton_states=(0, 1), tol=1e-12)
    a, b = solve(_energy_problem(ode), method), solve(_energy_problem(code), method)
    assert a.success and b.success and "newton-picard: converged" in b.message, b.message
    assert abs(a.free_values["p3"] - b.free_values["p3"]) < 1e-12
    assert np.max(np.abs(a.multipliers - b.multipliers)) < 1e-12
