"""Export a trained SB3 PPO/SAC/TD3 MLP policy (+ its ``VecNormalize``) to the weights-only agent format.

See ``vtrack_gym.baselines.numpy_policy`` for the format. Imports torch/SB3 only through the model passed in.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym.agents.run_signature import (
    MAX_RUN_FILE_BYTES,
    TRUST_MARKER,
    read_run_files,
    run_is_trusted,
    sign_run,
    signature,
    verified_run_files,
)
from vtrack_gym.baselines.numpy_policy import FORMAT, FORMAT_VERSION, env_record, save_agent

__all__ = ["TRUST_MARKER", "export", "export_bytes", "export_model", "export_run", "policy_layers", "run_is_trusted",
           "sign_run", "zip_algo"]


def _linear_stack(modules: Any) -> tuple[list[tuple[np.ndarray, np.ndarray]], list[str]]:
    """(weight (in, out), bias) of every Linear and the names of the activations between them."""
    import torch.nn as nn

    layers, acts = [], []
    for m in modules:
        if isinstance(m, nn.Linear):
            layers.append((m.weight.detach().cpu().numpy().T.copy(), m.bias.detach().cpu().numpy().copy()))
        elif isinstance(m, nn.Tanh):
            acts.append("tanh")
        elif isinstance(m, nn.ReLU):
            acts.append("relu")
        elif isinstance(m, (nn.Flatten, nn.Identity)):
            continue
        else:
            raise ValueError(f"cannot export layer {type(m).__name__} (only Linear, Tanh, ReLU)")
    return layers, acts


def _algo_of(model: Any) -> str:
    from stable_baselines3 import PPO, SAC, TD3

    for cls, name in ((PPO, "ppo"), (SAC, "sac"), (TD3, "td3")):
        if isinstance(model, cls):
            return name
    raise ValueError(f"export supports PPO, SAC and TD3 (got {type(model).__name__})")


def policy_layers(model: Any) -> tuple[str, list[tuple[np.ndarray, np.ndarray]], str, str]:
    """``(algo, [(w, b), ...], activation, output)`` of the deterministic actor of ``model``."""
    import torch.nn as nn

    algo = _algo_of(model)
    policy = model.policy
    if algo == "ppo":
        if getattr(policy, "squash_output", False):
            # gSDE without squashing is fine: its deterministic action is the same action_net mean
            raise ValueError("export supports PPO without squash_output")
        if not isinstance(policy.features_extractor, nn.Flatten) and type(policy.features_extractor).__name__ != \
                "FlattenExtractor":
            raise ValueError("export supports the default flatten feature extractor only")
        hidden, acts = _linear_stack(policy.mlp_extractor.policy_net)
        out, _ = _linear_stack([policy.action_net])
        layers, output = hidden + out, "clip"
    elif algo == "sac":
        actor = policy.actor
        if not isinstance(actor.mu, nn.Linear):
            # gSDE adds a Hardtanh(-clip_mean, clip_mean) before the tanh unless policy_kwargs clip_mean=0
            raise ValueError("export supports SAC actors whose mean layer is one Linear (with gSDE: clip_mean=0)")
        hidden, acts = _linear_stack(actor.latent_pi)
        out, _ = _linear_stack([actor.mu])
        layers, output = hidden + out, "tanh"
    else:
        mods = list(policy.actor.mu)
        if not mods or not isinstance(mods[-1], nn.Tanh):
            raise ValueError("TD3 actor must end with Tanh")
        layers, acts = _linear_stack(mods[:-1])
        output = "tanh"
    if len(acts) != len(layers) - 1 or len(set(acts)) > 1:
        raise ValueError(f"unsupported actor: {len(layers)} linear layers with activations {acts}")
    return algo, layers, (acts[0] if acts else "tanh"), output


def export(model: Any, vecnormalize: Any, path: str | Path, *, env_id: str = "", command: str = "",
           seed: int | None = None, warm_start: str = "", env: Any = None) -> tuple[Path, Path]:
    """Write ``<path>.json`` + ``<path>.npz`` for ``model`` (PPO/SAC/TD3 MlpPolicy) and its ``VecNormalize``.
    ``warm_start``: how the actor was initialised before RL (recorded in the provenance if not empty).
    ``env``: the env whose contract (observation layout, control period, action scaling) the file records;
    default: ``gym.make(env_id)`` (a vtrack env id), none when ``env_id`` is empty.

    ``vecnormalize`` may be None (no observation normalisation) or a ``VecNormalize`` with ``norm_obs``.
    """
    import stable_baselines3

    from vtrack_gym._version import __version__

    algo, layers, activation, output = policy_layers(model)
    space = model.action_space
    arrays: dict[str, np.ndarray] = {}
    for i, (w, b) in enumerate(layers):
        arrays[f"w{i}"] = w.astype(np.float32)
        arrays[f"b{i}"] = b.astype(np.float32)
    arrays["action_low"] = np.asarray(space.low, dtype=np.float32).reshape(-1)
    arrays["action_high"] = np.asarray(space.high, dtype=np.float32).reshape(-1)
    norm = vecnormalize is not None and bool(getattr(vecnormalize, "norm_obs", False))
    eps = float(vecnormalize.epsilon) if norm else 1e-8
    if norm:
        rms = vecnormalize.obs_rms
        arrays["obs_mean"] = np.asarray(rms.mean, dtype=np.float32)
        arrays["obs_var"] = np.asarray(rms.var, dtype=np.float32)
        arrays["clip_obs"] = np.array([vecnormalize.clip_obs], dtype=np.float32)
    obs_dim = int(np.prod(model.observation_space.shape))
    spec = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "algo": algo,
        "obs_dim": obs_dim,
        "action_dim": int(arrays["action_low"].size),
        "hidden_sizes": [int(w.shape[1]) for w, _ in layers[:-1]],
        "activation": activation,
        "output": output,
        "obs_norm": {"enabled": norm, "eps": eps},
        "provenance": {
            "env_id": str(env_id),
            "command": str(command),
            "timesteps": int(model.num_timesteps),
            "seed": None if seed is None else int(seed),
            "package_version": str(__version__),
            "sb3_version": str(stable_baselines3.__version__),
        },
    }
    if warm_start:
        spec["provenance"]["warm_start"] = str(warm_start)
    if env is None and env_id:
        import gymnasium as gym

        env = gym.make(env_id)
    if env is not None:
        spec["env"] = env_record(env)
        if len(spec["env"]["observation_names"]) != obs_dim:
            raise ValueError(f"the model takes {obs_dim} observations, the env's layout has "
                             f"{len(spec['env']['observation_names'])}")
    return save_agent(path, spec, arrays)


SB3_CLASSES = ("ppo", "sac", "td3")


TRAINING_ENV_KWARGS = ("control_period_s", "reward", "control")
"""Env settings a hyperparameter file may change for training (its ``env_kwargs``): the decision period [s],
``RewardConfig`` fields (a mapping, e.g. ``{w_ey: 1.0}``) and the control mode (``envs.control``; ``vtrack train
--control``)."""


def training_env_kwargs(raw: dict[str, Any] | None) -> dict[str, Any]:
    """The ``env_kwargs`` of a hyperparameter set as ``TrackingEnv`` keyword arguments, checked against
    ``TRAINING_ENV_KWARGS`` (``ValueError``); a ``reward`` mapping becomes a validated ``RewardConfig``."""
    kwargs = dict(raw or {})
    unknown = sorted(set(kwargs) - set(TRAINING_ENV_KWARGS))
    if unknown:
        raise ValueError(f"env_kwargs may set {', '.join(TRAINING_ENV_KWARGS)} (got {', '.join(unknown)})")
    if "reward" in kwargs:
        from vtrack_gym.envs.config import RewardConfig

        reward = kwargs["reward"]
        if not isinstance(reward, dict):
            raise ValueError(f"env_kwargs.reward must be a mapping of RewardConfig fields (got {reward!r})")
        try:
            kwargs["reward"] = RewardConfig(**reward)
        except TypeError as exc:
            raise ValueError(f"env_kwargs.reward: {exc}") from None
    return kwargs


_POLICY_MODULES = {"stable_baselines3.common.policies": "ppo", "stable_baselines3.ppo.policies": "ppo",
                   "stable_baselines3.sac.policies": "sac", "stable_baselines3.td3.policies": "td3"}
"""Module of an SB3 zip's ``policy_class`` -> the algorithm that saved it."""


