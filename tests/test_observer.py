"""The Kalman-filter observer of the paper's MPC and SMC: presets, estimation quality, dead-time identification,
and the closed loop under the robust suite's noise and delay."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.observer import LateralKalmanFilter, ObserverConfig, declared_noise_std
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.suite.suites import suite_episodes


@pytest.mark.parametrize("name", ["mpc", "smc"])
def test_observer_preset_is_the_default_with_the_filter_and_the_others_are_unchanged(name: str) -> None:
    env = gym.make("DLC120-v0")
    default = make_policy(name, env)
    observed = make_policy(name, env, preset="observer")
    assert observed.config == dataclasses.replace(default.config, observer=True)
    for preset in ("default", "paper", "hand"):
        policy = make_policy(name, env, preset=preset)
        assert policy.config.observer is False and policy.observer is None
    assert default.state_size == {"mpc": 9, "smc": 0}[name]
    assert observed.state_size == default.state_size + observed.observer.memory_size


def test_noise_covariance_is_the_envs_declared_sensor_noise() -> None:
    env = gym.make("DLC120-v0")
    noise = env.unwrapped.config.noise_std
    assert declared_noise_std(env) == tuple(noise)
    policy = make_policy("mpc", env, preset="observer")
    # measurement order e_y, e_phi, e_y_dot, e_phi_dot, v_y, yaw_rate, road_wheel_angle (v_x is not used)
    expected = np.square([noise[0], noise[1], noise[2], noise[3], noise[5], noise[6], noise[7]])
    np.testing.assert_allclose(np.diag(policy.observer.r_cov), expected)


def _drive_with_filter(options: dict, config: ObserverConfig | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Drive DLC120-v0 with the observer MPC; (estimated e_y, true e_y, identified dead time at the end)."""
    env = gym.make("DLC120-v0")
    policy = make_policy("mpc", env, preset="observer")
    kf = LateralKalmanFilter(policy.design, policy.layout, policy.control_period_s, declared_noise_std(env), config)
    obs, _ = env.reset(seed=3, options=options)
    mem = kf.initial_memory(obs[None, :])[0]
    estimates, truth = [], []
    state = None
    for step in range(900):
        action, state = policy.predict(obs, state=state, episode_start=step == 0)
        kf.update(obs.astype(np.float64), mem)
        estimates.append(mem[0])
        kf.record_command(mem, float(action[0]) * policy.max_steer_rad)
        obs, _, terminated, truncated, info = env.step(action)
        truth.append(info["e_y_m"])
        if terminated or truncated:
            break
    # the estimate at step k belongs to the measurement at step k, the truth before the step: shift by one
    return np.array(estimates[1:]), np.array(truth[:-1]), kf.dead_time_steps(mem)


def test_filter_removes_most_of_the_lateral_error_noise() -> None:
    est, true, _ = _drive_with_filter({"sensor_noise": 1.0})
    sigma = gym.make("DLC120-v0").unwrapped.config.noise_std[0]
    error = np.sqrt(np.mean((est - true) ** 2))
    assert error < 0.5 * sigma, f"estimate error {error:.4f} m vs sensor noise {sigma} m"


@pytest.mark.parametrize("delay_s", [0.0, 0.03])
def test_actuator_dead_time_is_identified(delay_s: float) -> None:
    *_, steps = _drive_with_filter({"sensor_noise": 0.5, "actuator_delay_s": delay_s})
    assert steps == round(delay_s / 0.01)


def test_observer_mpc_completes_both_paper_scenarios() -> None:
    for env_id in ("DLC120-v0", "LateralTracking-v0"):
        env = gym.make(env_id)
        trace = rollout(make_policy("mpc", env, preset="observer"), env, seed=0)
        assert trace.termination == "completed" and trace.success, env_id


def test_observer_smc_completes_the_double_lane_change() -> None:
    env = gym.make("DLC120-v0")
    trace = rollout(make_policy("smc", env, preset="observer"), env, seed=0)
    assert trace.termination == "completed" and trace.success


def test_observer_mpc_passes_a_noisy_delayed_lane_change_the_raw_mpc_spins_out_on() -> None:
    """Robust suite seed 101: 30 ms actuator delay, 0.59 x sensor noise, mu 1.09, 127 km/h."""
    episode = next(ep for ep in suite_episodes("robust") if ep.env_id == "DLC120-v0" and ep.seed == 101)
    outcomes = {}
    for preset in ("default", "observer"):
        env = gym.make(episode.env_id)
        trace = rollout(make_policy("mpc", env, preset=preset), env, seed=episode.seed, options=episode.options)
        outcomes[preset] = (trace.termination, trace.success)
    assert outcomes["default"][0] == "spin_out"
    assert outcomes["observer"] == ("completed", True)
