"""A scenario composed of parts: a new manoeuvre with its own success criterion from the public parts (this file
plus one registry entry, made with ``gymnasium.make``), the vehicle and control-period parts actually used, the one
track registry and the criteria's live verdicts checked against whole-trajectory rules."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.criteria import (
    Auto,
    CarsView,
    Completed,
    ConeGates,
    EndReached,
    Lap,
    SuccessCriterion,
)
from vtrack_gym.envs.registration import register_scenario
from vtrack_gym.envs.scenarios import SCENARIOS, Scenario
from vtrack_gym.envs.speed import HoldSpeed
from vtrack_gym.envs.track_sources import TRACKS, TrackSource
from vtrack_gym.envs.tracking_env import TrackingEnv
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.vehicle.catalog import load_vehicle


# ------------------------------------------------------------------ a new manoeuvre, defined here
class BandState(NamedTuple):
    """Per car: the largest |e_y| of the episode so far [m]."""

    peak_abs_e_y: np.ndarray


@dataclass(frozen=True, kw_only=True)
class StaysInBand(SuccessCriterion):
    """The end of the track reached with |e_y| <= ``band_m`` at every control step; metric ``peak_abs_e_y_m``."""

    name: ClassVar[str] = "stays_in_band"
    per_step: ClassVar[bool] = True
    band_m: float

    def start(self, paths: tuple, vehicle: object, n: int) -> BandState:
        return BandState(np.zeros(n))

    def reset_car(self, state: BandState, i: int, vehicle: object) -> None:
        state.peak_abs_e_y[i] = 0.0

    def observe_step(self, state: BandState, cars: CarsView) -> None:
        np.maximum(state.peak_abs_e_y, np.abs(cars.lateral_error_m), out=state.peak_abs_e_y)

    def verdict(self, state: BandState, cars: CarsView) -> np.ndarray:
        return cars.completed & (state.peak_abs_e_y <= self.band_m)

    def metrics(self, state: BandState, i: int, track: int) -> dict[str, float]:
        return {"peak_abs_e_y_m": float(state.peak_abs_e_y[i])}


def _band_scenario(name: str, band_m: float) -> Scenario:
    return Scenario(name=name, track=TrackSource(track="step_curvature"), speed=HoldSpeed(target_speed_mps=12.0),
                    success=StaysInBand(band_m=band_m), time_limit_s=40.0)


WIDE = _band_scenario("TestStepBand-v0", 0.5)
TIGHT = _band_scenario("TestStepBandTight-v0", 0.002)


def test_a_new_maneuver_with_its_own_criterion_is_one_file_plus_one_registry_entry() -> None:
    assert register_scenario(WIDE) == "vtrack/TestStepBand-v0"
    register_scenario(TIGHT)
    verdicts = {}
    for scenario in (WIDE, TIGHT):
        env = gym.make(scenario.env_id)
        assert env.spec.max_episode_steps == 4000
        trace = rollout(vtrack_gym.make_policy("lqr", env), env, seed=0)
        peak = float(np.max(np.abs(trace["e_y_m"])))
        figures = env.unwrapped.success_metrics()
        assert figures["peak_abs_e_y_m"] == peak  # the live figure is the whole trajectory's
        assert trace.termination == "completed"
        assert trace.success == (peak <= scenario.success.band_m)
        verdicts[scenario.name] = trace.success
        env.close()
    assert verdicts == {"TestStepBand-v0": True, "TestStepBandTight-v0": False}  # both verdicts occur


def test_the_new_criterion_judges_every_car_of_the_vector_env_like_the_single_env() -> None:
    register_scenario(TIGHT)
    envs = gym.make_vec(TIGHT.env_id, num_envs=3, vectorization_mode="vector_entry_point")
    envs.reset(seed=5)
    singles = [gym.make(TIGHT.env_id) for _ in range(3)]
    for i, env in enumerate(singles):
        env.reset(seed=5 + i)
    steer = np.array([[0.0], [0.004], [-0.004]], dtype=np.float32)
    for _ in range(150):
        envs.step(steer)
        for i, env in enumerate(singles):
            env.step(steer[i])
    for i, env in enumerate(singles):
        assert envs.unwrapped.success_metrics(i) == env.unwrapped.success_metrics()
    envs.close()


def test_a_name_is_registered_once() -> None:
    register_scenario(WIDE)
    assert register_scenario(WIDE) == WIDE.env_id  # the same parts again: idempotent
    with pytest.raises(ValueError, match="already registered"):
        register_scenario(_band_scenario("TestStepBand-v0", 0.3))
    with pytest.raises(ValueError, match="already registered"):
        register_scenario(Scenario(name="DLC120-v0"))


# ------------------------------------------------------------------ parts that are read
def test_the_vehicle_part_builds_the_car_and_a_make_kwarg_replaces_it() -> None:
    suv_dlc = Scenario(name="x", track=TrackSource(track="double_lane_change"),
                       speed=HoldSpeed(target_speed_mps=20.0), vehicle="suv", time_limit_s=10.0)
    env = TrackingEnv(suv_dlc)
    suv = load_vehicle("suv")
    assert env.config.vehicle == suv
    env.reset(seed=0)
    lane = env.current_path.gates[0]   # the ISO 3888 lanes are sized for the car the scenario names
    assert lane.y_left_m - lane.y_right_m == pytest.approx(1.1 * suv.chassis.body_width_m + 0.25)
    sports = TrackingEnv(suv_dlc, vehicle="sports")
    assert sports.config.vehicle == load_vehicle("sports")


def test_the_control_period_part_sets_the_env_period_and_the_step_limit() -> None:
    slow = Scenario(name="x", track=TrackSource(track="double_lane_change"), speed=HoldSpeed(target_speed_mps=20.0),
                    control_period_s=0.02, time_limit_s=10.0)
    env = TrackingEnv(slow)
    assert env.control_period_s == 0.02 and env.config.n_substeps == 10
    assert slow.max_episode_steps == 500 == env._sim.max_steps
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert info["time_s"] == pytest.approx(0.02)


def test_parts_are_keyword_only_and_validated() -> None:
    with pytest.raises(TypeError):
        Scenario("x")
    with pytest.raises(ValueError, match=r"Scenario\.speed must be"):
        Scenario(name="x", speed=12.0)
    with pytest.raises(ValueError, match=r"Scenario\.control_period_s must be"):
        Scenario(name="x", control_period_s=0.5)
    with pytest.raises(ValueError, match=r"HoldSpeed\.random_range_mps"):
        HoldSpeed(target_speed_mps=10.0, random_range_mps=(20.0, 10.0))
    with pytest.raises(ValueError, match="closed= and smoothing_m= apply to a CSV track file only"):
        TrackSource(track="handling_course", closed=True)


# ------------------------------------------------------------------ one track registry, criteria chosen per path
def test_every_builtin_track_name_is_one_registry_entry_and_builds() -> None:
    for name in TRACKS:
        source = TrackSource(track=name, bank_size=2)
        assert source.is_builtin
        paths = source.paths(1.9)
        assert paths and all(p.length_m > 0.0 for p in paths)
    for scenario in SCENARIOS.values():
        assert not isinstance(scenario.track.track, str) or scenario.track.track in TRACKS


def test_auto_picks_the_criterion_of_the_paths() -> None:
    course = TrackSource(track="handling_course").paths(1.9)
    dlc = TrackSource(track="double_lane_change").paths(1.9)
    step = TrackSource(track="step_curvature").paths(1.9)
    assert Auto().resolve(course) == Lap() and Auto().resolve(step) == EndReached()
    assert Auto().resolve(dlc) == ConeGates() and Auto().resolve(course + step) == Completed()
    assert EndReached().resolve(course) == EndReached()  # a named criterion is itself