def zip_algo(model_zip: str | Path | bytes) -> str | None:
    """The algorithm (ppo/sac/td3) whose policy an SB3 ``model.zip`` (a path or its bytes) holds, read from its
    JSON ``data`` member (no unpickling); None if the file does not say."""
    import io
    import json
    import zipfile

    try:
        with zipfile.ZipFile(io.BytesIO(model_zip) if isinstance(model_zip, bytes) else model_zip) as zf:
            info = zf.getinfo("data")
            if info.file_size > 16 << 20:
                return None
            data = json.loads(zf.read(info))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile, RecursionError):
        return None
    policy = data.get("policy_class") if isinstance(data, dict) else None
    return _POLICY_MODULES.get(policy.get("__module__", "")) if isinstance(policy, dict) else None


def _looks_normalised(model_space: Any, env_space: Any) -> bool:
    """True if ``model_space`` (a model's observation space) is a symmetric constant box unlike the env's raw
    observation space: the model was trained on scaled observations (e.g. VecNormalize's clipped range)."""
    low, high = getattr(model_space, "low", None), getattr(model_space, "high", None)
    if low is None or high is None or not np.all(np.isfinite(high)) or np.shape(low) != np.shape(env_space.low):
        return False
    symmetric = np.allclose(low, -high) and np.allclose(high, np.ravel(high)[0])
    return bool(symmetric and not (np.allclose(low, env_space.low) and np.allclose(high, env_space.high)))


