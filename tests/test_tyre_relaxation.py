"""Tyre relaxation length: off by default (the paper's instant tyres), a first-order slip-angle lag when set."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle, load_vehicle_record, parse_vehicle
from vtrack_gym.vehicle.kernels import state_derivative
from vtrack_gym.vehicle.packing import pack_params
from vtrack_gym.vehicle.params import TyreParams, VehicleParams
from vtrack_gym.vehicle.plant import Plant
from vtrack_gym.vehicle.steady_state import grip_limit


def _with_relaxation(params: VehicleParams, sigma_m: float) -> VehicleParams:
    return dataclasses.replace(params, tyres=dataclasses.replace(params.tyres, relaxation_length_m=sigma_m))


def _cornering_state() -> np.ndarray:
    x = np.zeros(L.N_STATE)
    x[L.S_VX], x[L.S_VY], x[L.S_R], x[L.S_DELTA] = 25.0, -0.4, 0.2, 0.03
    return x


@pytest.mark.parametrize("name", list_vehicles())
def test_off_in_every_shipped_car(name: str) -> None:
    assert load_vehicle(name).tyres.relaxation_length_m == 0.0
    assert VehicleParams().tyres.relaxation_length_m == 0.0


def test_lag_state_follows_its_equation_and_feeds_the_force() -> None:
    sigma = 0.5
    x = _cornering_state()
    vx, vy, r, delta = x[L.S_VX], x[L.S_VY], x[L.S_R], x[L.S_DELTA]
    p0 = VehicleParams()
    a1, a2 = p0.chassis.cg_to_front_axle_m, p0.chassis.cg_to_rear_axle_m
    alpha_f = delta - math.atan2(vy + a1 * r, vx)
    alpha_r = -math.atan2(vy - a2 * r, vx)
    x[L.S_ALF], x[L.S_ALR] = 0.5 * alpha_f, 0.2 * alpha_r
    relaxed = pack_params(_with_relaxation(p0, sigma))
    dx, _ = state_derivative(x, delta, 0.2, 0.0, relaxed)
    assert dx[L.S_ALF] == pytest.approx(vx / sigma * (alpha_f - x[L.S_ALF]), rel=1e-12)
    assert dx[L.S_ALR] == pytest.approx(vx / sigma * (alpha_r - x[L.S_ALR]), rel=1e-12)
    dx_off, _ = state_derivative(x, delta, 0.2, 0.0, pack_params(p0))
    assert dx_off[L.S_ALF] == 0.0 == dx_off[L.S_ALR]
    assert dx[L.S_VY] != pytest.approx(dx_off[L.S_VY], rel=1e-3)      # lagged angles: less lateral force
    x[L.S_ALF], x[L.S_ALR] = alpha_f, alpha_r                           # lag caught up: the instant tyre's forces
    dx_caught, _ = state_derivative(x, delta, 0.2, 0.0, relaxed)
    for i in (L.S_VX, L.S_VY, L.S_R, L.S_ROLL_RATE):
        assert dx_caught[i] == pytest.approx(dx_off[i], rel=1e-12, abs=1e-12)


def test_step_steer_front_slip_rises_with_the_time_constant_sigma_over_v() -> None:
    """After one time constant sigma / v the lagged front slip has covered 1 - 1/e of a step of the steering (a
    little less: the slip angle itself shrinks as the car starts to turn)."""
    sigma, v, step_rad, dt = 0.5, 20.0, 0.02, 0.0005
    base = VehicleParams()
    base = dataclasses.replace(base, steering=dataclasses.replace(base.steering, time_constant_s=0.0))
    plant = Plant(_with_relaxation(base, sigma), physics_dt_s=dt)
    plant.reset(v_x=v)
    plant.step(np.array([[step_rad, 0.0, 0.0]]), round(sigma / v / dt))
    expected = step_rad * (1.0 - math.exp(-1.0))
    assert 0.95 * expected < plant.state[0, L.S_ALF] < expected


def test_steady_state_limit_is_unchanged() -> None:
    p0 = VehicleParams()
    assert grip_limit(_with_relaxation(p0, 0.5), 40.0).a_y_mps2 == pytest.approx(grip_limit(p0, 40.0).a_y_mps2,
                                                                                rel=1e-9)


def test_bad_lengths_and_the_earlier_file_format() -> None:
    with pytest.raises(ValueError, match=r"relaxation_length_m must be 0 \(off\) or in \[0.1, 2.0\] m"):
        TyreParams(relaxation_length_m=0.05)
    with pytest.raises(ValueError, match=r"TyreParams.relaxation_length_m must be in \[0.0, 2.0\]"):
        TyreParams(relaxation_length_m=3.0)
    doc = json.loads(load_vehicle_record("hatchback").to_json())
    doc["tyres"]["relaxation_length_m"]["value"] = 0.5
    assert parse_vehicle(json.dumps(doc)).params.tyres.relaxation_length_m == 0.5
    old = json.loads(load_vehicle_record("suv").to_json())
    old["format"] = "vtrack-vehicle/1"
    roll = old["roll"]
    roll["roll_inertia_kgm2"] = {"value": load_vehicle("suv").roll.roll_inertia_kgm2, "source": "CHOICE: x"}
    del roll["roll_inertia_cg_kgm2"], old["tyres"]["relaxation_length_m"]
    record = parse_vehicle(json.dumps(old))
    assert record.params == load_vehicle("suv") and record.sources["tyres"]["relaxation_length_m"].startswith("CHOICE")
