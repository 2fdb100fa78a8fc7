"""DAgger of a race baseline on the training circuits of the race split: ``vtrack train --algo dagger --env
vtrack/Race-v0`` (the circuits: ``tracks.race_circuits.RACE_SPLIT["train"]``; the validation and held-out circuits
and the shipped race ids are refused).

Each round drives ``circuits_per_round`` training circuits (``vtrack/Race-v0`` with ``track=`` the circuit and
``laps=`` ``config.laps``, standing start; the held-out ids are never made), one race each: round 0 with the expert
at the wheel, every later round with the clone, plus the AR(1) perturbation of ``imitation.collect`` in both cases.
Every visited state is labelled with the expert's action (a race baseline at ``expert_grip_scale`` of the car's
limits: the recipe's, ``agents.recipes.DAGGER_RECIPES``, is ``centreline`` at 0.7, the centre line being what the
agent sees; stateless, so its label is a function of the state) and the actor is refitted on all rounds
(``imitation._fit``'s MSE, each output's error weighted by its spread, the steering one also by (v / 10 m/s)^2).

The agent does not see a racing line: it reads the race observation without ``lap_fraction`` (a station on one
circuit means nothing on another), i.e. the tracking errors to the centre line, the curvature and reference-speed
previews, the speed and time errors and the distances to the two edges. The file records those names, so the agent
binds to any race env by name (``NumpyPolicy.check_env``).
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
from vtrack_gym.agents.expert_identity import ExpertIdentity, expert_identity

log = logging.getLogger(__name__)

RACE_ENV_ID = "vtrack/Race-v0"
"""The race id a training circuit is driven as (``track=`` the circuit)."""
HIDDEN_FIELDS = ("lap_fraction",)
"""Race observation fields the agent does not read (they name a place on one circuit only)."""


@documented
@dataclass(frozen=True)
class RaceDaggerConfig:
    """Settings of a race DAgger run (perturbations as fractions of the action range, ``noise_corr_s`` [s])."""

    expert: str = "raceline"
    expert_grip_scale: float = ranged(0.9, ge=0.5, le=1.0)              # the expert's profile at this share of grip
    rounds: int = ranged(8, ge=0, le=100, integer=True)                # rounds driven by the clone
    circuits_per_round: int = ranged(8, ge=1, le=1000, integer=True)
    laps: int = ranged(1, ge=1, le=5, integer=True)                    # laps of each training race
    steps: int = ranged(10**6, ge=10, le=10**6, integer=True)          # at most this many steps of each race
    noise_std: float = ranged(0.01, ge=0.0, le=1.0)                    # steering, at <= 10 m/s (1/v^2 above)
    noise_corr_s: float = ranged(0.2, gt=0.0, le=10.0, unit="s")
    demand_noise_std: float = ranged(0.02, ge=0.0, le=1.0)
    epochs: int = ranged(20, ge=1, le=1000, integer=True)
    batch_size: int = ranged(1024, ge=16, le=10**6, integer=True)
    learning_rate: float = ranged(1e-3, ge=1e-6, le=1.0)
    hidden_sizes: tuple[int, ...] = (64, 64)

    def __post_init__(self) -> None:
        validate(self)
        sizes = tuple(self.hidden_sizes)
        if not sizes or len(sizes) > 4 or any(not isinstance(h, int) or not 1 <= h <= 512 for h in sizes):
            raise ValueError(f"RaceDaggerConfig.hidden_sizes must be 1 to 4 ints in [1, 512] (got "
                             f"{self.hidden_sizes!r})")

    def as_dict(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "hidden_sizes": list(self.hidden_sizes)}

    def imitation(self) -> Any:
        """The fit's settings as the ``imitation.BCConfig`` that ``_fit`` reads."""
        from vtrack_gym.agents.imitation import BCConfig

        return BCConfig(expert=self.expert, epochs=self.epochs, batch_size=self.batch_size,
                        learning_rate=self.learning_rate, noise_corr_s=self.noise_corr_s)


