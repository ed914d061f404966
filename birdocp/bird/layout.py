"""Layout of the bird model: the state, the per-time data vector and the structural switches.

The state x = (u [m/s] forward along x', w [m/s] down along z', q [rad/s] pitch rate nose-up, theta
[rad] pitch angle), then the aerodynamic states of an unsteady or dynamic-stall section; the data
vector d(t, p) is the column-major blocks :data:`DATA_BLOCKS` (then the wing-mass sums, then the
unsteady blocks); :class:`Structure` is what changes the graphs (everything else is a number in p).
Used by :mod:`birdocp.bird.loads`, :mod:`birdocp.bird.graphs` and :mod:`birdocp.bird.model`.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from birdocp.bird import aero
from birdocp.bird import inertia
from birdocp.bird import subdivide
from birdocp.bird import unsteady
from birdocp.bird.config import PARAM_NAMES, Config

N_EL = aero.N_ELEMENTS
STATE_NAMES = ("u_mps", "w_mps", "q_radps", "theta_rad")

def data_blocks(n: int = aero.N_ELEMENTS) -> tuple:
    """Layout of the per-time data vector d (column-major blocks) of a lifting line of ``n`` elements
    (16, or 16 k with ``aero.span_subdivisions = k``).

    Parameters
    ----------
    n : int
        Number of lifting-line elements of both wings.

    Returns
    -------
    tuple
        ``(name, rows, columns)`` of each block, in order.
    """
    return (
        ("r_m", (3, n)),          # element centres relative to G, code frame
        ("v_kin_mps", (3, n)),    # kinematic velocity of the centres
        ("c_hat", (3, n)),        # chord directions (leading -> trailing edge)
        ("up", (3, n)),           # 'up' normals
        ("tau", (3, n)),          # spanwise directions n x c_hat
        ("ds_m", (n, 1)),         # element lengths
        ("G", (n, n)),            # Gamma = G (|Vp| alpha); unsteady/stall structures: K (downwash per unit Gamma)
        ("Wx", (n, n)),           # induced velocity e1 = Wx (|Vp| alpha); unsteady/stall: per unit Gamma
        ("Wy", (n, n)),           # induced velocity e2 = Wy (|Vp| alpha); unsteady/stall: per unit Gamma
        ("nodes_m", (3, n + 1)),  # element end nodes relative to G (the tail's induced velocity)
        ("chord_m", (n, 1)),      # element chords (the optional profile drag)
    )


DATA_BLOCKS = data_blocks(N_EL)


def _offsets(n: int = N_EL):
    out, k = {}, 0
    for name, (r, c) in data_blocks(n):
        out[name] = (k, r, c)
        k += r * c
    return out, k


DATA_OFFSETS, N_DATA = _offsets(N_EL)


def n_data(n: int) -> int:
    """Size of the aerodynamic data blocks of ``n`` elements (:data:`N_DATA` for 16).

    Parameters
    ----------
    n : int
        Number of lifting-line elements of both wings.

    Returns
    -------
    int
        Number of values.
    """
    return _offsets(n)[1]


N_MASS = len(inertia.MASS_BLOCK)
"""A model with wing masses appends the sums :data:`birdocp.bird.inertia.MASS_BLOCK` to the data
vector: its data has N_DATA + N_MASS values, the first N_DATA laid out as :data:`DATA_BLOCKS`."""


def unpack_mass(d):
    """The wing-mass sums of a data vector of a model with wing masses, as a dict of scalars.

    Parameters
    ----------
    d : casadi.SX, MX or DM
        Data vector.

    Returns
    -------
    dict
    """
    return {k: d[N_DATA + i] for i, k in enumerate(inertia.MASS_BLOCK)}


def elements_of(size: int) -> int:
    """The element count of a data vector of ``size`` values: ``16 k`` when it is the blocks of a
    line cut ``k`` > 1 times (with or without the wing-mass sums; such a model has no unsteady
    blocks), else 16.

    Parameters
    ----------
    size : int
        Number of values in the data vector.

    Returns
    -------
    int
        Number of lifting-line elements of both wings.
    """
    for k in range(subdivide.MAX_SUBDIVISIONS, 1, -1):
        if size - n_data(N_EL * k) in (0, N_MASS):
            return N_EL * k
    return N_EL


def unpack_data(d, n: int | None = None):
    """Blocks of a data vector (SX/MX/DM) as a dict of matrices.

    Parameters
    ----------
    d : casadi.SX, MX or DM
        Data vector.
    n : int, optional
        Number of elements (default: read off the vector's size, :func:`elements_of`).

    Returns
    -------
    dict
        Block name to matrix.
    """
    n = n or elements_of(int(d.shape[0] * d.shape[1]))
    return {name: ca.reshape(d[k:k + r * c], r, c) for name, (k, r, c) in _offsets(n)[0].items()}


def air_state(x, wind_mps):
    """The state as the aerodynamics sees it: (u - wind_u, w - wind_w, q, theta).

    ``wind_mps`` = (W_X, W_Z): the air's velocity in the inertial frame (X forward horizontal, Z down,
    m/s), uniform over the bird; rotated into the body frame (x' forward, z' down) by the pitch angle
    theta: ``wind_u = cos(theta) W_X - sin(theta) W_Z``, ``wind_w = sin(theta) W_X + cos(theta) W_Z``.
    The state's u, w stay the inertial velocity of G in the body frame (the equations of motion are
    unchanged); a zero wind gives back x exactly.

    Parameters
    ----------
    x : casadi.SX
        Body state (u, w, q, theta, ...).
    wind_mps : sequence
        (W_X, W_Z) [m/s].

    Returns
    -------
    casadi.SX
    """
    th = x[3]
    c, s = ca.cos(th), ca.sin(th)
    return ca.vertcat(x[0] - (c * wind_mps[0] - s * wind_mps[1]),
                      x[1] - (s * wind_mps[0] + c * wind_mps[1]), x[2], th)


def air_wind_rate(x, wind_mps, wind_rate_mps2):
    """The time derivative of the wind's body-frame components (wind_u, wind_w) of :func:`air_state`
    along the motion [m/s^2]: ``R(theta) dW/dt - omega x W_b``, i.e.
    ``(cos(theta) dW_X - sin(theta) dW_Z - q wind_w, sin(theta) dW_X + cos(theta) dW_Z + q wind_u)``.

    ``wind_rate_mps2`` is the inertial rate of the wind at G along the trajectory, ``dW/dt + dW/dX' X'``
    (its own time rate plus its change along the flight path); the second part is the rotation of
    the body frame with the pitch rate q (the wind is uniform over the bird: no air rotation).

    Parameters
    ----------
    x : casadi.SX
        Body state (u, w, q, theta, ...).
    wind_mps : sequence
        (W_X, W_Z), inertial frame (X forward horizontal, Z down) [m/s].
    wind_rate_mps2 : sequence
        (dW_X/dt, dW_Z/dt) along the trajectory [m/s^2].

    Returns
    -------
    casadi.SX
        (d wind_u/dt, d wind_w/dt) [m/s^2].
    """
    q, th = x[2], x[3]
    c, s = ca.cos(th), ca.sin(th)
    wind_u = c * wind_mps[0] - s * wind_mps[1]
    wind_w = s * wind_mps[0] + c * wind_mps[1]
    return ca.vertcat(c * wind_rate_mps2[0] - s * wind_rate_mps2[1] - q * wind_w,
                      s * wind_rate_mps2[0] + c * wind_rate_mps2[1] + q * wind_u)

def param(p, name):
    """The entry ``name`` (:data:`birdocp.bird.config.PARAM_NAMES`) of the parameter vector p.

    Parameters
    ----------
    p : casadi.SX or array_like
        Parameter vector.
    name : str
        Dotted key.

    Returns
    -------
    casadi.SX or float
    """
    return p[PARAM_NAMES.index(name)]


@dataclass(frozen=True)
class Structure:
    """What changes the graphs (everything else is a number in ``p``)."""

    frequency_hz: float
    circulation: str
    relaxed_evaluations: int
    kinematic_velocity: str
    backward_step_s: float
    tail: bool = False
    wing_mass: bool = False
    drag: bool = False
    unsteady: str = "none"
    section: str = "linear"
    newton_steps: int = 5
    smooth_geometry: bool = False
    span_direction: str = "leading_line"
    span_subdivisions: int = 1
    collocation: str = "quarter"
    normalwash: str = "angle"

    @property
    def n_elements(self) -> int:
        """Lifting-line elements: 16 times ``span_subdivisions``."""
        return N_EL * self.span_subdivisions

    @property
    def aero_extra(self) -> bool:
        """True when the unsteady or stall-aware section is on (``aero.unsteady``, ``aero.section``)."""
        return self.unsteady != "none" or self.section != "linear"

    @property
    def n_aero_states(self) -> int:
        """Aerodynamic states after (u, w, q, theta): lag states and separation states."""
        return unsteady.n_aero_states(self.unsteady, self.section, N_EL)

    @property
    def state_names(self) -> tuple[str, ...]:
        return STATE_NAMES + unsteady.aero_state_names(self.unsteady, self.section, N_EL)

    @staticmethod
    def of(cfg: Config) -> "Structure":
        a = cfg.aero
        dr = cfg.drag
        return Structure(cfg.gait.frequency_hz, a.circulation, a.relaxed_evaluations,
                         a.kinematic_velocity, a.backward_step_s,
                         bool(cfg.tail.enabled or cfg.tail.opening_angle_deg > 0),
                         bool(cfg.wing.inertial_terms or cfg.wing.mass_kg > 0),
                         drag=bool(dr.enabled or dr.body_drag_coefficient > 0 or dr.profile_drag_coefficient > 0),
                         unsteady=a.unsteady, section=a.section,
                         newton_steps=int(a.newton_steps) if a.section != "linear" else 5,
                         smooth_geometry=bool(cfg.wing.smooth_geometry), span_direction=a.span_direction,
                         span_subdivisions=int(a.span_subdivisions), collocation=a.collocation,
                         normalwash=a.normalwash)

