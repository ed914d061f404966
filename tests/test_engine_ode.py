"""General ODE engine: autonomous orbits (unknown period), Hopf starts, Lyapunov exponents.

References are independent: the Stuart-Landau oscillator's exact orbit, scipy solve_ivp of the
state and variational equations from the converged points, linear systems, the divergence of
Lorenz, the published largest Lorenz exponent, central finite differences of the shooting residual."""
import json
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from birdocp.engine.equilibria import continue_equilibria, find_equilibrium, orbit_from_hopf
from birdocp.engine.lyapunov import largest_lyapunov_exponent, lyapunov_exponents
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from birdocp.engine.orbits import orbit_residual_system

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts" / "examples"))


def sl(x, t, p):
    mu, w, b = p[0], p[1], p[2]
    r2 = x[0] ** 2 + x[1] ** 2
    return ca.vertcat(mu * x[0] - w * x[1] - r2 * (x[0] - b * x[1]), w * x[0] + mu * x[1] - r2 * (b * x[0] + x[1]))


SL = ODE.from_function(sl, 2, ("mu", "omega", "b"))


def rossler(x, t, p):
    return ca.vertcat(-x[1] - x[2], x[0] + p[0] * x[1], p[1] + x[2] * (x[0] - p[2]))


ROSSLER = ODE.from_function(rossler, 3, ("a", "b", "c"))


def test_autonomy_is_detected_from_the_expression():
    assert SL.autonomous and ROSSLER.autonomous
    forced = ODE.from_function(lambda x, t, p: ca.vertcat(x[1], -x[0] + ca.cos(t)), 2, 0, forcing_period=2 * np.pi)
    assert not forced.autonomous and forced.forcing_period == pytest.approx(2 * np.pi)


@pytest.mark.parametrize("integrator", ["rk4", "radau", "gauss"])
def test_stuart_landau_exact_orbit(integrator):
    mu, w = 0.5, 2.0
    T = 2 * np.pi / w
    r = solve(OrbitProblem(SL, [mu, w, 0.0], [0.9, 0.1], period_guess=3.0),
              OrbitMethod(points=4, steps_per_period=120, integrator=integrator))
    assert r.success, r.message
    assert abs(r.period - T) < 1e-6
    assert abs(np.hypot(*r.x0) - np.sqrt(mu)) < 1e-6
    assert abs(r.trivial_multiplier - 1) < 1e-9
    assert r.nontrivial_multipliers.size == 1
    assert abs(r.nontrivial_multipliers[0] - np.exp(-2 * mu * T)) < 1e-6
    assert r.stable
    # the error estimate (2N steps, Richardson) is of the size of the true error
    err_T = abs(r.period - T)
    assert 0.3 * err_T - 1e-10 <= r.error_estimate["period"] <= 3 * err_T + 1e-10


def test_accuracy_request_chooses_the_steps():
    r = solve(OrbitProblem(SL, [0.5, 2.0, 0.0], [0.9, 0.1], period_guess=3.0),
              OrbitMethod(points=4, steps_per_period=None, accuracy=1e-10))
    assert r.success and r.accurate, r.message
    assert abs(r.period - np.pi) < 1e-9
    coarse = solve(OrbitProblem(SL, [0.5, 2.0, 0.0], [0.9, 0.1], period_guess=3.0),
                   OrbitMethod(points=4, steps_per_period=24, accuracy=1e-10))
    assert coarse.success and coarse.accurate is False and "INACCURATE" in coarse.message


