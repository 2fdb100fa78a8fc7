"""The decoupled baselines: every steering baseline paired with the paper's PD-FLC drives the longitudinal control
modes (``make_policy(name, env)`` whatever ``control`` is), closed loop through ``gym.make``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from vtrack_gym import make_policy
from vtrack_gym.baselines.decoupled import Decoupled
from vtrack_gym.baselines.registry import available_policies

PAPER_IDS = ("DLC120-v0", pytest.param("LateralTracking-v0", marks=pytest.mark.slow))


def episode(policy_name: str, env_id: str, control: str, max_steps: int | None = None) -> dict:
    env = gym.make(env_id, control=control)
    policy = make_policy(policy_name, env)
    obs, info = env.reset(seed=0)
    e_y, e_v = [], []
    done = False
    while not done and (max_steps is None or len(e_y) < max_steps):
        action, _ = policy.predict(obs)
        obs, _, term, trunc, info = env.step(action)
        e_y.append(info["e_y_m"])
        e_v.append(info["speed_error_mps"])
        done = term or trunc
    return {"max_e_y": float(np.max(np.abs(e_y))), "rms_e_v": float(np.sqrt(np.mean(np.square(e_v)))),
            "success": bool(info["success"]), "termination": info["termination"]}


@pytest.mark.parametrize("name", ["mpc", "smc", "lqr"])
@pytest.mark.parametrize("env_id", PAPER_IDS)
def test_steer_accel_reproduces_the_steer_mode(name: str, env_id: str) -> None:
    """steer_accel with the decoupled baseline: both scenarios completed, max |e_y| within 25 % of the steer
    mode's (it is within 0.2 %: only the float32 observation and action differ) and the same RMS speed error."""
    steer = episode(name, env_id, "steer")
    accel = episode(name, env_id, "steer_accel")
    assert accel["success"] and steer["success"], (steer, accel)
    assert abs(accel["max_e_y"] - steer["max_e_y"]) <= 0.25 * steer["max_e_y"]
    assert accel["max_e_y"] == pytest.approx(steer["max_e_y"], rel=2e-3)
    assert accel["rms_e_v"] == pytest.approx(steer["rms_e_v"], rel=2e-3)


def test_mpc_holds_the_lane_change_speed_within_half_a_metre_per_second() -> None:
    assert episode("mpc", "DLC120-v0", "steer_accel")["rms_e_v"] < 0.5


@pytest.mark.parametrize("name", ["mpc", "lqr"])
def test_steer_rate_accel_completes_the_lane_change(name: str) -> None:
    found = episode(name, "DLC120-v0", "steer_rate_accel")
    assert found["success"], found


@pytest.mark.parametrize("name", [n for n in available_policies() if n not in ("mpc_osqp", "nmpc")])
@pytest.mark.parametrize("control", ["steer_accel", "steer_rate_accel"])
def test_every_baseline_drives_every_mode(name: str, control: str) -> None:
    env = gym.make("DLC120-v0", control=control)
    policy = make_policy(name, env)
    assert isinstance(policy, Decoupled) and policy.policy_id == name
    obs, _ = env.reset(seed=0)
    action, state = policy.predict(obs)
    assert action.shape == (2,) and action.dtype == np.float32 and np.isfinite(action).all()
    assert state.shape == (1, policy.state_size)
    batch, _ = policy.predict(np.stack([obs, obs]))
    assert batch.shape == (2, 2)


def test_steer_mode_gets_the_plain_steering_policy() -> None:
    assert not isinstance(make_policy("mpc", gym.make("DLC120-v0")), Decoupled)


def test_the_plain_loop_and_the_sb3_state_protocol_give_one_episode() -> None:
    def run(pass_state: bool) -> np.ndarray:
        env = gym.make("DLC120-v0", control="steer_rate_accel")
        policy = make_policy("mpc", env)
        obs, _ = env.reset(seed=0)
        state, start, rows = None, True, []
        for _ in range(300):
            if pass_state:
                action, state = policy.predict(obs, state=state, episode_start=np.array([start]))
            else:
                action, _ = policy.predict(obs)
            start = False
            obs, *_ = env.step(action)
            rows.append(obs)
        return np.array(rows)

    np.testing.assert_array_equal(run(True), run(False))


def test_the_demand_is_the_pd_flc_pedals() -> None:
    """The decoupled demand reproduces the env's own PD-FLC pedals: throttle and brake of steer_accel equal the
    steer mode's over the first steps of the lane change (up to the float32 action)."""
    def pedals(control: str) -> np.ndarray:
        env = gym.make("DLC120-v0", control=control)
        policy = make_policy("lqr", env)
        obs, _ = env.reset(seed=0)
        out = []
        for _ in range(200):
            action, _ = policy.predict(obs)
            obs, *_, info = env.step(action)
            out.append((info["throttle"], info["brake_n"]))
        return np.array(out)

    np.testing.assert_allclose(pedals("steer_accel"), pedals("steer"), rtol=1e-5, atol=1e-5)
