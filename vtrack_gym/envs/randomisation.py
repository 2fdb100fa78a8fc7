"""Scenario parts drawn per episode: the start (``Start``) and the domain randomisation (``Randomisation``).

``Randomisation.draw`` fills every reset option the caller left at its default (and did not give explicitly,
``ResetOptions.explicit``) from the scenario's range, using the car's own generator; a scenario without ranges
draws nothing, so its episodes consume no random numbers for it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate

RANDOMISED_RANGES: dict[str, tuple[float, float]] = {"friction_range": (0.1, 1.5), "mass_scale_range": (0.5, 2.0),
                                                   "sensor_noise_range": (0.0, 5.0),
                                                   "steering_rate_scale_range": (0.25, 10.0),
                                                   "initial_lateral_offset_range_m": (-2.0, 2.0),
                                                   "initial_heading_error_range_rad": (-0.5, 0.5)}
"""The allowed span of each range (the matching reset option's range)."""
_OPTION_OF: dict[str, tuple[str, float | None]] = {
    "friction_range": ("friction_mu", None), "mass_scale_range": ("mass_scale", 1.0),
    "sensor_noise_range": ("sensor_noise", 0.0), "steering_rate_scale_range": ("steering_rate_scale", 1.0),
    "initial_lateral_offset_range_m": ("initial_lateral_offset_m", 0.0),
    "initial_heading_error_range_rad": ("initial_heading_error_rad", 0.0)}
"""Range -> (the reset option it draws, that option's default)."""


@documented
@dataclass(frozen=True, kw_only=True)
class Start:
    """How an episode starts: at the reference speed (``at_speed``) or at rest, and the share of episodes that
    start at rest regardless (``standstill_fraction``)."""

    at_speed: bool = False
    standstill_fraction: float = ranged(0.0, ge=0.0, le=1.0)

    def __post_init__(self) -> None:
        validate(self)

    def initial_speed_mps(self, v_ref_mps: float, rng: np.random.Generator) -> float:
        """The car's speed at reset [m/s] (draws from ``rng`` only when ``standstill_fraction`` > 0)."""
        v0 = v_ref_mps if self.at_speed else 0.0
        if self.standstill_fraction > 0.0 and rng.random() < self.standstill_fraction:
            v0 = 0.0
        return v0


@documented
@dataclass(frozen=True, kw_only=True)
class Randomisation:
    """Domain randomisation, drawn per episode: friction mu, mass scale and sensor-noise scale uniform in their
    ranges (``None``: off), an actuator delay of a whole number of control periods uniform in
    [0, ``max_actuator_delay_s``], a steering rate-limit scale, and the start's offset from the path [m] and
    heading error [rad] uniform in theirs."""

    friction_range: tuple[float, float] | None = None
    mass_scale_range: tuple[float, float] | None = None
    sensor_noise_range: tuple[float, float] | None = None
    max_actuator_delay_s: float = ranged(0.0, ge=0.0, le=0.5, unit="s")
    steering_rate_scale_range: tuple[float, float] | None = None
    initial_lateral_offset_range_m: tuple[float, float] | None = None
    initial_heading_error_range_rad: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        for name, (lo, hi) in RANDOMISED_RANGES.items():
            value = getattr(self, name)
            if value is not None and not (isinstance(value, tuple) and len(value) == 2
                                          and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                  for v in value) and lo <= value[0] <= value[1] <= hi):
                raise ValueError(f"Randomisation.{name} must be None or a (low, high) tuple with "
                                 f"{lo} <= low <= high <= {hi} (got {value!r})")
        validate(self)

    @property
    def is_off(self) -> bool:
        """True when nothing is drawn."""
        return all(getattr(self, f.name) in (None, 0.0) for f in fields(self))

    def draw(self, options: Any, rng: np.random.Generator, control_period_s: float) -> Any:
        """``options`` (``ResetOptions``) with every free knob drawn from its range, in the field order of this
        class (the delay in whole control periods of ``control_period_s`` [s])."""
        changes: dict[str, float] = {}

        def free(name: str, default: float | None) -> bool:
            return name not in options.explicit and getattr(options, name) == default

        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "max_actuator_delay_s":
                if value > 0.0 and free("actuator_delay_s", 0.0):
                    steps = int(rng.integers(0, int(value / control_period_s + 1e-9) + 1))
                    changes["actuator_delay_s"] = steps * control_period_s
            elif value is not None and free(*_OPTION_OF[f.name]):
                changes[_OPTION_OF[f.name][0]] = float(rng.uniform(*value))
        return replace(options, **changes) if changes else options
