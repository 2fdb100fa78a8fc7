"""Reward-driven fine-tune of a race agent on the race split's training circuits: ``vtrack train --algo sac --env
vtrack/Race-v0 --init-from dagger_race_v2``.

The actor of a shipped (or saved) race agent file is loaded into a ``RegularisedSAC`` model (its observation
statistics kept fixed), and SAC then trains on ``vtrack/Race-v0``'s reward (``envs.race_reward.RaceReward``),
each episode one race of ``laps`` lap(s) on a training circuit drawn at random from
``tracks.race_circuits.RACE_SPLIT["train"]`` (the validation and held-out circuits and the race ids are never
made). Three things keep the fine-tune near a policy that already laps:

* critic warm-up: for the first ``critic_warmup_steps`` env steps only the critics learn (the actor drives as
  loaded, with its exploration noise), so the first actor steps follow a critic that knows the loaded policy;
* a behaviour-cloning term (``bc_weight``, TD3+BC) on the loaded agent's own deterministic actions along
  ``demo_races`` noise-free races on training circuits: a trust region around the start, not an expert;
* the entropy target set to the loaded exploration noise (``init_log_std`` on both outputs), so SAC's learned
  entropy coefficient holds the noise there instead of raising it to SB3's default target (-action_dim), and that
  coefficient starting at ``init_ent_coef`` (0.01), not SB3's 1: the race reward is about 0.03 a step, so |Q| is
  about 3, and at 1 the entropy term would outweigh the return in the actor loss until the coefficient decayed.

The run folder holds ``config.json``, ``episodes.jsonl`` (one line per training race: steps, return,
termination, lap-time fraction, circuit; the reward curve) and ``agent.json`` + ``agent.npz`` (the fine-tuned
actor, ``agents.export``'s format, reading the loaded agent's observation names).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate

log = logging.getLogger(__name__)


@documented
@dataclass(frozen=True)
class RaceFinetuneConfig:
    """Settings of a race fine-tune (steps are env steps of 10 ms; ``init_log_std`` of the action's fraction)."""

    timesteps: int = ranged(60_000, ge=1, le=10**8, integer=True)
    critic_warmup_steps: int = ranged(20_000, ge=0, le=10**8, integer=True)  # before the first actor update
    learning_rate: float = ranged(1e-5, gt=0.0, le=1.0)
    bc_weight: float = ranged(1000.0, ge=0.0, le=1e6)
    demo_races: int = ranged(6, ge=1, le=1000, integer=True)          # noise-free races of the loaded agent
    laps: int = ranged(1, ge=1, le=5, integer=True)                    # laps of each training race
    init_log_std: float = ranged(-3.0, ge=-10.0, le=1.0)
    init_ent_coef: float = ranged(0.01, gt=0.0, le=10.0)               # SAC's learned entropy coefficient, start
    buffer_size: int = ranged(300_000, ge=1000, le=10**8, integer=True)
    batch_size: int = ranged(256, ge=16, le=10**6, integer=True)
    learning_starts: int = ranged(1000, ge=0, le=10**8, integer=True)
    gamma: float = ranged(0.99, gt=0.0, lt=1.0)
    critic_sizes: tuple[int, ...] = (256, 256)

    def __post_init__(self) -> None:
        validate(self)
        sizes = tuple(self.critic_sizes)
        if not sizes or len(sizes) > 4 or any(not isinstance(h, int) or not 1 <= h <= 1024 for h in sizes):
            raise ValueError(f"RaceFinetuneConfig.critic_sizes must be 1 to 4 ints in [1, 1024] (got "
                             f"{self.critic_sizes!r})")

    def as_dict(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "critic_sizes": list(self.critic_sizes)}


def _circuit_env_class() -> type:
    import gymnasium as gym

    class RaceCircuits(gym.Env):
        """One race per episode on a circuit drawn from ``circuits``, the observation cut to ``names``."""

        def __init__(self, circuits: tuple[str, ...], names: tuple[str, ...], laps: int, seed: int) -> None:
            self.circuits, self.names, self.laps = circuits, names, laps
            self.rng = np.random.default_rng(seed)
            self.envs: dict[str, Any] = {}
            self.circuit = circuits[0]
            first = self._env(self.circuit)
            self.kept = _indices(first, names)
            self.observation_space = gym.spaces.Box(-np.inf, np.inf, (len(names),), np.float32)
            self.action_space = first.action_space

        def _env(self, name: str) -> Any:
            from vtrack_gym.agents.race_dagger import RACE_ENV_ID
            from vtrack_gym.tracks.race_circuits import race_circuit

            if name not in self.envs:
                self.envs[name] = gym.make(RACE_ENV_ID, track=race_circuit(name), laps=self.laps)
            return self.envs[name]

        def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
            self.circuit = self.circuits[int(self.rng.integers(len(self.circuits)))]
            obs, info = self._env(self.circuit).reset(seed=int(self.rng.integers(2**31)))
            return np.asarray(obs, np.float32)[self.kept], info

        def step(self, action: Any) -> Any:
            obs, reward, terminated, truncated, info = self.envs[self.circuit].step(action)
            return np.asarray(obs, np.float32)[self.kept], reward, terminated, truncated, {**info,
                                                                                            "circuit": self.circuit}

    return RaceCircuits


def _indices(env: Any, names: tuple[str, ...]) -> np.ndarray:
    """Indices of ``names`` in ``env``'s observation (``ValueError`` naming a missing one)."""
    layout = list(env.unwrapped.observation_layout.names)
    missing = [n for n in names if n not in layout]
    if missing:
        raise ValueError(f"the agent reads observation fields the race env does not have: {missing}")
    return np.array([layout.index(n) for n in names], dtype=np.intp)


def load_actor(model: Any, vecnorm: Any, policy: Any, init_log_std: float) -> float:
    """Copy ``policy``'s (a ``NumpyPolicy``, tanh layers) weights and observation statistics into the SAC actor
    and ``vecnorm``; the log-std head is set to the constant ``init_log_std``. Returns the largest |action|
    difference between the two on 256 observations drawn around the statistics (a check of the copy)."""
    import torch
    import torch.nn as nn

    layers = [m for m in [*model.actor.latent_pi, model.actor.mu] if isinstance(m, nn.Linear)]
    weights = policy._weights
    if len(layers) != len(weights) or any(tuple(layer.weight.shape) != w.T.shape
                                          for layer, (w, _) in zip(layers, weights, strict=True)):
        raise ValueError("the SAC actor's layers do not match the agent's (hidden_sizes and activation)")
    with torch.no_grad():
        for layer, (w, b) in zip(layers, weights, strict=True):
            layer.weight.copy_(torch.as_tensor(w.T, dtype=torch.float32))
            layer.bias.copy_(torch.as_tensor(b, dtype=torch.float32))
        model.actor.log_std.weight.zero_()
        model.actor.log_std.bias.fill_(init_log_std)
    vecnorm.obs_rms.mean = policy.obs_mean.copy()
    vecnorm.obs_rms.var = 1.0 / policy._obs_scale ** 2 - float(policy.spec["obs_norm"]["eps"])
    vecnorm.clip_obs = policy.clip_obs
    vecnorm.training = False
    rng = np.random.default_rng(0)
    x = (policy.obs_mean + rng.standard_normal((256, policy.obs_dim)) / policy._obs_scale).astype(np.float32)
    mine = model.predict(vecnorm.normalize_obs(x), deterministic=True)[0]
    return float(np.max(np.abs(mine - policy.predict(x)[0])))


def demonstrations(env: Any, policy: Any, races: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``races`` noise-free races of ``policy`` on ``env`` (a ``RaceCircuits``): (observations, its actions, the
    terminations)."""
    seen, actions, ends = [], [], []
    for _ in range(races):
        obs, _ = env.reset()
        done = False
        while not done:
            action = np.asarray(policy.predict(obs)[0], np.float32)
            seen.append(obs)
            actions.append(action)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        ends.append(str(info["termination"] or "time_limit"))
    return np.asarray(seen, np.float32), np.asarray(actions, np.float32), ends


def _episode_logger(path: Path) -> Any:
    """An SB3 callback appending one line per finished training race to ``path`` (the reward curve)."""
    from stable_baselines3.common.callbacks import BaseCallback

    class EpisodeLog(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.ret, self.t0 = 0.0, time.perf_counter()

        def _on_step(self) -> bool:
            self.ret += float(self.locals["rewards"][0])
            if self.locals["dones"][0]:
                info = self.locals["infos"][0]
                frac = float(info.get("lap_time_fraction", math.nan))
                line = {"t": int(self.num_timesteps), "wall_s": round(time.perf_counter() - self.t0, 1),
                        "return": round(self.ret, 2), "termination": str(info.get("termination") or "time_limit"),
                        "lap_time_fraction": None if math.isnan(frac) else round(frac, 4),
                        "circuit": info.get("circuit")}
                with path.open("a", encoding="utf-8") as f:
                    f.write(json.dumps(line) + "\n")
                log.info("race fine-tune: %s", line)
                self.ret = 0.0
            return True

    return EpisodeLog()


def _model(env: Any, config: RaceFinetuneConfig, hidden: list[int], seed: int) -> tuple[Any, Any]:
    """(the ``RegularisedSAC`` model on ``env`` behind a frozen ``VecNormalize``, that ``VecNormalize``)."""
    import torch.nn as nn
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from vtrack_gym.agents.regularised_sac import RegularisedSAC

    vecnorm = VecNormalize(DummyVecEnv([lambda: env]), norm_obs=True, norm_reward=False, training=False)
    dim = int(env.action_space.shape[0])
    entropy = dim * (config.init_log_std + 0.5 * math.log(2.0 * math.pi * math.e))  # the Gaussian's, per action
    model = RegularisedSAC("MlpPolicy", vecnorm, seed=seed, device="cpu", verbose=0,
                           learning_rate=config.learning_rate, buffer_size=config.buffer_size,
                           batch_size=config.batch_size, learning_starts=config.learning_starts, gamma=config.gamma,
                           ent_coef=f"auto_{config.init_ent_coef}", target_entropy=entropy, bc_weight=config.bc_weight,
                           actor_delay_steps=config.critic_warmup_steps,
                           policy_kwargs={"net_arch": {"pi": hidden, "qf": list(config.critic_sizes)},
                                          "activation_fn": nn.Tanh})
    return model, vecnorm


def finetune_race(init_from: str | Path, config: RaceFinetuneConfig | None = None, seed: int = 0,
                  run_dir: str | Path = "vtrack_runs/race_finetune", *, command: str = "",
                  overwrite: bool = False, torch_threads: int | None = 1) -> dict[str, Any]:
    """Fine-tune the race agent ``init_from`` (a shipped agent's name or an agent file) with SAC on the race
    split's training circuits (module docstring); writes ``run_dir``. Returns ``{"run_dir", "agent", "train_s",
    "load_check", "actor_max_abs_change"}``."""
    import torch

    from vtrack_gym._version import __version__
    from vtrack_gym.agents.race_dagger import export_race_agent
    from vtrack_gym.agents.sb3_logger import log_outside_tmp
    from vtrack_gym.agents.train import check_run_dir
    from vtrack_gym.tracks.race_circuits import RACE_SPLIT

    config = config or RaceFinetuneConfig()
    if torch_threads:
        torch.set_num_threads(torch_threads)
    policy = _load(init_from)
    names = tuple(policy.spec["env"]["observation_names"])
    run = Path(run_dir)
    for f in check_run_dir(run, overwrite):
        f.unlink()
    run.mkdir(parents=True, exist_ok=True)
    settings = {"algo": "sac", "env_id": "vtrack/Race-v0", "init_from": str(init_from),
                "circuits": list(RACE_SPLIT["train"]), "seed": seed, "command": command, "finetune": config.as_dict(),
                "package_version": __version__, "torch_version": torch.__version__,
                "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    (run / "config.json").write_text(json.dumps(settings, indent=2) + "\n", encoding="utf-8")
    env = _circuit_env_class()(tuple(RACE_SPLIT["train"]), names, config.laps, seed)
    t0 = time.perf_counter()
    demo_obs, demo_act, ends = demonstrations(env, policy, config.demo_races)
    log.info("race fine-tune: %d demonstration states from %s", len(demo_obs), ends)
    model, vecnorm = _model(env, config, list(policy.spec["hidden_sizes"]), seed)
    check = load_actor(model, vecnorm, policy, config.init_log_std)
    model.set_demonstrations(demo_obs, demo_act)
    log_outside_tmp(model, run)
    model.learn(total_timesteps=config.timesteps, callback=_episode_logger(run / "episodes.jsonl"))
    train_s = round(time.perf_counter() - t0, 1)
    base = env.envs[env.circuits[0]].unwrapped
    agent_json, _ = export_race_agent(
        model, vecnorm, names, run / "agent", command=command, seed=seed,
        warm_start=f"{policy.name}, fine-tuned by SAC on Race-v0's reward on {len(env.circuits)} training circuits "
                   f"of the race split ({config.timesteps} steps, behaviour-cloning weight {config.bc_weight})",
        control_period_s=float(base.control_period_s),
        max_road_wheel_angle_rad=float(base.design_model.max_road_wheel_angle_rad))
    change = actor_change(policy, agent_json)
    summary = {"run_dir": str(run), "agent": str(agent_json), "train_s": train_s, "load_check": check,
               "demo_races": ends, "actor_max_abs_change": change}
    (run / "finetune.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary


def _load(init_from: str | Path) -> Any:
    """The agent ``init_from`` names: a shipped agent (``baselines.shipped``) or an agent file."""
    from vtrack_gym.baselines.numpy_policy import load_agent
    from vtrack_gym.baselines.shipped import shipped_agents

    shipped = shipped_agents()
    policy = load_agent(shipped[str(init_from)] if str(init_from) in shipped else init_from)
    if not (policy.spec.get("env") or {}).get("observation_names") or policy.action_dim != 2:
        raise ValueError(f"--init-from must be a race agent (two outputs, observation names recorded): "
                         f"{init_from!r} is not")
    if policy.spec["activation"] != "tanh":
        raise ValueError(f"--init-from: only tanh agents can be loaded into the SAC actor ({init_from!r} is "
                         f"{policy.spec['activation']})")
    policy.name = str(init_from)
    return policy


def actor_change(before: Any, agent_json: str | Path) -> float:
    """Largest |weight or bias| change between ``before`` (a ``NumpyPolicy``) and the agent file's actor."""
    from vtrack_gym.baselines.numpy_policy import load_agent

    after = load_agent(agent_json)
    return float(max(np.max(np.abs(wa - wb)) for la, lb in zip(after._weights, before._weights, strict=True)
                     for wa, wb in zip(la, lb, strict=True)))
