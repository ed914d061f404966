"""Forced van der Pol oscillator: the 1:3 subharmonic orbit (period three forcing periods).

System and parameters: R. Seydel, Practical Bifurcation and Stability Analysis, 3rd ed., Springer
(2010), the forced van der Pol example:  y1' = y2,  y2' = delta (1 - y1^2) y2 - y1 + gamma cos(omega t),
delta = 4, gamma = 0.5, omega = 1.8; the orbit has period 3 x 2 pi / omega = 10.4719755.
Start: a point reached after a transient (rounded), phase t0 = 0.

    python scripts/examples/forced_van_der_pol.py [--out DIR]   (default results/engine/forced_van_der_pol/)
"""
import casadi as ca
import numpy as np

from birdocp.engine.lyapunov import lyapunov_exponents
from birdocp.engine.ode import ODE
from example_common import accurate_orbit, begin, plot_orbit, write_result

PARAMS = {"delta": 4.0, "gamma": 0.5, "omega": 1.8}


def vdp(x, t, p):
    d, g, w = p[0], p[1], p[2]
    return ca.vertcat(x[1], d * (1 - x[0] ** 2) * x[1] - x[0] + g * ca.cos(w * t))


def make_ode():
    return ODE.from_function(vdp, 2, tuple(PARAMS), forcing_period=2 * np.pi / PARAMS["omega"],
                             state_names=("y1", "y2"))


def main():
    out, ode, p = begin("forced_van_der_pol", __doc__, make_ode, PARAMS)
    T = 3 * ode.forcing_period
    orbit = accurate_orbit(ode, p, [1.5, -0.2], T, points=7, integrator="radau")
    ly = lyapunov_exponents(ode, orbit.x0, p, t_total=100 * T, dt=T / 1200, t_transient=0.0, renorm_time=T / 6)
    res = write_result(out, "forced_van_der_pol", __doc__.split("\n\n")[1], PARAMS, orbit, ly)
    plot_orbit(out, "Forced van der Pol (delta = 4, gamma = 0.5, omega = 1.8): 1:3 orbit", orbit, ("y1", "y2"))
    print(f"{orbit.status}: T = {res['period']:.10f}, x0 = {orbit.x0}, multipliers = {orbit.multipliers}, "
          f"steps {orbit.method['steps_per_period']}, error estimate {orbit.error_estimate}")
    print(f"Lyapunov exponents {ly.exponents} +- {ly.standard_error} (the orbit is stable: the largest is "
          f"ln|multiplier_1| / T = {np.log(abs(orbit.multipliers[0])) / T:.6f})")


if __name__ == "__main__":
    main()
