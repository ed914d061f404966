"""
Feedback: stabilise the unstable cycle through a shoulder joint
===============================================================

The reference cycle has one multiplier outside the unit circle, so the bird needs feedback. Here the
wingbeat map is linearised exactly at the cycle, ``dx[k+1] = M dx[k] + B du[k]``, where ``du`` are
changes of gait parameters held over one wingbeat, and a discrete LQR gain is designed on it
(:func:`birdocp.studies.control.design_controller`). A coarse grid (3 shooting points, 48 RK4
steps) keeps the tutorial quick; the study in ``results/control/`` uses the paper's grid.
"""

# %%
# The cycle and the controller
# ----------------------------
import matplotlib.pyplot as plt
import numpy as np

from birdocp.bird.config import Config
from birdocp.studies.control import design_controller
from birdocp.studies.trim import trim

cycle = trim(Config(), points=3, steps_per_period=48)
ctl = design_controller(cycle, ["gait.shoulder_sweep.offset_deg"], updates_per_beat=1)
print("open-loop multipliers:  ", np.round(ctl.map.multipliers, 5))
print("closed-loop multipliers:", np.round(ctl.closed_loop_multipliers, 5))
print(f"closed-loop spectral radius {ctl.spectral_radius:.4f}: a deviation shrinks 100x in "
      f"{np.log(100) / -np.log(ctl.spectral_radius):.1f} wingbeats")

# %%
# One joint is enough: the sweep offset, corrected once per wingbeat from the state at the beat's
# start, moves the expanding multiplier inside the unit circle. Below, the open- and closed-loop
# multipliers against the unit circle.
th = np.linspace(0, 2 * np.pi, 200)
fig, ax = plt.subplots(figsize=(5, 5))
ax.plot(np.cos(th), np.sin(th), color="0.6", lw=1, label="unit circle")
ol, cl = ctl.map.multipliers, ctl.closed_loop_multipliers
ax.plot(ol.real, ol.imag, "o", color="tab:red", label="open loop")
ax.plot(cl.real, cl.imag, "s", mfc="none", color="tab:blue", label="closed loop (sweep offset)")
ax.set_aspect("equal")
ax.set_xlabel("Re L")
ax.set_ylabel("Im L")
ax.legend(loc="lower left")
ax.grid(alpha=0.3)
ax.set_title("Wingbeat-to-wingbeat feedback through the sweep offset")
plt.show()
