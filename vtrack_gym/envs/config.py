"""Frozen configuration of the envs: reward, env settings, reset options (all SI units); the scenarios live in
``envs.scenarios`` (``Scenario`` and the paper's entries are re-exported here)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from vtrack_gym._ranges import closed_ranges, documented, ranged, validate
from vtrack_gym.envs.observation import DEFAULT_NOISE_STD, NOISY_FIELDS, OBS, ObservationLayout
from vtrack_gym.envs.pdflc import PDFLCConfig
from vtrack_gym.envs.scenarios import DLC120, KMH, LATERAL_TRACKING, RANDOM_TRACKS, TRACK, Scenario
from vtrack_gym.vehicle.params import VehicleParams

__all__ = ["DLC120", "KMH", "LATERAL_TRACKING", "RANDOM_TRACKS", "TRACK", "EnvConfig", "ResetOptions", "RewardConfig",
           "Scenario", "validate_numeric_options"]


@documented
@dataclass(frozen=True)
class RewardConfig:
    """Per-step reward ``r = alive - w_ey q(e_y, ey_scale) - w_ephi q(e_phi, ephi_scale) - w_effort a^2
    - w_rate min((da / rate_scale)^2, 1)``.

    with the bounded cusped penalty ``q(x, s) = |x| / (|x| + s)`` in [0, 1), ``a`` the normalised steering action
    and ``da`` its change since the previous step. Each penalty is bounded, so with the defaults every step of
    driving earns at least ``alive - w_ey - w_ephi - w_effort - w_rate = 0.15`` > 0: ending an episode early never
    pays (the old quadratic terms reached -5 per step at 1 m of error, less than a crash). The cusp gives a slope
    at every error: 1 cm of e_y costs 0.045, 10 cm 0.25, 1 m 0.45 (w_ey = 0.5, ey_scale = 0.1 m). On a failure
    termination (off road, spin-out, wheel lift) ``failure_penalty`` is added once (negative). Completing the
    course gives ``completion_bonus``. Every term is reported in ``info`` (``reward_tracking``,
    ``reward_heading``, ``reward_effort``, ``reward_rate``, ``reward_terminal``, ``reward_speed``).

    In the longitudinal control modes (``steer_accel``, ``steer_rate_accel``: ``envs.control``) the reward also has
    the speed-tracking term ``reward_speed = -w_speed q(e_v, speed_scale_mps)`` with e_v = v_x - v_ref, bounded in
    (-w_speed, 0] like the others (with the defaults every step still earns at least 0.05); ``a`` is then the
    steering command (in ``steer_rate_accel`` the integrated command, not the rate). In ``steer`` mode the term is
    exactly 0 and is not added.
    """

    # Bounded so that every reward is finite: |r| <= alive + w_ey + w_ephi + w_effort + w_rate + |penalty| + bonus
    # <= 8e6 at the range edges.
    alive: float = ranged(1.0, ge=0.0, le=1e6)
    w_ey: float = ranged(0.5, ge=0.0, le=1e6)
    ey_scale_m: float = ranged(0.1, ge=1e-6, le=1e3, unit="m")
    w_ephi: float = ranged(0.2, ge=0.0, le=1e6)
    ephi_scale_rad: float = ranged(0.05, ge=1e-6, le=1e3, unit="rad")
    w_effort: float = ranged(0.05, ge=0.0, le=1e6)
    w_rate: float = ranged(0.1, ge=0.0, le=1e6)
    rate_scale: float = ranged(0.1, ge=1e-6, le=2.0)
    failure_penalty: float = ranged(-10.0, ge=-1e6, le=0.0)
    completion_bonus: float = ranged(0.0, ge=0.0, le=1e6)
    w_speed: float = ranged(0.1, ge=0.0, le=1e6)
    speed_scale_mps: float = ranged(1.0, ge=1e-6, le=1e3, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)


MAX_NOISE_STD = 1.0
"""Upper bound of each ``EnvConfig.noise_std`` entry (SI units; x ``sensor_noise`` <= 5 at reset). Noisy observations
are also clipped to the observation box, so they stay finite and inside it for any accepted value."""


@documented
@dataclass(frozen=True)
class EnvConfig:
    """Everything an env instance needs besides its scenario."""

    control_period_s: float = ranged(0.01, ge=0.001, le=0.1, unit="s")
    physics_dt_s: float = ranged(0.002, ge=1e-4, le=0.002, unit="s")  # 500 Hz to 10 kHz
    model: str = "nonlinear"
    vehicle: VehicleParams = field(default_factory=VehicleParams)  # or a name of vehicle.list_vehicles() / a file
    reward: RewardConfig = field(default_factory=RewardConfig)
    layout: ObservationLayout = OBS
    speed_controller: PDFLCConfig = field(default_factory=PDFLCConfig)  # the inner PD-FLC loop (paper Table 3)
    # Sensor noise standard deviations at ``sensor_noise = 1`` (reset option scales them), one per entry of
    # ``observation.NOISY_FIELDS`` in its unit; the default is the observation table's noise column.
    noise_std: tuple[float, ...] = DEFAULT_NOISE_STD
    # what the action drives (envs.control.CONTROL_MODES): "steer" (the PD-FLC holds the speed), "steer_accel",
    # "steer_rate_accel"; the two longitudinal modes add the tracking errors at the end of the layout
    control: str = "steer"

    def __post_init__(self) -> None:
        from vtrack_gym.envs.control import check_control

        check_control(self.control)
        if self.control != "steer" and not self.layout.tracking_errors:
            object.__setattr__(self, "layout", replace(self.layout, tracking_errors=True))
        if not isinstance(self.vehicle, VehicleParams):  # a shipped vehicle's name or a vehicle file path
            from vtrack_gym.vehicle.catalog import resolve_vehicle

            object.__setattr__(self, "vehicle", resolve_vehicle(self.vehicle))
        validate(self)
        ratio = self.control_period_s / self.physics_dt_s
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError("EnvConfig.control_period_s must be an integer multiple of physics_dt_s "
                             f"(got {self.control_period_s} / {self.physics_dt_s} = {ratio})")
        from vtrack_gym.vehicle.layout import MODEL_IDS

        if self.model not in MODEL_IDS:
            raise ValueError(f"EnvConfig.model must be one of {', '.join(MODEL_IDS)} (got {self.model!r})")
        if len(self.noise_std) != len(NOISY_FIELDS) or any(
                isinstance(s, (bool, np.bool_)) or not isinstance(s, numbers.Real) or not (0.0 <= s <= MAX_NOISE_STD)
                for s in self.noise_std):
            raise ValueError(f"EnvConfig.noise_std must be {len(NOISY_FIELDS)} numbers in [0, {MAX_NOISE_STD}], one "
                             f"per {', '.join(NOISY_FIELDS)} (got {self.noise_std!r})")

    @property
    def n_substeps(self) -> int:
        """Physics steps per control period."""
        return round(self.control_period_s / self.physics_dt_s)


@documented
@dataclass(frozen=True)
class ResetOptions:
    """Scenario knobs that ``reset(options=...)`` may override (``None`` = scenario default)."""

    initial_lateral_offset_m: float = ranged(0.0, ge=-2.0, le=2.0, unit="m")
    # the car's heading minus the path's at the start (positive: pointing left of the path)
    initial_heading_error_rad: float = ranged(0.0, ge=-0.5, le=0.5, unit="rad")
    friction_mu: float | None = ranged(None, ge=0.1, le=1.5)
    mass_scale: float = ranged(1.0, ge=0.5, le=2.0)
    target_speed_mps: float | None = ranged(None, ge=1.0, le=45.0, unit="m/s")
    sensor_noise: float = ranged(0.0, ge=0.0, le=5.0)
    actuator_delay_s: float = ranged(0.0, ge=0.0, le=0.5, unit="s")
    # multiplies the steering actuator's rate limit (1 = the vehicle's own, 0.87 rad/s road-wheel for the default)
    steering_rate_scale: float = ranged(1.0, ge=0.25, le=10.0)
    # the option names the caller gave (``from_dict``): a scenario's randomisation never overrides them, even
    # when a given value equals the default (an explicit offset of 0 m on the training mix is 0 m)
    explicit: frozenset[str] = field(default=frozenset(), compare=False, repr=False)

    RANGES: ClassVar[dict[str, tuple[float, float]]]
    """Option name -> closed range [lo, hi] (from the fields' declared ranges; set below the class)."""

    def __post_init__(self) -> None:
        validate(self)

    @classmethod
    def from_dict(cls, options: dict[str, Any] | None) -> ResetOptions:
        """Validate a Gymnasium ``options`` dict; unknown or out-of-range keys raise ``ValueError`` naming them."""
        if not options:
            return cls()
        if not isinstance(options, dict):
            raise ValueError(f"reset options must be a dict (got {type(options).__name__})")
        values = validate_numeric_options(options, cls.RANGES)
        return cls(**values, explicit=frozenset(values))


ResetOptions.RANGES = closed_ranges(ResetOptions)


def validate_numeric_options(options: dict[str, Any], ranges: dict[str, tuple[float, float]],
                             extra_valid: tuple[str, ...] = ()) -> dict[str, float]:
    """Check every option is a known name with a finite number in its range; ``ValueError`` naming it.

    ``extra_valid`` lists option names handled elsewhere (only used in the "valid options" message).
    """
    values: dict[str, float] = {}
    for key, value in options.items():
        if key not in ranges:
            valid = ", ".join([*extra_valid, *sorted(ranges)])
            raise ValueError(f"unknown reset option {key!r}; valid options: {valid}")
        lo, hi = ranges[key]
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise ValueError(f"reset option {key!r} must be a real number in [{lo}, {hi}] (got "
                             f"{type(value).__name__} {value!r}; bools, strings and arrays are refused)")
        try:
            v = float(value)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"reset option {key!r} must be a number in [{lo}, {hi}] (got {value!r})") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise ValueError(f"reset option {key!r} must be in [{lo}, {hi}] (got {value!r})")
        values[key] = v
    return values
