"""The RL recipes' hyperparameter files: reading them, what their keys mean, and the range checks.

``hyperparams/<algo>.yaml`` holds one entry per registered env id in rl_zoo3's format, so rl_zoo3 trains from the
file as it is::

    python -m rl_zoo3.train --algo ppo --env vtrack/TrainingMix20Hz-v0 --gym-packages vtrack_gym \\
        --conf-file vtrack_gym/agents/hyperparams/ppo.yaml

``vtrack train`` reads the same files with ``yaml.safe_load`` and evaluates nothing: ``policy_kwargs`` (a Python
``dict(...)`` expression in rl_zoo3's format) is parsed by ``parse_policy_kwargs``, which accepts only literals
and the activations ``nn.Tanh`` / ``nn.ReLU``; ``callback`` may name ``FIXED_SCALING_CALLBACK`` only (the fixed
observation scales, ``obs_scaling``); ``noise_type: normal`` with ``noise_std`` is Gaussian action noise
(TD3). Settings rl_zoo3 has no key for (the warm start's ``bc_finetune``, ``RegularisedSAC``'s loss weights)
live in ``hyperparams/extensions.yaml`` under the algorithm and env id; ``load_hyperparams`` merges them in.
"""

from __future__ import annotations

import ast
import hashlib
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

ALGOS = ("ppo", "sac", "td3")
RECIPE_ENV_ID = "vtrack/TrainingMix20Hz-v0"
"""The training env of the from-scratch recipes: the training mix at a 50 ms decision period (20 Hz), as the shipped
``ppo`` and ``sac`` agents were trained."""
DEFAULT_ENV_ID = RECIPE_ENV_ID
"""``vtrack train``'s env without ``--bc-expert``."""
IMITATION_ENV_ID = "LateralTrackingRandom-v0"
"""Training env of the behaviour-cloning recipes (``bc``), whose ``bc_finetune`` settings live under it."""
REGULARISED_SAC_KEYS = frozenset({"bc_weight", "temporal_smoothness", "spatial_smoothness", "spatial_noise"})
"""SAC hyperparameters that select ``regularised_sac.RegularisedSAC`` (extra actor-loss terms)."""
HYPERPARAMS_DIR = Path(__file__).with_name("hyperparams")
EXTENSIONS_FILE = HYPERPARAMS_DIR / "extensions.yaml"
"""``vtrack train``'s settings rl_zoo3 has no key for: ``{algo: {env id: {key: value}}}``."""
EXTENSION_KEYS = frozenset({"bc_finetune"}) | REGULARISED_SAC_KEYS
"""Keys ``extensions.yaml`` may hold."""
FIXED_SCALING_CALLBACK = "vtrack_gym.agents.obs_scaling.FixedObservationScaling"
"""The one ``callback`` a hyperparameter entry may name: fixed physical observation scales (``obs_scaling``)."""
ACTIVATIONS = {"Tanh": "tanh", "ReLU": "relu"}
"""``nn.<name>`` allowed as ``activation_fn`` in ``policy_kwargs`` -> the agent format's activation name."""


def _read_yaml(path: Path) -> tuple[Any, str]:
    """``(yaml.safe_load of path, SHA-256 of its bytes)``."""
    import yaml

    raw = path.read_bytes()
    return yaml.safe_load(raw.decode("utf-8")), hashlib.sha256(raw).hexdigest()


