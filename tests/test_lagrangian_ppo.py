"""Constrained RL on ``info["cost"]``: PPO-Lagrangian (``agents.lagrangian``) on a narrow road judged by the body
rule; the multiplier follows its update rule from the costs the env reported, and the agent's reward is penalised."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from vtrack_gym.agents.lagrangian import CostPenalisedVecEnv, LagrangianConfig, train_lagrangian_ppo
from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv
from vtrack_gym.tracks import Path as TrackPath


def _narrow_road() -> TrackPath:
    """A 1.9 m wide straight: the hatchback's body (1.916 m) cannot stay within it, every step breaks the body
    rule (the constraint can only be met by the multiplier's limit, which is what these tests look at)."""
    return TrackPath.from_points(np.linspace(0.0, 200.0, 101), np.zeros(101), half_width_m=0.95)


def test_penalised_reward_is_the_env_reward_minus_multiplier_times_cost() -> None:
    inner = TrackingSB3VecEnv("vtrack/Track-v0", num_envs=2, track=_narrow_road(), speed_profile=8.0,
                              track_limits="body")
    twin = TrackingSB3VecEnv("vtrack/Track-v0", num_envs=2, track=_narrow_road(), speed_profile=8.0,
                             track_limits="body")
    env = CostPenalisedVecEnv(inner, LagrangianConfig(initial_multiplier=2.5))
    for e in (env, twin):
        e.seed(3)
        e.reset()
    actions = np.array([[0.3], [-0.3]], dtype=np.float32)
    costs = []
    for _ in range(40):
        env.step_async(actions)
        twin.step_async(actions)
        _, r_pen, _, infos = env.step_wait()
        _, r_raw, _, _ = twin.step_wait()
        cost = np.array([i["cost"] for i in infos])
        assert np.allclose(r_pen, r_raw - 2.5 * cost)
        costs.append(cost)
    assert (np.concatenate(costs) == 1.0).all()


def test_lagrangian_ppo_updates_the_multiplier_from_the_rollouts_costs() -> None:
    config = LagrangianConfig(cost_limit=0.01, multiplier_lr=5.0)
    model, env = train_lagrangian_ppo("vtrack/Track-v0", 512, config=config, num_envs=2, seed=0,
                                      ppo_kwargs={"n_steps": 128, "batch_size": 64, "n_epochs": 1},
                                      track=_narrow_road(), speed_profile=8.0, track_limits="body")
    assert len(env.history) == 2                       # one update per rollout of 2 x 128 steps
    multiplier = 0.0
    for mean_cost, after in env.history:
        assert 0.0 <= mean_cost <= 1.0
        multiplier = min(max(multiplier + 5.0 * (mean_cost - 0.01), 0.0), config.max_multiplier)
        assert after == pytest.approx(multiplier, abs=1e-12)
    assert env.history[0] == (1.0, pytest.approx(5.0 * 0.99))          # every step broke the rule
    action, _ = model.predict(env.reset(), deterministic=True)
    assert action.shape == (2, 1)


def test_config_is_validated_naming_the_field() -> None:
    with pytest.raises(ValueError, match="cost_limit"):
        LagrangianConfig(cost_limit=2.0)
