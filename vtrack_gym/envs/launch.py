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


def with_launch(scenario: Any, vehicle: Any, launch: str, control: str) -> Any:
    """``scenario`` with its reference leaving a standing start as ``launch`` says (module docstring)."""
    from vtrack_gym.tracks.path import MIN_V_REF_MPS
    from vtrack_gym.tracks.speed_profiles import SpeedRamp

    if check_launch(launch) == "step":
        return scenario
    if control == "steer":
        raise ValueError("launch='powertrain' applies to the longitudinal control modes (control='steer_accel' or "
                         "'steer_rate_accel'); in 'steer' the paper's PD-FLC holds the set speed from the start")
    held = getattr(scenario.speed, "held_set_speed_mps", None)   # only a part that holds one set speed has it
    v_set = held() if callable(held) else None
    if v_set is None or scenario.start.at_speed:
        raise ValueError(f"launch='powertrain' applies to a scenario that holds one set speed from rest "
                         f"(LateralTracking-v0); {scenario.env_id} does not")
    ramp = SpeedRamp(v_start_mps=MIN_V_REF_MPS, v_end_mps=v_set, accel_mps2=launch_accel_mps2(vehicle, v_set))
    return replace(scenario, speed=ramp)
