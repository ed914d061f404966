"""Prescribed-kinematics harnesses of the unsteady section model (docs/model_unsteady.md).

* :class:`PrescribedWing`: a straight rectangular wing of n lifting-line elements (or a 2-D strip,
  ``aspect_ratio=None``: no trailing wake) in a uniform stream U, plunging (h up) and pitching about
  its quarter chord (theta nose-up) with prescribed h(t), theta(t); the body is held (u = U, w = q = 0),
  only the aerodynamic states move. It measures the loads of the mid-span element per unit span, the
  periodic response (Newton on the period map) and the indicial response. This is the 2-D limit in
  which the model must reproduce Theodorsen / Jones (Wagner), Garrick's propulsion and the static polar.
* :func:`held_bird_cycle`: the bird's flapping wing with its gait, the body held at a fixed state (e.g.
  the trim state): cycle-mean lift and thrust and the phase of the lift peak, for any ``aero.unsteady``
  and ``aero.section``.

Element data are analytic: c_hat = (0, -sin theta, cos theta), up = (0, cos theta, sin theta),
r = (y_j, h, 0), v_kin = (0, h', 0) in the code frame (e1 span, e2 up, e3 back).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from birdocp.bird import aero, unsteady

__all__ = ["PrescribedWing", "harmonic", "held_bird_cycle", "first_harmonic"]


def harmonic(k: float, speed_mps: float, chord_m: float, plunge_m: float = 0.0, pitch_rad: float = 0.0,
             mean_pitch_rad: float = 0.0):
    """Kinematics ``t -> (h, theta)`` of a harmonic plunge h = h0 sin(omega t) (up) and pitch theta =
    theta_m + theta0 sin(omega t) (nose-up) at reduced frequency k = omega c / (2 U); returns
    (kinematics, omega [rad/s], period [s]).

    Parameters
    ----------
    k : float
        Reduced frequency [-].
    speed_mps : float
        U [m/s].
    chord_m : float
        c [m].
    plunge_m : float
        h0 [m].
    pitch_rad : float
        theta0 [rad].
    mean_pitch_rad : float
        theta_m [rad].

    Returns
    -------
    tuple
        ``(kinematics, omega, period)``.
    """
    om = 2.0 * k * speed_mps / chord_m

    def kin(t):
        return plunge_m * ca.sin(om * t), mean_pitch_rad + pitch_rad * ca.sin(om * t)

    return kin, om, 2 * math.pi / om


def first_harmonic(t, y, omega):
    """Complex amplitude a of y ~ Re(a exp(i omega t)) over whole periods of uniform samples.

    Parameters
    ----------
    t : array_like
        Uniform sample times [s].
    y : array_like
        Samples.
    omega : float
        Angular frequency [rad/s].

    Returns
    -------
    complex
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    return 2.0 * np.mean(y * np.exp(-1j * omega * t))