def export_model(model_zip: str | Path, out: str | Path, algo: str, vecnormalize_pkl: str | Path | None = None, *,
                 env_id: str = "LateralTrackingRandom-v0", command: str = "",
                 seed: int | None = None, env_kwargs: dict[str, Any] | None = None,
                 raw_observations: bool | None = None) -> tuple[Path, Path]:
    """Export an SB3 ``model.zip`` (``algo`` ppo/sac/td3) and optionally its ``VecNormalize`` pickle to
    ``<out>.json`` + ``<out>.npz``, recording the contract (observation layout, control period, action scaling) of
    ``env_id`` made with ``env_kwargs`` (e.g. the training ``control_period_s``). SB3's files are pickle-based:
    only export models you produced or trust. Each file is read once and loaded from those bytes.

    Without ``vecnormalize_pkl`` the agent takes raw observations. ``raw_observations`` None: that is refused
    (``ValueError``) when a ``vecnormalize.pkl`` lies next to the model or the model's observation space looks
    normalised; True: the caller vouches the model was trained on raw observations. A model of another
    algorithm than ``algo``, a ``vecnormalize_pkl`` that is not a VecNormalize pickle and a model of a ``vtrack
    train`` run folder trained at another decision period than ``env_id``'s (``trained_period``) are ``ValueError``.
    """
    from vtrack_gym._io import read_regular_file
    from vtrack_gym.agents.trained_period import check_export_period

    if algo not in SB3_CLASSES:
        raise ValueError(f"unknown algo {algo!r}; valid: {', '.join(SB3_CLASSES)}")
    model_zip = Path(model_zip)
    check_export_period(model_zip, env_id, env_kwargs)   # a run folder's recorded period against the export env's
    model_bytes = read_regular_file(model_zip, MAX_RUN_FILE_BYTES, "SB3 model file")
    if vecnormalize_pkl is None and not raw_observations and (model_zip.parent / "vecnormalize.pkl").is_file():
        raise ValueError(f"--model {model_zip} has a vecnormalize.pkl next to it: the model was probably trained "
                         f"on normalised observations. Pass --vecnormalize {model_zip.parent / 'vecnormalize.pkl'} "
                         "(or --raw-observations if it really takes raw observations)")
    vec_bytes = None if vecnormalize_pkl is None else \
        read_regular_file(vecnormalize_pkl, MAX_RUN_FILE_BYTES, "VecNormalize file")
    sources = Sources(model=f"--model {model_zip}", vecnorm=f"--vecnormalize {vecnormalize_pkl}")
    return export_bytes(model_bytes, vec_bytes, out, algo, sources, env_id=env_id, command=command, seed=seed,
                        env_kwargs=env_kwargs, raw_observations=raw_observations)


@dataclass(frozen=True)
class Sources:
    """Where the model and VecNormalize bytes came from (named in messages)."""

    model: str
    vecnorm: str


def _load_model(model_bytes: bytes, algo: str, source: str) -> Any:
    """The SB3 model of ``algo`` loaded from ``model_bytes`` (never from a path); ``ValueError`` if not one."""
    import io

    from stable_baselines3 import PPO, SAC, TD3

    saved_by = zip_algo(model_bytes)
    if saved_by is not None and saved_by != algo:
        raise ValueError(f"{source} holds a {saved_by.upper()} model, not --algo {algo}: pass --algo {saved_by}")
    try:
        return {"ppo": PPO, "sac": SAC, "td3": TD3}[algo].load(io.BytesIO(model_bytes), device="cpu")
    except (KeyboardInterrupt, MemoryError):
        raise
    except Exception as exc:  # SB3 fails with whatever the mismatch trips over (AttributeError, TypeError, ...)
        raise ValueError(f"{source}: not a loadable SB3 {algo.upper()} model (--algo {algo}): "
                         f"{type(exc).__name__}: {exc}"[:600]) from None


