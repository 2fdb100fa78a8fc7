"""The car's g-g-v limits: lateral, forward and braking acceleration limits against speed, and its top speed.

``gg_limits(vehicle)`` tabulates them from the car's own physics on a flat road:

- lateral: the steady-state grip limit of the plant, ``vehicle.steady_state.lateral_limit_mps2`` (path lateral
  acceleration V^2 / R at the highest cornering equilibrium, load transfer and the drive force for drag included);
- forward: the powertrain, ``vehicle.longitudinal.forward_accel_limit_mps2`` (drive force at full throttle minus
  drag and rolling resistance, over the mass);
- braking: the brake system's force capped by the tyres' longitudinal grip mu m g (the plant's per-wheel friction
  ellipse caps a wheel's longitudinal force at mu F_z), plus the resistance, over the mass;
- top speed: ``vehicle.longitudinal.top_speed_mps`` (drive force = resistance).

The limits combine in a friction ellipse (``tracks.lap_time``). ``GGLimits.constant`` gives speed-independent
limits (analytic checks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

SPEED_STEP_MPS = 0.25
"""Spacing of the speed grid the limits are tabulated on [m/s] (plus the kinks: the speeds of the lateral-limit
curve, so that its piecewise-linear limit is reproduced exactly, and where the drive force turns from force- to
power-limited; linear interpolation between)."""


@dataclass(frozen=True, eq=False)
class GGLimits:
    """Acceleration limits [m/s^2] tabulated against speed: ``speeds_mps`` (increasing, from 0),
    ``lateral_mps2``, ``forward_mps2`` (may reach 0 at the top speed) and ``brake_mps2`` (> 0), each held at its
    end values beyond the grid; ``top_speed_mps`` [m/s]; ``name`` says whose limits they are."""

    speeds_mps: np.ndarray = field(repr=False)
    lateral_mps2: np.ndarray = field(repr=False)
    forward_mps2: np.ndarray = field(repr=False)
    brake_mps2: np.ndarray = field(repr=False)
    top_speed_mps: float
    name: str = "the car"

    def __post_init__(self) -> None:
        arrays = [np.array(getattr(self, k), dtype=float) for k in
                  ("speeds_mps", "lateral_mps2", "forward_mps2", "brake_mps2")]
        n = arrays[0].size
        if n < 2 or any(a.shape != (n,) or not np.all(np.isfinite(a)) for a in arrays):
            raise ValueError("GGLimits arrays must be finite, 1-D, of one length >= 2")
        if arrays[0][0] != 0.0 or np.any(np.diff(arrays[0]) <= 0.0):
            raise ValueError("GGLimits.speeds_mps must start at 0 m/s and increase")
        if np.any(arrays[1] <= 0.0) or np.any(arrays[3] <= 0.0) or np.any(arrays[2] < 0.0):
            raise ValueError("GGLimits: lateral and brake limits must be > 0, forward limits >= 0 m/s^2")
        if not (math.isfinite(self.top_speed_mps) and self.top_speed_mps > 0.0):
            raise ValueError(f"GGLimits.top_speed_mps must be a finite speed > 0 m/s (got {self.top_speed_mps})")
        for name, a in zip(("speeds_mps", "lateral_mps2", "forward_mps2", "brake_mps2"), arrays, strict=True):
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    @classmethod
    def constant(cls, lateral_mps2: float, forward_mps2: float, brake_mps2: float, top_speed_mps: float,
                 name: str = "constant limits") -> GGLimits:
        """Limits independent of speed (lateral, forward, brake [m/s^2]), up to ``top_speed_mps`` [m/s]."""
        speeds = np.array([0.0, float(top_speed_mps)])
        return cls(speeds, np.full(2, float(lateral_mps2)), np.full(2, float(forward_mps2)),
                   np.full(2, float(brake_mps2)), float(top_speed_mps), name)

    def at(self, speed_mps: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(lateral, forward, brake) limits [m/s^2] at ``speed_mps`` [m/s]."""
        v = np.asarray(speed_mps, dtype=float)
        return tuple(np.interp(v, self.speeds_mps, a) for a in (self.lateral_mps2, self.forward_mps2,
                                                                 self.brake_mps2))


def gg_limits(vehicle: object = None) -> GGLimits:
    """The g-g-v limits of ``vehicle`` (``VehicleParams``, a shipped car's name or a vehicle file; None: the
    paper's car), as the module docstring says. Solving the lateral limit curve takes about 3 s the first time
    for a car (cached after)."""
    from vtrack_gym.vehicle.catalog import resolve_vehicle
    from vtrack_gym.vehicle.longitudinal import (
        MIN_POWER_SPEED_MPS,
        forward_accel_limit_mps2,
        resistance_n,
        top_speed_mps,
    )
    from vtrack_gym.vehicle.params import GRAVITY_MPS2
    from vtrack_gym.vehicle.steady_state import lateral_limit_curve, lateral_limit_mps2

    car = resolve_vehicle(vehicle)
    power = car.powertrain
    top = top_speed_mps(car)
    if not math.isfinite(top):
        raise ValueError(f"{car.name}: no top speed (no drag); give the car a drag area > 0")
    kinks = np.append(lateral_limit_curve(car)[0], [MIN_POWER_SPEED_MPS, power.max_power_w / power.max_drive_force_n])
    speeds = np.union1d(np.arange(math.ceil(top / SPEED_STEP_MPS) + 1) * SPEED_STEP_MPS, kinks[kinks < top])
    mass = car.chassis.mass_kg
    brake_force = min(car.brakes.pedal_gain * car.brakes.max_pedal_force_n,
                      car.tyres.friction_mu * mass * GRAVITY_MPS2)
    brake = (brake_force + resistance_n(car, speeds)) / mass
    forward = np.maximum(forward_accel_limit_mps2(car, speeds), 0.0)
    lateral = np.asarray(lateral_limit_mps2(car, speeds), dtype=float)
    return GGLimits(speeds, lateral, forward, brake, top, car.name)


__all__ = ["GGLimits", "gg_limits"]
