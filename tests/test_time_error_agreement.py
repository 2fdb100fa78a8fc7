"""The env's per-step time error and the row's time lag are one definition; the profile's authority follows who
drives the pedals."""

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.tracks.speed_limits import speed_profile_from_limits
from vtrack_gym.vehicle.longitudinal import top_speed_mps


@pytest.mark.parametrize("control", ["steer", "steer_accel"])
def test_row_time_lag_equals_the_envs_last_time_error(control):
    env = gym.make("DLC120-v0", control=control)
    trace = rollout(vtrack_gym.make_policy("mpc", env), env, seed=0)
    env.close()
    lag = evaluate_trace(trace)["time_lag_s"]
    assert lag == pytest.approx(float(trace.signals["time_error_s"][-1]), rel=1e-9, abs=1e-12)
    assert 0.0 < lag < 1.0


def test_profile_counts_on_full_throttle_only_when_the_agent_drives_the_pedals():
    profile = speed_profile_from_limits("envelope", 200.0)
    loop = gym.make("vtrack/Track-v0", speed_profile=profile)
    agent = gym.make("vtrack/Track-v0", speed_profile=profile, control="steer_accel")
    v_loop = loop.unwrapped.speed_tables[0].v_mps
    v_agent = agent.unwrapped.speed_tables[0].v_mps
    car = loop.unwrapped.config.vehicle
    assert np.all(v_agent >= v_loop - 1e-12) and v_agent.max() > v_loop.max()
    assert v_agent.max() <= top_speed_mps(car, 1.0) + 1e-9
    loop.close()
    agent.close()
