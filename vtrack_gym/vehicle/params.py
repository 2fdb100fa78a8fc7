"""Vehicle parameters as frozen, validated dataclasses (SI units throughout).

Mass model: the sprung mass ``m_s = mass_kg - unsprung_mass_kg`` has its CG at ``cg_height_m`` (CarSim states the
sprung mass's CG; so does the paper's data set), the unsprung mass sits at the wheel centres
(``unsprung_cg_height_m``, split front/rear by ``front_unsprung_share``). The whole car's CG height
(:attr:`VehicleParams.total_cg_height_m`) is their mass-weighted mean; lateral and longitudinal load transfer both
use it (see ``kernels.py``): the longitudinal transfer is the rigid-body ``m a_x h / l``; the steady lateral
transfer is the rigid-body ``m a_y h / t`` plus the sideways shift of the rolled sprung mass's CG,
``m_s h_s (a_y (cos phi - 1) + g sin phi) / t`` (real physics, ~6 % on the paper's car with its roll stiffness;
zero for a rigid suspension; ``steady_state.lateral_transfer_n``).

The default car is the paper's CarSim "C-Class, Hatchback". Values from the paper's Nomenclature are marked
``paper``; values from the public reproduction of the same CarSim data set (ETH IDSC ``car_model``,
``bare/ctype_hatchback.m``) are marked ``IDSC``; everything else is our own modelling choice and is marked
``CHOICE`` with the reasoning next to it.

Every field declares its allowed range next to it (``ranged``, see ``vtrack_gym._ranges``: bounds named ``gt``/
``ge``/``lt``/``le``); ``__post_init__`` validates them and raises ``ValueError`` naming the offending field and
its allowed range, e.g. ``ValueError: ChassisParams.mass_kg must be > 0.0 kg (got -1.0)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

from vtrack_gym._ranges import documented, ranged, validate

GRAVITY_MPS2 = 9.81
"""Standard gravity used by every model [m/s^2] (paper: g = 9.81)."""

MIN_RELAXATION_LENGTH_M = 0.1
"""Shortest tyre relaxation length [m] other than 0 (off): at 45 m/s and a 2 ms physics step it lags by 2.2 ms, so
the RK4 integration resolves it (v dt / sigma < 1)."""


@documented
@dataclass(frozen=True)
class ChassisParams:
    """Rigid-body data of the whole car."""

    mass_kg: float = ranged(1413.0, gt=0.0, unit="kg")  # paper (IDSC: 1412 = 1270 sprung + 4 x 35.5 unsprung)
    # paper, I_z. This is CarSim's SPRUNG-mass I_zz; the paper (and so the design model and our plant) uses it as
    # the whole car's yaw inertia. The four unsprung corners would add ~430 kg m^2 (not modelled, CHOICE).
    # below ~5 kg m^2 the yaw mode is too fast for the 2 ms physics step (NaN at 120 km/h)
    yaw_inertia_kgm2: float = ranged(1536.7, ge=5.0, le=1e6, unit="kg m^2")
    cg_to_front_axle_m: float = ranged(1.015, gt=0.0, unit="m")  # paper, a1
    cg_to_rear_axle_m: float = ranged(1.895, gt=0.0, unit="m")  # paper, a2
    # IDSC: CG height of the SPRUNG mass above ground (whole car: VehicleParams.total_cg_height_m)
    cg_height_m: float = ranged(0.54, gt=0.0, unit="m")
    track_width_m: float = ranged(1.675, gt=0.0, unit="m")  # IDSC (front = rear)
    body_width_m: float = ranged(1.916, gt=0.0, unit="m")  # IDSC
    body_length_m: float = ranged(4.75, gt=0.0, unit="m")  # IDSC
    cg_to_front_end_m: float = ranged(1.915, gt=0.0, lt="body_length_m", unit="m")  # IDSC

    def __post_init__(self) -> None:
        validate(self)

    @property
    def wheelbase_m(self) -> float:
        """Wheelbase l = a1 + a2 [m]."""
        return self.cg_to_front_axle_m + self.cg_to_rear_axle_m


@documented
@dataclass(frozen=True)
class TyreParams:
    """Lateral tyre data: the paper's axle cornering stiffnesses and a normalised Pacejka shape.

    Each wheel's lateral force is ``F_y = mu * F_z * D * sin(C * atan(B * alpha))`` with B chosen so that the
    slope at the static axle load equals the paper's axle cornering stiffness (independent of mu), and a
    degressive load sensitivity of the cornering stiffness (``load_sensitivity``) so that load transfer matters.
    With a relaxation length sigma (``relaxation_length_m`` > 0) the force follows each axle's slip angle through
    a first-order lag, d(alpha_lag)/dt = |v_x| / sigma (alpha - alpha_lag); 0 (the default) is off.
    """

    # paper, C_af, axle (both tyres) [N/rad]
    front_cornering_stiffness_npr: float = ranged(128662.0, gt=0.0, unit="N/rad")
    rear_cornering_stiffness_npr: float = ranged(69890.0, gt=0.0, unit="N/rad")  # paper, C_ar, axle [N/rad]
    friction_mu: float = ranged(0.9, gt=0.0, le=2.0)  # paper, road friction coefficient
    front_shape_c: float = ranged(1.367, ge=1.0, lt=2.0)  # IDSC Pacejka C (front)
    front_peak_d: float = ranged(0.962, gt=0.0, le=2.0)  # IDSC Pacejka D (front), peak = mu * D * F_z
    rear_shape_c: float = ranged(1.365, ge=1.0, lt=2.0)  # IDSC Pacejka C (rear)
    rear_peak_d: float = ranged(0.974, gt=0.0, le=2.0)  # IDSC Pacejka D (rear)
    # CHOICE: per-wheel cornering stiffness C(Fz) = C0 (Fz/Fz0) (1 - eps (Fz/Fz0 - 1)); eps = 0.15 gives the
    # usual 5-15 % loss of axle stiffness under full lateral load transfer of a passenger car.
    load_sensitivity: float = ranged(0.15, ge=0.0, le=0.5)
    # CHOICE: rolling-resistance coefficient of a passenger-car tyre on asphalt.
    rolling_resistance_coeff: float = ranged(0.012, ge=0.0, le=0.1)
    # CHOICE: tyre relaxation length sigma [m]; the force follows a slip angle lagged by sigma / |v_x| (0.4-0.6 m is
    # typical of passenger-car tyres); 0 = off, the force follows the slip angle instantly (the paper's model)
    relaxation_length_m: float = ranged(0.0, ge=0.0, le=2.0, unit="m")

    def __post_init__(self) -> None:
        validate(self)
        if 0.0 < self.relaxation_length_m < MIN_RELAXATION_LENGTH_M:
            raise ValueError(f"TyreParams.relaxation_length_m must be 0 (off) or in [{MIN_RELAXATION_LENGTH_M}, 2.0] m "
                             f"(got {self.relaxation_length_m}): a shorter one lags by less than the 2 ms physics "
                             "step at speed and the integration would not resolve it")


@documented
@dataclass(frozen=True)
class RollParams:
    """Roll degree of freedom of the sprung mass (all CHOICE: the paper and CarSim data give none)."""

    unsprung_mass_kg: float = ranged(142.0, ge=0.0, unit="kg")  # IDSC: 4 x 35.5 kg
    # CHOICE: the unsprung mass acts at the wheel centres, height = loaded tyre radius (IDSC rolling radius 0.325 m)
    unsprung_cg_height_m: float = ranged(0.325, gt=0.0, unit="m")
    # CHOICE: front axle's share of the unsprung mass; a FWD car's front corners (drive shafts, larger brakes,
    # strut) are heavier than a twist-beam rear's: ~ the static front axle load share a2 / l = 0.651
    front_unsprung_share: float = ranged(0.65, ge=0.0, le=1.0)
    # CHOICE: C-segment sprung-mass roll inertia 400-500 kg m^2
    roll_inertia_kgm2: float = ranged(450.0, gt=0.0, unit="kg m^2")
    roll_stiffness_nmpr: float = ranged(75000.0, gt=0.0, unit="N m/rad")  # CHOICE: total (front + rear) 60-90 kN m/rad
    # CHOICE: total 4-6 kN m s/rad (damping ratio ~0.45)
    roll_damping_nmspr: float = ranged(5000.0, ge=0.0, unit="N m s/rad")
    roll_centre_height_m: float = ranged(0.10, ge=0.0, unit="m")  # CHOICE: ~0.1 m for McPherson/twist-beam
    # CHOICE: front share of roll stiffness and damping
    front_roll_stiffness_share: float = ranged(0.60, ge=0.0, le=1.0)

    def __post_init__(self) -> None:
        validate(self)


@documented
@dataclass(frozen=True)
class SteeringParams:
    """Steering actuator: first-order lag with a rate limit; hand-wheel = road-wheel x ratio (all CHOICE)."""

    max_road_wheel_angle_rad: float = ranged(0.6, gt=0.0, le=1.2, unit="rad")  # CHOICE: ~34 deg road-wheel limit
    steering_ratio: float = ranged(16.0, gt=0.0)  # CHOICE: hand-wheel / road-wheel, C-segment ~16:1
    # CHOICE: hand-wheel rate limit [deg/s] (EPS actuators)
    max_hand_wheel_rate_dps: float = ranged(800.0, gt=0.0, unit="deg/s")
    # CHOICE: actuator lag; 0 means an ideal (instant) actuator
    time_constant_s: float = ranged(0.03, ge=0.0, le=1.0, unit="s")

    def __post_init__(self) -> None:
        validate(self)

    @property
    def max_road_wheel_rate_radps(self) -> float:
        """Road-wheel rate limit [rad/s] implied by the hand-wheel rate limit and the ratio."""
        return math.radians(self.max_hand_wheel_rate_dps) / self.steering_ratio


@documented
@dataclass(frozen=True)
class PowertrainParams:
    """Front-wheel drive, power-limited: F_drive = throttle * min(F_max, P_max / max(v, v_eps)) (CHOICE)."""

    max_power_w: float = ranged(100_000.0, gt=0.0, unit="W")  # CHOICE: ~100 kW C-segment engine, at the wheels
    # CHOICE: low-gear traction limit at the wheels (~0.43 g)
    max_drive_force_n: float = ranged(6000.0, gt=0.0, unit="N")
    front_drive_share: float = ranged(1.0, ge=0.0, le=1.0)  # CHOICE: front-wheel drive
    # CHOICE: C_d A = 0.30 x 2.2 m^2; road vehicles stay below 20 m^2 (far more stops a car within one physics step)
    drag_area_m2: float = ranged(0.66, ge=0.0, le=20.0, unit="m^2")
    air_density_kgpm3: float = ranged(1.2, ge=0.0, unit="kg/m^3")  # standard air

    def __post_init__(self) -> None:
        validate(self)


@documented
@dataclass(frozen=True)
class BrakeParams:
    """Brake: total wheel brake force = gain x pedal force, split front/rear (CHOICE).

    A gain of 60 N/N gives 0.65 g at the paper's largest reported pedal force (~150 N).
    """

    pedal_gain: float = ranged(60.0, gt=0.0, unit="N/N")  # CHOICE: [N wheel force / N pedal force]
    max_pedal_force_n: float = ranged(500.0, gt=0.0, unit="N")  # CHOICE: pedal forces are clipped to [0, this]
    front_brake_share: float = ranged(0.70, ge=0.0, le=1.0)  # CHOICE: front share of the brake force

    def __post_init__(self) -> None:
        validate(self)


@documented
@dataclass(frozen=True)
class LowSpeedParams:
    """Blend from the dynamic to the kinematic single-track model at low speed (CommonRoad-style, CHOICE)."""

    blend_start_mps: float = ranged(1.0, gt=0.0, unit="m/s")  # below: purely kinematic
    blend_end_mps: float = ranged(3.0, gt="blend_start_mps", unit="m/s")  # above: purely dynamic
    # how fast v_y and r are pulled onto the kinematic values; at least 2.5 physics steps of 2 ms (stability)
    relaxation_time_s: float = ranged(0.05, ge=0.005, le=10.0, unit="s")
    # CHOICE: lag of the accelerations used for load transfer
    load_transfer_lag_s: float = ranged(0.02, gt=0.0, unit="s")

    def __post_init__(self) -> None:
        validate(self)


@dataclass(frozen=True)
class VehicleParams:
    """Everything the plant and the controllers' design models need, grouped by subsystem."""

    name: str = "C-Class Hatchback (paper)"
    chassis: ChassisParams = field(default_factory=ChassisParams)
    tyres: TyreParams = field(default_factory=TyreParams)
    roll: RollParams = field(default_factory=RollParams)
    steering: SteeringParams = field(default_factory=SteeringParams)
    powertrain: PowertrainParams = field(default_factory=PowertrainParams)
    brakes: BrakeParams = field(default_factory=BrakeParams)
    low_speed: LowSpeedParams = field(default_factory=LowSpeedParams)

    def __post_init__(self) -> None:
        if self.roll.unsprung_mass_kg >= self.chassis.mass_kg:
            raise ValueError("RollParams.unsprung_mass_kg must be < ChassisParams.mass_kg "
                             f"(got {self.roll.unsprung_mass_kg} >= {self.chassis.mass_kg})")
        if self.roll.roll_centre_height_m >= self.chassis.cg_height_m:
            raise ValueError("RollParams.roll_centre_height_m must be < ChassisParams.cg_height_m "
                             f"(got {self.roll.roll_centre_height_m} >= {self.chassis.cg_height_m})")
        c = self.chassis
        m_s = c.mass_kg - self.roll.unsprung_mass_kg
        for axle, (m_axle, m_u_axle) in zip(("front", "rear"), self.axle_masses_kg(), strict=True):
            if m_u_axle >= m_axle:
                raise ValueError(f"the {axle} axle's unsprung mass (RollParams.unsprung_mass_kg x share = "
                                 f"{m_u_axle:.1f} kg) must be < its static mass {m_axle:.1f} kg")
        h_s = c.cg_height_m - self.roll.roll_centre_height_m
        if self.roll.roll_stiffness_nmpr <= m_s * GRAVITY_MPS2 * h_s:
            raise ValueError("RollParams.roll_stiffness_nmpr must exceed m_s g h_s = "
                             f"{m_s * GRAVITY_MPS2 * h_s:.0f} N m/rad (else the body rolls over statically)")

    @property
    def sprung_mass_kg(self) -> float:
        """m_s = m - m_u [kg]."""
        return self.chassis.mass_kg - self.roll.unsprung_mass_kg

    def axle_masses_kg(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """((front static mass, front unsprung mass), (rear ..., rear ...)) [kg]; static mass = m a2 / l, m a1 / l."""
        c, r = self.chassis, self.roll
        m_uf = r.unsprung_mass_kg * r.front_unsprung_share
        return ((c.mass_kg * c.cg_to_rear_axle_m / c.wheelbase_m, m_uf),
                (c.mass_kg * c.cg_to_front_axle_m / c.wheelbase_m, r.unsprung_mass_kg - m_uf))

    @property
    def total_cg_height_m(self) -> float:
        """Whole-car CG height h = (m_s h_s,cg + m_u h_u) / m [m] (the rigid-body load-transfer height)."""
        c, r = self.chassis, self.roll
        return (self.sprung_mass_kg * c.cg_height_m + r.unsprung_mass_kg * r.unsprung_cg_height_m) / c.mass_kg

    def with_mass_scale(self, scale: float) -> VehicleParams:
        """Return a copy with mass and yaw/roll inertias multiplied by ``scale`` (0.5..2)."""
        if not (0.5 <= scale <= 2.0):
            raise ValueError(f"mass_scale must be in [0.5, 2.0] (got {scale})")
        chassis = replace(self.chassis, mass_kg=self.chassis.mass_kg * scale,
                          yaw_inertia_kgm2=self.chassis.yaw_inertia_kgm2 * scale)
        roll = replace(self.roll, roll_inertia_kgm2=self.roll.roll_inertia_kgm2 * scale,
                       unsprung_mass_kg=self.roll.unsprung_mass_kg * scale)
        return replace(self, chassis=chassis, roll=roll)

    def with_friction(self, mu: float) -> VehicleParams:
        """Return a copy on a road with friction coefficient ``mu`` (0.1..1.5)."""
        if not (0.1 <= mu <= 1.5):
            raise ValueError(f"friction_mu must be in [0.1, 1.5] (got {mu})")
        return replace(self, tyres=replace(self.tyres, friction_mu=mu))

    def with_steering_rate_scale(self, scale: float) -> VehicleParams:
        """Return a copy whose steering actuator's rate limit is multiplied by ``scale`` (0.25..10); lock and ratio
        unchanged (a faster or slower EPS motor)."""
        if not (0.25 <= scale <= 10.0):
            raise ValueError(f"steering_rate_scale must be in [0.25, 10.0] (got {scale})")
        rate = self.steering.max_hand_wheel_rate_dps * scale
        return replace(self, steering=replace(self.steering, max_hand_wheel_rate_dps=rate))

    def as_dict(self) -> dict[str, object]:
        """Nested plain-dict view (for provenance records and JSON)."""
        out: dict[str, object] = {"name": self.name}
        for f in fields(self):
            if f.name == "name":
                continue
            sub = getattr(self, f.name)
            out[f.name] = {g.name: getattr(sub, g.name) for g in fields(sub)}
        return out


@documented
@dataclass(frozen=True)
class DesignModel:
    """The linear single-track design model's parameters, as the controllers see them (paper Nomenclature)."""

    mass_kg: float = ranged(gt=0.0, unit="kg")
    yaw_inertia_kgm2: float = ranged(gt=0.0, unit="kg m^2")
    cg_to_front_axle_m: float = ranged(gt=0.0, unit="m")
    cg_to_rear_axle_m: float = ranged(gt=0.0, unit="m")
    front_cornering_stiffness_npr: float = ranged(gt=0.0, unit="N/rad")
    rear_cornering_stiffness_npr: float = ranged(gt=0.0, unit="N/rad")
    max_road_wheel_angle_rad: float = ranged(0.6, gt=0.0, unit="rad")
    max_road_wheel_rate_radps: float = ranged(math.radians(800.0) / 16.0, gt=0.0, unit="rad/s")
    steering_ratio: float = ranged(16.0, gt=0.0)
    friction_mu: float = ranged(0.9, gt=0.0)

    def __post_init__(self) -> None:
        validate(self)

    @property
    def wheelbase_m(self) -> float:
        """l = a1 + a2 [m]."""
        return self.cg_to_front_axle_m + self.cg_to_rear_axle_m

    @classmethod
    def from_vehicle(cls, params: VehicleParams) -> DesignModel:
        """The nominal design parameters of ``params`` (what a control engineer would be given)."""
        c, t, s = params.chassis, params.tyres, params.steering
        return cls(c.mass_kg, c.yaw_inertia_kgm2, c.cg_to_front_axle_m, c.cg_to_rear_axle_m,
                   t.front_cornering_stiffness_npr, t.rear_cornering_stiffness_npr,
                   s.max_road_wheel_angle_rad, s.max_road_wheel_rate_radps, s.steering_ratio, t.friction_mu)


def paper_vehicle() -> VehicleParams:
    """The paper's C-class hatchback with every CHOICE at its documented default."""
    return VehicleParams()
