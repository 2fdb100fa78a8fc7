"""The plain loop ``action, _ = policy.predict(obs)`` drives every shipped policy exactly like the SB3 loop.

For every baseline (default preset) and every shipped agent, on both paper scenarios, one episode is run twice
with fresh policies: once dropping the returned state, once passing ``state`` and ``episode_start`` back (as
``evaluate_policy`` does). Both loops call the same law on the same observations, so the episodes must be
bit-equal (actions and the tracking error of every step). LateralTracking-v0 is cut at 3000 steps (30 s, the
first curves) to keep CI short; DLC120-v0 runs to its end.
"""

from __future__ import annotations

import importlib.util

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the envs)
from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.baselines.shipped import shipped_agent_factories

SCENARIOS = {"DLC120-v0": None, "LateralTracking-v0": 3000}
AGENTS = {n: make for n, make in shipped_agent_factories().items() if make(None).action_dim == 1}
"""The shipped steering agents (the loop below drives the ``steer`` mode; ``bc_accel`` drives the pedals too)."""


def _factory(name: str):
    if name in AGENTS:
        return AGENTS[name]
    if name == "mpc_osqp" and importlib.util.find_spec("osqp") is None:
        pytest.skip("mpc_osqp needs the osqp package")
    return lambda env: make_policy(name, env)


def _episode(make, env_id: str, max_steps: int | None, plain: bool) -> tuple[np.ndarray, np.ndarray, str]:
    """(actions (T,), e_y [m] (T,), how it ended) of one seed-0 episode of a fresh policy."""
    env = gym.make(env_id)
    policy = make(env)
    obs, _ = env.reset(seed=0)
    state, start = None, np.ones(1, dtype=bool)
    actions, e_y, end = [], [], "max_steps"
    while max_steps is None or len(actions) < max_steps:
        if plain:
            action, _ = policy.predict(obs)
        else:
            action, state = policy.predict(obs, state=state, episode_start=start)
            start = np.zeros(1, dtype=bool)
        obs, _, terminated, truncated, info = env.step(np.asarray(action, dtype=np.float32).reshape(1))
        actions.append(float(np.asarray(action).reshape(-1)[0]))
        e_y.append(float(info["e_y_m"]))
        if terminated or truncated:
            end = info["termination"] if terminated else "time_limit"
            break
    env.close()
    return np.array(actions), np.array(e_y), end


@pytest.mark.parametrize("env_id", list(SCENARIOS))
@pytest.mark.parametrize("name", [*available_policies(), *sorted(AGENTS)])
def test_plain_loop_equals_sb3_loop(name: str, env_id: str) -> None:
    make = _factory(name)
    plain = _episode(make, env_id, SCENARIOS[env_id], plain=True)
    sb3 = _episode(make, env_id, SCENARIOS[env_id], plain=False)
    assert plain[2] == sb3[2]
    np.testing.assert_array_equal(plain[0], sb3[0])
    np.testing.assert_array_equal(plain[1], sb3[1])


def test_shipped_agents_are_listed() -> None:
    """The comparison above covers the shipped agents (from scratch and imitation)."""
    assert {"ppo", "ppo_bc", "sac", "sac_bc"} <= set(AGENTS)


@pytest.mark.parametrize("name", ["mpc", "mpc_osqp"])
def test_reset_and_episode_start_start_a_new_episode(name: str) -> None:
    """After ``reset()`` (or with ``episode_start=True``) the plain loop's memory starts afresh."""
    make = _factory(name)
    env = gym.make("DLC120-v0")
    policy = make(env)
    first = []
    for restart in ("fresh", "reset", "episode_start"):
        if restart == "reset":
            policy.reset()
        obs, _ = env.reset(seed=0)
        actions = []
        for k in range(200):
            flag = restart == "episode_start" and k == 0
            action, _ = policy.predict(obs, episode_start=flag)
            obs, *_ = env.step(np.asarray(action, dtype=np.float32).reshape(1))
            actions.append(float(action[0]))
        if restart == "fresh":
            first = actions
        assert actions == first, restart
    env.close()
