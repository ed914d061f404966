"""
A branch of periodic orbits with special points
===============================================

:func:`birdocp.engine.continuation.continuation` follows periodic orbits through a parameter by
pseudo-arclength continuation and watches for folds, branch points, period doublings and
Neimark-Sacker points. Here it runs on two small forced systems whose answers are known exactly,
so what it reports can be checked (the bird's own branches, Experiment 3, are in the study pages:
``birdocp continue stability_margin --from -25 --to -32.5``).

A fold of cycles
----------------
``x' = (1 + y/2)(lam - x^2)``, ``y' = -y + sin(2 pi t)`` (period 1): for ``lam > 0`` there are two
cycles, ``x = +sqrt(lam)`` (stable) and ``x = -sqrt(lam)`` (unstable), which meet and vanish at
``lam = 0``: a fold, where a Floquet multiplier passes through +1.
"""

# %%
import casadi as ca
import matplotlib.pyplot as plt
import numpy as np

from birdocp.engine.continuation import continuation
from birdocp.engine.problem import OrbitProblem
from birdocp.engine.ode import ODE

x = ca.SX.sym("x", 2)
t = ca.SX.sym("t")
p = ca.SX.sym("p", 1)
lam = p[0]
rhs = ca.vertcat((1 + 0.5 * x[1]) * (lam - x[0] ** 2), -x[1] + ca.sin(2 * np.pi * t))
ode = ODE.from_rhs(ca.Function("fold", [x, t, p], [rhs]), 1.0, ("x", "y"), ("lam",))

problem = OrbitProblem(ode, [1.0], [1.0, 0.0])
branch = continuation(problem, "lam", 1.0, -1.0, points=3, steps_per_period=40)
print(branch.end_reason, f"{len(branch.points)} points")
for sp in branch.special_points:
    print(f"{sp.kind} at lam = {sp.parameter:.2e}, located: {sp.located}")

# %%
# The branch comes down the stable family, turns at the fold (located at ``lam = 0`` to round-off)
# and goes back up the unstable one to ``lam = 1`` (``end_reason = "reached_from"``).
lam_pts = np.array([pt.parameter for pt in branch.points])
x_pts = np.array([pt.x0[0] for pt in branch.points])
stable = np.array([pt.stable for pt in branch.points])
s = np.linspace(-1, 1, 201)
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(s ** 2, s, color="0.8", lw=4, label="exact: x = ±sqrt(lam)")
ax.plot(lam_pts[stable], x_pts[stable], "o", color="tab:blue", ms=4, label="stable cycle")
ax.plot(lam_pts[~stable], x_pts[~stable], "o", color="tab:red", ms=4, label="unstable cycle")
for sp in branch.special_points:
    ax.plot(sp.parameter, sp.x0[0], "k*", ms=12, label=sp.kind)


def finish(ax, ylabel, title):
    """Labels, legend and grid of a branch figure."""
    ax.set_xlabel("lam")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    plt.show()


finish(ax, "x(0) on the cycle", "fold of cycles")

# %%
# A period doubling
# -----------------
# A linear forced system that turns its state half a turn per period: its multipliers are
# ``-exp(lam)`` and ``-exp(-1)``, so one of them passes through -1 at ``lam = 0``.


def pd_rhs(x, t, lam):
    th = np.pi * t
    R = ca.vertcat(ca.horzcat(ca.cos(th), -ca.sin(th)), ca.horzcat(ca.sin(th), ca.cos(th)))
    A = np.pi * ca.DM([[0, -1], [1, 0]]) + R @ ca.diag(ca.vertcat(lam, -1)) @ R.T
    return A @ x + ca.vertcat(ca.sin(2 * np.pi * t), 0)


pd_ode = ODE.from_rhs(ca.Function("pd", [x, t, p], [pd_rhs(x, t, lam)]), 1.0, ("x", "y"), ("lam",))
pd_branch = continuation(OrbitProblem(pd_ode, [-0.5], [0.0, 0.0]), "lam", -0.5, 0.5,
                         points=3, steps_per_period=120)
for sp in pd_branch.special_points:
    L = np.array([complex(*m) for m in sp.multipliers])
    print(f"{sp.kind} at lam = {sp.parameter:.2e}; multipliers there: {np.round(L, 6)}")

fig, ax = plt.subplots(figsize=(6, 4))
lp = np.array([pt.parameter for pt in pd_branch.points])
mods = np.array([[complex(*m).real for m in pt.multipliers] for pt in pd_branch.points])
ax.plot(lp, mods, "o-", ms=3)
ax.plot(lp, -np.exp(lp), color="0.6", lw=4, alpha=0.5, label="exact -exp(lam)")
ax.axhline(-1, color="k", lw=0.6)
for sp in pd_branch.special_points:
    ax.axvline(sp.parameter, color="k", ls="--", label=sp.kind)
finish(ax, "real multipliers (the second stays at -exp(-1))", "a multiplier through -1")