class PrescribedWing:
    """A rectangular wing (or 2-D strip) with prescribed plunge and pitch; see the module.

    Parameters
    ----------
    unsteady, section : str
        as ``aero.unsteady`` and ``aero.section``.
    chord_m, speed_mps : float
        chord c and stream speed U.
    aspect_ratio : float or None
        span / chord of the lifting line; None: a 2-D strip (no trailing wake, K = 0).
    n : int
        lifting-line elements (the mid-span element n // 2 - 1 is measured).
    **params
        numbers of the section model: ``rho``, ``cla``, ``eps``, ``kappa``, ``chi_w``, ``chi_nc``,
        ``alpha1_deg``, ``cd90``, ``Tf``, ``T2``, ``newton_steps`` (defaults: the configuration's).
    """

    def __init__(self, unsteady="wagner", section="linear", chord_m=0.2, speed_mps=18.0, aspect_ratio=1e4,
                 n=16, **params):
        self.c, self.U, self.n = float(chord_m), float(speed_mps), int(n)
        self.opts = {"unsteady": unsteady, "section": section, "newton_steps": int(params.pop("newton_steps", 5))}
        d = {"rho": 1.225, "cla": 2 * math.pi, "eps": 1.0, "kappa": 1.0, "chi_w": 1.0, "chi_nc": 1.0,
             "alpha1_deg": 17.0, "cd90": 2.0, "Tf": 3.0, "T2": 1.7}
        unknown = set(params) - set(d)
        if unknown:
            raise ValueError(f"PrescribedWing: unknown parameters {sorted(unknown)}")
        d.update(params)
        self.prm = dict(d, alpha1=math.radians(d["alpha1_deg"]), a0=1.0 - d["eps"] * (_unsteady_sum()))
        span = self.c * (aspect_ratio if aspect_ratio else 1.0)
        y = np.linspace(-span / 2, span / 2, self.n + 1)
        self.ds = np.diff(y)
        self.yc = 0.5 * (y[1:] + y[:-1])
        if aspect_ratio:
            Vx, Vy, K = aero.induced_matrices([ca.DM([v, 0, 0]) for v in self.yc], [ca.DM([v, 0, 0]) for v in y])
            self.wake = {k: ca.DM(ca.evalf(v)) for k, v in (("K", K), ("Vx", Vx), ("Vy", Vy))}
        else:
            self.wake = {k: ca.DM.zeros(self.n, self.n) for k in ("K", "Vx", "Vy")}
        self.nz = _unsteady_states(unsteady, section, self.n)
        self.mid = self.n // 2 - 1

    def functions(self, kin):
        """``f(z, t) -> zdot`` and ``out(z, t) -> outputs`` (:attr:`OUTPUTS`) for kinematics ``kin``."""
        t = ca.SX.sym("t")
        h, th = kin(t)
        hd = ca.jtimes(h, t, ca.SX(1))
        n, c = self.n, self.c
        one = ca.DM.ones(1, n)
        r = ca.vertcat(ca.DM(self.yc).T, h * one, 0 * one)
        v_kin = ca.vertcat(0 * one, hd * one, 0 * one)
        c_hat = ca.vertcat(0 * one, -ca.sin(th) * one, ca.cos(th) * one)
        up = ca.vertcat(0 * one, ca.cos(th) * one, ca.sin(th) * one)
        tau = ca.vertcat(*[ca.cross(up[:, j], c_hat[:, j]).T for j in range(n)]).T
        chord, ds = c * ca.DM.ones(n, 1), ca.DM(self.ds)
        ud = unsteady.element_data(r, v_kin, c_hat, up, tau, chord, ds, lambda e: ca.jtimes(e, t, ca.SX(1)))
        base = {"r": r, "v_kin": v_kin, "c_hat": c_hat, "up": up, "tau": tau, "ds": ds, "chord": chord}
        z = ca.SX.sym("z", self.nz)
        nu = ca.vertcat(self.U, 0, 0)
        s = unsteady.section_loads(self.opts, nu, z, base, ud, self.wake, self.prm)
        j = self.mid
        dsj = float(self.ds[j])
        F_att = s["dF_att"][:, j] / dsj
        F_mid = s["dF_mid"][:, j] / dsj
        if s["wagner"]:
            F_nc = s["nc_coef"][j] * ud["n_hat"][:, j] / dsj
            couple = s["couple0"][j] / dsj
        else:
            F_nc, couple = ca.SX.zeros(3, 1), ca.SX(0)
        lever = s["r_mid"][:, j] - r[:, j]
        M_qc = (lever[1] * (F_mid + F_nc)[2] - lever[2] * (F_mid + F_nc)[1]) + couple * ud["tau_hat"][0, j]
        rmd = ud["r_mid_dot"][:, j]
        Vj = s["V"][:, j]
        Vm = ca.vertcat(-rmd[0], -rmd[1], self.U - rmd[2])
        om = ud["omega_k"][j]
        P_flap = -(ca.dot(F_att, v_kin[:, j]) + ca.dot(F_mid + F_nc, rmd) + couple * om)
        P_aero = ca.dot(F_att, Vj) + ca.dot(F_mid + F_nc, Vm) - couple * om
        outs = {"lift_circulatory_Npm": F_att[1] + F_mid[1], "lift_Npm": F_att[1] + F_mid[1] + F_nc[1],
                "moment_qc_Nmpm": M_qc, "thrust_Npm": -(F_att + F_mid + F_nc)[2], "gamma_m2ps": s["Gamma"][j],
                "cl_circulatory": 2 * s["Gamma"][j] / (c * s["Vp_norm"][j]), "alpha_E_rad": s["alpha_E"][j],
                "alpha_geo_rad": s["alpha"][j], "f_sep": s["f"][j], "flapping_power_Wpm": P_flap,
                "aerodynamic_power_Wpm": P_aero, "body_power_Wpm": -(F_att + F_mid + F_nc)[2] * self.U,
                "h_m": h, "theta_rad": th, "newton_residual": s["newton_residual"]}
        self.OUTPUTS = tuple(outs)
        zd = s["zdot"] if self.nz else ca.SX.zeros(0, 1)
        return (ca.Function("f", [z, t], [zd]), ca.Function("out", [z, t], [ca.vertcat(*outs.values())]))

    def _step(self, f, h):
        z, t = ca.SX.sym("z", self.nz), ca.SX.sym("t")
        k1 = f(z, t)
        k2 = f(z + h / 2 * k1, t + h / 2)
        k3 = f(z + h / 2 * k2, t + h / 2)
        k4 = f(z + h * k3, t + h)
        return ca.Function("step", [z, t], [z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])

    def history(self, kin, t_end_s, steps, z0=None) -> dict:
        """RK4 from z0 (default: at rest, z = 0 and f = 1) over [0, t_end]: outputs at the step times."""
        f, out = self.functions(kin)
        h = float(t_end_s) / steps
        step = self._step(f, h)
        z = np.zeros(self.nz) if z0 is None else np.asarray(z0, float)
        if z0 is None and self.opts["section"] == "dynamic-stall":
            z[-self.n:] = 1.0
        ts = h * np.arange(steps + 1)
        Z = np.asarray(step.mapaccum(steps)(ca.DM(z), ca.DM(ts[:-1]).T)) if self.nz else np.zeros((0, steps))
        Zall = np.hstack([z[:, None], Z])
        O = np.asarray(out.map(steps + 1)(ca.DM(Zall), ca.DM(ts).T))
        return {"t_s": ts, **{k: O[i] for i, k in enumerate(self.OUTPUTS)}, "z": Zall}

    def periodic(self, kin, period_s, steps=400, newton=3) -> dict:
        """The periodic response (aerodynamic states periodic: Newton on the RK4 period map), outputs at
        the ``steps`` step times of one period (closing point excluded), plus the Newton residual."""
        f, out = self.functions(kin)
        h = float(period_s) / steps
        step = self._step(f, h)
        ts = h * np.arange(steps)
        z0 = ca.MX.sym("z0", self.nz)
        zT = step.mapaccum(steps)(z0, ca.DM(ts).T)[:, -1] if self.nz else z0
        F = ca.Function("F", [z0], [zT - z0, ca.jacobian(zT - z0, z0)])
        z = np.zeros(self.nz)
        if self.opts["section"] == "dynamic-stall":
            z[-self.n:] = 1.0
        res = 0.0
        for _ in range(newton if self.nz else 0):
            r, J = (np.asarray(v) for v in F(z))
            z = z - np.linalg.solve(J, r.ravel())
        if self.nz:
            res = float(np.max(np.abs(np.asarray(F(z)[0]))))
        Z = np.hstack([z[:, None], np.asarray(step.mapaccum(steps - 1)(ca.DM(z), ca.DM(ts[:-1]).T))]) \
            if self.nz else np.zeros((0, steps))
        O = np.asarray(out.map(steps)(ca.DM(Z), ca.DM(ts).T))
        return {"t_s": ts, **{k: O[i] for i, k in enumerate(self.OUTPUTS)}, "z": Z, "periodicity_residual": res}


