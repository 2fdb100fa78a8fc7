"""How the reference leaves a standing start in the longitudinal control modes (the ``launch=`` make kwarg).

A held-speed scenario that starts at rest (``LateralTracking-v0``: 40 km/h on the handling course) asks for its set
speed from t = 0: the speed error starts at the whole set speed and its time law runs at the set speed from the
start, a step no car can follow. ``launch="step"`` (the default; every id's behaviour) keeps it. ``"powertrain"``
replaces the step by a ramp the car can drive: from ``MIN_V_REF_MPS`` at s = 0 the reference speeds up at
``LAUNCH_SHARE`` of the car's least full-throttle forward acceleration between rest and the set speed
(``vehicle.longitudinal.forward_accel_limit_mps2``: drive force less drag and rolling resistance over the mass),
v^2 linear in s (``tracks.speed_profiles.SpeedRamp``), then holds the set speed; the speed error, the speed
preview and the time law (``time_error``) follow the ramp. The share below 1 leaves the speed law headroom.

Only in ``steer_accel`` and ``steer_rate_accel`` (in ``steer`` the paper's PD-FLC holds the set speed from the
start), and only for a scenario that holds one set speed from rest; a ``ValueError`` names the field otherwise.

With ``launch="step"`` (or no ``launch``) in a longitudinal mode, such a scenario warns (``UserWarning``) naming the
car's figures: the time and distance its full throttle needs to reach the set speed (``full_throttle_launch``), and
``launch="powertrain"`` as the reference it can follow. The episode is the id's own.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

LAUNCHES: dict[str, str] = {
    "step": "the set speed from the start (every id's default)",
    "powertrain": "from rest, a ramp at LAUNCH_SHARE of the car's full-throttle acceleration up to the set speed",
}
"""Launch name -> how the reference leaves a standing start."""
LAUNCH_SHARE = 0.75
"""Share of the car's least full-throttle forward acceleration [-] that the ``"powertrain"`` ramp asks for."""


def check_launch(launch: object) -> str:
    """``launch`` if it is a launch name (``LAUNCHES``); ``ValueError`` naming ``launch`` and the allowed values."""
    if not isinstance(launch, str) or launch not in LAUNCHES:
        raise ValueError(f"launch must be one of {', '.join(map(repr, LAUNCHES))} (got {launch!r})")
    return launch


def launch_accel_mps2(vehicle: Any, set_speed_mps: float) -> float:
    """The ``"powertrain"`` ramp's acceleration [m/s^2]: ``LAUNCH_SHARE`` x the car's least full-throttle forward
    acceleration between rest and ``set_speed_mps`` [m/s]; ``ValueError`` naming the car when it has none there."""
    from vtrack_gym.vehicle.longitudinal import forward_accel_limit_mps2

    speeds = np.linspace(0.0, set_speed_mps, 64)
    least = float(np.min(forward_accel_limit_mps2(vehicle, speeds)))
    if least <= 0.0:
        raise ValueError(f"launch='powertrain': {vehicle.name} cannot reach {set_speed_mps:.2f} m/s at full "
                         "throttle (its top speed is lower)")
    return LAUNCH_SHARE * least


def full_throttle_launch(vehicle: Any, set_speed_mps: float) -> tuple[float, float]:
    """(time [s], distance [m]) the car needs from rest to ``set_speed_mps`` [m/s] at full throttle on a flat road:
    ``t = int dv / a(v)`` and ``s = int v dv / a(v)`` with ``a(v)`` the car's full-throttle forward acceleration
    (``vehicle.longitudinal.forward_accel_limit_mps2``), by the trapezoid rule on 512 speeds; ``ValueError``
    naming the car when it cannot reach that speed."""
    from vtrack_gym.vehicle.longitudinal import forward_accel_limit_mps2

    speeds = np.linspace(0.0, set_speed_mps, 512)
    accel = forward_accel_limit_mps2(vehicle, speeds)
    if float(np.min(accel)) <= 0.0:
        raise ValueError(f"{vehicle.name} cannot reach {set_speed_mps:.2f} m/s at full throttle (its top speed "
                         "is lower)")
    return float(np.trapezoid(1.0 / accel, speeds)), float(np.trapezoid(speeds / accel, speeds))


def held_from_rest(scenario: Any) -> float | None:
    """The one set speed [m/s] ``scenario`` holds from a standing start, None when it has none (a speed profile, a
    set speed drawn per episode, or a start at speed)."""
    held = getattr(scenario.speed, "held_set_speed_mps", None)   # only a part that holds one set speed has it
    v_set = held() if callable(held) else None
    return None if v_set is None or scenario.start.at_speed else float(v_set)


def warn_step_launch(scenario: Any, vehicle: Any, control: str) -> None:
    """Warn (``UserWarning``) that ``scenario``'s reference steps from rest to a set speed the car cannot reach at
    once, naming the car's full-throttle time and distance, when ``control`` is a longitudinal mode (module
    docstring); nothing otherwise."""
    v_set = held_from_rest(scenario) if control != "steer" else None
    if v_set is None:
        return
    import warnings

    seconds, metres = full_throttle_launch(vehicle, v_set)
    least = launch_accel_mps2(vehicle, v_set) / LAUNCH_SHARE
    warnings.warn(f"{scenario.env_id} in control={control!r}: the reference holds {v_set:.2f} m/s from t = 0 while "
                  f"the car starts at rest; {vehicle.name} needs {seconds:.2f} s and {metres:.1f} m at full "
                  f"throttle to reach it (at least {least:.2f} m/s^2), so the speed error starts at the whole set "
                  "speed; launch='powertrain' gives a reference it can follow", UserWarning, stacklevel=2)


def with_launch(scenario: Any, vehicle: Any, launch: str, control: str) -> Any:
    """``scenario`` with its reference leaving a standing start as ``launch`` says (module docstring); the
    ``"step"`` launch of a longitudinal mode warns when the car cannot follow it (``warn_step_launch``)."""
    from vtrack_gym.tracks.path import MIN_V_REF_MPS
    from vtrack_gym.tracks.speed_profiles import SpeedRamp

    if check_launch(launch) == "step":
        warn_step_launch(scenario, vehicle, control)
        return scenario
    if control == "steer":
        raise ValueError("launch='powertrain' applies to the longitudinal control modes (control='steer_accel' or "
                         "'steer_rate_accel'); in 'steer' the paper's PD-FLC holds the set speed from the start")
    v_set = held_from_rest(scenario)
    if v_set is None:
        raise ValueError(f"launch='powertrain' applies to a scenario that holds one set speed from rest "
                         f"(LateralTracking-v0); {scenario.env_id} does not")
    ramp = SpeedRamp(v_start_mps=MIN_V_REF_MPS, v_end_mps=v_set, accel_mps2=launch_accel_mps2(vehicle, v_set))
    return replace(scenario, speed=ramp)
