"""
Trim the reference flight and read its Floquet multipliers
==========================================================

The paper's reference case: a northern bald ibis flapping at 4 Hz with an amplitude of 42 deg, its
wing root 5 cm ahead of the centre of mass. :func:`birdocp.studies.trim.trim` finds the periodic
flight by multiple shooting (IPOPT, exact CasADi derivatives) and the Floquet multipliers of the
cycle: the eigenvalues of the monodromy matrix, the Jacobian of the one-period map. A multiplier
outside the unit circle is a mode that grows from one wingbeat to the next.
"""

# %%
# Solve
# -----
# ``Config()`` is the reference case; every number of it can be changed with ``with_values``.
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import Config
from birdocp.studies.trim import trim

cfg = Config()
res = trim(cfg)
print(res.success, res.status, f"{res.iterations} iterations, max residual {res.max_residual:.1e}")
print(f"mean forward speed {res.mean_forward_speed_mps:.4f} m/s, "
      f"mean vertical speed {res.mean_vertical_speed_mps:+.4f} m/s (positive climbing)")

# %%
# The multipliers
# ---------------
# Largest modulus first. The Floquet exponent ``ln(L)/T`` [1/s] turns a multiplier into a growth
# rate; ``doubling_times_s`` is ``ln 2 / Re(exponent)`` (negative: a halving time).
for L, mu, td in zip(res.multipliers, res.floquet_exponents, res.doubling_times_s):
    kind = "doubles" if td > 0 else "halves"
    print(f"L = {L.real:+.5f} {L.imag:+.5f}j   |L| = {abs(L):.5f}   exponent {mu.real:+.4f} 1/s   "
          f"{kind} in {abs(td):.3f} s")
print("stable" if res.stable else "unstable", "cycle")

# %%
# One real multiplier is larger than 1: the flight is **unstable**, a perturbation along its
# eigenvector doubles in about half a second. The complex pair is a damped oscillation (about one
# turn in five wingbeats) and the last mode decays fast. Right: the cycle itself, the states over
# one wingbeat (``trajectory_t``, ``trajectory_x``; u, w [m/s] along the body axes x' forward and z'
# down, q [rad/s] nose-up, theta [rad]).
th = np.linspace(0, 2 * np.pi, 200)
fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
ax = axes[0]
ax.plot(np.cos(th), np.sin(th), color="0.6", lw=1)
ax.plot(res.multipliers.real, res.multipliers.imag, "o", color="tab:red")
for i, L in enumerate(res.multipliers):
    ax.annotate(f"L{i}", (L.real, L.imag), textcoords="offset points", xytext=(5, 5))
ax.set_aspect("equal")
ax.set_xlabel("Re L")
ax.set_ylabel("Im L")
ax.set_title("Floquet multipliers and the unit circle")
ax.grid(alpha=0.3)

ax = axes[1]
t = 1000 * res.trajectory_t
ax.plot(t, res.trajectory_x[:, 0] - res.trajectory_x[:, 0].mean(), label="u - mean(u) [m/s]")
ax.plot(t, res.trajectory_x[:, 1], label="w [m/s]")
ax.plot(t, res.trajectory_x[:, 2], label="q [rad/s]")
ax.plot(t, np.degrees(res.trajectory_x[:, 3]) / 10, label="theta / 10 [deg]")
ax.set_xlabel("t [ms]")
ax.set_title("states over one wingbeat")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()

# %%
# Changing the gait
# -----------------
# Dotted keys address every number of the configuration (``birdocp config`` prints them all).
from birdocp.bird.config import with_values

res44 = trim(with_values(cfg, {"gait.shoulder_flap.amplitude_deg": 44.0}), warm_start=res)
print(f"A = 44 deg: mean vertical speed {res44.mean_vertical_speed_mps:+.4f} m/s, "
      f"largest |L| {abs(res44.multipliers[0]):.4f}")