def test_shooting_jacobian_including_period_against_finite_differences():
    m = OrbitMethod(points=4, steps_per_period=60)
    for integ in ("rk4", "radau"):
        ev = orbit_residual_system(ROSSLER, OrbitMethod(points=4, steps_per_period=60, integrator=integ),
                                   period_free=True, free_idx=(2,), n_lin=1)
        ev.set_context([0.2, 0.2, 5.7], 5.0, 0.0, np.r_[np.ones(12), 0.0, 0.0][None, :], [1.0])
        rng = np.random.default_rng(1)
        z = np.r_[rng.normal(size=12) + np.tile([1, 5, 3], 4), 5.8, 5.7]
        _, J = ev.evaluate(z)
        Jfd = np.zeros_like(J)
        for k in range(z.size):
            e = np.zeros_like(z)
            e[k] = 1e-6
            Jfd[:, k] = (ev.g(z + e) - ev.g(z - e)) / 2e-6
        assert np.max(np.abs(J - Jfd)) < 1e-6 * (1 + np.max(np.abs(J))), integ
    assert m.points == 4


def test_rossler_ipopt_and_lm_agree():
    pr = OrbitProblem(ROSSLER, [0.2, 0.2, 5.7], [0.1, 5.0, 3.6], period_guess=5.0)
    # one fixed section for both: the same equations (a moving section ends where each solver's path does)
    a = solve(pr, OrbitMethod(points=5, steps_per_period=200, solver="lm", phase="fixed"))
    b = solve(pr, OrbitMethod(points=5, steps_per_period=200, solver="ipopt", phase="fixed"))
    assert a.success and b.success, (a.message, b.message)
    assert abs(a.period - b.period) < 1e-9 and np.max(np.abs(a.x0 - b.x0)) < 1e-8
    assert not a.stable  # the period-1 orbit of the chaotic attractor is unstable (multiplier ~ -2.4)


@pytest.mark.parametrize("points", [2, 11, 31])
@pytest.mark.parametrize("solver", ["lm", "ipopt"])
def test_rossler_from_the_reference_start_for_any_number_of_points(points, solver):
    # the reference toolbox reported success on an equilibrium here with 30 points
    r = solve(OrbitProblem(ROSSLER, [0.2, 0.2, 5.7], [0.1, 5.0, 3.6], period_guess=5.0),
              OrbitMethod(points=points, solver=solver))
    assert r.success and r.accurate, r.message
    # the committed example orbit (checked against scipy in test_example_result_against_scipy)
    ref = json.loads((ROOT / "results" / "engine" / "rossler" / "result.json").read_text())
    assert abs(r.period - ref["period"]) < 1e-5 and r.amplitude > 10


@pytest.mark.parametrize("case", [
    (SL, [0.5, 2.0, 0.0], [1e-3, 0.0], 3.0),                 # unstable focus inside the orbit
    (SL, [-0.5, 2.0, 0.0], [1e-2, 0.0], 3.0),                # stable focus, no orbit at all
    (ROSSLER, [0.2, 0.2, 5.7], [0.0075, -0.035, 0.035], 5.0),  # next to Rossler's inner equilibrium
])
@pytest.mark.parametrize("solver", ["lm", "ipopt"])
def test_no_success_on_an_equilibrium(case, solver):
    ode, p, x, T = case
    for pts in (5, 31):
        r = solve(OrbitProblem(ode, p, x, period_guess=T),
                  OrbitMethod(points=pts, steps_per_period=30 * (pts - 1), solver=solver, max_iter=30,
                                    error_estimate=False))
        if r.success:  # allowed only when it found a true orbit
            assert r.amplitude > 1e-2, r.message
        else:
            assert r.status != "converged"
    e = find_equilibrium(ode, p, x)
    r = solve(OrbitProblem(ode, p, e.x, period_guess=T), OrbitMethod(points=5, steps_per_period=100))
    assert not r.success and r.status in ("bad_phase_point", "equilibrium")


