"""Vehicle parameters as frozen, validated dataclasses (SI units throughout).

The default car is the paper's CarSim "C-Class, Hatchback". Values from the paper's Nomenclature are marked
``paper``; values from the public reproduction of the same CarSim data set (ETH IDSC ``car_model``,
``bare/ctype_hatchback.m``) are marked ``IDSC``; everything else is our own modelling choice and is marked
``CHOICE`` with the reasoning next to it.

Every dataclass validates itself in ``__post_init__`` and raises ``ValueError`` naming the offending field and
its allowed range, e.g. ``ValueError: ChassisParams.mass_kg must be > 0 (got -1.0)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

GRAVITY_MPS2 = 9.81
"""Standard gravity used by every model [m/s^2] (paper: g = 9.81)."""


def _check(owner: object, name: str, low: float | None = None, high: float | None = None,
           *, low_inclusive: bool = False, high_inclusive: bool = True) -> None:
    """Raise ``ValueError`` unless ``owner.name`` is finite and within (low, high)."""
    value = getattr(owner, name)
    label = f"{type(owner).__name__}.{name}"
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise ValueError(f"{label} must be a finite number (got {value!r})")
    if low is not None and (value < low or (value == low and not low_inclusive)):
        op = ">=" if low_inclusive else ">"
        raise ValueError(f"{label} must be {op} {low} (got {value})")
    if high is not None and (value > high or (value == high and not high_inclusive)):
        op = "<=" if high_inclusive else "<"
        raise ValueError(f"{label} must be {op} {high} (got {value})")


@dataclass(frozen=True)
class ChassisParams:
    """Rigid-body data of the whole car."""

    mass_kg: float = 1413.0                 # paper (IDSC: 1412 = 1270 sprung + 4 x 35.5 unsprung)
    yaw_inertia_kgm2: float = 1536.7        # paper, I_z
    cg_to_front_axle_m: float = 1.015       # paper, a1
    cg_to_rear_axle_m: float = 1.895        # paper, a2
    cg_height_m: float = 0.54               # IDSC
    track_width_m: float = 1.675            # IDSC (front = rear)
    body_width_m: float = 1.916             # IDSC
    body_length_m: float = 4.75             # IDSC
    cg_to_front_end_m: float = 1.915        # IDSC

    def __post_init__(self) -> None:
        for name in ("mass_kg", "yaw_inertia_kgm2", "cg_to_front_axle_m", "cg_to_rear_axle_m",
                     "cg_height_m", "track_width_m", "body_width_m", "body_length_m", "cg_to_front_end_m"):
            _check(self, name, 0.0)
        if self.cg_to_front_end_m >= self.body_length_m:
            raise ValueError("ChassisParams.cg_to_front_end_m must be < body_length_m "
                             f"(got {self.cg_to_front_end_m} >= {self.body_length_m})")

    @property
    def wheelbase_m(self) -> float:
        """Wheelbase l = a1 + a2 [m]."""
        return self.cg_to_front_axle_m + self.cg_to_rear_axle_m


@dataclass(frozen=True)
class TyreParams:
    """Lateral tyre data: the paper's axle cornering stiffnesses and a normalised Pacejka shape.

    Each wheel's lateral force is ``F_y = mu * F_z * D * sin(C * atan(B * alpha))`` with B chosen so that the
    slope at the static axle load equals the paper's axle cornering stiffness (independent of mu), and a
    degressive load sensitivity of the cornering stiffness (``load_sensitivity``) so that load transfer matters.
    """

    front_cornering_stiffness_npr: float = 128662.0  # paper, C_af, axle (both tyres) [N/rad]
    rear_cornering_stiffness_npr: float = 69890.0    # paper, C_ar, axle [N/rad]
    friction_mu: float = 0.9                          # paper, road friction coefficient
    front_shape_c: float = 1.367                      # IDSC Pacejka C (front)
    front_peak_d: float = 0.962                       # IDSC Pacejka D (front), peak = mu * D * F_z
    rear_shape_c: float = 1.365                       # IDSC Pacejka C (rear)
    rear_peak_d: float = 0.974                        # IDSC Pacejka D (rear)
    # CHOICE: per-wheel cornering stiffness C(Fz) = C0 (Fz/Fz0) (1 - eps (Fz/Fz0 - 1)); eps = 0.15 gives the
    # usual 5-15 % loss of axle stiffness under full lateral load transfer of a passenger car.
    load_sensitivity: float = 0.15
    # CHOICE: rolling-resistance coefficient of a passenger-car tyre on asphalt.
    rolling_resistance_coeff: float = 0.012

    def __post_init__(self) -> None:
        _check(self, "front_cornering_stiffness_npr", 0.0)
        _check(self, "rear_cornering_stiffness_npr", 0.0)
        _check(self, "friction_mu", 0.0, 2.0)
        for name in ("front_shape_c", "rear_shape_c"):
            _check(self, name, 1.0, 2.0, low_inclusive=True, high_inclusive=False)
        for name in ("front_peak_d", "rear_peak_d"):
            _check(self, name, 0.0, 2.0)
        _check(self, "load_sensitivity", 0.0, 0.5, low_inclusive=True)
        _check(self, "rolling_resistance_coeff", 0.0, 0.1, low_inclusive=True)


@dataclass(frozen=True)
class RollParams:
    """Roll degree of freedom of the sprung mass (all CHOICE: the paper and CarSim data give none)."""

    unsprung_mass_kg: float = 142.0          # IDSC: 4 x 35.5 kg
    roll_inertia_kgm2: float = 450.0         # CHOICE: C-segment sprung-mass roll inertia 400-500 kg m^2
    roll_stiffness_nmpr: float = 75000.0     # CHOICE: total (front + rear) 60-90 kN m/rad
    roll_damping_nmspr: float = 5000.0       # CHOICE: total 4-6 kN m s/rad (damping ratio ~0.45)
    roll_centre_height_m: float = 0.10       # CHOICE: ~0.1 m for McPherson/twist-beam
    front_roll_stiffness_share: float = 0.60  # CHOICE: front share of roll stiffness and damping

    def __post_init__(self) -> None:
        _check(self, "unsprung_mass_kg", 0.0, low_inclusive=True)
        _check(self, "roll_inertia_kgm2", 0.0)
        _check(self, "roll_stiffness_nmpr", 0.0)
        _check(self, "roll_damping_nmspr", 0.0, low_inclusive=True)
        _check(self, "roll_centre_height_m", 0.0, low_inclusive=True)
        _check(self, "front_roll_stiffness_share", 0.0, 1.0, low_inclusive=True)


@dataclass(frozen=True)
class SteeringParams:
    """Steering actuator: first-order lag with a rate limit; hand-wheel = road-wheel x ratio (all CHOICE)."""

    max_road_wheel_angle_rad: float = 0.6    # CHOICE: ~34 deg road-wheel limit
    steering_ratio: float = 16.0             # CHOICE: hand-wheel / road-wheel, C-segment ~16:1
    max_hand_wheel_rate_dps: float = 800.0   # CHOICE: hand-wheel rate limit [deg/s] (EPS actuators)
    time_constant_s: float = 0.03            # CHOICE: actuator lag; 0 means an ideal (instant) actuator

    def __post_init__(self) -> None:
        _check(self, "max_road_wheel_angle_rad", 0.0, 1.2)
        _check(self, "steering_ratio", 0.0)
        _check(self, "max_hand_wheel_rate_dps", 0.0)
        _check(self, "time_constant_s", 0.0, 1.0, low_inclusive=True)

    @property
    def max_road_wheel_rate_radps(self) -> float:
        """Road-wheel rate limit [rad/s] implied by the hand-wheel rate limit and the ratio."""
        return math.radians(self.max_hand_wheel_rate_dps) / self.steering_ratio


@dataclass(frozen=True)
class PowertrainParams:
    """Front-wheel drive, power-limited: F_drive = throttle * min(F_max, P_max / max(v, v_eps)) (CHOICE)."""

    max_power_w: float = 100_000.0           # CHOICE: ~100 kW C-segment engine, at the wheels
    max_drive_force_n: float = 6000.0        # CHOICE: low-gear traction limit at the wheels (~0.43 g)
    front_drive_share: float = 1.0           # CHOICE: front-wheel drive
    drag_area_m2: float = 0.66               # CHOICE: C_d A = 0.30 x 2.2 m^2
    air_density_kgpm3: float = 1.2           # standard air

    def __post_init__(self) -> None:
        _check(self, "max_power_w", 0.0)
        _check(self, "max_drive_force_n", 0.0)
        _check(self, "front_drive_share", 0.0, 1.0, low_inclusive=True)
        _check(self, "drag_area_m2", 0.0, low_inclusive=True)
        _check(self, "air_density_kgpm3", 0.0, low_inclusive=True)


@dataclass(frozen=True)
class BrakeParams:
    """Brake: total wheel brake force = gain x pedal force, split front/rear (CHOICE).

    A gain of 60 N/N gives 0.65 g at the paper's largest reported pedal force (~150 N).
    """

    pedal_gain: float = 60.0                 # CHOICE: [N wheel force / N pedal force]
    max_pedal_force_n: float = 500.0         # CHOICE: pedal forces are clipped to [0, this]
    front_brake_share: float = 0.70          # CHOICE: front share of the brake force

    def __post_init__(self) -> None:
        _check(self, "pedal_gain", 0.0)
        _check(self, "max_pedal_force_n", 0.0)
        _check(self, "front_brake_share", 0.0, 1.0, low_inclusive=True)


@dataclass(frozen=True)
class LowSpeedParams:
    """Blend from the dynamic to the kinematic single-track model at low speed (CommonRoad-style, CHOICE)."""

    blend_start_mps: float = 1.0             # below: purely kinematic
    blend_end_mps: float = 3.0               # above: purely dynamic
    relaxation_time_s: float = 0.05          # how fast v_y and r are pulled onto the kinematic values
    load_transfer_lag_s: float = 0.02        # CHOICE: lag of the accelerations used for load transfer

    def __post_init__(self) -> None:
        _check(self, "blend_start_mps", 0.0)
        _check(self, "blend_end_mps", 0.0)
        if self.blend_end_mps <= self.blend_start_mps:
            raise ValueError("LowSpeedParams.blend_end_mps must be > blend_start_mps "
                             f"(got {self.blend_end_mps} <= {self.blend_start_mps})")
        _check(self, "relaxation_time_s", 0.0)
        _check(self, "load_transfer_lag_s", 0.0)


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
        m_s = self.chassis.mass_kg - self.roll.unsprung_mass_kg
        h_s = self.chassis.cg_height_m - self.roll.roll_centre_height_m
        if self.roll.roll_stiffness_nmpr <= m_s * GRAVITY_MPS2 * h_s:
            raise ValueError("RollParams.roll_stiffness_nmpr must exceed m_s g h_s = "
                             f"{m_s * GRAVITY_MPS2 * h_s:.0f} N m/rad (else the body rolls over statically)")

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

    def as_dict(self) -> dict[str, object]:
        """Nested plain-dict view (for provenance records and JSON)."""
        out: dict[str, object] = {"name": self.name}
        for f in fields(self):
            if f.name == "name":
                continue
            sub = getattr(self, f.name)
            out[f.name] = {g.name: getattr(sub, g.name) for g in fields(sub)}
        return out


@dataclass(frozen=True)
class DesignModel:
    """The linear single-track design model's parameters, as the controllers see them (paper Nomenclature)."""

    mass_kg: float
    yaw_inertia_kgm2: float
    cg_to_front_axle_m: float
    cg_to_rear_axle_m: float
    front_cornering_stiffness_npr: float
    rear_cornering_stiffness_npr: float
    max_road_wheel_angle_rad: float = 0.6
    max_road_wheel_rate_radps: float = math.radians(800.0) / 16.0
    steering_ratio: float = 16.0
    friction_mu: float = 0.9

    def __post_init__(self) -> None:
        for name in ("mass_kg", "yaw_inertia_kgm2", "cg_to_front_axle_m", "cg_to_rear_axle_m",
                     "front_cornering_stiffness_npr", "rear_cornering_stiffness_npr",
                     "max_road_wheel_angle_rad", "max_road_wheel_rate_radps", "steering_ratio", "friction_mu"):
            _check(self, name, 0.0)

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
