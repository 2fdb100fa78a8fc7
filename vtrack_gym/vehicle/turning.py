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
_STEADY_WINDOW_S = 2.0       # the last seconds [s] in which V / r must be steady
_STEADY_RTOL = 1e-3          # relative spread of V / r [-] allowed in that window


def kinematic_turning_radius_m(params: VehicleParams) -> float:
    """CG radius [m] of the kinematic single-track model at full lock: sqrt(a2^2 + (l / tan delta_max)^2)."""
    c = params.chassis
    rear_axle = c.wheelbase_m / math.tan(params.steering.max_road_wheel_angle_rad)
    return math.hypot(c.cg_to_rear_axle_m, rear_axle)


def min_turning_radius_m(params: VehicleParams, speed_mps: float = WALKING_SPEED_MPS) -> float:
    """The CG's path radius [m] of the plant at full left lock, its speed held at ``speed_mps`` [m/s] (0.1 to
    10 m/s) by the throttle and brake, after ``_SETTLE_S`` of simulated time (module docstring). Raises
    ValueError when V / r is not steady over the last ``_STEADY_WINDOW_S`` (the car spins at that speed)."""
    from vtrack_gym.vehicle import layout as L
    from vtrack_gym.vehicle.plant import Plant

    if not (math.isfinite(speed_mps) and 0.1 <= speed_mps <= 10.0):
        raise ValueError(f"speed_mps must be in [0.1, 10] m/s (got {speed_mps})")
    plant = Plant(params)
    plant.reset(v_x=speed_mps)
    u = np.zeros((1, L.N_INPUT))
    u[0, L.U_DELTA] = params.steering.max_road_wheel_angle_rad
    brake_gain = params.chassis.mass_kg / params.brakes.pedal_gain       # pedal [N] per m/s of excess speed
    n_periods = int(_SETTLE_S / (_PERIOD_STEPS * plant.physics_dt_s))
    radii = np.empty(n_periods)
    for k in range(n_periods):
        speed = math.hypot(plant.state[0, L.S_VX], plant.state[0, L.S_VY])
        err = speed_mps - speed
        u[0, L.U_THROTTLE] = min(max(0.05 + 2.0 * err, 0.0), 1.0)
        u[0, L.U_BRAKE] = min(max(-brake_gain * err, 0.0), params.brakes.max_pedal_force_n) \
            if u[0, L.U_THROTTLE] == 0.0 else 0.0
        plant.step(u, _PERIOD_STEPS)
        radii[k] = math.hypot(plant.state[0, L.S_VX], plant.state[0, L.S_VY]) / plant.state[0, L.S_R]
    last = radii[-int(_STEADY_WINDOW_S / (_PERIOD_STEPS * plant.physics_dt_s)):]
    if not (np.all(np.isfinite(last)) and np.ptp(last) <= _STEADY_RTOL * abs(float(np.mean(last)))):
        raise ValueError(f"no steady circle at full lock at speed_mps={speed_mps} m/s: V/r ranges over "
                         f"[{np.min(last):.3f}, {np.max(last):.3f}] m in the last {_STEADY_WINDOW_S} s (the car "
                         "spins or oscillates at its grip limit); use a lower speed")
    return float(radii[-1])


__all__ = ["WALKING_SPEED_MPS", "kinematic_turning_radius_m", "min_turning_radius_m"]
