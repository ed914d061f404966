"""Redox oscillator (a stiff circadian oscillator): orbit with the Radau IIA integrator.

System and parameters: M. del Olmo, A. Kramer, H. Herzel, "A robust model for circadian redox
oscillations", Int. J. Mol. Sci. 20 (2019) 2368, with the parameters of the reference toolbox's
example: D1' = p - a A D1 - d D1,  D2' = d D1 - e D2,  R' = e D2 - q R,  A' = b (1 - A) R - a A D1,
a = 1000, b = 2, d = 0.2, e = 0.1, q = 0.1, p = 1. The fast A-D1 reaction (rate a = 1000) makes it
stiff: an explicit RK4 grid of 2000 steps per period diverges; Radau IIA needs ~128.
Start: a point on the attractor after a transient (rounded), period guess 25.

    python scripts/examples/redox.py [--out DIR]      (default results/engine/redox/)
"""
import casadi as ca

from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from example_common import accurate_orbit, begin, plot_orbit, write_result

PARAMS = {"a": 1000.0, "b": 2.0, "d": 0.2, "e": 0.1, "q": 0.1, "p": 1.0}


def redox(x, t, p):
    a, b, d, e, q, pr = (p[i] for i in range(6))
    D1, D2, R, A = x[0], x[1], x[2], x[3]
    return ca.vertcat(pr - a * A * D1 - d * D1, d * D1 - e * D2, e * D2 - q * R, b * (1 - A) * R - a * A * D1)


def make_ode():
    return ODE.from_function(redox, 4, tuple(PARAMS), state_names=("D1", "D2", "R", "A"))


def main():
    out, ode, p = begin("redox", __doc__, make_ode, PARAMS)
    orbit = accurate_orbit(ode, p, [0.3, 0.29, 0.42, 0.0028], 25.0, integrator="radau")
    # the same orbit with the explicit RK4 on 2000 steps per period, from the same guess (for comparison)
    rk4 = solve(OrbitProblem(ode, p, [0.3, 0.29, 0.42, 0.0028], period_guess=25.0),
                OrbitMethod(points=5, steps_per_period=2000, integrator="rk4", error_estimate=False))
    res = write_result(out, "redox", __doc__.split("\n\n")[1], PARAMS, orbit,
                       extra={"rk4_2000_steps": {"success": rk4.success, "status": rk4.status}})
    plot_orbit(out, "Redox oscillator (del Olmo et al. 2019), Radau IIA", orbit, ("D1", "D2", "R", "A"),
               phase=(0, 2))
    print(f"{orbit.status}: T = {res['period']:.10f}, multipliers = {orbit.multipliers}, "
          f"steps {orbit.method['steps_per_period']}, error estimate {orbit.error_estimate}, wall {orbit.wall_s}")
    print(f"explicit RK4 with 2000 steps per period: {rk4.status}")


if __name__ == "__main__":
    main()
