"""The sections of a configuration (:class:`birdocp.bird.config.Config`): frozen dataclasses whose
defaults are the paper's reference case, every number with its unit in its name.

Split from :mod:`birdocp.bird.config` (which re-exports every name here) to keep modules small.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Joint:
    """Harmonic joint law ``q(t) = offset + amplitude * sin(2 pi f t + phase)``."""

    offset_deg: float = 0.0
    """The mean angle of the joint over a beat."""
    amplitude_deg: float = 0.0
    """Half the peak-to-peak excursion about the offset."""
    phase_deg: float = 0.0
    """The phase of the sine at t = 0 (the flap's phase sets the beat's start)."""


@dataclass(frozen=True)
class Body:
    """Rigid body of the bird: its mass and pitch inertia, the gravity it flies in and the chord that
    scales its stability margin."""

    mass_kg: float = 1.2
    """Mass of the whole bird, wings included (M); the body alone has M - 2 wing.mass_kg."""
    pitch_inertia_kgm2: float = 0.1
    """Pitch inertia of the body ALONE about its own centre of mass G_b (the wings' is added by the
    model when they have mass)."""
    gravity_mps2: float = 9.81
    """Gravitational acceleration g (inertial frame, downwards)."""
    reference_chord_m: float = 0.2
    """Mean chord c̄ used for the stability margin SM = -root_ahead_m / c̄ and moment coefficients."""


@dataclass(frozen=True)
class Wing:
    """Skeleton and feathers of the (right) wing; the left wing is its mirror image."""

    arm_length_m: float = 0.134
    """Humerus: shoulder to elbow."""
    forearm_length_m: float = 0.162
    """Radius/ulna: elbow to wrist."""
    hand_length_m: float = 0.084
    """Carpometacarpus and digits: wrist to the hand's tip."""
    feather_lengths_m: tuple[float, ...] = (0.25, 0.225, 0.20, 0.175, 0.15, 0.125, 0.10)
    """Master feathers 0 (hand tip) .. 6 (shoulder); only 0, 2, 4 and 6 shape the trailing edge."""
    root_ahead_m: float = 0.05
    """Distance of the wing root (shoulder) ahead of the centre of mass G, along the body axis."""
    shoulder_half_separation_m: float = 0.05
    """Half the distance between the two shoulders, along the span."""
    section_half_thickness_m: float = 0.01
    smoothing_radius_m: float = 0.05
    """Corner-smoothing radius R_s of the edge resampling."""
    smooth_geometry: bool = False
    """Replace the wing geometry's switches (segment search, corner sweeps, nearest points) by the
    switch-free, C-infinity formulation of docs/model.md §4.8 (corners rounded over R_s / 4), so that
    the RK4 grid converges at order 4. False: the reference geometry, bit for bit."""
    mass_kg: float = 0.0
    """Mass of ONE wing (bones, muscle, skin, feathers). 0 = massless wings, the paper's model bit for
    bit. It is part of ``body.mass_kg`` (the whole bird): the body alone has body.mass_kg - 2 mass_kg.
    A large bird's wing is ~7 % of its mass (van den Berg & Rayner 1995: 0.086 kg at 1.2 kg)."""
    mass_share_arm: float = 0.50
    """Share of the wing mass in a uniform rod shoulder -> elbow (humerus, muscle, skin, coverts)."""
    mass_share_forearm: float = 0.25
    """Share in a uniform rod elbow -> wrist."""
    mass_share_hand: float = 0.08
    """Share in a uniform rod wrist -> hand tip."""
    mass_share_primaries: float = 0.10
    """Share on feathers 0, 1, 2 (split 0.45, 0.30, 0.25), each a rod tapering linearly to the tip."""
    mass_share_secondaries: float = 0.07
    """Share on feathers 3, 4, 5, 6 (split 0.30, 0.30, 0.25, 0.15), tapered rods."""
    inertial_terms: bool = False
    """Put the wing-mass terms in the model graphs even at mass_kg = 0 (implied by mass_kg > 0), e.g.
    to continue from massless wings; at mass 0 they change nothing (bit for bit)."""



@dataclass(frozen=True)
class SideOffsets:
    """Offsets added to the joint laws of ONE wing (an asymmetric gait): the wing's joint ``j`` follows
    ``offset + d_offset + (amplitude + d_amplitude) sin(2 pi f t + phase + d_phase)`` with the
    ``d_...`` values here (deg). Each wing's angles are in its own mirrored frame (flap tip up, sweep
    tip forward, incidence leading edge up on both sides), so equal offsets on both sides keep the
    gait symmetric. Zero everywhere (the default) leaves the law of :class:`Gait` unchanged; a
    non-zero value needs ``model.degrees_of_freedom = 6``."""

    shoulder_incidence: Joint = Joint()
    shoulder_flap: Joint = Joint()
    shoulder_sweep: Joint = Joint()
    elbow_flex: Joint = Joint()
    hand_twist: Joint = Joint()
    wrist_flex: Joint = Joint()
    wrist_spread: Joint = Joint()