def _entry(data: Any, env_id: str, source: Path) -> dict[str, Any]:
    """The mapping under ``env_id`` (or its other spelling, with or without ``vtrack/``) in a loaded file."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: expected a mapping of env ids")
    for key in (env_id, f"vtrack/{env_id}", env_id.removeprefix("vtrack/")):
        if key in data:
            if not isinstance(data[key], dict):
                raise ValueError(f"{source}: entry {key!r} must be a mapping")
            return dict(data[key])
    raise KeyError(env_id)


def load_hyperparams(algo: str, env_id: str = DEFAULT_ENV_ID) -> tuple[dict[str, Any], str]:
    """``(hyperparameters for env_id, SHA-256 of the file)`` from ``hyperparams/<algo>.yaml``, with the entry's
    ``extensions.yaml`` settings merged in. ``env_id`` is a registered id; an un-namespaced id also finds its
    ``vtrack/`` entry and the reverse."""
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {ALGOS} (got {algo!r})")
    path = HYPERPARAMS_DIR / f"{algo}.yaml"
    data, digest = _read_yaml(path)
    try:
        params = _entry(data, env_id, path)
    except KeyError:
        raise ValueError(f"{path}: no hyperparameters for {env_id!r} (have {sorted(data)})") from None
    extensions, _ = _read_yaml(EXTENSIONS_FILE)
    try:
        extra = _entry((extensions or {}).get(algo) or {}, env_id, EXTENSIONS_FILE)
    except KeyError:
        extra = {}
    unknown = sorted(set(extra) - EXTENSION_KEYS)
    if unknown:
        raise ValueError(f"{EXTENSIONS_FILE}: {algo}/{env_id} may set {sorted(EXTENSION_KEYS)} (got {unknown})")
    return {**params, **extra}, digest


def _literal(node: ast.AST) -> Any:
    """The value of one node of a ``policy_kwargs`` expression (see ``parse_policy_kwargs``)."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
        if any(kw.arg is None for kw in node.keywords):
            raise ValueError("policy_kwargs: dict(**...) is not allowed")
        return {kw.arg: _literal(kw.value) for kw in node.keywords}
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "nn":
        if node.attr not in ACTIVATIONS:
            raise ValueError(f"policy_kwargs: activation_fn must be one of "
                             f"{', '.join('nn.' + a for a in ACTIVATIONS)} (got nn.{node.attr})")
        return ACTIVATIONS[node.attr]
    if isinstance(node, ast.Dict):
        return {_literal(k): _literal(v) for k, v in zip(node.keys, node.values, strict=True) if k is not None}
    if isinstance(node, (ast.List, ast.Tuple)):
        return [_literal(e) for e in node.elts]
    try:
        return ast.literal_eval(node)
    except ValueError:
        allowed = ", ".join("nn." + a for a in ACTIVATIONS)
        raise ValueError(f"policy_kwargs: only dict(...), lists, numbers, strings and {allowed} are allowed "
                         f"(got {ast.unparse(node)!r})") from None


def parse_policy_kwargs(raw: str | Mapping[str, Any] | None) -> dict[str, Any]:
    """``policy_kwargs`` as a dict with ``activation_fn`` a name of ``ACTIVATIONS``' values: a mapping as it is,
    or rl_zoo3's string form (``"dict(net_arch=[64, 64], activation_fn=nn.Tanh)"``) parsed, never evaluated."""
    if raw is None:
        return {}
    if isinstance(raw, str):
        try:
            tree = ast.parse(raw, mode="eval").body
        except SyntaxError as exc:
            raise ValueError(f"policy_kwargs: not a dict(...) expression ({exc.msg}): {raw[:200]!r}") from None
        raw = _literal(tree)
    if not isinstance(raw, Mapping):
        raise ValueError(f"policy_kwargs must be a mapping or a dict(...) expression (got {raw!r})"[:300])
    return dict(raw)


def policy_kwargs(raw: str | Mapping[str, Any] | None) -> dict[str, Any]:
    """SB3's ``policy_kwargs`` from a hyperparameter entry's (``parse_policy_kwargs``): the activation name as its
    torch class, ``net_arch`` as lists."""
    import torch.nn as nn

    kwargs = parse_policy_kwargs(raw)
    act = kwargs.get("activation_fn")
    if act is not None:
        if act not in ACTIVATIONS.values():
            raise ValueError(f"policy_kwargs.activation_fn must be one of {tuple(ACTIVATIONS.values())} "
                             f"(got {act!r})")
        kwargs["activation_fn"] = {"tanh": nn.Tanh, "relu": nn.ReLU}[act]
    net_arch = kwargs.get("net_arch")
    if isinstance(net_arch, dict):
        kwargs["net_arch"] = {k: list(v) for k, v in net_arch.items()}
    return kwargs


def observation_scaling(params: dict[str, Any]) -> str:
    """Pop ``callback`` from ``params``: ``"fixed"`` if it names ``FIXED_SCALING_CALLBACK``, ``"running"`` if
    absent (VecNormalize's running statistics); any other callback is ``ValueError``."""
    callback = params.pop("callback", None)
    if callback is None:
        return "running"
    if callback != FIXED_SCALING_CALLBACK:
        raise ValueError(f"callback may only be {FIXED_SCALING_CALLBACK} (fixed observation scales) "
                         f"(got {callback!r})")
    return "fixed"


def action_noise(params: dict[str, Any], dim: int) -> Any:
    """Pop ``noise_type`` / ``noise_std`` from ``params``: SB3's Gaussian action noise for ``normal`` (std a
    fraction of the action range), None without a ``noise_type``."""
    noise_type, std = params.pop("noise_type", None), params.pop("noise_std", None)
    if noise_type is None:
        if std is not None:
            raise ValueError("noise_std needs noise_type: normal")
        return None
    if noise_type != "normal":
        raise ValueError(f"noise_type must be 'normal' (got {noise_type!r})")
    from stable_baselines3.common.noise import NormalActionNoise

    return NormalActionNoise(np.zeros(dim), _number("noise_std", std, 0.0, 10.0) * np.ones(dim))


