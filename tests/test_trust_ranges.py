"""Vehicle and env values inside their declared ranges drive without NaN: the ranges of the fields that gave NaN
(yaw inertia, drag area, relaxation time) and of the physics step are tightened to what the physics supports, and
a randomised target speed range (HoldSpeed.random_range_mps) is checked; each refusal names the field and its range."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import vtrack_gym  # noqa: F401  (registers the envs)
from vtrack_gym.envs.config import EnvConfig
from vtrack_gym.envs.speed import HoldSpeed
from vtrack_gym.vehicle.catalog import VehicleFileError, load_vehicle
from vtrack_gym.vehicle.params import VehicleParams

HATCHBACK = Path(__file__).resolve().parents[1] / "vtrack_gym" / "vehicle" / "data" / "hatchback.json"
TIGHTENED = {("chassis", "yaw_inertia_kgm2"): (5.0, 1e6), ("powertrain", "drag_area_m2"): (0.0, 20.0),
             ("low_speed", "relaxation_time_s"): (0.005, 10.0)}


def _vehicle(values: dict[tuple[str, str], float]) -> VehicleParams:
    base = VehicleParams()
    groups: dict[str, dict[str, float]] = {}
    for (group, name), value in values.items():
        groups.setdefault(group, {})[name] = value
    return dataclasses.replace(base, **{g: dataclasses.replace(getattr(base, g), **v) for g, v in groups.items()})


def _drive(vehicle: VehicleParams | str, seed: int, steps: int = 250) -> None:
    """Random full-lock steering on the 120 km/h double lane change: finite observations and rewards."""
    env = gym.make("DLC120-v0", config=EnvConfig(vehicle=vehicle))
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(rng.uniform(-1.0, 1.0, 1).astype(np.float32))
        assert np.all(np.isfinite(obs)) and np.isfinite(reward)
        if terminated or truncated:
            break
    env.close()


@pytest.mark.parametrize(("group", "name", "value"), [
    ("chassis", "yaw_inertia_kgm2", 1e-6), ("powertrain", "drag_area_m2", 1e6),
    ("low_speed", "relaxation_time_s", 1e-6)])
def test_values_that_gave_nan_are_refused_naming_field_and_range(group, name, value):
    with pytest.raises(ValueError, match=rf"{name} must be in \["):
        _vehicle({(group, name): value})


@pytest.mark.parametrize("dt", [1e-9, 1e-300, 0.0])
def test_a_tiny_physics_step_is_refused_naming_the_field(dt):
    with pytest.raises(ValueError, match=r"EnvConfig.physics_dt_s must be in \[0.0001, 0.002\] s"):
        EnvConfig(physics_dt_s=dt)


@pytest.mark.parametrize("speeds", [(float("nan"), 1e9), (40.0, 1.0), (0.0, 10.0), (10.0, 46.0), ("6", "35"),
                                    (True, 30.0), (5.0,)])
def test_target_speed_range_is_checked(speeds):
    with pytest.raises(ValueError, match=r"HoldSpeed\.random_range_mps must be None or \(low, high\)"):
        HoldSpeed(target_speed_mps=15.0, random_range_mps=speeds)
    assert HoldSpeed(target_speed_mps=15.0, random_range_mps=(6.0, 35.0)).random_range_mps == (6.0, 35.0)


@pytest.mark.parametrize("edge", [0, 1])
@pytest.mark.parametrize("field", sorted(TIGHTENED))
def test_the_edges_of_the_tightened_ranges_drive_without_nan(field, edge):
    _drive(_vehicle({field: TIGHTENED[field][edge]}), seed=edge + 1)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(yaw=st.floats(5.0, 1e6), drag=st.floats(0.0, 20.0), relax=st.floats(0.005, 10.0), seed=st.integers(0, 99))
def test_property_a_vehicle_file_inside_the_ranges_drives_without_nan(tmp_path, yaw, drag, relax, seed):
    doc = json.loads(HATCHBACK.read_text())
    doc["chassis"]["yaw_inertia_kgm2"]["value"] = yaw
    doc["powertrain"]["drag_area_m2"]["value"] = drag
    doc["low_speed"]["relaxation_time_s"]["value"] = relax
    path = tmp_path / f"car{seed}.json"
    path.write_text(json.dumps(doc))
    _drive(str(path), seed, steps=120)


def test_a_vehicle_file_outside_the_ranges_names_the_field(tmp_path):
    doc = json.loads(HATCHBACK.read_text())
    doc["powertrain"]["drag_area_m2"]["value"] = 1e6
    path = tmp_path / "car.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(VehicleFileError, match=r"drag_area_m2 must be in \[0.0, 20.0\]"):
        load_vehicle(path)