def _load_vecnormalize(vec_bytes: bytes, env_id: str, source: str) -> Any:
    """The ``VecNormalize`` unpickled from ``vec_bytes`` (what ``VecNormalize.load`` does, from bytes), frozen."""
    import pickle

    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    try:
        vecnorm = pickle.loads(vec_bytes)  # the caller vouches for these bytes (signature or --trust)
    except (KeyboardInterrupt, MemoryError):
        raise
    except (pickle.UnpicklingError, EOFError, AttributeError, TypeError, ValueError, ImportError,
            IndexError, KeyError, AssertionError) as exc:
        raise ValueError(f"{source} is not a VecNormalize pickle (vecnormalize.pkl of the training run) for "
                         f"{env_id or 'DLC120-v0'}: {type(exc).__name__}: {exc}"[:600]) from None
    if not isinstance(vecnorm, VecNormalize):
        raise ValueError(f"{source} is not a VecNormalize pickle")
    vecnorm.set_venv(TrackingSB3VecEnv(env_id or "DLC120-v0", 1))
    vecnorm.training = False
    return vecnorm


def export_bytes(model_bytes: bytes, vec_bytes: bytes | None, out: str | Path, algo: str, sources: Sources, *,
                 env_id: str, command: str, seed: int | None, env_kwargs: dict[str, Any] | None,
                 raw_observations: bool | None) -> tuple[Path, Path]:
    """``export_model`` on bytes already read (and, for a run folder, verified): the model and its
    ``VecNormalize`` are loaded from exactly these bytes."""
    model = _load_model(model_bytes, algo, sources.model)
    vecnorm = None if vec_bytes is None else _load_vecnormalize(vec_bytes, env_id, sources.vecnorm)
    if vecnorm is None and not raw_observations and env_id:
        import gymnasium as gym

        if _looks_normalised(model.observation_space, gym.make(env_id).observation_space):
            raise ValueError(f"{sources.model} takes observations in a symmetric box unlike {env_id}'s raw "
                             "ones: it was probably trained on normalised observations. Pass --vecnormalize "
                             "V.pkl (or --raw-observations if it really takes raw observations)")
    contract = None
    if env_id and env_kwargs:
        import gymnasium as gym

        contract = gym.make(env_id, **env_kwargs)
    return export(model, vecnorm, out, env_id=env_id, command=command, seed=seed, env=contract)


def _run_signature(run: Path, key: bytes) -> str:
    """The signature of ``run``'s files as they are now (each read once), with ``key``."""
    return signature(run, key, read_run_files(run))


def export_run(run_dir: str | Path, out: str | Path, *, trust: bool = False) -> tuple[Path, Path]:
    """Export the SB3 model of a ``vtrack train`` run folder to ``<out>.json`` + ``<out>.npz``.

    Reads ``config.json`` (algo, env, seed, command), ``model.zip`` and ``vecnormalize.pkl`` once each. Those two
    are SB3's own pickle-based formats (loading them runs any code they contain): unless ``trust`` is true, the
    bytes read must carry the signature ``vtrack train`` wrote with this user's key, else ``ValueError``; the model
    is then loaded from those same bytes (a file swapped after the check is never loaded).
    """
    import json

    run = Path(run_dir)
    config_file = run / "config.json"
    if not config_file.is_file():
        raise ValueError(f"{run} is not a `vtrack train` run folder (no config.json)")
    files = verified_run_files(run, trust=trust)
    try:
        config = json.loads(files["config.json"] or b"")
    except (ValueError, RecursionError) as exc:
        raise ValueError(f"{config_file}: not a JSON run config ({exc})"[:400]) from None
    if not isinstance(config, dict):
        raise ValueError(f"{config_file}: not a JSON object")
    algo = config.get("algo")
    if algo not in SB3_CLASSES:
        raise ValueError(f"{config_file}: unknown algo {algo!r}; valid: {', '.join(SB3_CLASSES)}")
    model_bytes = files["model.zip"]
    if model_bytes is None:
        raise ValueError(f"{run / 'model.zip'}: SB3 model file not found")
    env_id = str(config.get("env_id", config.get("env", "")))
    seed = config.get("seed")
    hyper = config.get("hyperparams")
    env_kwargs = hyper.get("env_kwargs") if isinstance(hyper, dict) else None
    sources = Sources(model=f"--run-dir {run}: model.zip", vecnorm=f"--run-dir {run}: vecnormalize.pkl")
    return export_bytes(model_bytes, files["vecnormalize.pkl"], out, algo, sources, env_id=env_id,
                        command=str(config.get("command", "")), seed=seed if isinstance(seed, int) else None,
                        env_kwargs=training_env_kwargs(env_kwargs if isinstance(env_kwargs, dict) else None),
                        raw_observations=None)
