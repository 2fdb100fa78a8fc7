"""Adapter from the batched simulation to stable-baselines3's ``VecEnv`` (SB3 does not take Gymnasium vector envs).

SB3 semantics: a finished sub-env is reset inside the same ``step_wait``; its last observation is in
``infos[i]["terminal_observation"]`` and ``infos[i]["TimeLimit.truncated"]`` says whether the time limit
ended it. Seeding: ``seed(s)`` then ``reset()`` seeds sub-env i with ``s + i`` (like SB3's DummyVecEnv).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

from vtrack_gym.envs.sim import TERMINATION_NAMES
from vtrack_gym.envs.vector_env import TrackingVectorEnv


class TrackingSB3VecEnv(VecEnv):
    """``VecEnv`` over a ``TrackingVectorEnv``'s batched simulation (one compiled call per step)."""

    def __init__(self, env_id_or_vector_env: str | TrackingVectorEnv = "LateralTrackingRandom-v0",
                 num_envs: int = 8, **kwargs: Any) -> None:
        if isinstance(env_id_or_vector_env, TrackingVectorEnv):
            self.venv = env_id_or_vector_env
        else:
            self.venv = TrackingVectorEnv(env_id_or_vector_env, num_envs=num_envs, **kwargs)
        super().__init__(self.venv.num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._actions = np.zeros(self.num_envs)
        self._pending_seed: int | None = None

    def reset(self) -> VecEnvObs:
        seed, self._pending_seed = self._pending_seed, None
        obs, _ = self.venv.reset(seed=seed, options=self._options[0] if self._options and self._options[0] else None)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        sim = self.venv.sim
        from vtrack_gym.envs.tracking_env import check_actions

        reward, terminated, truncated = sim.step(check_actions(self._actions, self.num_envs))
        obs = sim.obs.copy()
        done = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if done.any():
            idx = np.flatnonzero(done)
            for i in idx:
                infos[i] = {
                    "terminal_observation": obs[i].copy(),
                    "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                    "termination": TERMINATION_NAMES[int(sim.term[i])] if terminated[i] else "time_limit",
                    "progress_m": float(sim.progress[i]),
                }
                sim.reset_car(int(i), sim.last_options[i])
            sim.observe_after_reset(idx)
            obs[idx] = sim.obs[idx]
        return obs, reward.astype(np.float32), done, infos

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        self._pending_seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        images = self.venv.render()
        return list(images) if images is not None else [None] * self.num_envs

    def _indices(self, indices: VecEnvIndices) -> Iterable[int]:
        if indices is None:
            return range(self.num_envs)
        if isinstance(indices, int):
            return [indices]
        return indices

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        method = getattr(self.venv, method_name)
        return [method(*method_args, **method_kwargs) for _ in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._indices(indices)]
