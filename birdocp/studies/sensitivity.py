"""Exact sensitivities of the Floquet multipliers to gait and morphology parameters.

At a converged cycle x0(p) of the one-period map Phi (RK4 on the stage grid of the shooting):

* the cycle moves with p by the implicit-function theorem on the periodicity condition
  ``Phi(x0, p) = x0``: ``dx0/dp = (I - Mon)^-1 dPhi/dp``;
* the monodromy ``Mon = dPhi/dx0`` then changes by ``dMon = d2Phi/dx0 dx0 [dx0/dp] + d2Phi/dx0 dp``
  (forward-over-forward CasADi AD through the RK4 steps, along one parameter direction at a time; the
  per-time data's derivative ``dD/dp`` comes from forward AD of the geometry graph);
* a simple multiplier moves by ``dL_i = w_i^H dMon v_i`` (left/right eigenvectors with ``W V = I``),
  its modulus by ``Re(conj(L_i) dL_i) / |L_i|``.

With ``hold_level=True`` the flapping amplitude is re-solved to keep the mean vertical speed fixed:
``dA/dp = -(dW/dp)/(dW/dA)`` with W the period mean of ``u sin(theta) - w cos(theta)`` (its total
derivatives include the cycle change too), and ``dL/dp|level = dL/dp + dL/dA dA/dp``.

All derivatives are exact (to round-off) for the discretised problem the trim solves.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from birdocp.bird.config import PARAM_NAMES, Config
from birdocp.engine.cache import owned_cache
from birdocp.engine.floquet import multiplier_order
from birdocp.engine.integrate import RK4Grid
from birdocp.engine.results import result_dict, serial
from birdocp.engine.sensitivity import orbit_state_derivative, total_derivative
from birdocp.bird.model import get_model

__all__ = ["SensitivityResult", "multiplier_sensitivities", "cycle_derivatives", "DEFAULT_PARAMETERS", "unit_of", "SecondOrderMaps"]

from birdocp.bird.keys import AMPLITUDE_KEY  # noqa: E402

DEFAULT_PARAMETERS = tuple(k for k in PARAM_NAMES
                           if k.startswith("gait.") or k in (
                               "wing.root_ahead_m", "wing.arm_length_m", "wing.forearm_length_m",
                               "wing.hand_length_m", "wing.feather_lengths_m.0", "wing.feather_lengths_m.2",
                               "wing.feather_lengths_m.4", "wing.feather_lengths_m.6",
                               "wing.shoulder_half_separation_m", "body.mass_kg", "body.pitch_inertia_kgm2"))
"""Gait (every joint offset, amplitude and phase) and morphology parameters ranked by default."""


def unit_of(key: str) -> tuple[str, float]:
    """(display unit, factor from the parameter's own unit): degrees stay degrees, metres are shown
    per cm, the rest per its own unit.

    Parameters
    ----------
    key : str
        Dotted key.

    Returns
    -------
    unit : str
    factor : float
    """
    if key.endswith("_deg"):
        return "deg", 1.0
    if key.endswith("_m"):
        return "cm", 0.01
    if key.endswith("_kg"):
        return "kg", 1.0
    if key.endswith("_kgm2"):
        return "kg m^2", 1.0
    return key.rsplit("_", 1)[-1], 1.0


@dataclass
class SensitivityResult:
    parameters: list          # parameter keys
    multipliers: np.ndarray = field(metadata=serial(complex=True))  # at the cycle, largest modulus first
    # (n_params, 4) complex, per unit of the parameter's own unit
    d_multipliers: np.ndarray = field(metadata=serial(complex=True))
    d_moduli: np.ndarray      # (n_params, 4)
    d_x0: np.ndarray          # (n_params, 4)
    # (n_params,) m/s per unit
    d_mean_vertical_speed: np.ndarray = field(metadata=serial(key="d_mean_vertical_speed_mps"))
    hold_level: bool
    # (n_params,) deg per unit (hold_level only)
    d_amplitude: np.ndarray | None = field(metadata=serial(key="d_amplitude_deg"))
    # the cycle differentiated: its state at t = 0, flapping amplitude [deg] and exact validity
    # (CycleValidity.to_dict(); every row is a derivative at this one cycle)
    x0: np.ndarray | None = None
    amplitude_deg: float | None = None
    validity: dict | None = None

    @property
    def valid(self) -> bool | None:
        """Whether the model holds on the cycle differentiated (None: not checked)."""
        return None if self.validity is None else bool(self.validity.get("valid"))

    def ranked(self, mode: int = 0) -> list[dict]:
        """Rows sorted by |d modulus of multiplier `mode`| per display unit (deg or cm).

        Parameters
        ----------
        mode : int
            Index of the multiplier (largest modulus first).

        Returns
        -------
        list of dict
        """
        rows = []
        for k, key in enumerate(self.parameters):
            unit, f = unit_of(key)
            rows.append({"parameter": key, "unit": unit,
                         "d_modulus_per_unit": float(self.d_moduli[k, mode] * f),
                         "d_multiplier_per_unit": [float(self.d_multipliers[k, mode].real * f),
                                                   float(self.d_multipliers[k, mode].imag * f)],
                         "d_mean_vertical_speed_mps_per_unit": float(self.d_mean_vertical_speed[k] * f),
                         "d_amplitude_deg_per_unit": (None if self.d_amplitude is None
                                                      else float(self.d_amplitude[k] * f)),
                         "valid": self.valid})
        rows.sort(key=lambda r: -abs(r["d_modulus_per_unit"]))
        return rows

    def to_dict(self) -> dict:
        """JSON-ready dict (:func:`birdocp.engine.results.result_dict`, with the ranking of the
        expanding multiplier's sensitivities, each row with ``valid``: the model holds on the cycle).

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return result_dict(self, extra={"ranked_expanding": self.ranked(0), "valid": self.valid})


class SecondOrderMaps:
    """Functions for one (model, steps): period map with the mean-W quadrature, its x0-Jacobian, and
    directional derivatives of both along (dx0, dD, dp)."""

    @classmethod
    def get(cls, model, steps: int, w_output=None):
        """The maps of (model, steps), built once and kept by ``model.model`` (``model``: a configured
        planar model, or any object with ``model`` (the owner), ``ode`` and ``data``; ``w_output``: the ``(x, d, p)`` Function of the
        mean vertical speed, default the planar model's).

        Parameters
        ----------
        model : object
            Configured planar model or an object with ``model``, ``ode`` and ``data``.
        steps : int
            RK4 steps per period.
        w_output : casadi.Function, optional
            ``(x, d, p)`` Function of the mean vertical speed.

        Returns
        -------
        SecondOrderMaps
        """
        return owned_cache(model.model).build(("second_order_maps", int(steps)), lambda: cls(model, steps, w_output))

    def __init__(self, model, steps: int, w_output=None):
        from birdocp.bird.flight import flight_outputs

        self.model = model.model
        W = w_output if w_output is not None else flight_outputs(model.ode.nd, model.ode.nx)["vertical_speed_mps"]
        self.grid = grid = RK4Grid(model.ode, steps, 1, outputs=(W,))
        nx, nd, np_ = model.ode.nx, model.ode.nd, model.ode.np
        x0 = ca.MX.sym("x0", nx)
        D = ca.MX.sym("D", nd, 3 * steps)
        p = ca.MX.sym("p", np_)
        xT, _, q = grid.period_map(x0, D, p)
        Mon = ca.jacobian(xT, x0)
        dx0 = ca.MX.sym("dx0", nx)
        dD = ca.MX.sym("dD", nd, 3 * steps)
        dp = ca.MX.sym("dp", np_)
        z = ca.vertcat(x0, ca.vec(D), p)
        dz = ca.vertcat(dx0, ca.vec(dD), dp)
        outs = ca.vertcat(xT, q, ca.vec(Mon))
        self.base = ca.Function("base", [x0, D, p], [xT, q, Mon])
        self.directional = ca.Function("directional", [x0, D, p, dx0, dD, dp], [ca.jtimes(outs, z, dz)])
        self.n_times = 2 * steps + 1
        self.data_fwd = model.data.forward(1).map(self.n_times)


def cycle_derivatives(so: SecondOrderMaps, period_s: float, x0, p, param_indices, cycle_states=None):
    """Exact derivatives of a converged cycle's multipliers, x0 and mean vertical speed along some
    parameters, the cycle's change included.

    Parameters
    ----------
    so : SecondOrderMaps
        Second-order period maps of the model.
    period_s : float
        Period [s].
    x0, p : array_like
        Start state and parameter vector of the cycle.
    param_indices : sequence of int
        Indices into ``p``.
    cycle_states : sequence of int, optional
        The states whose periodicity makes the orbit isolated (default: all). A state nothing depends on
        (the heading of a 6-DOF bird) adds a multiplier 1, so ``I - Mon`` is singular in it: leave it
        out, its ``dx0`` is 0.

    Returns
    -------
    tuple
        ``(multipliers, d_multipliers, d_moduli, d_x0, d_mean_vertical_speed)``: multipliers largest
        modulus first (nx), then arrays (n_params, nx) and (n_params,) per unit of each parameter.
    """
    grid = so.grid
    p = np.asarray(p, float)
    times = ca.DM(grid.times(0.0)).reshape((1, -1))
    Dgrid = grid.data_grid(times, ca.DM(p))
    idx = grid.block_index
    D = Dgrid[:, idx]
    x0 = ca.DM(np.asarray(x0, float))
    _, qT, Mon = so.base(x0, D, ca.DM(p))
    Mon = np.asarray(Mon)
    nx = Mon.shape[0]
    cs = list(range(nx)) if cycle_states is None else list(cycle_states)
    lam, V = np.linalg.eig(Mon)
    order = multiplier_order(lam)
    lam, V = lam[order], V[:, order]
    Wl = np.linalg.inv(V)
    zeroD = ca.DM.zeros(D.shape)
    zerox = ca.DM.zeros(nx)
    zerop = ca.DM.zeros(len(p))

    def split(v):
        v = np.asarray(v).ravel()
        return v[:nx], v[nx], v[nx + 1:].reshape(nx, nx, order="F")

    # Second derivatives along the state directions (shared by every parameter).
    dx_terms = []
    for i in range(nx):
        e = np.zeros(nx)
        e[i] = 1.0
        dx_terms.append(split(so.directional(x0, D, ca.DM(p), ca.DM(e), zeroD, zerop)))

    n = len(param_indices)
    dL = np.zeros((n, nx), complex)
    dmod = np.zeros((n, nx))
    dx0s = np.zeros((n, nx))
    dW = np.zeros(n)
    for k, j in enumerate(param_indices):
        ep = np.zeros(len(p))
        ep[j] = 1.0
        dDgrid = so.data_fwd(times, ca.DM(p), Dgrid, ca.DM.zeros(1, so.n_times), ca.DM(ep))
        dPhi_dp, dq_dp, dMon_p = split(so.directional(x0, D, ca.DM(p), zerox, dDgrid[:, idx], ca.DM(ep)))
        dx0 = np.zeros(nx)
        dx0[cs] = orbit_state_derivative(Mon[np.ix_(cs, cs)], dPhi_dp[cs])
        dMon = total_derivative(dMon_p, np.stack([t[2] for t in dx_terms], axis=-1), dx0)
        dq = total_derivative(dq_dp, np.array([t[1] for t in dx_terms]), dx0)
        dx0s[k] = dx0
        dW[k] = dq / period_s
        dL[k] = np.array([Wl[i] @ dMon @ V[:, i] for i in range(nx)])
        dmod[k] = np.real(np.conj(lam) * dL[k]) / np.abs(lam)
    return lam, dL, dmod, dx0s, dW


def multiplier_sensitivities(cycle_result, parameters=None, *, hold_level: bool = False) -> SensitivityResult:
    """Exact derivatives of the multipliers of a converged trim, the change of the cycle included.

    Parameters
    ----------
    cycle_result : TrimResult
        A converged trim (or level) result.
    parameters : sequence of str, optional
        Keys of :data:`PARAM_NAMES` (default :data:`DEFAULT_PARAMETERS`).
    hold_level : bool
        Re-solve the amplitude along each direction to keep the mean vertical speed.

    Returns
    -------
    SensitivityResult
        d(multiplier)/d(parameter) and d|multiplier|/d(parameter) per parameter, in the parameter's
        units; ``ranked()`` orders them by their effect on the largest modulus.
    """
    cfg: Config = cycle_result.cfg
    c = cycle_result.cycle
    if not c.success:
        raise ValueError("the trim did not converge: sensitivities need a converged cycle")
    params = list(parameters or DEFAULT_PARAMETERS)
    for k in params:
        if k not in PARAM_NAMES:
            raise ValueError(f"unknown parameter {k!r}")
    if hold_level:
        if cycle_result.cycle.free_values:
            raise ValueError("hold_level needs a fixed-amplitude trim (a level() result is one: pass it as a trim)")
        params = [k for k in params if k != AMPLITUDE_KEY] + [AMPLITUDE_KEY]
    m = get_model(cfg)
    so = SecondOrderMaps.get(m, int(c.method["steps_per_period"]))
    lam, dL, dmod, dx0s, dW = cycle_derivatives(so, m.period_s, c.x0, c.p, [PARAM_NAMES.index(k) for k in params])
    n = len(params)

    dA = None
    if hold_level:
        a = params.index(AMPLITUDE_KEY)
        dA = -dW / dW[a]
        dL = dL + np.outer(dA, dL[a])
        dmod = dmod + np.outer(dA, dmod[a])
        dx0s = dx0s + np.outer(dA, dx0s[a])
        dW = dW + dA * dW[a]
        keep = [k for k in range(n) if k != a]  # the amplitude is the re-solved variable, not a parameter
        params = [params[k] for k in keep]
        dL, dmod, dx0s, dW, dA = dL[keep], dmod[keep], dx0s[keep], dW[keep], dA[keep]
    v = getattr(cycle_result, "validity", None)
    return SensitivityResult(params, lam, dL, dmod, dx0s, dW, hold_level, dA, np.asarray(c.x0, float),
                             float(getattr(cycle_result, "amplitude_deg", np.nan)),
                             v.to_dict() if v is not None else None)
