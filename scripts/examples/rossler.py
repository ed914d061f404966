"""Rossler system: the period-1 unstable periodic orbit (period unknown) and its multipliers.

System and parameters: O. E. Rossler, "An equation for continuous chaos", Phys. Lett. A 57 (1976)
397-398:  x' = -y - z,  y' = x + a y,  z' = b + z (x - c),  a = b = 0.2, c = 5.7 (chaotic regime).
Start: x = (0.1, 5, 3.6), period guess 5 (the starting point of the reference toolbox's example).
Also: the period-1 branch continued in c from 2.5 (where it is stable) to 5.7, with its period
doubling (the first of the cascade, at c ~ 2.83).

    python scripts/examples/rossler.py [--out DIR]      (default results/engine/rossler/)
"""
import casadi as ca

from birdocp.engine.continuation.autonomous import continue_orbits
from birdocp.engine.lyapunov import lyapunov_exponents
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from example_common import accurate_orbit, begin, plot_orbit, write_result

PARAMS = {"a": 0.2, "b": 0.2, "c": 5.7}


def rossler(x, t, p):
    a, b, c = p[0], p[1], p[2]
    return ca.vertcat(-x[1] - x[2], x[0] + a * x[1], b + x[2] * (x[0] - c))


def make_ode():
    return ODE.from_function(rossler, 3, tuple(PARAMS), state_names=("x", "y", "z"))


def main():
    out, ode, p = begin("rossler", __doc__, make_ode, PARAMS)
    orbit = accurate_orbit(ode, p, [0.1, 5.0, 3.6], 5.0)
    ly = lyapunov_exponents(ode, orbit.x0, p, t_total=2000.0, dt=0.02, t_transient=100.0, renorm_time=2.0)
    start = solve(OrbitProblem(ode, [0.2, 0.2, 2.5], [3.0, 0.0, 0.1], period_guess=6.0),
                  OrbitMethod(points=5, steps_per_period=400))
    branch = continue_orbits(start, ode, "c", 5.7, step=0.2)
    cs = [pt.parameter for pt in branch.points]
    mods = [max(pt.moduli) for pt in branch.points]

    def panel(ax):
        ax.plot(cs, mods, "o-", color="tab:blue", ms=3, label="period-1 orbit")
        for sp in branch.special_points:
            ax.plot(sp.parameter, max(sp.moduli), "r*", ms=12, label=f"{sp.kind.replace('_', ' ')} c = {sp.parameter:.4f}")
        ax.axhline(1.0, color="0.6", lw=1)
        ax.set_xlabel("c")
        ax.set_ylabel("largest |non-trivial multiplier|")
        ax.set_title("continuation in c (a = b = 0.2)")
        ax.legend(fontsize=8)

    extra = {"branch_c": {"end_reason": branch.end_reason, "c": cs, "period": [pt.period for pt in branch.points],
                          "max_modulus": mods,
                          "special_points": [{"kind": sp.kind, "c": sp.parameter, "period": sp.free_values["period"]}
                                             for sp in branch.special_points]}}
    res = write_result(out, "rossler", __doc__.split("\n\n")[1], PARAMS, orbit, ly, extra)
    plot_orbit(out, "Rossler (a = b = 0.2, c = 5.7): period-1 orbit", orbit, ("x", "y", "z"), extra_panel=panel)
    print(f"{orbit.status}: T = {res['period']:.10f}, x0 = {orbit.x0}, multipliers = {orbit.multipliers}, "
          f"|trivial - 1| = {orbit.trivial_multiplier_error:.1e}, error estimate {orbit.error_estimate}")
    print(f"Lyapunov exponents {ly.exponents} +- {ly.standard_error}")
    print(f"branch in c: {branch.end_reason}, special points {extra['branch_c']['special_points']}")


if __name__ == "__main__":
    main()