@pytest.mark.parametrize("solver", ["lm", "ipopt"])
def test_equilibrium_amplitude_check_rejects_a_converged_constant(solver):
    # the section through x_ref orthogonal to f(x_ref) contains the equilibrium when x_ref . f(x_ref) = 0,
    # i.e. for Stuart-Landau when |x_ref| = sqrt(mu): x_ref = (0.3, 0), mu = 0.09 gives the section y = 0
    # through the origin. From near-constant points the solvers converge to the origin (all equations
    # hold, any T); the amplitude check must turn that into a failure.
    pts = 1e-4 * np.array([[1, 2], [-1, 1], [0, -1], [1, 0], [1, 2]])
    r = solve(OrbitProblem(SL, [0.09, 1.0, 0.0], pts, period_guess=6.0, phase_point=[0.3, 0.0]),
              OrbitMethod(points=5, steps_per_period=40, solver=solver))
    assert r.max_residual <= 1e-10  # the equations are solved ...
    assert not r.success and r.status == "equilibrium"  # ... but by an equilibrium


def test_hopf_point_and_branch_of_stuart_landau():
    br = continue_equilibria(SL, [-0.5, 2.0, 0.0], "mu", [0.01, 0.0], 0.5, ds=0.1)
    assert br.status == "ok" and len(br.hopf) == 1
    h = br.hopf[0]
    assert abs(h.p[0]) < 1e-10 and abs(h.omega - 2.0) < 1e-10
    assert br.stable[0] and not br.stable[-1]
    for eps in (0.05, 0.2):
        o = orbit_from_hopf(SL, h, eps)
        assert o.success, o.message
        assert abs(o.p[0] - eps ** 2) < 1e-6  # mu = r^2: the square-root law, exactly here
        assert abs(np.hypot(*o.x0) - eps) < 1e-9
        assert abs(o.period - np.pi) < 1e-5
    # the branch continued from the Hopf start (b = 0.5: the period varies, T = 2 pi / (omega - b mu))
    from birdocp.engine.continuation.autonomous import continue_orbits

    hb = continue_equilibria(SL, [-0.5, 2.0, 0.5], "mu", [0.01, 0.0], 0.5, ds=0.1).hopf[0]
    first = orbit_from_hopf(SL, hb, 0.05, OrbitMethod(points=5, steps_per_period=200))
    br = continue_orbits(first, SL, "mu", 0.8, step=0.05)
    assert br.end_reason == "reached_to" and len(br.points) >= 4
    for pt in br.points:
        assert abs(np.hypot(*pt.x0) - np.sqrt(pt.parameter)) < 1e-6
        assert abs(pt.period - 2 * np.pi / (2.0 - 0.5 * pt.parameter)) < 1e-6


# -- every example orbit against scipy (state + variational equations from the committed point) ----
EXAMPLES = ["rossler", "lorenz", "forced_van_der_pol", "redox", "goodwin", "stuart_landau"]


def _scipy_monodromy(ode, x0, p, t0, T, method):
    """x(t0 + T) and the monodromy by scipy's integrator on the state + variational equations (the
    right-hand side and its Jacobian are evaluated through CasADi; the integration is scipy's)."""
    nx = ode.nx
    y, t = ca.SX.sym("y", nx + nx * nx), ca.SX.sym("t")
    x, Phi = y[:nx], ca.reshape(y[nx:], nx, nx)
    fx = ode.rhs(x, t, ca.DM(p))
    dy = ca.vertcat(fx, ca.vec(ca.mtimes(ca.jacobian(fx, x), Phi)))
    F = ca.Function("aug", [t, y], [dy, ca.jacobian(dy, y)])

    def rhs(t, y):
        return np.asarray(F(t, y)[0]).ravel()

    def jac(t, y):
        return np.asarray(F(t, y)[1])

    y0 = np.concatenate([x0, np.eye(nx).ravel(order="F")])
    s = solve_ivp(rhs, (t0, t0 + T), y0, method=method, rtol=1e-11, atol=1e-13,
                  **({"jac": jac} if method == "LSODA" else {}))
    return s.y[:nx, -1], s.y[nx:, -1].reshape(nx, nx, order="F")


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_result_against_scipy(name):
    mod = __import__(name)
    res = json.loads((ROOT / "results" / "engine" / name / "result.json").read_text())
    assert res["success"] and res["accurate"]
    ode = mod.make_ode()
    p = np.array(list(res["params"].values()), float)
    x0 = np.array(res["x0"])
    stiff = name in ("redox", "forced_van_der_pol")
    xT, Mo = _scipy_monodromy(ode, x0, p, 0.0, res["period"], "LSODA" if stiff else "DOP853")
    scale = 1 + np.max(np.abs(x0))
    lam_max = max(abs(complex(*m)) for m in res["multipliers"])
    assert np.max(np.abs(xT - x0)) < 1e-6 * scale * max(1.0, lam_max), name  # return error
    lam = np.linalg.eigvals(Mo)
    ours = [complex(*m) for m in res["multipliers"]]
    for v in ours:
        assert np.min(np.abs(lam - v)) < 1e-6 * max(1.0, abs(v)), (name, v, lam)
    assert [abs(v) for v in ours] == sorted((abs(v) for v in ours), reverse=True)
    if ode.autonomous:
        assert abs(res["trivial_multiplier_error"]) < 1e-8


