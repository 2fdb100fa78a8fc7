"""The brake-balance deceleration: where the fixed brake split brings an axle's brake force to mu F_z, and the race
baselines' profile braking within it."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.vehicle.brake_balance import brake_balance_decel_mps2
from vtrack_gym.vehicle.params import GRAVITY_MPS2, VehicleParams


def axle_usage(car: VehicleParams, decel: float) -> tuple[float, float]:
    """(front, rear) brake force over mu F_z of the axle when braking at ``decel`` [m/s^2] with the fixed split."""
    ch, mu = car.chassis, car.tyres.friction_mu
    wheelbase = ch.cg_to_front_axle_m + ch.cg_to_rear_axle_m
    transfer = ch.mass_kg * decel * ch.cg_height_m / wheelbase
    front_load = ch.mass_kg * GRAVITY_MPS2 * ch.cg_to_rear_axle_m / wheelbase + transfer
    rear_load = ch.mass_kg * GRAVITY_MPS2 * ch.cg_to_front_axle_m / wheelbase - transfer
    force = ch.mass_kg * decel
    share = car.brakes.front_brake_share
    return share * force / (mu * front_load), (1.0 - share) * force / (mu * rear_load)


def test_the_rear_axle_reaches_its_grip_first_at_the_balance_deceleration() -> None:
    car = VehicleParams()
    decel = brake_balance_decel_mps2(car)
    assert decel == pytest.approx(6.594, abs=1e-3)
    front, rear = axle_usage(car, decel)
    assert rear == pytest.approx(1.0, rel=1e-12) and front < 1.0
    assert decel < car.tyres.friction_mu * GRAVITY_MPS2          # what a brake-force cap alone would allow


def test_more_front_brake_moves_the_limit_to_the_front_axle() -> None:
    car = VehicleParams()
    front_biased = dataclasses.replace(car, brakes=dataclasses.replace(car.brakes, front_brake_share=0.9))
    decel = brake_balance_decel_mps2(front_biased)
    front, rear = axle_usage(front_biased, decel)
    assert front == pytest.approx(1.0, rel=1e-12) and rear < 1.0


def test_the_race_baselines_profile_brakes_within_the_balance() -> None:
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy("raceline", env)
    v = policy.table
    decel = -np.diff(v ** 2) / (2.0 * policy.line.ds_m)
    car = env.unwrapped.config.vehicle
    drag = 0.5 * car.powertrain.air_density_kgpm3 * car.powertrain.drag_area_m2 * v.max() ** 2
    resistance = (drag + car.tyres.rolling_resistance_coeff * car.chassis.mass_kg * GRAVITY_MPS2) / car.chassis.mass_kg
    assert decel.max() <= brake_balance_decel_mps2(car) + resistance + 1e-9
    assert decel.max() > 0.9 * brake_balance_decel_mps2(car)       # it does brake near it
