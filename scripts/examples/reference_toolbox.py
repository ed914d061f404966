"""The reference toolbox's small examples as birdocp problems: the systems, parameters and starting
guesses (point, period guess) that the reference toolbox's own example scripts use, plus the Lorenz
unstable orbits around C+ (sigma = 10, beta = 8/3) at r = 21, 22, 23 and 24.73.

* isothermal: R. Seydel, Practical Bifurcation and Stability Analysis, eq. (7.15), lambda = 11,
  guess (40, 20, 20), period 0.5 (the guess lies in the basin of a stable equilibrium);
* Goodwin: D. Gonze et al., Biophys. J. 89 (2005) 120, guess (0.1, 1, 1), period 23 h;
* redox: M. del Olmo et al., Int. J. Mol. Sci. 20 (2019) 2368, guess (0.5, 0.5, 0.6, 0.2), period 23
  (stiff: Radau IIA);
* torus: the reference's three-variable example at lambda = 2, guess (0.9, 0.9, 0.9), period 200
  (about 8 loops of the orbit, whose minimal period is 8 pi exactly: x, y rotate at 1/4 rad per time
  unit on an invariant circle);
* Lorenz: the guesses of the reference's Lorenz runs are not published with its examples; here each
  is a point of the orbit rounded to 0.1 with the period rounded to 0.01 (and, separately, the exact
  orbit point with the period 30 % off).

    from reference_toolbox import NAMES, make   # make(name) -> Example(ode, p, x, period, method kwargs)
"""
from __future__ import annotations

from typing import NamedTuple

import casadi as ca

from birdocp.engine.ode import ODE


class Example(NamedTuple):
    ode: ODE
    p: list
    x: list
    period: float
    method: dict


def _isothermal(x, t, p):
    return ca.vertcat(x[0] * (30 - 0.25 * x[0] - x[1] - x[2]) + 0.001 * x[1] ** 2 + 0.1,
                      x[1] * (x[0] - 0.001 * x[1] - p[0]) + 0.1, x[2] * (16.5 - x[0] - 0.5 * x[2]) + 0.1)


def _goodwin(x, t, p):
    k1, k2, k3, k4, k5, k6, n = 0.7, 0.45, 0.7, 0.35, 0.7, 0.35, 7
    return ca.vertcat(k1 / (1 + x[2] ** n) - k2 * x[0] / (1 + x[0]), k3 * x[0] - k4 * x[1] / (1 + x[1]),
                      k5 * x[1] - k6 * x[2] / (1 + x[2]))


def _redox(x, t, p):
    a, b, d, e, q, pr = 1000.0, 2.0, 0.2, 0.1, 0.1, 1.0
    D1, D2, R, A = x[0], x[1], x[2], x[3]
    return ca.vertcat(pr - a * A * D1 - d * D1, d * D1 - e * D2, e * D2 - q * R, b * (1 - A) * R - a * A * D1)


def _torus(x, t, p):
    r = x[2] + 0.2 * (1 - x[2] ** 2)
    return ca.vertcat((p[0] - 3) * x[0] - 0.25 * x[1] + x[0] * r, 0.25 * x[0] + (p[0] - 3) * x[1] + x[1] * r,
                      p[0] * x[2] - (x[0] ** 2 + x[1] ** 2 + x[2] ** 2))


def _lorenz(x, t, p):
    return ca.vertcat(p[0] * (x[1] - x[0]), x[0] * (p[1] - x[2]) - x[1], x[0] * x[1] - p[2] * x[2])


def make(name: str) -> Example:
    """The example ``name`` (a key of :data:`NAMES`), its ODE built afresh."""
    if name == "isothermal":
        return Example(ODE.from_function(_isothermal, 3, ("lam",)), [11.0], [40.0, 20.0, 20.0], 0.5, {"points": 5})
    if name == "goodwin":
        return Example(ODE.from_function(_goodwin, 3), [], [0.1, 1.0, 1.0], 23.0, {"points": 5})
    if name == "redox":
        return Example(ODE.from_function(_redox, 4), [], [0.5, 0.5, 0.6, 0.2], 23.0,
                       {"points": 5, "integrator": "radau"})
    if name == "torus":
        return Example(ODE.from_function(_torus, 3, ("lam",)), [2.0], [0.9, 0.9, 0.9], 200.0, {"points": 5})
    if name.startswith("lorenz"):
        r = name.split("_")[1]
        x, T = LORENZ_GUESSES[r]
        return Example(ODE.from_function(_lorenz, 3, ("sigma", "r", "beta")), [10.0, float(r), 8.0 / 3.0], x, T,
                       {"points": 9})
    raise KeyError(name)


# a point of each orbit rounded to 0.1, the period rounded to 0.01
LORENZ_GUESSES = {"21": ([11.2, 8.5, 27.6], 0.82), "22": ([11.0, 8.6, 27.8], 0.76),
                  "23": ([10.6, 8.7, 27.6], 0.72), "24.73": ([8.2, 8.0, 24.1], 0.65)}
NAMES = ["redox", "isothermal", "torus", "goodwin"] + [f"lorenz_{r}" for r in LORENZ_GUESSES]
# no periodic orbit near the guess (both non-trivial equilibria are stable foci at r = 10): a failure
LORENZ_GUESSES["10"] = ([5.0, 5.0, 10.0], 0.8)
FAILURES = ["lorenz_10"]
# the reference toolbox's first-solve wall times quoted in issue 27 (s); Lorenz: about 4 s
REFERENCE_WALL_S = {"redox": 0.31, "isothermal": 0.26, "torus": 3.1, "lorenz": 4.0}