MAX_BATCH_SIZE = 2**17
"""Largest ``batch_size`` [transitions] (beyond what fits a 2-core machine's memory and time budget)."""
MAX_BUFFER_SIZE = 10**8
"""Largest off-policy ``buffer_size`` [transitions]."""
SB3_DEFAULTS = {"ppo": {"n_steps": 2048, "batch_size": 64},
                "sac": {"buffer_size": 1_000_000, "batch_size": 256, "learning_starts": 100},
                "td3": {"buffer_size": 1_000_000, "batch_size": 256, "learning_starts": 100}}
"""SB3's defaults of the hyperparameters ``check_hyperparams`` relates to each other, when a set omits them."""


def _number(key: str, value: Any, low: float, high: float, low_open: bool = False) -> float:
    """``value`` as a float if it is a finite real number in [low, high] (``(low, high]`` if ``low_open``), else
    ``ValueError`` naming the hyperparameter and its range."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and value <= high
    if not ok:
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}]" if np.isfinite(high) else \
            f"{'> ' if low_open else '>= '}{low:g}"
        raise ValueError(f"hyperparameter {key} must be a number {'in ' if np.isfinite(high) else ''}{interval} "
                         f"(got {value!r})")
    return float(value)


def _integer(key: str, value: Any, low: int, high: int) -> int:
    """``value`` if it is an int in [low, high], else ``ValueError`` naming the hyperparameter and its range."""
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"hyperparameter {key} must be an integer in [{low}, {high}] (got {value!r})")
    return value


def _batch_size(value: Any, low: int, limit: int, limit_text: str, fix: str) -> None:
    """``ValueError`` unless ``value`` is an int in [low, min(limit, MAX_BATCH_SIZE)]; the message says where
    the upper end comes from (``limit_text``) and how to fix it."""
    high = min(limit, MAX_BATCH_SIZE)
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"hyperparameter batch_size must be an integer in [{low}, {high}] ({limit_text}, at most "
                         f"{MAX_BATCH_SIZE}) (got {value!r}): {fix}")


def _check_ppo(p: Mapping[str, Any], n_envs: int) -> int:
    """PPO's ranges; returns the transitions of one rollout (n_steps x n_envs)."""
    if "gae_lambda" in p:
        _number("gae_lambda", p["gae_lambda"], 0.0, 1.0)
    if "clip_range" in p and not isinstance(p["clip_range"], str):  # "lin_X": checked by _schedule
        _number("clip_range", p["clip_range"], 0.0, float("inf"), low_open=True)
    if "ent_coef" in p:
        _number("ent_coef", p["ent_coef"], 0.0, float("inf"))
    n_steps = _integer("n_steps", p["n_steps"], 1, 10**7)
    rollout = n_steps * n_envs
    if rollout < 2:
        raise ValueError(f"hyperparameter n_steps x n_envs must be >= 2 (got {n_steps} x {n_envs})")
    _batch_size(p["batch_size"], 2, rollout, f"n_steps x n_envs = {n_steps} x {n_envs} = {rollout}",
                "--set batch_size=N, or more --num-envs or n_steps")
    return rollout


def _check_sac_ent_coef(ent: Any) -> None:
    """SAC's ``ent_coef``: a number >= 0, ``auto`` or ``auto_X`` with a finite X > 0."""
    if not isinstance(ent, str):
        _number("ent_coef", ent, 0.0, float("inf"))
        return
    head, sep, start = ent.partition("_")
    try:   # "auto", or "auto_X" with a finite X > 0 ("auto_" and "auto_inf" crash inside SB3)
        ok = head == "auto" and (not sep or (math.isfinite(float(start)) and float(start) > 0.0))
    except ValueError:
        ok = False
    if not ok:
        raise ValueError(f"hyperparameter ent_coef must be a number >= 0, 'auto' or 'auto_X' with X > 0 (got {ent!r})")


