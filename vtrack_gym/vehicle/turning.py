"""The car's tightest turn: the radius its CG drives at full steering lock at walking pace.

``min_turning_radius_m`` runs the plant itself (``vehicle.plant``) with the road wheels held at full lock
(``SteeringParams.max_road_wheel_angle_rad``) and the speed held at ``speed_mps`` until the circle is steady, and
returns the CG's path radius V / r. Below ``LowSpeedParams.blend_start_mps`` the plant is the kinematic single-track
model, whose CG circles at ``kinematic_turning_radius_m`` = sqrt(a2^2 + (l / tan delta_max)^2) (rear axle on
radius l / tan delta_max); at higher speeds the tyres' slip widens the circle (understeer). What a track asks is a
radius; a car whose minimum turning radius exceeds the tightest radius a line through the track can have cannot
drive it at any speed (``tracks.layout_feasibility``).
"""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym.vehicle.params import VehicleParams

WALKING_SPEED_MPS = 0.8
"""Default speed [m/s] of :func:`min_turning_radius_m`: below every shipped car's kinematic blend start (1 m/s)."""
_PERIOD_STEPS = 5            # physics steps per held input (0.01 s at 500 Hz)
_SETTLE_S = 20.0             # simulated time [s] before the radius is read


def kinematic_turning_radius_m(params: VehicleParams) -> float:
    """CG radius [m] of the kinematic single-track model at full lock: sqrt(a2^2 + (l / tan delta_max)^2)."""
    c = params.chassis
    rear_axle = c.wheelbase_m / math.tan(params.steering.max_road_wheel_angle_rad)
    return math.hypot(c.cg_to_rear_axle_m, rear_axle)


def min_turning_radius_m(params: VehicleParams, speed_mps: float = WALKING_SPEED_MPS) -> float:
    """The CG's path radius [m] of the plant at full left lock, its speed held at ``speed_mps`` [m/s] (0.1 to
    10 m/s) by the throttle and brake, after ``_SETTLE_S`` of simulated time (module docstring)."""
    from vtrack_gym.vehicle import layout as L
    from vtrack_gym.vehicle.plant import Plant

    if not (math.isfinite(speed_mps) and 0.1 <= speed_mps <= 10.0):
        raise ValueError(f"speed_mps must be in [0.1, 10] m/s (got {speed_mps})")
    plant = Plant(params)
    plant.reset(v_x=speed_mps)
    u = np.zeros((1, L.N_INPUT))
    u[0, L.U_DELTA] = params.steering.max_road_wheel_angle_rad
    brake_gain = params.chassis.mass_kg / params.brakes.pedal_gain       # pedal [N] per m/s of excess speed
    for _ in range(int(_SETTLE_S / (_PERIOD_STEPS * plant.physics_dt_s))):
        speed = math.hypot(plant.state[0, L.S_VX], plant.state[0, L.S_VY])
        err = speed_mps - speed
        u[0, L.U_THROTTLE] = min(max(0.05 + 2.0 * err, 0.0), 1.0)
        u[0, L.U_BRAKE] = min(max(-brake_gain * err, 0.0), params.brakes.max_pedal_force_n) \
            if u[0, L.U_THROTTLE] == 0.0 else 0.0
        plant.step(u, _PERIOD_STEPS)
    speed = math.hypot(plant.state[0, L.S_VX], plant.state[0, L.S_VY])
    return float(speed / plant.state[0, L.S_R])


__all__ = ["WALKING_SPEED_MPS", "kinematic_turning_radius_m", "min_turning_radius_m"]
