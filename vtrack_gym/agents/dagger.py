"""DAgger (dataset aggregation) of a scripted expert into a small MLP agent: ``vtrack train --algo dagger``.

Behaviour cloning alone learns the expert's action on the expert's own states; the clone's small errors then lead
it to states the data never held, where its errors grow (compounding error). DAgger fixes the data, not the loss:

1. round 0: the expert drives the training env (with the AR(1) perturbation of ``imitation.collect``, so the data
   also hold the states just off its path) and the actor is fitted to its actions;
2. rounds 1..``rounds``: the *clone* drives (deterministic, plus the same perturbation), every visited state is
   labelled with the action the expert would take there, the labels join the aggregate and the actor is refitted on
   all rounds' data.

The fit is ``imitation._clone``'s: MSE on normalised observations, in the longitudinal modes the data with their
mirror image and each output's error weighted by its spread (the steering error also by (v / 10 m/s)^2). The actor
is an SB3 SAC actor (tanh output, ``hidden_sizes``) used only as a container, so the result exports to the package's
weights-only agent format (``agents.export``) and loads with ``make_policy``. No RL update is made; the evaluation
scenarios are never driven during training (the per-round record holds only training-env figures).

The run folder holds ``config.json`` (settings, versions, command, and the expert by content: ``"expert"``,
``agents.expert_identity``'s record with its ``policy_hash`` on the training env), ``dagger.json`` (per round:
transitions, the fit's MSE, how the round's episodes ended) and ``agent.json`` + ``agent.npz``, whose description
(``provenance.warm_start``) names the expert with that hash and the package version.
Everything here runs only when training is asked for (torch and SB3 are imported lazily).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.agents.expert_identity import ExpertIdentity, expert_identity

log = logging.getLogger(__name__)

@documented
@dataclass(frozen=True)
class DaggerConfig:
    """Settings of a DAgger run (perturbations as fractions of the action range, ``noise_corr_s`` [s])."""

    expert: str = "mpc"            # registry name of the expert (labels every visited state)
    expert_preset: str = "default"
    rounds: int = ranged(8, ge=0, le=100, integer=True)          # rounds driven by the clone after the expert's
    steps: int = ranged(3000, ge=10, le=10**6, integer=True)     # vector-env steps per round (x num_envs states)
    num_envs: int = ranged(16, ge=1, le=4096, integer=True)
    noise_std: float = ranged(0.02, ge=0.0, le=1.0)              # steering perturbation at <= 10 m/s (1/v^2 above)
    noise_corr_s: float = ranged(0.2, ge=0.0, le=10.0, unit="s")
    demand_noise_std: float = ranged(0.05, ge=0.0, le=1.0)       # pedal-demand perturbation
    epochs: int = ranged(20, ge=1, le=1000, integer=True)        # passes over the aggregate per round
    batch_size: int = ranged(1024, ge=16, le=10**6, integer=True)
    learning_rate: float = ranged(1e-3, ge=1e-6, le=1.0)
    hidden_sizes: tuple[int, ...] = (64, 64)                     # tanh layers of the actor

    def __post_init__(self) -> None:
        validate(self)
        for name in ("expert", "expert_preset"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ValueError(f"DaggerConfig.{name} must be a non-empty name (got {getattr(self, name)!r})")
        sizes = tuple(self.hidden_sizes)
        if not sizes or len(sizes) > 4 or any(not isinstance(h, int) or not 1 <= h <= 512 for h in sizes):
            raise ValueError(f"DaggerConfig.hidden_sizes must be 1 to 4 ints in [1, 512] (got {self.hidden_sizes!r})")

    def as_dict(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "hidden_sizes": list(self.hidden_sizes)}

    def imitation(self) -> Any:
        """The same settings as the ``imitation.BCConfig`` that ``collect`` and the fit read (the rounds are run
        here, not by ``imitation.warm_start``)."""
        from vtrack_gym.agents.imitation import BCConfig

        return BCConfig(expert=self.expert, expert_preset=self.expert_preset, steps=self.steps,
                        dagger_rounds=0, noise_std=self.noise_std, noise_corr_s=self.noise_corr_s,
                        demand_noise_std=self.demand_noise_std, epochs=self.epochs, batch_size=self.batch_size,
                        learning_rate=self.learning_rate)


def _actor_model(vecnorm: Any, config: DaggerConfig, seed: int) -> Any:
    """An SB3 SAC model on ``vecnorm`` whose actor (tanh layers of ``hidden_sizes``) holds the clone."""
    import torch.nn as nn
    from stable_baselines3 import SAC

    kwargs = {"net_arch": list(config.hidden_sizes), "activation_fn": nn.Tanh}
    return SAC("MlpPolicy", vecnorm, policy_kwargs=kwargs, buffer_size=max(config.num_envs, 64), learning_starts=0,
               seed=seed, device="cpu", verbose=0)


def aggregate(model: Any, venv: Any, vecnorm: Any, config: DaggerConfig, seed: int = 0) -> list[dict[str, Any]]:
    """Run the DAgger rounds on ``venv`` (a ``TrackingSB3VecEnv``): fit ``model``'s actor on the aggregate after
    each round. Returns one record per round (transitions, ``actor_mse`` [action units^2], ``terminations``,
    ``wall_s``)."""
    from vtrack_gym.agents.imitation import _Clone, _clone, collect

    bc = config.imitation()
    rounds, records = [], []
    for k in range(config.rounds + 1):
        t0 = time.perf_counter()
        driver = None if k == 0 else _Clone(model, vecnorm)
        rounds.append(collect(venv, bc, seed=seed + k, driver=driver))
        mse = _clone(model, vecnorm, rounds, bc, seed + k)
        records.append({"round": k, "driver": config.expert if k == 0 else "clone",
                        "transitions": rounds[-1].transitions, "actor_mse": mse,
                        "terminations": rounds[-1].terminations, "wall_s": round(time.perf_counter() - t0, 1)})
        log.info("DAgger round %d (%s drives): %s, actor MSE %.3g", k, records[-1]["driver"],
                 rounds[-1].terminations or "no episode ended", mse)
    return records


def _expert(venv: Any, config: DaggerConfig) -> ExpertIdentity:
    """The identity of the expert ``imitation.collect`` builds on ``venv`` (a ``TrackingSB3VecEnv``), taken on
    the native training env it wraps."""
    from vtrack_gym.baselines.registry import make_policy

    expert = make_policy(config.expert, venv, preset=config.expert_preset)
    return expert_identity(expert, venv.venv, f"{config.expert}[{config.expert_preset}]")


def _warm_start_text(env_id: str, config: DaggerConfig, expert: ExpertIdentity) -> str:
    return (f"DAgger of {expert.text()} on {env_id} ({config.rounds + 1} rounds of "
            f"{config.steps} x {config.num_envs} labelled states, {config.rounds} driven by the clone)")


def train_dagger(env_id: str = "vtrack/TrainingMixNominal-v0", control: str = "steer_accel",
                 config: DaggerConfig | None = None, seed: int = 0, run_dir: str | Path = "vtrack_runs/dagger", *,
                 command: str = "", overwrite: bool = False, torch_threads: int | None = 1) -> dict[str, Any]:
    """DAgger of ``config.expert`` on ``env_id`` in control mode ``control``; writes ``run_dir`` (the module
    docstring) and returns ``{"run_dir", "agent", "expert", "rounds", "train_s"}`` (``expert``:
    ``ExpertIdentity.as_dict``). ``env_id`` is a tracking env id the native vector env runs (the training env:
    never an evaluation scenario of a claim)."""
    import torch
    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym._version import __version__
    from vtrack_gym.agents.export import export
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv
    from vtrack_gym.agents.train import check_run_dir
    from vtrack_gym.envs.control import check_control

    config = config or DaggerConfig()
    if torch_threads:
        torch.set_num_threads(torch_threads)
    run = Path(run_dir)
    for f in check_run_dir(run, overwrite):
        f.unlink()
    venv = TrackingSB3VecEnv(env_id, num_envs=config.num_envs, control=check_control(control))
    try:
        vecnorm = VecNormalize(venv, norm_obs=True, norm_reward=False, clip_obs=10.0)
        model = _actor_model(vecnorm, config, seed)
        expert = _expert(venv, config)
        run.mkdir(parents=True, exist_ok=True)
        settings = {"algo": "dagger", "env_id": env_id, "control": control, "seed": seed, "command": command,
                    "dagger": config.as_dict(), "expert": expert.as_dict(), "package_version": __version__,
                    "torch_version": torch.__version__,
                    "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        (run / "config.json").write_text(json.dumps(settings, indent=2) + "\n", encoding="utf-8")
        t0 = time.perf_counter()
        records = aggregate(model, venv, vecnorm, config, seed)
        train_s = time.perf_counter() - t0
        (run / "dagger.json").write_text(json.dumps({"rounds": records, "train_s": round(train_s, 1)}, indent=2)
                                         + "\n", encoding="utf-8")
        agent_json, _ = export(model, vecnorm, run / "agent", env_id=env_id, command=command, seed=seed,
                               warm_start=_warm_start_text(env_id, config, expert), env=venv.venv)
    finally:
        venv.close()
    return {"run_dir": str(run), "agent": str(agent_json), "expert": expert.as_dict(), "rounds": records,
            "train_s": round(train_s, 1)}


def dagger_recipe(env_id: str | None = None, *, seed: int = 0, run_dir: Any = "vtrack_runs/dagger",
                  command: str = "", overwrite: bool = False, **changes: Any) -> dict[str, Any]:
    """Run the DAgger recipe of ``env_id`` (``agents.recipes.DAGGER_RECIPES``) with ``changes`` (``expert``,
    ``expert_preset``, ``rounds``, ``steps``, ``num_envs``, ``circuits_per_round``, ``control``; None keeps the
    recipe's value) and return the run's summary (``train_dagger``, or ``agents.race_dagger.train_race_dagger``
    for ``vtrack/Race-v0``)."""
    from vtrack_gym.agents.recipes import DAGGER_DEFAULT_ENV_ID, DAGGER_RECIPES

    env_id = env_id or DAGGER_DEFAULT_ENV_ID
    if env_id not in DAGGER_RECIPES:
        raise ValueError(f"--algo dagger has recipes for {', '.join(DAGGER_RECIPES)} (got --env {env_id!r})")
    settings = {**DAGGER_RECIPES[env_id], **{k: v for k, v in changes.items() if v is not None}}
    if env_id == "vtrack/Race-v0":
        from vtrack_gym.agents.race_dagger import RaceDaggerConfig, train_race_dagger

        unused = sorted(set(settings) - set(RaceDaggerConfig.__dataclass_fields__))
        if unused:
            raise ValueError(f"--algo dagger --env vtrack/Race-v0 takes no {', '.join(unused)} (it drives the "
                             "race's own control mode, one car per training circuit)")
        return train_race_dagger(RaceDaggerConfig(**settings), seed, run_dir, command=command, overwrite=overwrite)
    control = settings.pop("control")
    if "circuits_per_round" in settings:
        raise ValueError(f"--dagger-circuits applies to --env vtrack/Race-v0 only (got --env {env_id})")
    return train_dagger(env_id, control, DaggerConfig(**settings), seed, run_dir, command=command,
                        overwrite=overwrite)
