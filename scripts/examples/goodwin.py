"""Goodwin oscillator (circadian clock model): the limit cycle and its multipliers.

System and parameters: D. Gonze, S. Bernard, C. Waltermann, A. Kramer, H. Herzel, "Spontaneous
synchronization of coupled circadian oscillators", Biophys. J. 89 (2005) 120-129 (single cell):
X' = k1 K1^n / (K1^n + Z^n) - k2 X / (K2 + X),  Y' = k3 X - k4 Y / (K4 + Y),  Z' = k5 Y - k6 Z / (K6 + Z),
k1 = k3 = k5 = 0.7, k2 = 0.45, k4 = k6 = 0.35, K1 = K2 = K4 = K6 = 1, n = 7 (period ~24 h).
Start: a point on the attractor after a transient (rounded), period guess 24 h.

    python scripts/examples/goodwin.py [--out DIR]      (default results/engine/goodwin/)
"""
import casadi as ca

from birdocp.engine.ode import ODE
from example_common import accurate_orbit, begin, plot_orbit, write_result

PARAMS = {"k1": 0.7, "k2": 0.45, "k3": 0.7, "k4": 0.35, "k5": 0.7, "k6": 0.35,
          "K1": 1.0, "K2": 1.0, "K4": 1.0, "K6": 1.0, "n": 7.0}


def goodwin(x, t, p):
    k1, k2, k3, k4, k5, k6, K1, K2, K4, K6, n = (p[i] for i in range(11))
    X, Y, Z = x[0], x[1], x[2]
    return ca.vertcat(k1 * K1 ** n / (K1 ** n + Z ** n) - k2 * X / (K2 + X),
                      k3 * X - k4 * Y / (K4 + Y),
                      k5 * Y - k6 * Z / (K6 + Z))


def make_ode():
    return ODE.from_function(goodwin, 3, tuple(PARAMS), state_names=("X", "Y", "Z"))


def main():
    out, ode, p = begin("goodwin", __doc__, make_ode, PARAMS)
    orbit = accurate_orbit(ode, p, [0.11, 0.74, 2.6], 24.0)
    res = write_result(out, "goodwin", __doc__.split("\n\n")[1], PARAMS, orbit)
    plot_orbit(out, "Goodwin oscillator (Gonze et al. 2005)", orbit, ("X", "Y", "Z"), phase=(0, 2),
               time_unit="h")
    print(f"{orbit.status}: T = {res['period']:.10f} h, multipliers = {orbit.multipliers}, "
          f"steps {orbit.method['steps_per_period']}, error estimate {orbit.error_estimate}")


if __name__ == "__main__":
    main()
