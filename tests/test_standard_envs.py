"""The standards' ids (-v1) through ``gymnasium.make``: the planned line for the driven car, the entry-speed
protocols in the compiled step (coast, held throttle) in the single and the vector env, the make kwargs and their
refusals, and a baseline passing ISO 3888-2 closed loop at its default entry speed."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.scenarios import ISO3888_2_ENTRY_KMH, TRACKING_MARGIN_M
from vtrack_gym.tracks.feasibility import coast_speed_mps, entry_speed_bound_kmh, planned_maneuver
from vtrack_gym.tracks.maneuvers import build_maneuver
from vtrack_gym.vehicle.catalog import load_vehicle

KMH = 1.0 / 3.6
SIGNALS = ("station_m", "x_m", "v_mps", "throttle", "brake_n", "target_speed_mps")


def _drive_straight(env: gym.Env, steps: int) -> dict[str, np.ndarray]:
    """Signals of an episode with the wheel held straight (the car runs on along the approach's line)."""
    target = env.unwrapped.observation_layout.index("target_speed")
    vx = env.unwrapped.observation_layout.index("v_x")
    out: dict[str, list[float]] = {k: [] for k in (*SIGNALS, "obs_target", "obs_vx")}
    env.reset(seed=0)
    for _ in range(steps):
        obs, _, term, trunc, info = env.step(np.zeros(1, dtype=np.float32))
        for k in SIGNALS:
            out[k].append(float(info[k]))
        out["obs_target"].append(float(obs[target]))
        out["obs_vx"].append(float(obs[vx]))
        if term or trunc:
            break
    return {k: np.array(v) for k, v in out.items()}


def test_coast_releases_the_pedals_at_the_entry_gate_and_the_car_coasts_as_theory_says() -> None:
    env = gym.make("vtrack/ISO3888-2-v1")
    gate = env.unwrapped.current_path.gates[0].s_start_m
    vehicle = env.unwrapped.config.vehicle
    sig = _drive_straight(env, 1500)
    env.close()
    released = np.concatenate([[False], sig["station_m"][:-1] >= gate])  # the step after crossing the gate
    assert 500 < np.argmax(released) and released[-1] and sig["station_m"][-1] > gate + 60.0
    approach = ~released & (sig["station_m"] > 20.0)
    assert np.all(sig["throttle"][approach] > 0.0)                       # the speed loop holds against drag
    assert np.allclose(sig["v_mps"][approach], ISO3888_2_ENTRY_KMH * KMH, atol=0.1)
    assert np.all(sig["throttle"][released] == 0.0) and np.all(sig["brake_n"][released] == 0.0)
    # after the release the target speed shown is the car's own speed (observation and info)
    np.testing.assert_array_equal(sig["target_speed_mps"][released], sig["v_mps"][released])
    np.testing.assert_allclose(sig["obs_target"][released], sig["obs_vx"][released], rtol=1e-6)
    # driving straight on, the plant's coast matches the closed-form drag + rolling-resistance solution
    k0 = int(np.argmax(released))
    v0, x0 = sig["v_mps"][k0], sig["x_m"][k0]
    predicted = coast_speed_mps(vehicle, v0, sig["x_m"][k0:] - x0)
    drop, predicted_drop = v0 - sig["v_mps"][-1], v0 - predicted[-1]
    assert drop > 0.5
    assert drop == pytest.approx(predicted_drop, rel=0.03)


def test_hold_throttle_keeps_the_throttle_of_the_entry_gate() -> None:
    env = gym.make("vtrack/ISO3888-1-v1")
    gate = env.unwrapped.current_path.gates[0].s_start_m
    sig = _drive_straight(env, 1000)
    env.close()
    released = np.concatenate([[False], sig["station_m"][:-1] >= gate])
    k0 = int(np.argmax(released))
    assert k0 > 0 and released.sum() > 100
    held = sig["throttle"][k0 - 1]
    assert held > 0.0 and np.all(sig["throttle"][released] == held) and np.all(sig["brake_n"][released] == 0.0)
    # the speed loop brings the car to the gate within 1 % of the entry speed (a PD loop: a small steady error);
    # the held throttle balances drag and rolling resistance, so on the straight it keeps the speed it crossed at
    v_gate = sig["v_mps"][k0 - 1]
    assert v_gate == pytest.approx(80.0 * KMH, rel=0.01)
    assert np.allclose(sig["v_mps"][released], v_gate, rtol=0.001)


def test_vector_env_runs_the_same_protocol_bit_for_bit() -> None:
    single = gym.make("vtrack/ISO3888-2-v1", entry_speed_kmh=45.0)
    vec = gym.make_vec("vtrack/ISO3888-2-v1", num_envs=2, vectorization_mode="vector_entry_point",
                       entry_speed_kmh=45.0)
    gate = single.unwrapped.current_path.gates[0].s_start_m
    obs1, _ = single.reset(seed=0)
    obsv, _ = vec.reset(seed=0)
    np.testing.assert_array_equal(obsv[0], obs1)
    crossed = 0
    for k in range(1100):
        action = np.float32(0.02 * np.sin(k / 80.0))
        obs1, _, term, _, info1 = single.step(np.array([action]))
        obsv, _, _, _, infov = vec.step(np.full((2, 1), action))
        np.testing.assert_array_equal(obsv[0], obs1)
        crossed += info1["station_m"] > gate + 1.0
        if term:
            break
    assert crossed > 50 and infov["throttle"][0] == 0.0
    single.close()
    vec.close()


# ------------------------------------------------------------------------------------------ make kwargs
def test_the_default_line_is_the_planned_line_for_the_driven_car() -> None:
    for env_id, name in (("vtrack/ISO3888-2-v1", "iso3888_2"), ("vtrack/Slalom-v1", "slalom")):
        for car in ("hatchback", "suv"):
            env = gym.make(env_id, vehicle=car)
            planned = planned_maneuver(name, load_vehicle(car), TRACKING_MARGIN_M).path
            assert env.unwrapped.current_path is planned
            env.close()
            lane_centres = gym.make(env_id, vehicle=car, reference="lane_centres")
            width = load_vehicle(car).chassis.body_width_m
            np.testing.assert_array_equal(lane_centres.unwrapped.current_path.table,
                                          build_maneuver(name, vehicle_width_m=width).path.table)
            lane_centres.close()


def test_entry_speed_kwarg_sets_the_start_and_the_held_speed() -> None:
    env = gym.make("vtrack/ISO3888-2-v1", entry_speed_kmh=42.0)
    _, info = env.reset(seed=0)
    assert info["v_mps"] == pytest.approx(42.0 * KMH) and info["target_speed_mps"] == pytest.approx(42.0 * KMH)
    env.close()


@pytest.mark.parametrize("bad", [250.0, 0.0, -10.0, float("nan"), 200.5])
def test_entry_speed_out_of_range_is_refused_naming_the_field_the_limit_and_the_car(bad: float) -> None:
    with pytest.raises(ValueError, match=r"entry_speed_kmh must be in \(0, 200\] km/h \(got .* for 'Compact SUV"):
        gym.make("vtrack/ISO3888-2-v1", entry_speed_kmh=bad, vehicle="suv")


def test_protocol_kwargs_are_refused_where_they_do_not_apply() -> None:
    with pytest.raises(ValueError, match="entry_speed_kmh applies to the ids with an entry-speed protocol"):
        gym.make("vtrack/DLC120-v0", entry_speed_kmh=60.0)
    with pytest.raises(ValueError, match="entry_speed_kmh applies to the ids with an entry-speed protocol"):
        gym.make("vtrack/Slalom-v1", entry_speed_kmh=60.0)
    with pytest.raises(ValueError, match="entry_speed_kmh must be a number of km/h"):
        gym.make("vtrack/ISO3888-2-v1", entry_speed_kmh="fast")
    with pytest.raises(ValueError, match="reference must be one of planned, lane_centres"):
        gym.make("vtrack/ISO3888-2-v1", reference="racing")
    with pytest.raises(ValueError, match="reference= applies to the cone-lined manoeuvres"):
        gym.make("vtrack/StepCurvature-v0", reference="planned")


def test_a_car_too_wide_for_the_gates_is_refused_through_make() -> None:
    car = load_vehicle("hatchback")
    wide = dataclasses.replace(car, name="wide van", chassis=dataclasses.replace(car.chassis, body_width_m=4.2))
    for env_id in ("vtrack/ISO3888-2-v1", "vtrack/ISO3888-1-v1", "vtrack/Slalom-v1"):
        with pytest.raises(ValueError, match=r"ChassisParams.body_width_m = 4.2 m of 'wide van' is too wide for "
                                             r"\w+: its cone lanes are sized for cars up to 4 m wide"):
            gym.make(env_id, vehicle=wide)


def test_the_old_iso3888_2_raises_the_deprecation_error_naming_the_latest() -> None:
    with pytest.raises(gym.error.DeprecatedEnv, match=r"Please use `vtrack/ISO3888-2-v2` instead"):
        gym.make("vtrack/ISO3888-2-v0")


# ------------------------------------------------------------------------------------------ closed loop
def _episode(policy: str, **make_kwargs: object) -> tuple[dict, dict]:
    env = gym.make("vtrack/ISO3888-2-v1", **make_kwargs)
    try:
        pol = vtrack_gym.make_policy(policy, env)
        obs, info = env.reset(seed=0)
        while True:
            action, _ = pol.predict(obs)
            obs, _, term, trunc, info = env.step(action)
            if term or trunc:
                return info, env.unwrapped.success_metrics()
    finally:
        env.close()


def test_nmpc_passes_iso3888_2_at_its_default_entry_speed() -> None:
    info, metrics = _episode("nmpc")
    assert info["termination"] == "completed" and metrics["cones_hit"] == 0.0 and info["success"]
    assert info["v_mps"] < ISO3888_2_ENTRY_KMH * KMH - 0.5              # it coasted


def test_above_the_physical_bound_the_nmpc_fails_honestly() -> None:
    """80 km/h, the standard's commonly cited speed, is above the car's physical bound (about 67 km/h): measured,
    the nmpc baseline hits cones there (a pass would mean the env let it cut through the physics)."""
    assert entry_speed_bound_kmh(load_vehicle("hatchback")) < 70.0
    info, metrics = _episode("nmpc", entry_speed_kmh=80.0)
    assert not info["success"] and (metrics["cones_hit"] > 0 or info["termination"] != "completed")
