"""Lorenz system: the shortest unstable periodic orbit ("AB") and the attractor's Lyapunov spectrum.

System and parameters: E. N. Lorenz, "Deterministic nonperiodic flow", J. Atmos. Sci. 20 (1963)
130-141:  x' = sigma (y - x),  y' = x (rho - z) - y,  z' = x y - beta z,  sigma = 10, rho = 28,
beta = 8/3. Start of the orbit: the point of the AB orbit on the section z = 27 listed (to 4 digits
here) by D. Viswanath, "Symbolic dynamics and periodic orbits of the Lorenz attractor",
Nonlinearity 16 (2003) 1035-1056, period guess 1.5587. Lyapunov spectrum: QR method on the exact
tangent flow over 2000 time units; published largest exponent 0.9056 (J. C. Sprott, Chaos and
Time-Series Analysis, OUP 2003). The sum of the spectrum must equal the divergence -(sigma+1+beta).

    python scripts/examples/lorenz.py [--out DIR]      (default results/engine/lorenz/)
"""
import casadi as ca

from birdocp.engine.lyapunov import lyapunov_exponents
from birdocp.engine.ode import ODE
from example_common import accurate_orbit, begin, plot_orbit, write_result

PARAMS = {"sigma": 10.0, "rho": 28.0, "beta": 8.0 / 3.0}


def lorenz(x, t, p):
    s, r, b = p[0], p[1], p[2]
    return ca.vertcat(s * (x[1] - x[0]), x[0] * (r - x[2]) - x[1], x[0] * x[1] - b * x[2])


def make_ode():
    return ODE.from_function(lorenz, 3, tuple(PARAMS), state_names=("x", "y", "z"))


def main():
    out, ode, p = begin("lorenz", __doc__, make_ode, PARAMS)
    orbit = accurate_orbit(ode, p, [-13.7636, -19.5788, 27.0], 1.5587, points=9)
    ly = lyapunov_exponents(ode, [1.0, 1.0, 1.0], p, t_total=2000.0, dt=0.005, t_transient=50.0)
    div = -(PARAMS["sigma"] + 1 + PARAMS["beta"])

    def panel(ax):
        for k in range(3):
            ax.plot(ly.history_t, ly.history[:, k], label=f"lambda_{k + 1} = {ly.exponents[k]:.4f}")
        ax.set_xscale("log")
        ax.set_yscale("symlog", linthresh=0.1)
        ax.set_ylim(-30, 300)
        ax.set_xlabel("averaging time (time units)")
        ax.set_ylabel("running estimate (1 / time unit)")
        ax.set_title("Lyapunov spectrum (QR)")
        ax.legend(fontsize=8, loc="upper right", ncol=1)

    res = write_result(out, "lorenz", __doc__.split("\n\n")[1], PARAMS, orbit, ly,
                       {"lyapunov_sum": ly.sum, "divergence": div})
    plot_orbit(out, "Lorenz (sigma = 10, rho = 28, beta = 8/3): orbit AB and exponents", orbit,
               ("x", "y", "z"), phase=(0, 2), extra_panel=panel)
    print(f"{orbit.status}: T = {res['period']:.10f}, multipliers = {orbit.multipliers}, "
          f"error estimate {orbit.error_estimate}")
    print(f"Lyapunov exponents {ly.exponents} +- {ly.standard_error}; sum {ly.sum:.6f} (divergence {div:.6f})")


if __name__ == "__main__":
    main()