def test_engine_solve_matches_scipy_on_redox_with_radau():
    import redox

    ode = redox.make_ode()
    p = list(redox.PARAMS.values())
    r = solve(OrbitProblem(ode, p, [0.3, 0.29, 0.42, 0.0028], period_guess=25.0),
              OrbitMethod(points=5, steps_per_period=128, integrator="radau"))
    assert r.success, r.message
    xT, Mo = _scipy_monodromy(ode, r.x0, np.array(p), 0.0, r.period, "LSODA")
    assert np.max(np.abs(xT - r.x0)) < 1e-6
    lam = np.sort(np.abs(np.linalg.eigvals(Mo)))[::-1]
    assert np.max(np.abs(lam[:2] - np.abs(r.multipliers[:2]))) < 1e-6


# -- Lyapunov exponents ------------------------------------------------------------------------
def test_lyapunov_linear_system_is_exact():
    A = np.array([[-1.0, 2.0, 0.0], [-2.0, -1.0, 0.0], [0.0, 0.0, 0.3]])
    lin = ODE.from_function(lambda x, t, p: ca.mtimes(ca.DM(A), x), 3, 0)
    r = lyapunov_exponents(lin, [1.0, 1.0, 1.0], [], t_total=40.0, dt=0.01, t_transient=30.0, renorm_time=0.5)
    assert np.max(np.abs(r.exponents - np.array([0.3, -1.0, -1.0]))) < 1e-8
    r1 = largest_lyapunov_exponent(lin, [1.0, 1.0, 1.0], [], t_total=20.0, dt=0.01, t_transient=30.0)
    assert abs(r1.exponents[0] - 0.3) < 1e-8


def test_lyapunov_of_a_forced_system_and_of_a_stable_forced_orbit():
    # forced linear: the forcing does not enter the tangent flow, exponents = eigenvalues
    A = np.array([[-0.5, 1.0], [-1.0, -0.5]])
    ode = ODE.from_function(lambda x, t, p: ca.mtimes(ca.DM(A), x) + ca.vertcat(0, p[0] * ca.cos(t)), 2, 1,
                            forcing_period=2 * np.pi)
    assert not ode.autonomous
    r = lyapunov_exponents(ode, [1.0, 0.0], [2.0], t_total=20.0, dt=0.01, t_transient=5.0, renorm_time=0.5)
    assert np.max(np.abs(r.exponents - [-0.5, -0.5])) < 1e-8
    # forced van der Pol: on its stable 1:3 orbit the exponents are ln|multiplier| / T (committed result)
    res = json.loads((ROOT / "results" / "engine" / "forced_van_der_pol" / "result.json").read_text())
    lam1 = np.log(np.hypot(*res["multipliers"][0])) / res["period"]
    le, se = res["lyapunov_exponents"][0], res["lyapunov_standard_error"][0]
    assert abs(le - lam1) < 3 * se + 1e-3, (le, lam1, se)


