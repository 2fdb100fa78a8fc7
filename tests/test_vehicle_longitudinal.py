"""The car's longitudinal limits against the plant: full throttle on the flat at several speeds, and the top speed."""

import numpy as np
import pytest

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.catalog import list_vehicles, resolve_vehicle
from vtrack_gym.vehicle.longitudinal import (
    brake_decel_limit_mps2,
    forward_accel_limit_fn,
    forward_accel_limit_mps2,
    resistance_n,
    top_speed_mps,
)
from vtrack_gym.vehicle.plant import Plant


@pytest.mark.parametrize("name", list_vehicles())
def test_top_speed_balances_power_and_resistance(name):
    car = resolve_vehicle(name)
    v = top_speed_mps(car)
    assert car.powertrain.max_power_w / v == pytest.approx(float(resistance_n(car, v)), rel=1e-9)


@pytest.mark.parametrize("speed", [5.0, 20.0, 40.0])
def test_forward_limit_matches_the_plant_at_full_throttle(speed):
    """The plant's a_x after a 0.1 s full-throttle run straight ahead, against the limit at the mean speed."""
    car = resolve_vehicle(list_vehicles()[0])
    plant = Plant(car, n=1)
    plant.reset(v_x=speed)
    u = np.zeros((1, L.N_INPUT))
    u[0, L.U_THROTTLE] = 1.0
    plant.step(u, 50)  # settle the load-transfer lag and the tyre slip
    v0 = plant.state[0, L.S_VX]
    plant.step(u, 50)
    v1 = plant.state[0, L.S_VX]
    measured = (v1 - v0) / (50 * plant.physics_dt_s)
    assert measured == pytest.approx(float(forward_accel_limit_mps2(car, 0.5 * (v0 + v1))), rel=0.02)


def test_brake_limit_exceeds_forward_limit():
    car = resolve_vehicle(list_vehicles()[0])
    assert float(brake_decel_limit_mps2(car, 20.0)) > float(forward_accel_limit_mps2(car, 20.0)) > 0.0


@pytest.mark.parametrize("name", list_vehicles())
def test_the_scalar_forward_limit_is_the_array_one(name):
    car = resolve_vehicle(name)
    speeds = np.concatenate([[0.0, 0.5, 1.0], np.linspace(1.5, 80.0, 60)])
    for throttle in (1.0, 0.348, 0.1):
        scalar = forward_accel_limit_fn(car, throttle)
        got = np.array([scalar(float(v)) for v in speeds])
        np.testing.assert_allclose(got, forward_accel_limit_mps2(car, speeds, throttle), rtol=1e-12, atol=1e-12)