@dataclass(frozen=True)
class Gait:
    """Prescribed wing kinematics: one harmonic law per joint, all at the flapping frequency."""

    frequency_hz: float = 4.0
    shoulder_incidence: Joint = Joint(math.degrees(0.2), math.degrees(0.014), -90.0)
    """Shoulder rotation about the span axis (wing pitch). Paper: "shoulder y"; code slot s_x."""
    shoulder_flap: Joint = Joint(0.0, 42.0, 180.0)
    """Shoulder rotation about the body axis (flapping, positive tip up). Paper: "shoulder x" (A_sx)."""
    shoulder_sweep: Joint = Joint(-19.0, 20.0, 90.0)
    """Shoulder rotation about the vertical (sweep, positive tip forward). Paper: "shoulder z";
    the offset is -19 deg as in the reference implementation (the paper's table prints +19)."""
    elbow_flex: Joint = Joint(30.0, 30.0, -90.0)
    """Elbow flexion in the wing plane. Paper: "elbow x"; code slot e_y."""
    hand_twist: Joint = Joint(0.0, 30.0, -90.0)
    """Twist of the hand about the span axis, applied at the elbow. Paper: "wrist y"; code slot e_x."""
    wrist_flex: Joint = Joint(-30.0, 30.0, 90.0)
    """Wrist flexion in the wing plane. Paper: "wrist z"; code slot w_y."""
    wrist_spread: Joint = Joint(0.0, 0.0, 0.0)
    """Wrist rotation about the body axis; not in the paper (identically 0). Code slot w_z."""
    right_offset: SideOffsets = SideOffsets()
    """Offsets of the right wing's joint laws (deg; six degrees of freedom only), e.g.
    ``gait.right_offset.shoulder_flap.amplitude_deg = 2``."""
    left_offset: SideOffsets = SideOffsets()
    """Offsets of the left wing's joint laws (deg; six degrees of freedom only)."""

    @property
    def period_s(self) -> float:
        return 1.0 / self.frequency_hz



@dataclass(frozen=True)
class Aero:
    """Quasi-steady lifting-line aerodynamics."""

    air_density_kgm3: float = 1.225
    lift_slope_per_rad: float = 2.0 * math.pi
    circulation: str = "exact"
    """``exact``: the lifting-line equation solved exactly (linear solve); ``relaxed``: the reference
    implementation's under-relaxed iteration with a fixed count of evaluations from zero."""
    relaxed_evaluations: int = 39
    kinematic_velocity: str = "exact"
    """``exact``: time derivative of the geometry by AD; ``backward-difference``: as the reference."""
    backward_step_s: float = 2.5e-5
    span_direction: str = "leading_line"
    """``leading_line``: each section's span direction from the relaxed leading line (the paper's model);
    ``element``: along the lifting-line element the vortices follow (:mod:`birdocp.bird.span`)."""
    span_subdivisions: int = 1
    """Sub-elements per lifting-line element, 1..8, same geometry (linear quasi-steady section only;
    :mod:`birdocp.bird.subdivide`); 1: the paper's model, bit for bit."""
    collocation: str = "quarter"
    """``quarter``: each section sees the wake at its centre on the lifting line (the paper's model);
    ``three_quarter``: Weissinger's three-quarter-chord flow tangency (:mod:`birdocp.bird.collocation`;
    linear quasi-steady section only)."""
    normalwash: str = "angle"
    """The section law's normalwash (:data:`birdocp.bird.collocation.NORMALWASHES`): ``angle``: ``|Vp| alpha``,
    lift linear in the section angle (the paper's model); ``tangency``: ``|Vp| sin(alpha)``, the flow
    tangency of a flat plate (lift linear in the sine of the angle, local lift slope ``C_la cos(alpha)``;
    the law a vortex lattice solves; linear quasi-steady section only)."""
    unsteady: str = "none"
    """``none``: quasi-steady section; ``wagner``: two lag states per element on the effective
    normalwash (Jones's indicial response), the 3/4-chord pitch-rate term and the added-mass loads."""
    section: str = "linear"
    """``linear``: C_l = C_la alpha; ``stall``: static polar f0(alpha) blend of attached and flat-plate
    lift, circulation by ``newton_steps`` Newton steps; ``dynamic-stall``: a separation state per element
    (Goman-Khrabrov)."""
    newton_steps: int = 5
    """Newton steps of the stall circulation (structural)."""
    wagner_weight: float = 1.0
    """epsilon: homotopy 0 = quasi-steady section, 1 = Jones's indicial response."""
    wagner_time_scale: float = 1.0
    """kappa: multiplies every lag time constant (kappa -> 0: quasi-steady limit)."""
    pitch_rate_weight: float = 1.0
    """chi_omega: weight of the 3/4-chord pitch-rate term (belongs with added_mass_weight)."""
    added_mass_weight: float = 1.0
    """chi_nc: weight of the non-circulatory (added-mass) loads."""
    separation_angle_deg: float = 17.0
    """alpha_1 [deg]: f0(alpha_1) = 1/2."""
    flat_plate_cd90: float = 2.0
    """C_D90: normal-force coefficient of the separated section at 90 deg."""
    separation_lag_semichords: float = 3.0
    """T_f: separation lag tau_1 = T_f c / (2 |Vp|) [semichords]."""
    separation_delay_semichords: float = 1.7
    """T_2: separation delay tau_2 = T_2 c / (2 |Vp|) [semichords] (with ``wagner`` only)."""