def test_lyapunov_of_an_ode_with_data_is_that_of_the_same_system_in_time():
    """An ODE whose forcing comes through its data function (d = cos t) has the exponents of the same
    system written with t in its right-hand side (the tangent steps take the data at each time)."""
    A = ca.DM([[-0.5, 1.0], [-1.0, -0.5]])
    x, d, p, t = ca.SX.sym("x", 2), ca.SX.sym("d"), ca.SX.sym("p", 1), ca.SX.sym("t")
    rhs = ca.Function("f", [x, d, p], [ca.mtimes(A, x) + ca.vertcat(0, p[0] * d) + 0.1 * ca.vertcat(x[1] ** 3, 0)])
    data = ca.Function("data", [t, p], [ca.cos(t)])
    with_data = ODE(rhs=rhs, data=data, forcing_period=2 * np.pi)
    in_time = ODE.from_function(lambda x, t, p: ca.mtimes(A, x) + ca.vertcat(0, p[0] * ca.cos(t))
                                + 0.1 * ca.vertcat(x[1] ** 3, 0), 2, 1, forcing_period=2 * np.pi)
    kw = dict(t_total=10.0, dt=0.01, t_transient=2.0, renorm_time=0.5)
    a = lyapunov_exponents(with_data, [1.0, 0.0], [2.0], **kw).exponents
    b = lyapunov_exponents(in_time, [1.0, 0.0], [2.0], **kw).exponents
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_lorenz_spectrum_sum_and_largest_exponent():
    import lorenz

    ode = lorenz.make_ode()
    p = list(lorenz.PARAMS.values())
    r = lyapunov_exponents(ode, [1.0, 1.0, 1.0], p, t_total=100.0, dt=0.005, t_transient=10.0)
    assert abs(r.sum - (-(10 + 1 + 8 / 3))) < 1e-4  # sum = mean divergence of f
    assert abs(r.exponents[1]) < 0.05  # the flow direction
    big = largest_lyapunov_exponent(ode, [1.0, 1.0, 1.0], p, t_total=1000.0, dt=0.01, t_transient=10.0)
    # published 0.9056 (Sprott 2003): within 4 standard errors plus the RK4 bias at dt = 0.01
    assert abs(big.exponents[0] - 0.9056) < 4 * big.standard_error[0] + 0.005, (big.exponents, big.standard_error)


# -- continuation of autonomous orbits (the engine's continuation with the period as an unknown) ------
def test_continuation_period_varies_as_exact():
    from birdocp.engine.continuation.autonomous import continue_orbits

    p = [0.2, 2.0, 0.5]  # b = 0.5: angular frequency omega - b mu, radius sqrt(mu)
    o = solve(OrbitProblem(SL, p, [0.45, 0.0], period_guess=3.3), OrbitMethod(points=5, steps_per_period=200))
    br = continue_orbits(o, SL, "mu", 1.0, step=0.1)
    assert br.end_reason == "reached_to" and len(br.points) >= 4
    for pt in br.points:
        mu = pt.parameter
        assert abs(pt.period - 2 * np.pi / (2.0 - 0.5 * mu)) < 1e-6
        assert pt.free_values["period"] == pt.period
        assert abs(np.hypot(*pt.x0) - np.sqrt(mu)) < 1e-6
        assert len(pt.multipliers) == 1  # the non-trivial one
        assert abs(pt.multipliers[0][0] - np.exp(-2 * mu * pt.period)) < 1e-6 and pt.stable
    assert not br.special_points