def _kept(names: tuple[str, ...]) -> np.ndarray:
    """Indices of the race observation the agent reads (all but ``HIDDEN_FIELDS``)."""
    return np.array([i for i, n in enumerate(names) if n not in HIDDEN_FIELDS], dtype=np.intp)


def drive_race(env: Any, expert: Any, driver: Any, config: RaceDaggerConfig,
               rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, str]:
    """One race on ``env`` driven by ``driver`` (``predict(raw obs) -> action``; the expert if None) with the AR(1)
    perturbation: (every visited observation (T, obs_dim), the expert's label for each (T, 2), the termination)."""
    from vtrack_gym.agents.imitation import NOISE_REFERENCE_SPEED_MPS

    obs, _ = env.reset(seed=int(rng.integers(2**31)))
    v_idx = list(env.unwrapped.observation_layout.names).index("v_x")
    rho = math.exp(-env.unwrapped.control_period_s / config.noise_corr_s)
    std = np.array([config.noise_std, config.demand_noise_std])
    noise = np.zeros(2)
    seen, labels = [], []
    while True:
        label = np.asarray(expert.predict(obs)[0], dtype=np.float32).reshape(2)
        base = label if driver is None else np.asarray(driver.predict(obs)[0], dtype=np.float32).reshape(2)
        noise = rho * noise + math.sqrt(1.0 - rho * rho) * std * rng.standard_normal(2)
        scale = np.array([(NOISE_REFERENCE_SPEED_MPS / max(float(obs[v_idx]), NOISE_REFERENCE_SPEED_MPS)) ** 2, 1.0])
        seen.append(obs)
        labels.append(label)
        obs, _, terminated, truncated, info = env.step(np.clip(base + noise * scale, -1.0, 1.0).astype(np.float32))
        if terminated or truncated or len(seen) >= config.steps:
            end = str(info["termination"] or ("time_limit" if truncated else "step_cap"))
            return np.asarray(seen, np.float32), np.asarray(labels, np.float32), end


