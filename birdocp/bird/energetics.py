"""Power, energy balance and the derived flight-energetics outputs of a cycle (docs/studies/energetics.md).

All powers are computed from the same element forces and velocities as the dynamics
(:func:`birdocp.bird.model.load_terms`), in the code frame (dot products are frame-invariant):

* ``aerodynamic_power_W`` P_aero = sum_j F_j . V_j: power delivered to the air (induced + profile +
  parasite + tail losses); F_j the force of the air on element j, V_j its relative air velocity;
* ``flapping_power_W`` P_flap = -sum_j F_j . v_kin,j: the aerodynamic part of the power the wing joints
  supply through the wing's motion relative to the body (negative: the air drives the wing);
* ``body_power_W`` P_body = Fx' u + Fz' w + My' q: the power of all aerodynamic loads on the body's
  rigid motion ("thrust power");
* ``induced_power_W`` = -sum_j dF_j . v_ind,j, ``profile_power_W`` = sum_j dD_j . V_j,
  ``parasite_power_W`` = F_par . U_inf and ``tail_power_W`` (the tail's loads on the air; a body-fixed
  point) -- their sum is P_aero;
* instantaneous identity P_flap = P_aero + P_body (to round-off, every evaluation);
* over a periodic cycle mean P_body = m g mean(W) (0 in level flight), so mean P_flap = mean P_aero
  + m g mean(W).

Period means come from quadrature states integrated by the same RK4 stages as the state
(:class:`birdocp.engine.integrate.RK4Grid` with the power vector as an output). The positive-work
power (muscles that cannot recover negative work) is the mean of max(P_sh, 0) from the samples at the
N RK4 step times; P_sh = P_flap + inertial power (:func:`shoulder_power_W`; the inertial part is 0 for
massless wings).

Derived (each labelled with its definition): cost of transport P / (m g U), Strouhal number
f A / U (A the peak-to-peak excursion of the wingtip's z' coordinate relative to the body over one
period, tip of feather 0), reduced frequency k = pi f c / U (half-chord convention, c =
``body.reference_chord_m``) and the span-based k_f = 2 pi f b / U (b the largest tip-to-tip span over the
wingbeat).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES
from birdocp.bird.model import load_terms, unpack_data
from birdocp.engine.cache import owned_cache

__all__ = ["POWER_NAMES", "PowerFunctions", "power_functions", "shoulder_power_W", "cycle_energetics",
           "ENERGETICS_KEYS"]

POWER_NAMES = ("aerodynamic_power_W", "flapping_power_W", "body_power_W", "induced_power_W",
               "profile_power_W", "parasite_power_W", "tail_power_W")
"""Rows of :attr:`PowerFunctions.power` (W), followed by the forward and vertical speeds U, W (m/s)."""

ENERGETICS_KEYS = ("mean_aerodynamic_power_W", "mean_flapping_power_W", "mean_body_power_W",
                   "mean_induced_power_W", "mean_profile_power_W", "mean_parasite_power_W",
                   "mean_tail_power_W", "mean_shoulder_power_W",
                   "mean_positive_power_W", "mean_negative_power_W", "cost_of_transport",
                   "cost_of_transport_positive", "strouhal_number", "wingtip_excursion_m",
                   "reduced_frequency", "reduced_frequency_span", "max_span_m")
"""Scalar outputs of :func:`cycle_energetics` reported by ``trim`` and ``level``. The wings' inertial
power is not among them: its keys (``mean_inertial_power_W``, ...) belong to the wing-mass outputs, and
:func:`cycle_energetics` takes it as an input."""

TIP_NODE = -1
"""The wingtip is the last node of the merged line (right wing, tip of feather 0; docs/model.md §4.1)."""


def _p(p, name):
    return p[PARAM_NAMES.index(name)]


def _mid_chord_powers(lt: dict, u, w, q):
    """(P_aero, P_flap) parts [W] of the loads at mid-chord (separated and added-mass forces) and of the
    added-mass couples of an unsteady/stall section (0 otherwise): sum (dF_mid + dF_nc) . V_mid - C omega
    and -sum (dF_mid + dF_nc) . r_mid' - C omega_k, with V_mid = U_inf - Omega x r_mid - r_mid'."""
    if "sec" not in lt:
        return ca.SX(0), ca.SX(0)
    sec = lt["sec"]
    rm, rmd, Fm = sec["r_mid"], sec["r_mid_dot"], lt["dF_mid"]
    n = rm.shape[1]
    ones = ca.DM.ones(1, n)
    Vm = ca.vertcat(-rmd[0, :], w * ones + q * rm[2, :] - rmd[1, :], u * ones - q * rm[1, :] - rmd[2, :])
    Pa = ca.sum2(ca.sum1(Fm * Vm))
    Pf = -ca.sum2(ca.sum1(Fm * rmd))
    if sec["wagner"]:
        Pa = Pa - ca.sum2(lt["couple"] * sec["omega"])
        Pf = Pf - ca.sum2(lt["couple"] * sec["omega_k"])
    return Pa, Pf


class PowerFunctions:
    """The power Functions of one :class:`birdocp.bird.model.BirdModel` (built once, see
    :func:`power_functions`).

    ``power(x, d, p)``: column of :data:`POWER_NAMES` (W) followed by U and W (m/s) and, when the wings
    have mass, the shoulders' inertial power (W) (row names: ``names``), at state x, data d.
    ``energy(x, p)``: rigid-body mechanical energy E_b = m (u^2 + w^2)/2 + I q^2/2 (J, without the
    potential part; dE_b/dt + m g W = P_body along the motion).
    """

    def __init__(self, model):
        self.model = model
        x = ca.SX.sym("x", model.ode.nx)  # (u, w, q, theta) and the aerodynamic states, if any
        d = ca.SX.sym("d", model.ode.nd)  # N_DATA, plus the wing-mass sums when the wings have mass
        p = ca.SX.sym("p", len(PARAM_NAMES))
        lt = load_terms(model.structure, x, d, p)
        u, w, q, th = x[0], x[1], x[2], x[3]
        F_el = lt["dF"] + lt["dD"]
        V = lt["V"]
        P_mid_aero, P_mid_flap = _mid_chord_powers(lt, u, w, q)
        U_inf = ca.vertcat(0, w, u)
        P_par = ca.dot(lt["F_par"], U_inf)
        if lt["tail"] is not None:
            Lt, Dt, Mt = lt["tail"]
            P_tail = -(-Dt * u - Lt * w + Mt * q)  # the tail is body-fixed: what it takes from the body
        else:
            P_tail = ca.SX(0)
        P_aero = ca.sum2(ca.sum1(F_el * V)) + P_par + P_tail + P_mid_aero
        P_flap = -ca.sum2(ca.sum1(F_el * lt["v_kin"])) + P_mid_flap
        P_body = lt["Fx_N"] * u + lt["Fz_N"] * w + lt["My_Nm"] * q
        v_wake = lt["vind"] if "sec" not in lt else lt["vind"] + lt["sec"]["v_s"]
        P_ind = -ca.sum2(ca.sum1(lt["dF"] * v_wake)) + P_mid_aero
        P_pro = ca.sum2(ca.sum1(lt["dD"] * V))
        U = u * ca.cos(th) + w * ca.sin(th)
        W = u * ca.sin(th) - w * ca.cos(th)
        rows = [P_aero, P_flap, P_body, P_ind, P_pro, P_par, P_tail, U, W]
        self.names = POWER_NAMES + ("forward_speed_mps", "vertical_speed_mps")
        if getattr(model, "wing_power_d", None) is not None:
            # wings with mass: the power the shoulders spend on the wings' masses (docs/studies/inertia.md, powers)
            from birdocp.bird.model import WING_POWER_NAMES

            wp = model.wing_power_d(x, d, p)
            rows.append(wp[WING_POWER_NAMES.index("shoulder_inertial_power_W")])
            self.names += ("shoulder_inertial_power_W",)
        self.power = ca.Function("power", [x, d, p], [ca.vertcat(*rows)], ["x", "d", "p"], ["power"])
        # smooth positive part 1/2 (P + sqrt(P^2 + eps^2)) of the flapping power (error <= eps/2)
        eps = ca.SX.sym("eps")
        self.positive_flapping = ca.Function(
            "positive_flapping", [x, d, p, eps], [0.5 * (P_flap + ca.sqrt(P_flap ** 2 + eps ** 2))])
        m, I = _p(p, "body.mass_kg"), _p(p, "body.pitch_inertia_kgm2")
        self.energy = ca.Function("energy", [x, p], [0.5 * m * (u ** 2 + w ** 2) + 0.5 * I * q ** 2])
        tip = unpack_data(d)["nodes_m"][:, TIP_NODE]
        self.tip = ca.Function("tip", [d], [tip])  # wingtip relative to G, code frame (e2 up)
        self._grids: dict = {}

    def grid(self, steps_per_period: int):
        """A one-segment RK4 grid with the power vector as quadrature output (cached per steps)."""
        from birdocp.engine.integrate import RK4Grid

        g = self._grids.get(steps_per_period)
        if g is None:
            g = self._grids[steps_per_period] = RK4Grid(self.model.ode, int(steps_per_period), 1,
                                                        outputs=(self.power,))
        return g


def power_functions(model) -> PowerFunctions:
    """The :class:`PowerFunctions` of a :class:`~birdocp.bird.model.BirdModel` (built once, kept by the model).

    Parameters
    ----------
    model : BirdModel or ConfiguredModel
        The model.

    Returns
    -------
    PowerFunctions
    """
    model = getattr(model, "model", model)
    return owned_cache(model).build("power_functions", lambda: PowerFunctions(model))


def shoulder_power_W(flapping_power_W, inertial_power_W=0.0):
    """The power the shoulder joints supply, P_sh = P_flap + inertial part (docs/studies/energetics.md).

    The one place where power terms are combined: with massless wings (the paper's model) the inertial
    part is 0 and P_sh = P_flap. Works on floats and numpy arrays (W).

    Parameters
    ----------
    flapping_power_W : float or ndarray
        Aerodynamic flapping power P_flap [W].
    inertial_power_W : float or ndarray
        Inertial part [W].

    Returns
    -------
    float or ndarray
        P_sh [W].
    """
    return np.add(flapping_power_W, inertial_power_W)


def _positive_negative(samples_W):
    s = np.asarray(samples_W, float)
    return float(np.mean(np.maximum(s, 0.0))), float(np.mean(np.maximum(-s, 0.0)))


def cycle_energetics(model, p, x0, steps_per_period: int, t0: float = 0.0, inertial_power_W=None,
                     mean_inertial_power_W: float = 0.0) -> dict:
    """Powers and derived outputs of the periodic cycle through ``x0`` (state at ``t0``).

    Parameters
    ----------
    model : BirdModel or ConfiguredModel
        Model.
    p : array_like
        Parameter vector.
    x0 : array_like
        State at ``t0``.
    steps_per_period : int
        RK4 steps (the trim's grid, so the means are those of the solved cycle).
    t0 : float
        Start time [s].
    inertial_power_W : array_like, optional
        The wings' inertial power at the N sample times t0 + (k+1) T/N [W] (default: the model's own:
        the shoulders' inertial power when the wings have mass, else 0).
    mean_inertial_power_W : float
        Its mean [W].

    Returns
    -------
    dict
        The scalars of :data:`ENERGETICS_KEYS` (SI units, each named with its unit), ``means`` (every
        row of the power vector), ``samples`` (``t_s`` and each power in W at the N step times) and
        ``definitions`` (text).
    """
    pf = power_functions(model)
    grid = pf.grid(steps_per_period)
    p = np.asarray(p, float).ravel()
    D = grid.blocks_numeric(t0, p)
    pd = ca.DM(p)
    _, X, q = grid.period_map(ca.DM(np.asarray(x0, float)), D, pd)
    T = grid.ode.forcing_period
    N = grid.N
    mean = np.asarray(q).ravel() / T
    names = pf.names
    means = dict(zip(names, mean.tolist()))
    Dend = D[:, list(range(2, 3 * N, 3))]  # d(t0 + (k+1) h), the data of the trajectory's states
    S = np.asarray(pf.power.map(N)(X, Dend, pd))
    samples = {n: S[i] for i, n in enumerate(names)}
    t = t0 + grid.h * np.arange(1, N + 1)
    if inertial_power_W is None and "shoulder_inertial_power_W" in samples:  # wings with mass
        inertial_power_W = samples["shoulder_inertial_power_W"]
        mean_inertial_power_W = means["shoulder_inertial_power_W"]
    inertial = np.zeros(N) if inertial_power_W is None else np.asarray(inertial_power_W, float)
    P_sh = shoulder_power_W(samples["flapping_power_W"], inertial)
    pos, neg = _positive_negative(P_sh)
    mean_sh = float(shoulder_power_W(means["flapping_power_W"], mean_inertial_power_W))
    mg = float(_p(p, "body.mass_kg") * _p(p, "body.gravity_mps2"))
    U = means["forward_speed_mps"]
    f = 1.0 / T
    tips = np.asarray(pf.tip.map(N)(Dend))  # 3 x N, code frame: e1 span, e2 up
    A = float(np.max(tips[1]) - np.min(tips[1]))
    b = float(2 * np.max(tips[0]))
    c = float(_p(p, "body.reference_chord_m"))
    out = {f"mean_{n}": means[n] for n in POWER_NAMES}
    out.update({
        "mean_shoulder_power_W": mean_sh,
        "mean_positive_power_W": pos,
        "mean_negative_power_W": neg,
        "cost_of_transport": mean_sh / (mg * U) if U > 0 else float("nan"),
        "cost_of_transport_positive": pos / (mg * U) if U > 0 else float("nan"),
        "strouhal_number": f * A / U if U > 0 else float("nan"),
        "wingtip_excursion_m": A,
        "reduced_frequency": math.pi * f * c / U if U > 0 else float("nan"),
        "reduced_frequency_span": 2 * math.pi * f * b / U if U > 0 else float("nan"),
        "max_span_m": b,
        "mean_forward_speed_mps": U,
        "mean_vertical_speed_mps": means["vertical_speed_mps"],
        "mean_sampled_shoulder_power_W": float(np.mean(P_sh)),
    })
    out["samples"] = {"t_s": t, **{n: samples[n] for n in POWER_NAMES}, "shoulder_power_W": P_sh,
                      "inertial_power_W": inertial, "wingtip_height_m": tips[1]}
    out["definitions"] = DEFINITIONS
    return out


DEFINITIONS = {
    "mean_aerodynamic_power_W": "period mean of sum_j F_j . V_j (power delivered to the air)",
    "mean_flapping_power_W": "period mean of -sum_j F_j . v_kin,j (aerodynamic part of the joints' power)",
    "mean_body_power_W": "period mean of Fx' u + Fz' w + My' q (= m g mean W on a periodic cycle)",
    "mean_shoulder_power_W": "mean flapping power + mean inertial power (the cost with elastic storage)",
    "mean_positive_power_W": "mean of max(P_sh, 0) over the N RK4 step times (no storage of negative work)",
    "mean_negative_power_W": "mean of max(-P_sh, 0); positive - negative = sampled mean of P_sh",
    "cost_of_transport": "mean_shoulder_power_W / (m g mean U), mechanical, dimensionless",
    "cost_of_transport_positive": "mean_positive_power_W / (m g mean U)",
    "strouhal_number": "f A / mean U, A = peak-to-peak z' excursion of the wingtip relative to the body",
    "reduced_frequency": "pi f c / mean U (half-chord convention), c = body.reference_chord_m",
    "reduced_frequency_span": "2 pi f b / mean U, b = largest tip-to-tip span over the wingbeat",
}