def _unsteady_sum() -> float:
    return unsteady.A1 + unsteady.A2


def _unsteady_states(unsteady_mode: str, section: str, n: int) -> int:
    return unsteady.n_aero_states(unsteady_mode, section, n)


def held_bird_cycle(cfg, body_state=None, steps: int | None = None) -> dict:
    """The bird's wing flapping with ``cfg``'s gait while the body is held at ``body_state`` = (u [m/s],
    w [m/s], q [rad/s], theta [rad]) (default ``cfg.solve.initial_guess``; e.g. a trim's x0 with q = 0):
    the aerodynamic states are made periodic (Newton on the RK4 period map; none with the
    quasi-steady section) and the loads (added mass with zero body acceleration) sampled at the
    ``steps`` RK4 step times (default ``cfg.solve.steps_per_period``).

    Returns a dict: ``t_s``, ``lift_N`` (vertical, inertial frame, up), ``thrust_N`` (horizontal,
    forward), ``My_Nm`` at each step time; ``mean_lift_N``, ``mean_thrust_N``, ``lift_peak_phase_deg``
    (phase of the largest lift in the wingbeat, 0..360 deg from t = 0), ``periodicity_residual``, and
    ``cpu_s`` (process time of the computation, graphs included).

    Parameters
    ----------
    cfg : Config
        Configuration.
    body_state : sequence of float, optional
        Held body state.
    steps : int, optional
        RK4 steps per period.

    Returns
    -------
    dict
    """
    import time

    from birdocp.bird.model import get_model

    c0 = time.process_time()
    m = get_model(cfg)
    steps = int(steps or cfg.solve.steps_per_period)
    x4 = np.asarray(cfg.solve.initial_guess if body_state is None else body_state, float)
    T = 1.0 / cfg.gait.frequency_hz
    h = T / steps
    p = ca.DM(m.p0)
    nz = m.ode.nx - 4
    held = m.held_d
    nd = m.ode.nd
    if held is None:  # quasi-steady: no aerodynamic state, no added mass
        xh, dh, ph = ca.SX.sym("x", 4), ca.SX.sym("d", nd), ca.SX.sym("p", m.ode.np)
        held = ca.Function("held_d", [xh, dh, ph], [ca.SX.zeros(0, 1), m.loads_d(xh, dh, ph)])
    ts = h * np.arange(steps)
    # the wing data at the RK4 stage times, numbers (t, t + h/2, t + h of each step)
    D0, D1, D2 = (m.data.map(steps)(ca.DM(ts + off).T, ca.repmat(p, 1, steps)) for off in (0.0, h / 2, h))
    z, d0, d1, d2 = ca.SX.sym("z", nz), ca.SX.sym("d0", nd), ca.SX.sym("d1", nd), ca.SX.sym("d2", nd)
    xb = ca.DM(x4)

    def f(zz, dd):
        return held(ca.vertcat(xb, zz), dd, p)[0]

    fl = ca.Function("fl", [z, d0], [held(ca.vertcat(xb, z), d0, p)[1]])
    if nz:
        k1 = f(z, d0)
        k2 = f(z + h / 2 * k1, d1)
        k3 = f(z + h / 2 * k2, d1)
        k4 = f(z + h * k3, d2)
        step = ca.Function("step", [z, d0, d1, d2], [z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
        acc = step.mapaccum(steps)
        zm = ca.MX.sym("z", nz)
        Zm = acc(zm, D0, D1, D2)
        F = ca.Function("F", [zm], [Zm[:, -1] - zm, ca.jacobian(Zm[:, -1], zm), Zm])
        zc = m.complete_state(x4, m.p0, 0.0)[4:]
        for _ in range(3):
            r, J, _ = (np.asarray(v) for v in F(zc))
            zc = zc - np.linalg.solve(J - np.eye(nz), r.ravel())
        r, _, Zall = (np.asarray(v) for v in F(zc))
        res = float(np.max(np.abs(r)))
        Z = np.hstack([zc[:, None], Zall[:, :-1]])
    else:
        res, Z = 0.0, np.zeros((0, steps))
    L = np.asarray(fl.map(steps)(ca.DM(Z), D0))  # Fx', Fz', My' (body frame)
    th = x4[3]
    Fx, Fz = L[0], L[1]
    lift = -(Fz * math.cos(th) - Fx * math.sin(th))        # Z down -> up
    thrust = Fx * math.cos(th) + Fz * math.sin(th)         # X forward
    i = int(np.argmax(lift))
    return {"t_s": ts, "lift_N": lift, "thrust_N": thrust, "My_Nm": L[2], "mean_lift_N": float(lift.mean()),
            "mean_thrust_N": float(thrust.mean()), "lift_peak_phase_deg": float(360.0 * ts[i] / T),
            "periodicity_residual": res, "cpu_s": time.process_time() - c0}