def _container(obs_dim: int, config: RaceDaggerConfig, seed: int) -> tuple[Any, Any]:
    """(an SB3 SAC model whose actor holds the clone, its ``VecNormalize``: the observation statistics)."""
    import gymnasium as gym
    import torch.nn as nn
    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    class Spaces(gym.Env):
        observation_space = gym.spaces.Box(-np.inf, np.inf, (obs_dim,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

        def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
            return np.zeros(obs_dim, np.float32), {}

        def step(self, action: Any) -> Any:
            return np.zeros(obs_dim, np.float32), 0.0, True, False, {}

    vecnorm = VecNormalize(DummyVecEnv([Spaces]), norm_obs=True, norm_reward=False, clip_obs=10.0)
    model = SAC("MlpPolicy", vecnorm, policy_kwargs={"net_arch": list(config.hidden_sizes), "activation_fn": nn.Tanh},
                buffer_size=64, learning_starts=0, seed=seed, device="cpu", verbose=0)
    return model, vecnorm


class _Reader:
    """The clone as a ``predict(raw race obs)`` driver: the agent's fields selected, normalised."""

    def __init__(self, model: Any, vecnorm: Any, kept: np.ndarray) -> None:
        self.model, self.vecnorm, self.kept = model, vecnorm, kept

    def predict(self, obs: np.ndarray) -> tuple[np.ndarray, None]:
        x = self.vecnorm.normalize_obs(np.asarray(obs, np.float32)[self.kept][None])
        return self.model.predict(x, deterministic=True)[0][0], None


def _fit(model: Any, vecnorm: Any, data: list[tuple[np.ndarray, np.ndarray]], config: RaceDaggerConfig,
         seed: int) -> float:
    """Refit the actor on every race's (observations, labels) so far; returns the plain MSE [action units^2]."""
    import torch

    from vtrack_gym.agents.imitation import ExpertData, _clone

    obs = np.concatenate([o for o, _ in data])[:, None, :]
    label = np.concatenate([a for _, a in data])[:, None, :]
    empty = np.zeros(obs.shape[:2], np.float32)
    rounds = [ExpertData(obs, label, label, empty, empty.astype(bool), obs, {})]
    torch.manual_seed(seed)
    return _clone(model, vecnorm, rounds, config.imitation(), seed)


def aggregate_races(circuits: tuple[str, ...], config: RaceDaggerConfig, seed: int = 0,
                    vehicle: Any = None) -> tuple[Any, Any, tuple[str, ...], list[dict[str, Any]]]:
    """The DAgger rounds on ``circuits`` (names of ``tracks.race_circuits``): (the model, its ``VecNormalize``, the
    observation names the agent reads, one record per round)."""
    import gymnasium as gym

    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.tracks.race_circuits import race_circuit

    extra = {} if vehicle is None else {"vehicle": vehicle}
    envs: dict[str, Any] = {}
    rng = np.random.default_rng(seed)
    model = vecnorm = kept = names = None
    contract: dict[str, float] = {}
    data: list[tuple[np.ndarray, np.ndarray]] = []
    records: list[dict[str, Any]] = []
    for k in range(config.rounds + 1):
        t0 = time.perf_counter()
        ends: dict[str, int] = {}
        for j in range(config.circuits_per_round):
            name = circuits[(k * config.circuits_per_round + j) % len(circuits)]
            if name not in envs:
                envs[name] = gym.make(RACE_ENV_ID, track=race_circuit(name), laps=config.laps, **extra)
            env = envs[name]
            if kept is None:
                all_names = tuple(env.unwrapped.observation_layout.names)
                kept = _kept(all_names)
                names = tuple(all_names[i] for i in kept)
                model, vecnorm = _container(kept.size, config, seed)
                base = env.unwrapped
                contract = {"control_period_s": float(base.control_period_s),
                            "max_road_wheel_angle_rad": float(base.design_model.max_road_wheel_angle_rad)}
            driver = None if k == 0 else _Reader(model, vecnorm, kept)
            expert = make_policy(config.expert, env, grip_scale=config.expert_grip_scale)
            obs, labels, end = drive_race(env, expert, driver, config, rng)
            data.append((obs[:, kept], labels))
            ends[end] = ends.get(end, 0) + 1
        mse = _fit(model, vecnorm, data, config, seed + k)
        records.append({"round": k, "driver": config.expert if k == 0 else "clone", "races": ends, **contract,
                        "states": int(sum(o.shape[0] for o, _ in data)), "actor_mse": mse,
                        "wall_s": round(time.perf_counter() - t0, 1)})
        log.info("race DAgger round %d (%s drives): %s, actor MSE %.3g", k, records[-1]["driver"], ends, mse)
    return model, vecnorm, names, records


def export_race_agent(model: Any, vecnorm: Any, names: tuple[str, ...], path: str | Path, *, command: str = "",
                      seed: int = 0, warm_start: str = "", control_period_s: float,
                      max_road_wheel_angle_rad: float) -> tuple[Path, Path]:
    """Write the agent file (``agents.export``'s format) recording the observation ``names`` it reads."""
    import tempfile

    from vtrack_gym.agents.export import export
    from vtrack_gym.baselines.numpy_policy import save_agent

    with tempfile.TemporaryDirectory(prefix="vtrack-race-agent-") as tmp:
        spec_path, npz_path = export(model, vecnorm, Path(tmp) / "agent", command=command, seed=seed,
                                     warm_start=warm_start)
        spec = json.loads(Path(spec_path).read_text(encoding="utf-8"))
        spec["provenance"]["env_id"] = RACE_ENV_ID
        with np.load(npz_path, allow_pickle=False) as npz:
            arrays = {key: npz[key] for key in npz.files}
    spec["env"] = {"observation_names": list(names), "control_period_s": float(control_period_s),
                   "max_road_wheel_angle_rad": float(max_road_wheel_angle_rad)}
    return save_agent(path, spec, arrays)


def race_expert_identity(config: RaceDaggerConfig, circuit: str, vehicle: Any = None) -> ExpertIdentity:
    """The expert's identity (``agents.expert_identity``) taken on ``circuit``'s race env: a race baseline plans
    on its track, so its hash is that of the expert on this circuit (the first training circuit in a run)."""
    import gymnasium as gym

    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.tracks.race_circuits import race_circuit

    extra = {} if vehicle is None else {"vehicle": vehicle}
    env = gym.make(RACE_ENV_ID, track=race_circuit(circuit), laps=config.laps, **extra)
    try:
        expert = make_policy(config.expert, env, grip_scale=config.expert_grip_scale)
        label = f"{config.expert}[grip_scale={config.expert_grip_scale}] on {circuit}"
        return expert_identity(expert, env, label)
    finally:
        env.close()


def _warm_start_text(config: RaceDaggerConfig, circuits: tuple[str, ...], expert: ExpertIdentity) -> str:
    return (f"DAgger of {expert.text()} on {len(circuits)} training circuits of the race split "
            f"({config.rounds + 1} rounds of {config.circuits_per_round} races of {config.laps} lap(s), "
            f"{config.rounds} driven by the clone)")


def train_race_dagger(config: RaceDaggerConfig | None = None, seed: int = 0,
                      run_dir: str | Path = "vtrack_runs/race_dagger", *, circuits: tuple[str, ...] | None = None,
                      command: str = "", overwrite: bool = False, torch_threads: int | None = 1) -> dict[str, Any]:
    """DAgger of ``config.expert`` on the race split's training circuits (``circuits``: default
    ``RACE_SPLIT["train"]``); writes ``config.json``, ``dagger.json`` (per round) and ``agent.json`` + ``.npz`` into
    ``run_dir``. Returns ``{"run_dir", "agent", "rounds", "train_s"}``."""
    import torch

    from vtrack_gym._version import __version__
    from vtrack_gym.agents.train import check_run_dir
    from vtrack_gym.tracks.race_circuits import RACE_SPLIT

    config = config or RaceDaggerConfig()
    circuits = tuple(circuits or RACE_SPLIT["train"])
    barred = set(RACE_SPLIT["validation"]) | set(RACE_SPLIT["held_out"]) | set(RACE_SPLIT["held_out_ids"])
    if barred & set(circuits):
        raise ValueError(f"circuits must not include the race split's validation or held-out circuits or ids "
                         f"{sorted(barred & set(circuits))}")
    if torch_threads:
        torch.set_num_threads(torch_threads)
    run = Path(run_dir)
    for f in check_run_dir(run, overwrite):
        f.unlink()
    run.mkdir(parents=True, exist_ok=True)
    settings = {"algo": "dagger", "env_id": RACE_ENV_ID, "circuits": list(circuits), "seed": seed,
                "command": command, "dagger": config.as_dict(), "package_version": __version__,
                "torch_version": torch.__version__, "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
    expert = race_expert_identity(config, circuits[0])
    settings["expert"] = expert.as_dict()
    (run / "config.json").write_text(json.dumps(settings, indent=2) + "\n", encoding="utf-8")
    t0 = time.perf_counter()
    model, vecnorm, names, records = aggregate_races(circuits, config, seed)
    train_s = round(time.perf_counter() - t0, 1)
    (run / "dagger.json").write_text(json.dumps({"rounds": records, "train_s": train_s}, indent=2) + "\n",
                                     encoding="utf-8")
    agent_json, _ = export_race_agent(model, vecnorm, names, run / "agent", command=command, seed=seed,
                                      warm_start=_warm_start_text(config, circuits, expert),
                                      control_period_s=records[-1]["control_period_s"],
                                      max_road_wheel_angle_rad=records[-1]["max_road_wheel_angle_rad"])
    return {"run_dir": str(run), "agent": str(agent_json), "rounds": records, "train_s": train_s,
            "expert": expert.as_dict()}
