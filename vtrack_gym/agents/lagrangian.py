"""Constrained RL on the per-step cost: PPO with a Lagrange multiplier (PPO-Lagrangian) on top of stable-baselines3.

The env's ``info["cost"]`` (1.0 on a step that breaks the scenario's rule: a track limit with ``track_limits=``, a
cone gate, the road) is the constraint signal, Safety-Gymnasium's convention. ``CostPenalisedVecEnv`` hands the
agent ``reward - lambda * cost``; after every rollout ``LagrangeUpdate`` moves the multiplier by gradient ascent on
the constraint, ``lambda <- clip(lambda + lr (J_c - cost_limit), 0, max_multiplier)``, with J_c the mean cost per
step of that rollout: lambda grows while the agent breaks the rule more often than ``cost_limit`` allows and
shrinks back once it complies. ``train_lagrangian_ppo`` wires both to SB3's PPO.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecEnvWrapper

from vtrack_gym._ranges import documented, ranged, validate


@documented
@dataclass(frozen=True, kw_only=True)
class LagrangianConfig:
    """The multiplier's update: ``cost_limit`` the mean cost per step allowed (0: never break the rule),
    ``multiplier_lr`` its step per unit of constraint violation, ``initial_multiplier`` and ``max_multiplier``."""

    cost_limit: float = ranged(0.0, ge=0.0, le=1.0)
    multiplier_lr: float = ranged(1.0, gt=0.0, le=1000.0)
    initial_multiplier: float = ranged(0.0, ge=0.0, le=1000.0)
    max_multiplier: float = ranged(100.0, gt=0.0, le=1e6)

    def __post_init__(self) -> None:
        validate(self)


class CostPenalisedVecEnv(VecEnvWrapper):
    """A ``VecEnv`` whose reward is ``reward - multiplier * info["cost"]``; records the costs of the rollout."""

    def __init__(self, venv: Any, config: LagrangianConfig | None = None) -> None:
        super().__init__(venv)
        self.config = config or LagrangianConfig()
        self.multiplier = self.config.initial_multiplier
        self.history: list[tuple[float, float]] = []
        """(mean cost per step of a rollout, the multiplier after it) per ``update_multiplier``."""
        self._costs: list[np.ndarray] = []

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        obs, reward, done, infos = self.venv.step_wait()
        cost = np.array([float(info.get("cost", 0.0)) for info in infos])
        self._costs.append(cost)
        return obs, (reward - self.multiplier * cost).astype(np.float32), done, infos

    def update_multiplier(self) -> float:
        """One ascent step on the constraint from the costs since the last update; returns the new multiplier."""
        if not self._costs:
            return self.multiplier
        mean_cost = float(np.mean(np.concatenate(self._costs)))
        self._costs = []
        c = self.config
        self.multiplier = float(np.clip(self.multiplier + c.multiplier_lr * (mean_cost - c.cost_limit), 0.0,
                                        c.max_multiplier))
        self.history.append((mean_cost, self.multiplier))
        return self.multiplier


class LagrangeUpdate(BaseCallback):
    """Updates a ``CostPenalisedVecEnv``'s multiplier at the end of every PPO rollout (logged as
    ``lagrangian/multiplier`` and ``lagrangian/mean_cost``)."""

    def __init__(self, env: CostPenalisedVecEnv) -> None:
        super().__init__()
        self.env = env

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        self.env.update_multiplier()
        if self.env.history:
            self.logger.record("lagrangian/mean_cost", self.env.history[-1][0])
            self.logger.record("lagrangian/multiplier", self.env.multiplier)


def train_lagrangian_ppo(env_id: str, total_timesteps: int, *, config: LagrangianConfig | None = None,
                         num_envs: int = 4, seed: int = 0, ppo_kwargs: dict[str, Any] | None = None,
                         **env_kwargs: Any) -> tuple[Any, CostPenalisedVecEnv]:
    """PPO-Lagrangian on ``env_id`` (made with ``env_kwargs``, e.g. ``track=``, ``track_limits="body"``) for
    ``total_timesteps`` steps of ``num_envs`` batched cars; returns (the SB3 model, the penalised env, whose
    ``history`` holds each rollout's mean cost and multiplier)."""
    from stable_baselines3 import PPO

    from vtrack_gym.agents.sb3_logger import log_outside_tmp
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    if not isinstance(total_timesteps, int) or total_timesteps < 1:
        raise ValueError(f"total_timesteps must be a positive integer (got {total_timesteps!r})")
    env = CostPenalisedVecEnv(TrackingSB3VecEnv(env_id, num_envs=num_envs, **env_kwargs), config)
    env.seed(seed)
    model = PPO("MlpPolicy", env, seed=seed, verbose=0, **(ppo_kwargs or {}))
    log_outside_tmp(model)   # no run folder: SB3's default logger would leave an empty folder in $TMPDIR
    model.learn(total_timesteps=total_timesteps, callback=LagrangeUpdate(env))
    return model, env
