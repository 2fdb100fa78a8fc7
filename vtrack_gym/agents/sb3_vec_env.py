"""Adapter from the batched simulation to stable-baselines3's ``VecEnv`` (SB3 does not take Gymnasium vector envs).

Each step's ``infos[i]["cost"]`` is the env's ``info["cost"]`` (1.0 on a step that broke the scenario's rule).
SB3 semantics: a finished sub-env is reset inside the same ``step_wait``; its last observation is in
``infos[i]["terminal_observation"]`` and ``infos[i]["TimeLimit.truncated"]`` says whether the time limit
ended it. Seeding: ``seed(s)`` then ``reset()`` seeds sub-env i with ``s + i`` (like SB3's DummyVecEnv).
"""

from __future__ import annotations

from collections.abc import Sequence
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
        else:  # a registered id's own settings (e.g. its control period), then the caller's
            from gymnasium.envs.registration import registry

            spec = registry.get(env_id_or_vector_env) if isinstance(env_id_or_vector_env, str) else None
            spec_kwargs = dict(spec.kwargs) if spec is not None else {}
            scenario = spec_kwargs.pop("scenario", env_id_or_vector_env)
            self.venv = TrackingVectorEnv(scenario, num_envs=num_envs, **{**spec_kwargs, **kwargs})
        super().__init__(self.venv.num_envs, self.venv.single_observation_space, self.venv.single_action_space)
        self._actions = np.zeros((self.num_envs, *self.venv.single_action_space.shape))
        self._pending_seed: int | None = None

    def reset(self) -> VecEnvObs:
        """Reset every sub-env with its own ``set_options`` options (cars sharing options in one batched call)."""
        seed, self._pending_seed = self._pending_seed, None
        given = [dict(o) if o else {} for o in (self._options or [{}] * self.num_envs)]
        groups: list[dict[str, Any]] = []
        for o in given:
            if o not in groups:
                groups.append(o)
        if len(groups) == 1:
            obs, _ = self.venv.reset(seed=seed, options=groups[0] or None)
        else:
            for group in groups:
                mask = np.array([o == group for o in given], dtype=bool)
                seeds = None if seed is None else [seed + i if mask[i] else None for i in range(self.num_envs)]
                obs, _ = self.venv.reset(seed=seeds, options={**group, "reset_mask": mask})
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        sim = self.venv.sim
        from vtrack_gym.envs.tracking_env import check_actions

        reward, terminated, truncated = sim.step(check_actions(self._actions, self.num_envs,
                                                               self.venv.single_action_space.shape[0]))
        obs = sim.obs.copy()
        done = terminated | truncated
        cost = sim.safety()[0]    # info["cost"] of every car (envs.schema.SAFETY_SIGNALS), before any reset
        infos: list[dict[str, Any]] = [{"cost": float(c)} for c in cost]
        if done.any():
            idx = np.flatnonzero(done)
            for i in idx:
                infos[i] |= {
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

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        idx = [int(indices)] if isinstance(indices, (int, np.integer)) else [int(i) for i in indices]
        bad = [i for i in idx if not 0 <= i < self.num_envs]
        if bad:
            raise IndexError(f"sub-env indices {bad} out of range [0, {self.num_envs})")
        return idx

    def _all_or_refuse(self, what: str, indices: VecEnvIndices) -> list[int]:
        """The indices if they cover every sub-env; a shared attribute/method cannot act on a subset."""
        idx = self._indices(indices)
        if sorted(set(idx)) != list(range(self.num_envs)):
            raise ValueError(f"{what} is shared by all {self.num_envs} sub-envs of this batched simulation; it "
                             f"cannot act on sub-envs {idx} alone (use indices=None)")
        return idx

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value for _ in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set a shared attribute of the batched simulation; only with indices covering every sub-env."""
        self._all_or_refuse(f"attribute {attr_name!r}", indices)
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        """``reset(seed=None, options=None)`` resets exactly the sub-envs ``indices`` (seed ``s`` for each, as a
        single env would be) and returns their observations; any other method is shared by all sub-envs and is
        called once, with indices covering every sub-env."""
        if method_name == "reset":
            return self._reset_some(self._indices(indices), *method_args, **method_kwargs)
        idx = self._all_or_refuse(f"method {method_name!r}", indices)
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result for _ in idx]

    def _reset_some(self, idx: list[int], seed: int | None = None,
                    options: dict[str, Any] | None = None) -> list[np.ndarray]:
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[idx] = True
        seeds: list[int | None] = [seed if mask[i] else None for i in range(self.num_envs)]
        obs, _ = self.venv.reset(seed=seeds if seed is not None else None,
                                 options={**(options or {}), "reset_mask": mask})
        return [obs[i].copy() for i in idx]

    def env_is_wrapped(self, wrapper_class: type, indices: VecEnvIndices = None) -> list[bool]:
        return [False for _ in self._indices(indices)]
