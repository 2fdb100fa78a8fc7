"""``TrackingVectorEnv``: N cars in one batched call, a native ``gymnasium.vector.VectorEnv``.

Registered as each id's ``vector_entry_point``::

    envs = gymnasium.make_vec("DLC120-v0", num_envs=4096, vectorization_mode="vector_entry_point")

Autoreset follows Gymnasium's default ``NEXT_STEP`` mode: after sub-env i ends, the next ``step`` resets it
(its action is ignored, the reset options of its last ``reset`` call are reused) and returns its first
observation with reward 0 and both flags False.
``reset(seed=s)`` seeds sub-env i with ``s + i``, exactly like ``SyncVectorEnv``; sub-env i then reproduces a
single ``TrackingEnv`` reset with seed ``s + i`` bit for bit. ``options`` are the single env's reset options
(applied to every sub-env being reset) plus ``reset_mask`` (bool array) for a partial reset.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from vtrack_gym.envs.config import EnvConfig, ResetOptions, Scenario
from vtrack_gym.envs.control import action_space as control_action_space
from vtrack_gym.envs.scenarios import resolve_scenario, with_protocol
from vtrack_gym.envs.sim import TERMINATION_NAMES, BatchSim
from vtrack_gym.envs.tracking_env import ACTION_SPACE, check_actions, observation_space, scenario_config
from vtrack_gym.vehicle.params import DesignModel


def seeds_for(seed: int | list[int | None] | None, n: int) -> list[int | None]:
    """Per-sub-env seeds: ``seed + i`` for an int (Gymnasium's convention), a list as given, else None."""
    if seed is None:
        return [None] * n
    if isinstance(seed, (int, np.integer)):
        return [int(seed) + i for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"seed list must have num_envs = {n} entries (got {len(seeds)})")
    return seeds


def refuse_latency(given: dict[str, Any], what: str) -> None:
    """``ValueError`` when ``given`` holds compute latency (``envs.latency``): the vector env steps every car at once,
    so one decision's compute is not defined; charge it on the single env (``gym.make(..., latency=...)``)."""
    for key in ("latency", "latency_s", "latency_clock"):
        if key in given:
            raise ValueError(f"{what} {key!r} applies to the single env (gym.make(id, {key}=...)): the vector env "
                             "steps every car at once, so one decision's compute time is not defined")


class TrackingVectorEnv(VectorEnv):
    """Batched version of ``TrackingEnv`` (same scenario, config and per-car results)."""

    metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.NEXT_STEP}  # noqa: RUF012

    def __init__(self, scenario: str | Scenario = "LateralTracking-v0", num_envs: int = 1,
                 config: EnvConfig | None = None, render_mode: str | None = None, track: Any = None,
                 speed_profile: Any = None, half_width_m: float | None = None, closed: bool | None = None,
                 smoothing_m: float | None = None, allow_self_crossing: bool | None = None,
                 track_options: dict[str, Any] | None = None, max_episode_steps: int | None = None,
                 entry_speed_kmh: float | None = None, reference: str | None = None,
                 track_limits: str | None = None, **config_overrides: Any) -> None:
        scenario = resolve_scenario(scenario, track, speed_profile, half_width_m, closed, smoothing_m,
                                    {"allow_self_crossing": allow_self_crossing, "track_options": track_options})
        if not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer (got {num_envs!r})")
        refuse_latency(config_overrides, "argument")
        config = scenario_config(scenario, config, config_overrides)
        scenario = with_protocol(scenario, config.vehicle, entry_speed_kmh, reference, track_limits)
        self.scenario = scenario
        self.config = config
        self.num_envs = int(num_envs)
        self.render_mode = render_mode
        self.observation_layout = config.layout
        self.control_period_s = config.control_period_s
        self.design_model = DesignModel.from_vehicle(config.vehicle)
        self.single_observation_space = observation_space(config)
        self.control = config.control
        """What the actions drive (``envs.control``); the longitudinal modes take (num_envs, 2) actions."""
        self.single_action_space = ACTION_SPACE if config.control == "steer" else control_action_space(config.control)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.sim = BatchSim(scenario, config, self.num_envs)
        self.scenario = self.sim.scenario  # with its time limit resolved
        if max_episode_steps is not None:  # Gymnasium passes the spec's (the scenario's own limit by default)
            if not isinstance(max_episode_steps, (int, np.integer)) or max_episode_steps < 1:
                raise ValueError(f"max_episode_steps must be a positive integer (got {max_episode_steps!r})")
            self.sim.max_steps = int(max_episode_steps)
        self._autoreset = np.zeros(self.num_envs, dtype=bool)
        self._seeded = np.zeros(self.num_envs, dtype=bool)
        self._was_reset = np.zeros(self.num_envs, dtype=bool)
        self._all = np.ones(self.num_envs, dtype=bool)

    def reset(self, *, seed: int | list[int | None] | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        if options is not None and not isinstance(options, dict):
            raise ValueError(f"reset options must be a dict (got {type(options).__name__})")
        opts = dict(options or {})
        refuse_latency(opts, "reset option")
        mask = self._check_mask(opts.pop("reset_mask")) if "reset_mask" in opts else self._all
        reset_opts = ResetOptions.from_dict(opts)
        self.sim.delay_steps_of(reset_opts)
        seeds = seeds_for(seed, self.num_envs)
        idx = np.flatnonzero(mask)
        for i in idx:
            if seed is not None or not self._seeded[i]:  # otherwise the car's generator continues
                self.sim.seed(int(i), seeds[i])
                self._seeded[i] = True
            self.sim.reset_car(int(i), reset_opts)
        self.sim.observe_after_reset(idx)
        self._autoreset[idx] = False
        self._was_reset[idx] = True
        return self.sim.obs.copy(), self._infos(np.zeros(self.num_envs, dtype=bool))

    def _check_mask(self, mask: Any) -> np.ndarray:
        """``reset_mask`` as a bool (num_envs,) array; ``ValueError`` unless it is bools of that shape (a bool
        array, or a list / tuple of bools)."""
        arr = None
        if isinstance(mask, np.ndarray) and not isinstance(mask, np.ma.MaskedArray):
            arr = mask
        elif isinstance(mask, (list, tuple)) and all(isinstance(v, (bool, np.bool_)) for v in mask):
            arr = np.array(mask, dtype=bool)
        if arr is None or arr.dtype != np.bool_ or arr.shape != (self.num_envs,):
            got = f"{type(mask).__name__} of shape {arr.shape} and dtype {arr.dtype}" if arr is not None else repr(mask)
            raise ValueError(f"reset_mask must be a bool array of shape ({self.num_envs},) (got {got})")
        return arr.copy()

    def step(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        if not self._was_reset.all():
            never = np.flatnonzero(~self._was_reset)
            raise RuntimeError(f"call reset() before step(): sub-env(s) {never[:10].tolist()} have never been reset "
                               "(a reset_mask leaving some out on the first reset does not reset them)")
        a = check_actions(actions, self.num_envs, self.single_action_space.shape[0])
        sim = self.sim
        done_before = self._autoreset
        reward, terminated, truncated = sim.step(a, done_before if done_before.any() else None)
        if done_before.any():
            idx = np.flatnonzero(done_before)
            for i in idx:  # same scenario knobs as the car's last explicit reset
                sim.reset_car(int(i), sim.last_options[i])
            sim.observe_after_reset(idx)
            reward[idx] = 0.0
            terminated[idx] = False
            truncated[idx] = False
        self._autoreset = terminated | truncated
        return sim.obs.copy(), reward, terminated, truncated, self._infos(terminated)

    def _infos(self, terminated: np.ndarray) -> dict[str, Any]:
        """Every ``envs.schema.INFO_KEYS`` entry as a (num_envs, ...) array, with Gymnasium's ``_key`` masks."""
        infos: dict[str, Any] = self.sim.signals()  # envs.schema.INFO_KEYS order
        names = np.array(TERMINATION_NAMES, dtype=object)[self.sim.term]
        infos["termination"] = np.where(terminated, names, "")
        infos["success"] = terminated & self.sim.success()
        infos["cost"], infos["edge_margin_m"] = self.sim.safety()
        for key in list(infos):
            infos["_" + key] = self._all
        return infos

    def success_metrics(self, i: int) -> dict[str, float]:
        """The success criterion's leaderboard figures of sub-env ``i``'s current (or last) episode."""
        return self.sim.success_metrics(i)

    def render(self) -> tuple[np.ndarray, ...] | None:
        if self.render_mode != "rgb_array":
            gym.logger.warn("render() needs render_mode='rgb_array' on the vector env")
            return None
        from vtrack_gym.envs.render import EnvRenderer, RenderConfig

        if getattr(self, "_renderer", None) is None:
            self._renderer = EnvRenderer("rgb_array", RenderConfig(), self.config.vehicle.chassis,
                                         self.config.control_period_s, "")
        return tuple(self._renderer.draw(self.sim.paths[self.sim.veh_track[i]], self.sim, i)
                     for i in range(self.num_envs))
