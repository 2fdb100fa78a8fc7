"""What a speed profile may ask of a car's powertrain: forward acceleration and top speed at a throttle authority.

A profile bound to a car (``EnvelopeLimited`` with a ``throttle_authority``) speeds up at most as hard as the car's
drive force at that throttle fraction allows, less drag and rolling resistance (``vehicle.longitudinal``):
``a_x,max(v) = (F_drive(v, authority) - R(v)) / m``, and never faster than the speed where that reaches zero (the
car's top speed at that throttle). The authority is what drives the throttle: ``1.0`` an agent that commands the
throttle itself (the car's own full-throttle limit), ``SPEED_LOOP`` the env's PD-FLC, which the env resolves to the
largest throttle its speed loop holds (``envs.pdflc.speed_loop_throttle_authority``, 0.348 with the paper's gains).
The checks here warn (``UserWarning``) when a request lies beyond the car, naming the car's figure.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

SPEED_LOOP = "speed_loop"
"""``throttle_authority`` value meaning: the throttle the env's speed loop (PD-FLC) can hold, resolved by the env."""
KMH_PER_MPS = 3.6
ACCEL_TOLERANCE_MPS2 = 1e-6
"""A profile's acceleration may exceed the car's limit by this much [m/s^2] before a warning (rounding)."""


def check_throttle_authority(value: Any, field_name: str = "throttle_authority") -> None:
    """ValueError naming ``field_name`` unless ``value`` is None, ``SPEED_LOOP`` or a number in (0, 1]."""
    if value is None or value == SPEED_LOOP:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < float(value) <= 1.0:
        raise ValueError(f"{field_name} must be a throttle fraction in (0, 1], {SPEED_LOOP!r} (the env's speed "
                         f"loop) or None (no powertrain limit) (got {value!r})")


def check_powertrain_fields(profile: Any) -> None:
    """The powertrain fields of an ``EnvelopeLimited`` ``profile``: ValueError for a bad ``throttle_authority``, a
    ``max_accel_mps2`` of None without one, or a car bound without a numeric one; for a profile bound to a car, a
    ``UserWarning`` when ``max_accel_mps2`` or ``max_speed_mps`` asks for more than the car gives at its authority
    (:func:`check_accel_request`, :func:`capped_top_speed_mps`)."""
    name = type(profile).__name__
    check_throttle_authority(profile.throttle_authority, f"{name}.throttle_authority")
    if profile.max_accel_mps2 is None and profile.throttle_authority is None:
        raise ValueError(f"{name}.max_accel_mps2 = None (the powertrain's limit alone) needs a throttle_authority")
    if profile.vehicle is None:
        return
    if profile.throttle_authority is None or profile.throttle_authority == SPEED_LOOP:
        raise ValueError(f"{name} bound to a vehicle needs a throttle_authority in (0, 1] (got "
                         f"{profile.throttle_authority!r}; {SPEED_LOOP!r} is resolved by an env: for_car)")
    authority = float(profile.throttle_authority)
    check_accel_request(profile.max_accel_mps2, profile.vehicle, authority, f"{name}.max_accel_mps2")
    capped_top_speed_mps(profile.max_speed_mps, profile.vehicle, authority, f"{name}.max_speed_mps")


def forward_limit(vehicle: Any, authority: float, cap_mps2: float | None = None) -> Callable[[float], float]:
    """``v [m/s] -> min(cap_mps2, a_x,max(v))`` [m/s^2]: the forward acceleration ``vehicle`` (``VehicleParams``)
    gives at throttle ``authority`` less drag and rolling resistance (``longitudinal.forward_accel_limit_mps2``),
    capped by ``cap_mps2`` (None: no cap)."""
    from vtrack_gym.vehicle.longitudinal import forward_accel_limit_fn

    powertrain = forward_accel_limit_fn(vehicle, authority)
    if cap_mps2 is None:
        return powertrain
    cap = float(cap_mps2)

    def limit(v_mps: float) -> float:
        return min(cap, powertrain(v_mps))

    return limit


def powertrain_top_speed_mps(vehicle: Any, authority: float) -> float:
    """The car's top speed on the flat at throttle ``authority`` [m/s] (``longitudinal.top_speed_mps``)."""
    from vtrack_gym.vehicle.longitudinal import top_speed_mps

    return top_speed_mps(vehicle, authority)


def who(vehicle: Any, authority: float) -> str:
    """How a message names the car and its throttle authority."""
    return f"{vehicle.name!r} at throttle {authority:.3f}"


