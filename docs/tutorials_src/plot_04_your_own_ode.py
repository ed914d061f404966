"""
Periodic orbits of your own ODE
===============================

The engine under the bird (:mod:`birdocp.engine`) knows nothing of birds: it finds periodic orbits
of any time-periodic ODE ``x' = f(x, t, p)`` given as a CasADi Function, with their Floquet
multipliers, and follows them in a parameter. Here: the forced, damped Duffing oscillator

.. math:: \\ddot x + c \\dot x + k x + \\beta x^3 = F \\cos(\\omega t),

whose response to a strong forcing has two stable cycles (the classic hysteresis of the Duffing
resonance curve).
"""

# %%
# Pose the problem
# ----------------
# ``ODE.from_rhs(f, T, state_names, param_names)`` wraps ``f(x, t, p)`` (the data is the time); the period T is the
# forcing's. ``OrbitProblem`` adds the parameter values and a guess of the state at t = 0.
import casadi as ca
import matplotlib.pyplot as plt
import numpy as np

from birdocp.engine.integrate import simulate
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE
from birdocp.engine import OrbitMethod, solve

omega = 1.3
T = 2 * np.pi / omega
x = ca.SX.sym("x", 2)
t = ca.SX.sym("t")
p = ca.SX.sym("p", 4)
c, k, beta, F = p[0], p[1], p[2], p[3]
xdot = ca.vertcat(x[1], -c * x[1] - k * x[0] - beta * x[0] ** 3 + F * ca.cos(omega * t))
ode = ODE.from_rhs(ca.Function("duffing", [x, t, p], [xdot]), T, ("x", "v"), ("c", "k", "beta", "F"))
params = np.array([0.1, 1.0, 0.2, 0.3])   # c, k, beta, F

# %%
# Two cycles from two starts
# --------------------------
# A guess for each: the state after 30 periods of plain RK4 (:func:`~birdocp.engine.integrate.simulate`)
# from rest and from x = -3. Then multiple shooting with 5 points and 200 RK4 steps per period
# (``OrbitMethod`` holds the method's settings; IPOPT by default, ``solver="lm"`` for
# Levenberg-Marquardt).
method = OrbitMethod(points=5, steps_per_period=200)
cycles = {}
for name, start in (("small", [0.0, 0.0]), ("large", [-3.0, 0.0])):
    guess = simulate(ode, start, params, steps_per_period=200, n_periods=30)[1][-1]
    r = solve(OrbitProblem(ode, params, guess), method)
    amp = np.ptp(r.trajectory_x[:, 0]) / 2
    print(f"{name:5s}: success {r.success}, x(0) = {np.round(r.x0, 5)}, amplitude {amp:.4f}, "
          f"|L| = {np.round(np.abs(r.multipliers), 5)}, {'stable' if r.stable else 'unstable'}")
    cycles[name] = r

# %%
# Check one orbit independently: integrate it over ten periods with plain RK4 from its x(0); a
# periodic orbit comes back to x(0) after every period (a stable one stays there).
r = cycles["large"]
ts, X = simulate(ode, r.x0, params, steps_per_period=200, n_periods=10)
print("max |x(kT) - x(0)| over 10 periods:", np.max(np.abs(X[::200] - r.x0)))

# %%
# The product of the multipliers is known exactly for this system: the divergence of the vector
# field is ``-c``, so ``L1 L2 = exp(-c T)`` (Liouville's formula).
for name, r in cycles.items():
    print(f"{name}: L1 L2 = {np.prod(r.multipliers).real:.8f}, exp(-c T) = {np.exp(-params[0] * T):.8f}")

fig, ax = plt.subplots(figsize=(5.5, 4.5))
for name, r in cycles.items():
    ax.plot(r.trajectory_x[:, 0], r.trajectory_x[:, 1], label=f"{name} cycle")
    ax.plot(r.shooting_points[:, 0], r.shooting_points[:, 1], "k.", ms=6)
ax.set_xlabel("x")
ax.set_ylabel("dx/dt")
ax.set_title("two coexisting periodic responses (dots: shooting points)")
ax.legend()
ax.grid(alpha=0.3)
plt.show()
