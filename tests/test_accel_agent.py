"""The shipped agent that drives the pedals (``control="steer_accel"``) and the behaviour-cloning warm start in the
longitudinal modes: the decoupled expert's two outputs cloned, the clone exported, closed loop on both paper
scenarios through ``make_policy``."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines.decoupled import Decoupled
from vtrack_gym.baselines.numpy_policy import NumpyPolicy, load_agent
from vtrack_gym.baselines.resolve import shipped_names

AGENT = "bc_accel"
"""The shipped agent trained in ``steer_accel``: the behaviour-cloning warm start of the recipe (its 50k-step SAC
fine-tune drove the lap less precisely and failed the lane change as well, so the clone is shipped)."""


def drive(env_id: str) -> dict:
    """One seed-0 episode of the shipped agent on ``env_id`` in ``steer_accel``."""
    env = gym.make(env_id, control="steer_accel")
    policy = vtrack_gym.make_policy(AGENT, env)
    obs, info = env.reset(seed=0)
    e_y, e_v, done = [], [], False
    while not done:
        action, _ = policy.predict(obs)
        obs, _, term, trunc, info = env.step(action)
        e_y.append(info["e_y_m"])
        e_v.append(info["speed_error_mps"])
        done = term or trunc
    return {"success": bool(info["success"]), "termination": info["termination"],
            "max_e_y": float(np.max(np.abs(e_y))), "rms_e_v": float(np.sqrt(np.mean(np.square(e_v))))}


def test_the_agent_is_shipped_with_two_outputs_and_drives_as_it_is() -> None:
    assert AGENT in shipped_names()
    env = gym.make("DLC120-v0", control="steer_accel")
    policy = vtrack_gym.make_policy(AGENT, env)
    assert isinstance(policy, NumpyPolicy) and not isinstance(policy, Decoupled)   # not paired with the PD-FLC
    assert policy.action_dim == 2 and policy.spec["env"]["observation_names"][-2:] == ["speed_error", "time_error"]
    assert policy.provenance["warm_start"].startswith("behaviour cloning of mpc[default]")
    action, _ = policy.predict(env.reset(seed=0)[0])
    assert action.shape == (2,) and env.action_space.contains(action)
    with pytest.raises(ValueError, match="'speed_error' for the agent"):   # a steer env has no speed error to read
        vtrack_gym.make_policy(AGENT, gym.make("DLC120-v0"))


@pytest.mark.slow
def test_the_agent_laps_the_handling_course() -> None:
    """Closed loop, the handling-course lap from standstill at 40 km/h, the agent steering and driving the pedals:
    max |e_y| 0.026 m (the decoupled mpc: 0.020 m), RMS speed error 1.24 m/s (the PD-FLC: 1.26 m/s)."""
    result = drive("LateralTracking-v0")
    assert result["success"], result
    assert result["max_e_y"] < 0.05 and result["rms_e_v"] < 1.3, result


@pytest.mark.xfail(strict=True, reason="a target not met: the clone spins out 6.5 s into the lane change at "
                                       "120 km/h (its steering at that speed is not the mpc's; Control modes page)")
def test_the_agent_completes_the_lane_change() -> None:
    result = drive("DLC120-v0")
    assert result["success"], result


def test_the_agent_holds_the_speed_loop_when_the_mpc_steers() -> None:
    """The agent's demand alone, with the decoupled mpc's steering: the lane change passes with the speed held as
    the PD-FLC holds it (RMS speed error within 0.1 m/s of the PD-FLC's 0.488 m/s)."""
    env = gym.make("DLC120-v0", control="steer_accel")
    agent, mpc = vtrack_gym.make_policy(AGENT, env), vtrack_gym.make_policy("mpc", env)
    obs, info = env.reset(seed=0)
    state, e_v, done = None, [], False
    while not done:
        action, state = mpc.predict(obs, state)
        action = np.array([action[0], agent.predict(obs)[0][1]], dtype=np.float32)
        obs, _, term, trunc, info = env.step(action)
        e_v.append(info["speed_error_mps"])
        done = term or trunc
    assert info["success"] and abs(float(np.sqrt(np.mean(np.square(e_v)))) - 0.488) < 0.1


@pytest.mark.slow
def test_warm_start_clones_both_outputs_in_steer_accel(tmp_path: Path) -> None:
    """``train`` with a ``--bc-expert`` warm start in ``steer_accel``: the decoupled expert's [steering, demand]
    labels, a two-output clone exported before RL (``bc_agent``) and after."""
    from vtrack_gym.agents.imitation import BCConfig
    from vtrack_gym.agents.train import train

    bc = BCConfig(expert="lqr", steps=60, dagger_rounds=1, epochs=3, batch_size=64, critic_steps=20)
    train("sac", env_id="vtrack/TrainingMixNominal-v0", timesteps=64, seed=0, run_dir=tmp_path, num_envs=4,
          overrides={"buffer_size": 10_000, "gradient_steps": 1, "batch_size": 64}, eval_freq=0,
          final_eval=False, progress_bar=False, bc=bc)
    record = json.loads((tmp_path / "bc.json").read_text())
    assert record["transitions"] == 2 * 60 * 4 and record["replay_buffer_prefilled"] == 480
    assert max(record["fit"]["actor_mse"]) < 0.1
    config = json.loads((tmp_path / "config.json").read_text())
    assert config["hyperparams"]["env_kwargs"]["control"] == "steer_accel"
    clone, final = load_agent(tmp_path / "bc_agent"), load_agent(tmp_path / "agent")
    assert clone.action_dim == final.action_dim == 2
    assert clone.provenance["timesteps"] == 0 and clone.provenance["warm_start"].startswith("behaviour cloning")
    env = gym.make("DLC120-v0", control="steer_accel")
    assert vtrack_gym.make_policy(str(tmp_path / "bc_agent.json"), env).predict(env.reset(seed=0)[0])[0].shape == (2,)
