"""The deceleration the car's fixed brake split gives before an axle's brakes use all of its grip.

The brake force is split front/rear in a fixed ratio (``BrakeParams.front_brake_share``) and the plant caps each
wheel's longitudinal force at mu F_z (``vehicle.kernels``), its lateral force derated by the friction ellipse
sqrt(1 - (F_x / (mu F_z))^2): an axle braked to mu F_z has no lateral force left. Braking at a_x moves
m a_x h / L of load from the rear axle to the front, so with the paper's car's 70 / 30 split the rear axle reaches
its cap first, at

    share_r m a_x = mu (m g l_f / L - m a_x h / L)   ->   a_x = mu g l_f / (share_r L + mu h)

6.60 m/s^2 on the paper's hatchback, against the mu g = 8.83 m/s^2 a brake-force cap alone would allow
(``tracks.gg_limits``); the front axle, ``a_x = mu g l_r / (share_f L - mu h)``, only at 10.8 m/s^2.
"""

from __future__ import annotations

import math

from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams


def brake_balance_decel_mps2(vehicle: VehicleParams) -> float:
    """The largest braking deceleration [m/s^2] before an axle's brake force reaches mu F_z (flat road, the fixed
    brake split, longitudinal load transfer), at most the brake system's own (resistance not included)."""
    ch, mu = vehicle.chassis, vehicle.tyres.friction_mu
    wheelbase = ch.cg_to_front_axle_m + ch.cg_to_rear_axle_m
    share_f = vehicle.brakes.front_brake_share
    share_r = 1.0 - share_f
    rear = mu * GRAVITY_MPS2 * ch.cg_to_front_axle_m / (share_r * wheelbase + mu * ch.cg_height_m)
    denominator = share_f * wheelbase - mu * ch.cg_height_m
    front = mu * GRAVITY_MPS2 * ch.cg_to_rear_axle_m / denominator if denominator > 0.0 else math.inf
    system = vehicle.brakes.pedal_gain * vehicle.brakes.max_pedal_force_n / ch.mass_kg
    return min(rear, front, system)


__all__ = ["brake_balance_decel_mps2"]
