"""Stuart-Landau oscillator (Hopf normal form): Hopf point of the equilibrium and the orbit branch born there.

System: the Stuart-Landau equation z' = (mu + i omega) z - (1 + i b) |z|^2 z (Y. Kuramoto, Chemical
Oscillations, Waves, and Turbulence, Springer 1984, ch. 2; the normal form of a supercritical Hopf
bifurcation), in x = Re z, y = Im z, with omega = 1, b = 0. Exact answers: the equilibrium 0 loses
stability at mu = 0 (eigenvalues mu +- i omega); for mu > 0 the orbit is the circle of radius
sqrt(mu) with period 2 pi / omega and non-trivial multiplier exp(-2 mu T).
Here: the equilibrium is continued from mu = -0.5 to 1, the Hopf point located, the first orbit
started there from the critical eigenvector (amplitude 0.02, the parameter an unknown), the orbit
branch continued from it to mu = 1 (pseudo-arclength, period varying), and the orbit at mu = 1
solved on its own from the point (0.5, 0) with period guess 5.

    python scripts/examples/stuart_landau.py [--out DIR]      (default results/engine/stuart_landau/)
"""
import casadi as ca
import numpy as np

from birdocp.engine.continuation.autonomous import continue_orbits
from birdocp.engine.equilibria import continue_equilibria, orbit_from_hopf
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, OrbitProblem, solve
from example_common import out_dir, plot_orbit, write_result

PARAMS = {"mu": 1.0, "omega": 1.0, "b": 0.0}


def stuart_landau(x, t, p):
    mu, w, b = p[0], p[1], p[2]
    r2 = x[0] ** 2 + x[1] ** 2
    return ca.vertcat(mu * x[0] - w * x[1] - r2 * (x[0] - b * x[1]),
                      w * x[0] + mu * x[1] - r2 * (b * x[0] + x[1]))


def make_ode():
    return ODE.from_function(stuart_landau, 2, tuple(PARAMS), state_names=("x", "y"))


def main():
    out = out_dir("stuart_landau", __doc__)
    ode = make_ode()
    p = np.array(list(PARAMS.values()))
    eq = continue_equilibria(ode, [-0.5, 1.0, 0.0], "mu", [0.01, 0.0], 1.0, ds=0.1)
    hopf = eq.hopf[0]
    first = orbit_from_hopf(ode, hopf, 0.02, OrbitMethod(points=5, steps_per_period=200))
    branch = continue_orbits(first, ode, "mu", 1.0, step=0.02, max_dparam=0.1)
    orbit = solve(OrbitProblem(ode, p, [0.5, 0.0], period_guess=5.0),
                  OrbitMethod(points=5, steps_per_period=None, accuracy=1e-9))
    mus = np.array([pt.parameter for pt in branch.points])
    radii = np.array([np.hypot(*pt.x0) for pt in branch.points])

    def panel(ax):
        m = np.linspace(0, 1.05, 200)
        ax.plot(m, np.sqrt(m), color="0.6", lw=3, label="exact: r = sqrt(mu)")
        ax.plot(mus, radii, "o", color="tab:red", ms=4, label="branch continued from the Hopf start")
        ax.plot([hopf.p[0]], [0], "k*", ms=12, label=f"Hopf point mu = {hopf.p[0]:.1e}")
        ax.set_xlabel("mu")
        ax.set_ylabel("orbit radius |x0|")
        ax.set_title("branch born at the Hopf point")
        ax.legend(fontsize=8)

    T = 2 * np.pi / PARAMS["omega"]
    extra = {
        "hopf": hopf.to_dict(),
        "exact": {"radius": 1.0, "period": T, "nontrivial_multiplier": float(np.exp(-2 * PARAMS["mu"] * T))},
        "hopf_start": {"amplitude": 0.02, "mu": float(first.p[0]), "period": float(first.period),
                       "status": first.status},
        "branch": {"end_reason": branch.end_reason,
                   "points": [{"mu": pt.parameter, "radius": float(np.hypot(*pt.x0)), "period": pt.period,
                               "multipliers": pt.multipliers} for pt in branch.points]},
        "equilibrium_branch": {"mu": eq.params.tolist(), "max_real_eigenvalue": eq.eigenvalues.real.max(axis=1).tolist()},
    }
    res = write_result(out, "stuart_landau", __doc__.split("\n\n")[1], PARAMS, orbit, extra=extra)
    plot_orbit(out, "Stuart-Landau (omega = 1, b = 0): orbit at mu = 1 and the Hopf branch", orbit, ("x", "y"),
               extra_panel=panel)
    print(f"Hopf at mu = {hopf.p[0]:.3e}, omega = {hopf.omega:.12f}")
    print(f"branch: mu = {mus}, radius^2 - mu = {radii ** 2 - mus}")
    print(f"{orbit.status}: T = {res['period']:.12f} (2 pi = {T:.12f}), radius {np.hypot(*orbit.x0):.12f}, "
          f"multipliers {orbit.multipliers} (exact exp(-2 mu T) = {np.exp(-2 * T):.6e})")


if __name__ == "__main__":
    main()
