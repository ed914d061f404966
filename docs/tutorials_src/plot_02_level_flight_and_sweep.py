"""
Level flight and an amplitude sweep
===================================

At 42 deg the reference bird descends slowly. :func:`birdocp.studies.level.level` makes the flapping
amplitude an unknown of the shooting problem and adds one condition, a zero mean vertical speed over
the period, so level flight is one nonlinear solve. :func:`birdocp.studies.sweep.sweep` then solves
one cycle per amplitude, each warm-started from its neighbour.
"""

# %%
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import Config
from birdocp.studies.level import level

cfg = Config()
lv = level(cfg)
print(lv.success, lv.status)
print(f"level flight at A = {lv.amplitude_deg:.4f} deg (the paper: 43.47 deg), "
      f"mean vertical speed {lv.mean_vertical_speed_mps:.1e} m/s, forward {lv.mean_forward_speed_mps:.3f} m/s")
print("multipliers:", np.round(lv.multipliers, 5))

# %%
# A sweep over the amplitude
# --------------------------
# Four amplitudes (the paper's Experiment 2 uses 13, from 40 to 46 deg); ``progress=False`` keeps
# the output clean, ``out_dir=...`` would write each point as it is solved.
from birdocp.studies.sweep import sweep

rows = sweep(cfg, "amplitude", [40.0, 42.0, 44.0, 46.0], progress=False)
A = np.array([r["value"] for r in rows])
W = np.array([r["mean_vertical_speed_mps"] for r in rows])
L1 = np.array([r["modulus0"] for r in rows])
for a, w, l1 in zip(A, W, L1):
    print(f"A = {a:4.1f} deg: mean W = {w:+.4f} m/s, largest |L| = {l1:.4f}")

fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
axes[0].plot(A, W, "o-")
axes[0].axhline(0, color="k", lw=0.6)
axes[0].axvline(lv.amplitude_deg, color="tab:green", ls="--", label="level flight")
axes[0].set_xlabel("flapping amplitude A [deg]")
axes[0].set_ylabel("mean vertical speed [m/s] (climbing +)")
axes[0].legend()
axes[1].plot(A, L1, "o-", color="tab:red")
axes[1].axhline(1, color="k", lw=0.6)
axes[1].set_xlabel("flapping amplitude A [deg]")
axes[1].set_ylabel("largest multiplier modulus")
for ax in axes:
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()

# %%
# The mean vertical speed is nearly linear in the amplitude, and the cycle is unstable at every
# amplitude: the expanding multiplier barely moves.