@dataclass(frozen=True)
class Tail:
    """Optional slender delta-wing tail behind G (docs/model.md §7); off (zero loads) at opening angle 0."""

    enabled: bool = False
    """Put the tail terms in the model graphs. Implied by an opening angle > 0; set it to study the
    tail from an opening angle of 0 (which gives exactly zero loads)."""
    opening_angle_deg: float = 0.0
    """Opening angle beta of the delta; span = 2 length tan(beta / 2). 0 = no tail."""
    incidence_deg: float = 0.0
    """The tail's own incidence: the angle of the delta's plane to the body axis, positive with the
    leading edge (the root) up; added to the flow angle at the tail (its angle of attack). 0 = the
    tail in the body axis, as in the reference model (bit for bit)."""
    root_behind_m: float = 0.30
    """Distance of the tail root behind the centre of mass, along the body axis."""
    length_m: float = 0.25
    kinematic_viscosity_m2ps: float = 1.5e-5
    reynolds_speed_mps: float = 15.0
    """Reference speed of the tail's Reynolds number for the friction drag."""


@dataclass(frozen=True)
class Drag:
    """Optional drag terms of Pennycuick's flight model (docs/studies/energetics.md, the optional drag), off by default: with
    both coefficients 0 the terms are not built and the model is the paper's, bit for bit.

    Both act after the lifting-line solve (they do not change the circulation)."""

    enabled: bool = False
    """Put the drag terms in the model graphs even with zero coefficients (they then add exact zeros).
    Implied by a coefficient > 0."""
    body_drag_coefficient: float = 0.0
    """Body parasite drag coefficient C_Db (dimensionless), ``D_par = 1/2 rho S_b C_Db U^2`` at G, along
    the free stream. Published values: 0.1 (Pennycuick's current default, after Pennycuick, Klaassen,
    Kvist & Lindstroem 1996), 0.2 (afpt), up to 0.4 (older frozen-body values, Pennycuick 1989)."""
    body_frontal_area_m2: float = 0.0092
    """Body frontal area S_b [m^2]; default from Pennycuick's scaling for non-passerines,
    ``S_b = 0.00813 m^0.666`` (m in kg), at the reference mass 1.2 kg (passerines: 0.0129 m^0.614)."""
    profile_drag_coefficient: float = 0.0
    """Wing profile drag coefficient C_Dpro (dimensionless) of every element,
    ``dD_j = 1/2 rho C_Dpro c_j ds_j |Vp_j| Vp_j``. Published values: 0.014 (Pennycuick's Flight
    program), 2.66/sqrt(Re) ~ 0.0054 at Re 2.4e5 (afpt's laminar flat plate), ~0.026 (gliding Harris'
    hawk, Tucker & Heine 1990)."""