def _check_off_policy(algo: str, p: Mapping[str, Any], n_envs: int) -> int:
    """SAC's and TD3's ranges; returns the transitions SB3 collects between two updates (train_freq vector steps
    of n_envs; one vector step for an episode-counted train_freq)."""
    buffer_size = _integer("buffer_size", p["buffer_size"], 1, MAX_BUFFER_SIZE)
    _batch_size(p["batch_size"], 1, buffer_size, f"buffer_size = {buffer_size}", "--set batch_size=N")
    if "tau" in p:
        _number("tau", p["tau"], 0.0, 1.0, low_open=True)
    freq, unit = p.get("train_freq", 1), "step"
    if isinstance(freq, (list, tuple)):
        if len(freq) != 2 or freq[1] not in ("step", "episode"):
            raise ValueError(f"hyperparameter train_freq must be an integer >= 1 or [N, step|episode] (got {freq!r})")
        freq, unit = freq
    freq = _integer("train_freq", freq, 1, 10**9)
    if algo == "sac" and p.get("ent_coef") is not None:
        _check_sac_ent_coef(p["ent_coef"])
    return n_envs * (freq if unit == "step" else 1)


def check_hyperparams(algo: str, params: Mapping[str, Any], n_envs: Any, timesteps: int) -> dict[str, Any]:
    """Refuse (``ValueError`` naming the key and its range) values that crash SB3 or train nonsense: ``gamma``
    in (0, 1], ``gae_lambda`` in [0, 1], ``clip_range`` > 0, ``ent_coef`` >= 0 (SAC: or ``auto`` / ``auto_X``),
    ``tau`` in (0, 1], ``train_freq`` >= 1, ``learning_starts`` >= 0, ``batch_size`` in [2, n_steps x n_envs]
    (PPO) or [1, buffer_size] (SAC/TD3), at most ``MAX_BATCH_SIZE``. Returns notes for the run's config:
    ``timesteps_effective`` (the steps SB3 runs: PPO whole rollouts of n_steps x n_envs transitions, SAC/TD3
    whole collections of train_freq x n_envs) and warnings (SAC/TD3 ``learning_starts`` >= ``timesteps``: never
    updated)."""
    p = {**SB3_DEFAULTS[algo], **params}
    n_envs = _integer("n_envs", n_envs, 1, 4096)
    if "gamma" in p:
        _number("gamma", p["gamma"], 0.0, 1.0, low_open=True)
    if "learning_starts" in p:
        _integer("learning_starts", p["learning_starts"], 0, 10**12)
    chunk = _check_ppo(p, n_envs) if algo == "ppo" else _check_off_policy(algo, p, n_envs)
    notes: dict[str, Any] = {"timesteps_effective": -(-timesteps // chunk) * chunk, "warnings": []}
    if algo == "ppo" and notes["timesteps_effective"] != timesteps:
        notes["warnings"].append(f"PPO trains whole rollouts of n_steps x n_envs = {chunk} transitions: "
                                 f"--timesteps {timesteps} becomes {notes['timesteps_effective']}")
    if algo != "ppo" and p["learning_starts"] >= timesteps:
        notes["warnings"].append(f"learning_starts = {p['learning_starts']} >= --timesteps {timesteps}: the agent "
                                 "will never be updated (it stays the random initial policy)")
    return notes


def _schedule(name: str, value: Any) -> Any:
    """A number as is, or ``"lin_X"`` (rl-zoo's notation) as a schedule falling linearly from X to 0 over the run
    (SB3 calls it with the remaining progress, 1 -> 0)."""
    if not isinstance(value, str):
        return value
    head, _, number = value.partition("_")
    try:
        start = float(number)
    except ValueError:
        start = float("nan")
    if head != "lin" or not (start > 0.0 and start < 1e3):
        raise ValueError(f"{name} must be a number or 'lin_X' with X > 0, e.g. lin_3e-4 (got {value!r})")
    return lambda progress_remaining: progress_remaining * start


DAGGER_RECIPES: dict[str, dict[str, Any]] = {
    "vtrack/TrainingMixNominal-v0": {"expert": "lqr", "control": "steer_accel", "rounds": 8, "steps": 3000,
                                     "num_envs": 16},
    "vtrack/Race-v0": {"expert": "centreline", "expert_grip_scale": 0.7, "rounds": 12, "circuits_per_round": 6},
}
"""``vtrack train --algo dagger``'s recipes per training env id (``agents.dagger.dagger_recipe`` runs them;
``vtrack/Race-v0``: ``agents.race_dagger`` on the race split's training circuits): the shipped ``dagger_accel`` is
the first entry at seed 0, the shipped ``dagger_race_v2`` the second at seed 0 (the shipped ``dagger_race``: the
second at seed 0 on the smooth training circuits ``rc-0`` .. ``rc-23`` alone, before the corner circuits)."""
DAGGER_DEFAULT_ENV_ID = "vtrack/TrainingMixNominal-v0"
"""``--algo dagger``'s env without ``--env``."""