def test_continuation_locates_the_fold_of_a_subcritical_hopf_branch():
    from birdocp.engine.continuation.autonomous import continue_orbits

    def sub(x, t, p):  # r' = r (mu + r^2 - r^4): orbits r^2 = (1 +- sqrt(1 + 4 mu)) / 2, fold at mu = -1/4
        r2 = x[0] ** 2 + x[1] ** 2
        g = p[0] + r2 - r2 ** 2
        return ca.vertcat(g * x[0] - p[1] * x[1], p[1] * x[0] + g * x[1])

    ode = ODE.from_function(sub, 2, ("mu", "omega"))
    r0 = np.sqrt((1 + np.sqrt(1 + 4 * 0.2)) / 2)
    o = solve(OrbitProblem(ode, [0.2, 1.0], [r0, 0.0], period_guess=6.0), OrbitMethod(points=5, steps_per_period=200))
    assert o.success and o.stable
    br = continue_orbits(o, ode, "mu", -0.5, step=0.05, max_points=8)
    folds = [sp for sp in br.special_points if sp.kind == "fold"]
    assert folds, br.end_message
    f = folds[0]
    assert abs(f.parameter + 0.25) < 1e-6 and f.located
    assert abs(np.sum(np.square(f.x0)) - 0.5) < 1e-4
    assert not br.points[-1].stable  # the lower branch is unstable


def test_continuation_locates_rossler_period_doubling_checked_by_scipy():
    from birdocp.engine.continuation.autonomous import continue_orbits

    o = solve(OrbitProblem(ROSSLER, [0.2, 0.2, 2.5], [3.0, 0.0, 0.1], period_guess=6.0),
              OrbitMethod(points=5, steps_per_period=200))
    assert o.success and o.stable
    br = continue_orbits(o, ROSSLER, "c", 3.5, step=0.2)
    pd = [sp for sp in br.special_points if sp.kind == "period_doubling"]
    assert len(pd) == 1
    sp = pd[0]
    p = np.array([0.2, 0.2, sp.parameter])
    xT, Mo = _scipy_monodromy(ROSSLER, np.array(sp.x0), p, 0.0, sp.free_values["period"], "DOP853")
    assert np.max(np.abs(xT - np.array(sp.x0))) < 1e-6
    # a multiplier at -1 there (to the RK4 discretisation error at 200 steps, ~1e-6)
    assert np.min(np.abs(np.linalg.eigvals(Mo) + 1.0)) < 1e-5


def test_implicit_step_is_nan_when_its_stage_solve_fails():
    from birdocp.engine.steppers import make_step

    x, t, q = ca.SX.sym("x"), ca.SX.sym("t"), ca.SX.sym("q")
    st = make_step(ca.Function("f", [x, t, q], [ca.exp(q * x)]), "radau")  # x' = e^x blows up at t = 1/e
    h = 0.01
    exact = -np.log(np.exp(-1.0) - h)  # from x = 1
    assert abs(float(st(1.0, 0.0, 1.0, h)) - exact) < 1e-12
    assert np.isnan(float(st(1.0, 0.0, 1.0, 10.0)))  # no stage solution: NaN, not an unconverged value


@pytest.mark.slow
def test_example_script_writes_the_documented_keys(tmp_path):
    import subprocess

    out = tmp_path / "sl"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "examples" / "stuart_landau.py"), "--out", str(out)],
                   check=True, capture_output=True, timeout=300)
    res = json.loads((out / "result.json").read_text())
    assert (out / "orbit.png").stat().st_size > 10_000
    assert abs(res["period"] - 2 * np.pi) < 1e-6 and len(res["x0"]) == 2
    mods = [np.hypot(*m) for m in res["multipliers"]]
    assert len(mods) == 2 and mods == sorted(mods, reverse=True)  # trivial one included, largest first
    assert abs(res["multipliers"][0][0] - 1) < 1e-9 and abs(res["multipliers"][1][0] - np.exp(-4 * np.pi)) < 1e-8


