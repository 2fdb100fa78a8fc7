"""The car's own longitudinal limits on a flat road, as the plant computes its forces (``vehicle.kernels``).

Drive force ``F_d(v) = throttle * min(F_max, P_max / max(v, 1 m/s))`` (``PowertrainParams``), brake force
``pedal_gain * pedal`` (``BrakeParams``), resistance ``R(v) = 1/2 rho C_d A v^2 + f_r m g`` (drag and rolling
resistance). What a speed profile may ask of the car: a forward acceleration at most ``(F_d(v) - R(v)) / m`` and a
speed at most the top speed where ``F_d = R``. Grip limits (the friction ellipse) are the profile's other bound and
are not included here.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams

MIN_POWER_SPEED_MPS = 1.0
"""Below this speed [m/s] the plant's power limit reads P_max / 1 m/s (as ``vehicle.kernels``)."""


def drive_force_n(params: VehicleParams, speed_mps: np.ndarray | float, throttle: float = 1.0) -> np.ndarray:
    """Total drive force at the wheels [N] at ``speed_mps`` [m/s] and a throttle fraction in [0, 1]."""
    v = np.maximum(np.asarray(speed_mps, dtype=np.float64), MIN_POWER_SPEED_MPS)
    p = params.powertrain
    return throttle * np.minimum(p.max_drive_force_n, p.max_power_w / v)


def resistance_n(params: VehicleParams, speed_mps: np.ndarray | float) -> np.ndarray:
    """Drag plus rolling resistance on a flat road [N] at ``speed_mps`` [m/s] (>= 0)."""
    v = np.asarray(speed_mps, dtype=np.float64)
    p = params.powertrain
    drag = 0.5 * p.air_density_kgpm3 * p.drag_area_m2 * v * np.abs(v)
    return drag + params.tyres.rolling_resistance_coeff * params.chassis.mass_kg * GRAVITY_MPS2


def forward_accel_limit_mps2(params: VehicleParams, speed_mps: np.ndarray | float,
                             throttle: float = 1.0) -> np.ndarray:
    """Largest forward acceleration the powertrain gives at ``speed_mps`` [m/s^2] (negative above the top speed)."""
    return (drive_force_n(params, speed_mps, throttle) - resistance_n(params, speed_mps)) / params.chassis.mass_kg


def forward_accel_limit_fn(params: VehicleParams, throttle: float = 1.0) -> Callable[[float], float]:
    """:func:`forward_accel_limit_mps2` at ``throttle`` as a function of one speed ``v [m/s] -> [m/s^2]`` on plain
    floats (the same formula, without numpy's per-call cost: what a row-by-row speed-profile pass calls)."""
    p = params.powertrain
    m = params.chassis.mass_kg
    f_max, p_max = throttle * p.max_drive_force_n, throttle * p.max_power_w
    k_drag = 0.5 * p.air_density_kgpm3 * p.drag_area_m2
    rolling = params.tyres.rolling_resistance_coeff * m * GRAVITY_MPS2

    def limit(v_mps: float) -> float:
        drive = min(f_max, p_max / max(v_mps, MIN_POWER_SPEED_MPS))
        return (drive - k_drag * v_mps * abs(v_mps) - rolling) / m

    return limit


def brake_decel_limit_mps2(params: VehicleParams, speed_mps: np.ndarray | float) -> np.ndarray:
    """Largest deceleration of full brake pedal plus resistance at ``speed_mps`` [m/s^2] (> 0; grip not included)."""
    b = params.brakes
    return (b.pedal_gain * b.max_pedal_force_n + resistance_n(params, speed_mps)) / params.chassis.mass_kg


def top_speed_mps(params: VehicleParams, throttle: float = 1.0) -> float:
    """Speed [m/s] where the drive force at ``throttle`` equals the resistance (the car's top speed on the flat);
    ``ValueError`` if the drive force cannot even overcome rolling resistance."""
    if not 0.0 < throttle <= 1.0:
        raise ValueError(f"throttle must be in (0, 1] (got {throttle!r})")
    if forward_accel_limit_mps2(params, 0.0, throttle) <= 0.0:
        raise ValueError(f"{params.name}: a throttle of {throttle} does not overcome rolling resistance")
    lo, hi = 0.0, 1.0
    while forward_accel_limit_mps2(params, hi, throttle) > 0.0:
        lo, hi = hi, 2.0 * hi
        if hi > 1e4:
            return math.inf  # no drag: no top speed
    for _ in range(200):  # bisection to the last bit of the bracket
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        if forward_accel_limit_mps2(params, mid, throttle) > 0.0:
            lo = mid
        else:
            hi = mid
    return lo


__all__ = ["MIN_POWER_SPEED_MPS", "brake_decel_limit_mps2", "drive_force_n", "forward_accel_limit_fn",
           "forward_accel_limit_mps2", "resistance_n", "top_speed_mps"]