def capped_top_speed_mps(max_speed_mps: float, vehicle: Any, authority: float,
                         field_name: str = "max_speed_mps") -> float:
    """``max_speed_mps`` [m/s], or the car's top speed at ``authority`` when lower, with a ``UserWarning`` naming
    both in km/h."""
    top = powertrain_top_speed_mps(vehicle, authority)
    if max_speed_mps <= top:
        return float(max_speed_mps)
    warnings.warn(f"{field_name} = {max_speed_mps * KMH_PER_MPS:.1f} km/h is above the top speed of "
                  f"{who(vehicle, authority)}, {top * KMH_PER_MPS:.1f} km/h: the profile is capped at "
                  f"{top * KMH_PER_MPS:.1f} km/h", UserWarning, stacklevel=4)
    return top


def check_accel_request(max_accel_mps2: float | None, vehicle: Any, authority: float,
                        field_name: str = "max_accel_mps2") -> None:
    """A ``UserWarning`` when ``max_accel_mps2`` [m/s^2] exceeds the largest forward acceleration the car gives at
    ``authority`` at any speed (its value at rest), naming that figure: the powertrain bounds the profile anyway,
    so the requested figure is never reached."""
    if max_accel_mps2 is None:
        return
    peak = forward_limit(vehicle, authority)(0.0)
    if max_accel_mps2 > peak + ACCEL_TOLERANCE_MPS2:
        warnings.warn(f"{field_name} = {max_accel_mps2:.3f} m/s^2 is above the largest forward acceleration of "
                      f"{who(vehicle, authority)}, {peak:.3f} m/s^2 (at rest, less at speed): the profile follows "
                      "the powertrain's limit instead", UserWarning, stacklevel=4)


def worst_excess(v_mps: np.ndarray, ds_m: float, vehicle: Any, authority: float) -> tuple[int, float, float]:
    """Row interval where a speed table ``v_mps`` (v^2 linear between rows ``ds_m`` [m] apart) asks most beyond the
    car's forward limit at ``authority``: (interval index, its acceleration a_x [m/s^2], the car's limit there
    [m/s^2], taken at the faster end, where it is least)."""
    from vtrack_gym.vehicle.longitudinal import forward_accel_limit_mps2

    v = np.asarray(v_mps, dtype=float)
    a_x = np.diff(v * v) / (2.0 * ds_m)
    limit = forward_accel_limit_mps2(vehicle, np.maximum(v[1:], v[:-1]), authority)
    k = int(np.argmax(a_x - limit))
    return k, float(a_x[k]), float(limit[k])


def check_table_for_powertrain(v_mps: np.ndarray, ds_m: float, vehicle: Any, authority: float,
                               what: str) -> bool:
    """A ``UserWarning`` when the speeds ``v_mps`` [m/s] on rows ``ds_m`` [m] apart ask for more forward
    acceleration, or more speed, than ``vehicle`` gives at ``authority``, naming the worst station, the figures
    and the car (``what`` names the profile); True when it warned."""
    top = powertrain_top_speed_mps(vehicle, authority)
    k, a_x, limit = worst_excess(v_mps, ds_m, vehicle, authority)
    v_top = float(np.max(v_mps))
    if v_top > top * (1.0 + 1e-9):
        i = int(np.argmax(v_mps))
        warnings.warn(f"{what} asks for {v_top * KMH_PER_MPS:.1f} km/h at s = {i * ds_m:.1f} m, above the top "
                      f"speed of {who(vehicle, authority)}, {top * KMH_PER_MPS:.1f} km/h: the car cannot follow it",
                      UserWarning, stacklevel=4)
        return True
    if a_x > limit + ACCEL_TOLERANCE_MPS2:
        warnings.warn(f"{what} asks for {a_x:.3f} m/s^2 forward acceleration at s = {k * ds_m:.1f}-"
                      f"{(k + 1) * ds_m:.1f} m (reaching {max(v_mps[k], v_mps[k + 1]) * KMH_PER_MPS:.1f} km/h), "
                      f"above the {limit:.3f} m/s^2 of {who(vehicle, authority)} there: the car falls behind it",
                      UserWarning, stacklevel=4)
        return True
    return False


__all__ = ["SPEED_LOOP", "capped_top_speed_mps", "check_accel_request", "check_powertrain_fields",
           "check_table_for_powertrain", "check_throttle_authority", "forward_limit", "powertrain_top_speed_mps",
           "worst_excess"]