def test_shooting_success_is_the_residual_not_ipopts_status():
    # IPOPT told to accept almost anything returns Solved_To_Acceptable_Level (a CasADi "success")
    # at a residual of ~1: the forced shooting engine must not call that converged
    from birdocp.engine.problem import OrbitProblem
    from birdocp.engine.ode import ODE
    from birdocp.engine import OrbitMethod, solve

    x, t, p = ca.SX.sym("x", 2), ca.SX.sym("t"), ca.SX.sym("p", 0)
    duffing = ca.Function("duffing", [x, t, p], [ca.vertcat(x[1], -0.25 * x[1] - x[0] - 0.8 * x[0] ** 3
                                                            + 0.6 * ca.cos(1.3 * t))])
    prob = OrbitProblem(ODE.from_rhs(duffing, 2 * np.pi / 1.3), [], [0.5, 0.0])
    loose = {f"ipopt.acceptable_{k}": 1e10 for k in ("tol", "constr_viol_tol", "dual_inf_tol", "compl_inf_tol")}
    loose.update({"ipopt.acceptable_iter": 1, "ipopt.acceptable_obj_change_tol": 1e20})
    r = solve(prob, OrbitMethod(points=5, steps_per_period=148, ipopt_options=loose))
    assert r.status == "Solved_To_Acceptable_Level" and r.max_residual > 1e-3
    assert not r.success and "not converged" in r.message
    good = solve(prob, OrbitMethod(points=5, steps_per_period=148))
    assert good.success and good.max_residual <= 1e-9


def test_continuation_locates_the_torus_bifurcation_of_langfords_system():
    # Langford's system (Seydel, Practical Bifurcation and Stability Analysis, torus example): the
    # orbit is the circle r^2 = lam z - z^2 at height z with (lam - 3) + z + 0.2 (1 - z^2) = 0, angular
    # speed 0.25 (T = 8 pi). Its (r, z) dynamics has a Hopf point where lam = 2 z: lam = 2 exactly, with
    # frequency sqrt(det) = sqrt(2 r^2 (1 - 0.4 z)) = sqrt(1.2); the Neimark-Sacker multipliers there are
    # exp(+-i sqrt(1.2) 8 pi).
    from birdocp.engine.continuation.autonomous import continue_orbits

    def langford(x, t, p):
        lam, y1, y2, y3 = p[0], x[0], x[1], x[2]
        g = y3 + 0.2 * (1 - y3 ** 2)
        return ca.vertcat((lam - 3) * y1 - 0.25 * y2 + y1 * g, 0.25 * y1 + (lam - 3) * y2 + y2 * g,
                          lam * y3 - (y1 ** 2 + y2 ** 2 + y3 ** 2))

    ode = ODE.from_function(langford, 3, ("lambda",))
    z = (1 - np.sqrt(1 - 0.8)) / 0.4  # lam = 1.8: 0.2 z^2 - z + 1 = 0
    r = np.sqrt(1.8 * z - z ** 2)
    o = solve(OrbitProblem(ode, [1.8], [r * 0.9, 0.1, z * 1.05], period_guess=25.0), OrbitMethod(points=5))
    assert o.success and o.stable, o.message
    # within the requested (default) relative accuracy 1e-6, and within 3x the error estimate
    assert abs(o.period - 8 * np.pi) < 1e-6 * 8 * np.pi and abs(o.x0[2] - z) < 3e-6
    assert abs(o.period - 8 * np.pi) <= 3 * o.error_estimate["period"]
    br = continue_orbits(o, ode, "lambda", 2.2, step=0.05)
    ns = [sp for sp in br.special_points if sp.kind == "neimark_sacker"]
    assert len(ns) == 1 and abs(ns[0].parameter - 2.0) < 1e-4
    angle = np.angle(complex(*ns[0].multipliers[0]))
    exact = np.angle(np.exp(1j * np.sqrt(1.2) * 8 * np.pi))
    assert abs(abs(angle) - abs(exact)) < 1e-3
    assert not br.points[-1].stable