@dataclass(frozen=True)
class Solve:
    """Limit-cycle search: multiple shooting and the initial guess."""

    points: int = 5
    """Shooting points over one period, the closing point included (points - 1 segments)."""
    steps_per_period: int = 148
    """RK4 steps per period; a multiple of (points - 1)."""
    solver: str = "auto"
    """Nonlinear solver: "ipopt", "lm" (the paper's Levenberg-Marquardt), "newton-picard" (a model
    with aerodynamic states: Newton on the 4 body states and the free parameter of level flight, Picard
    iteration on the strongly damped aerodynamic states; the multipliers from one exact variational
    pass at the cycle) or "auto" ("newton-picard" for a model with aerodynamic states, "ipopt"
    otherwise)."""
    derivatives: str = "exact"
    """Jacobians: "exact" (automatic differentiation) or "fd" (finite differences; lm only)."""
    initial_guess: tuple[float, ...] = (18.0, 0.5, 0.1, 0.01)
    """State (u [m/s], w [m/s], q [rad/s], theta [rad]) at t = 0."""
    max_iter: int = 100
    """Iteration limit of the limit-cycle solve (IPOPT or Levenberg-Marquardt iterations), 1..100000."""
    tol: float = 0.0
    """Convergence tolerance of the limit-cycle solve (absolute max-norm of the shooting residual);
    0 = the solver's default: 1e-10 for ipopt (its ``tol`` and ``constr_viol_tol``), 1e-5 for lm."""


@dataclass(frozen=True)
class Validity:
    """Where the model holds: thresholds of the validity check of a cycle (:mod:`birdocp.bird.validity`).

    The model is a quasi-steady lifting line with a linear lift slope (no stall) and a straight wake
    along the body axis. A cycle is reported as *valid* when none of these limits is crossed. The
    defaults are deliberate, conservative choices, not fitted to any result:
    """

    stall_angle_deg: float = 15.0
    """Stall angle of a wing section (effective angle of attack, either sign). Bird wings and thin
    cambered aerofoils at Reynolds numbers 1e4-1e5 reach their maximum lift at about 10-20 deg
    (e.g. Withers 1981, J. Exp. Biol. 90, on bird wings as fixed aerofoils); 15 deg is mid-range and
    ignores the stall delay of a flapping wing (dynamic stall), so it errs on the side of caution."""
    max_stalled_fraction: float = 0.10
    """Largest allowed stalled share of the span-time area: the integral over the period and the span
    (element lengths as weights) of 'the element is beyond the stall angle', divided by span x period.
    A brief excursion at the wingtip stays well below it; 10 % of the lift-producing area-time
    working beyond stall is not a wing the linear model represents."""
    min_forward_speed_mps: float = 5.0
    """Smallest allowed forward speed u along the body axis. Quasi-steady aerodynamics needs a
    reduced frequency k = pi f c / U well below 1; with the reference wing (mean chord 0.2 m) at 4 Hz,
    k = 0.5 at 5 m/s (0.14 at the reference cycle's 18 m/s)."""
    max_abs_pitch_deg: float = 45.0
    """Largest allowed |theta| over the cycle: beyond it the cycle is a steep climb or a dive, far from
    the forward flight the model (and the paper) is about."""
    max_airflow_body_angle_deg: float = 20.0
    """Largest allowed angle between the airflow and the body axis, atan2(w, u) in absolute value.
    The wake is modelled as straight filaments along the body axis; with the airflow at an angle
    eps to it the trailing vortices leave along the wrong direction and the induced velocity is off by
    a term of order 1 - cos(eps) (6 % at 20 deg, 13 % at 30 deg) plus the wake's displacement."""


@dataclass(frozen=True)
class Model:
    """Degrees of freedom of the rigid body (:mod:`birdocp.bird.sixdof`) and the inertia the lateral
    motion needs.

    With 4 (the default) the bird moves in its plane of symmetry, state (u, w, q, theta), exactly as
    the paper; with 6 it has the state (u, v, w, p, q, r, phi, theta, psi) in body axes and the lifting
    line sees sideslip and roll and yaw rates. The inertias below are used only with 6.
    """

    degrees_of_freedom: int = 4
    """4 (longitudinal plane, the paper's model) or 6 (rigid body in space)."""
    roll_inertia_kgm2: float = 0.011
    """I_xx about the body axis x' through G [kg m^2]. An estimate: the body as a solid prolate
    spheroid of 1.2 kg and half-width 0.055 m (2/5 m b^2 = 0.0015) plus each wing as 0.12 kg (10 % of
    the bird's mass, the order of published wing-mass fractions) at 0.2 m from the plane of symmetry
    (2 x 0.12 x 0.2^2 = 0.0096). The lifting line's wings are massless in the dynamics; this number
    stands for them in roll."""
    yaw_inertia_kgm2: float = 0.11
    """I_zz about z' through G [kg m^2]: the pitch inertia body.pitch_inertia_kgm2 (0.1) plus the same
    wing estimate (0.0096), the body being axisymmetric about x'."""
    product_inertia_xz_kgm2: float = 0.0
    """I_xz [kg m^2] (0: x' and z' principal axes); the inertia tensor is
    [[I_xx, 0, -I_xz], [0, I_yy, 0], [-I_xz, 0, I_zz]]."""
