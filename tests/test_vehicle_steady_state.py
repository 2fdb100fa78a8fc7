"""Steady-state cornering solved from the plant's equations (``vehicle.steady_state``), checked against open-loop
simulation of the plant, and the plant's grip limit on a circle (issue 18: "the circle test reaches the plant's
grip limit within a few % of its analytic value"; the closed-loop half is in test_maneuver_suite.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from test_vehicle_load_transfer import ideal_steer, steady_circle

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle
from vtrack_gym.vehicle.params import GRAVITY_MPS2
from vtrack_gym.vehicle.steady_state import cornering_equilibrium, grip_limit

R_CIRCLE = 40.0  # ISO4138-Circle-v0's radius [m]


@pytest.mark.parametrize("name", list_vehicles())
@pytest.mark.parametrize(("v", "delta"), [(12.0, 0.06), (18.0, 0.05)])
def test_equilibrium_matches_the_simulated_steady_state(name: str, v: float, delta: float) -> None:
    """Hold a road-wheel angle and a speed until steady; the equilibrium solved for that radius and speed has the
    same steering angle, sideslip, roll and wheel loads."""
    params = ideal_steer(load_vehicle(name))
    state, out, radii = steady_circle(params, v, delta)
    speed = math.hypot(state[L.S_VX], state[L.S_VY])
    eq = cornering_equilibrium(params, float(np.mean(radii)), speed)
    assert eq.road_wheel_angle_rad == pytest.approx(delta, rel=1e-3)
    assert eq.sideslip_rad == pytest.approx(math.atan2(state[L.S_VY], state[L.S_VX]), abs=1e-4)  # 0.006 deg
    assert eq.roll_rad == pytest.approx(state[L.S_ROLL], rel=1e-3)
    assert eq.a_y_mps2 == pytest.approx(out[L.O_AY], rel=1e-3)
    assert eq.wheel_loads_n == pytest.approx(tuple(out[L.O_FZFL:L.O_FZRR + 1]), rel=1e-3)


@pytest.mark.parametrize("name", list_vehicles())
def test_grip_limit_is_where_the_equilibria_end(name: str) -> None:
    params = load_vehicle(name)
    limit = grip_limit(params, R_CIRCLE)
    assert np.max(np.abs(limit.wheel_loads_n)) > 0.0 and 0.0 < limit.throttle < 1.0
    below = cornering_equilibrium(params, R_CIRCLE, 0.995 * limit.speed_mps)
    assert below.a_y_mps2 < limit.a_y_mps2
    with pytest.raises(ValueError, match="above the plant's grip limit"):
        cornering_equilibrium(params, R_CIRCLE, 1.005 * limit.speed_mps)
    # below mu g: peak factors D < 1, degressive load sensitivity under load transfer, drive force on the tyres
    mu_g = params.tyres.friction_mu * GRAVITY_MPS2
    d_max = max(params.tyres.front_peak_d, params.tyres.rear_peak_d)
    assert 0.8 * mu_g < limit.a_y_mps2 < d_max * mu_g
    # a speed ramp (tangential acceleration) lowers it a little: more drive force, load moved rearwards
    assert 0.97 * limit.a_y_mps2 < grip_limit(params, R_CIRCLE, accel_mps2=0.2).a_y_mps2 < limit.a_y_mps2


def test_grip_limit_rises_towards_mu_g_as_the_tyre_losses_go() -> None:
    """Each loss mechanism of the plant's tyres lowers the limit: without load sensitivity it rises, and with peak
    factors D = 1 as well it rises again (still below mu g: the front tyres carry the drive force)."""
    base = load_vehicle("hatchback")
    no_eps = dataclasses.replace(base, tyres=dataclasses.replace(base.tyres, load_sensitivity=0.0))
    ideal = dataclasses.replace(no_eps, tyres=dataclasses.replace(no_eps.tyres, front_peak_d=1.0, rear_peak_d=1.0))
    a = [grip_limit(p, R_CIRCLE).a_y_mps2 for p in (base, no_eps, ideal)]
    assert a[0] < a[1] < a[2] < base.tyres.friction_mu * GRAVITY_MPS2


def test_bad_arguments() -> None:
    params = load_vehicle("hatchback")
    with pytest.raises(ValueError, match="radius_m must be > 0"):
        grip_limit(params, 0.0)
    with pytest.raises(ValueError, match="accel_mps2 must be >= 0"):
        grip_limit(params, 40.0, accel_mps2=-1.0)
