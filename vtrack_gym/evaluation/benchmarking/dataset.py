"""Minari datasets of a policy's episodes, for offline RL and imitation learning (the ``dataset`` extra).

``write_dataset("mpc", suite="paper", episodes=2)`` drives the policy (any ``vtrack_gym.make_policy`` spec: a
baseline, a preset, a shipped agent, an agent file) deterministically through the episodes and writes one Minari
dataset per env id, locally (under ``root``, else Minari's own folder: ``$MINARI_DATASETS_PATH`` or
``~/.minari/datasets``); nothing is downloaded. Dataset ids are ``vtrack/<env name>/<name>-v0``
(``vtrack/DLC120/mpc-paper-v0``).

Each dataset records the env's Gymnasium spec (id, entry point and keyword arguments), so
``minari.load_dataset(id).recover_environment()`` makes the same env (with ``vtrack_gym`` installed), and each
episode its reset seed and options (``options`` holds the suite's perturbations, e.g. the ``robust`` suite's
friction): resetting the recovered env with them and replaying the actions reproduces the observations.
Observations are the env's flat ``Box`` (names: ``env.unwrapped.observation_layout``), actions the steering
command as a fraction of the road-wheel limit.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import warnings
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vtrack_gym.evaluation.rollouts.rollout import step_action
from vtrack_gym.evaluation.suite.suites import Episode, get_suite, suite_names, with_vehicle

log = logging.getLogger(__name__)

NAMESPACE = "vtrack"
"""Minari namespace of the datasets this module writes."""
MAX_EPISODES = 10_000
"""Most episodes per env of one ``write_dataset`` call."""


def dataset_suites() -> tuple[str, ...]:
    """The registered suites ``write_dataset`` records (``Suite.dataset``: their episodes drive this package's own
    envs; ``highway`` drives highway-env's)."""
    return tuple(n for n in suite_names() if get_suite(n).dataset)


START_SPREAD: dict[str, float] = {"initial_lateral_offset_m": 0.2, "initial_heading_error_rad": 0.01}
"""Half-widths of the start each dataset episode draws from its seed (uniform): offset from the path [m], heading
error [rad]. The nominal scenarios are deterministic, so without it every seed would record the same episode."""


def start_options(seed: int) -> dict[str, float]:
    """The start of a dataset episode drawn from ``seed`` (``START_SPREAD``), as reset options."""
    rng = np.random.default_rng([seed, 0x5EED])
    return {k: round(float(rng.uniform(-half, half)), 4) for k, half in START_SPREAD.items()}


def _with_start(episode: Episode) -> Episode:
    """``episode`` with its seed's start, unless its options already set one (a suite's own perturbation wins)."""
    from dataclasses import replace

    drawn = {k: v for k, v in start_options(episode.seed).items() if k not in episode.options}
    return replace(episode, options={**episode.options, **drawn})


def dataset_episodes(suite: str | None = None, env: str | None = None, episodes: int = 1, seed: int = 0,
                     vehicle: str | None = None) -> dict[str, list[Episode]]:
    """The episodes to record, grouped by env id: ``episodes`` seeds from ``seed`` on, of every scenario of
    ``suite`` (its perturbations drawn from each seed, as ``suite_episodes(suite, seeds=...)``) or on ``env``; every
    episode starts from its seed's draw (``start_options``), so distinct seeds are distinct episodes."""
    if (suite is None) == (env is None):
        raise ValueError("give exactly one of suite= (a suite name) or env= (an env id)")
    if isinstance(episodes, bool) or not isinstance(episodes, int) or not 1 <= episodes <= MAX_EPISODES:
        raise ValueError(f"episodes must be an integer in [1, {MAX_EPISODES}] (got {episodes!r})")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0 (got {seed!r})")
    seeds = range(seed, seed + episodes)
    if suite is not None:
        if suite not in dataset_suites():
            raise ValueError(f"suite must be one of {', '.join(dataset_suites())} (got {suite!r})")
        chosen = get_suite(suite).episodes_for(seeds=seeds)
    else:
        from vtrack_gym.envs.registration import ALL_ENV_IDS

        if env not in ALL_ENV_IDS:
            raise ValueError(f"env must be a registered vtrack env id: {', '.join(ALL_ENV_IDS)} (got {env!r})")
        chosen = [Episode(str(env), s) for s in seeds]
    grouped: dict[str, list[Episode]] = {}
    for ep in with_vehicle([_with_start(ep) for ep in chosen], vehicle):
        grouped.setdefault(ep.env_id, []).append(ep)
    return grouped


def dataset_id(env_id: str, name: str) -> str:
    """``vtrack/<env name>/<name>-v0``: the env id without namespace and version, ``name`` with every character
    outside ``[A-Za-z0-9_-]`` replaced by ``_``."""
    env_name = re.sub(r"-v\d+$", "", env_id.rsplit("/", 1)[-1])
    clean = re.sub(r"[^A-Za-z0-9_-]", "_", name).strip("-_") or "policy"
    return f"{NAMESPACE}/{re.sub(r'[^A-Za-z0-9_-]', '_', env_name)}/{clean}-v0"


def numeric_infos(infos: Sequence[dict[str, Any]]) -> dict[str, np.ndarray]:
    """The ``info`` keys present in every step with a number, a bool or a fixed-shape numeric array, stacked over
    the steps (text such as ``termination`` is left out: the flags and ``success`` carry the outcome)."""
    keys = set(infos[0]).intersection(*infos[1:])
    stacked: dict[str, np.ndarray] = {}
    for key in sorted(keys):
        values = [np.asarray(info[key]) for info in infos]
        if all(v.dtype.kind in "biuf" and v.shape == values[0].shape for v in values):
            stacked[key] = np.stack(values)
    return stacked


def record_episode(env: Any, policy: Any, episode: Episode) -> Any:
    """One deterministic episode of ``policy`` on ``env`` as a Minari ``EpisodeBuffer`` (seed, options and the
    numeric ``info`` of the reset and of every step kept, ``numeric_infos``)."""
    from minari.data_collector import EpisodeBuffer

    obs, info = env.reset(seed=episode.seed, options=episode.options or None)
    observations, actions, rewards, terminations, truncations, infos = [obs], [], [], [], [], [info]
    terminated = truncated = False
    while not (terminated or truncated):
        action, _ = policy.predict(obs, deterministic=True)
        action = step_action(action, env.action_space.shape)
        obs, reward, terminated, truncated, info = env.step(action)
        observations.append(obs)
        actions.append(action)
        rewards.append(float(reward))
        terminations.append(bool(terminated))
        truncations.append(bool(truncated))
        infos.append(info)
    return EpisodeBuffer(seed=episode.seed, options=dict(episode.options) or None,
                         observations=np.stack(observations), actions=np.stack(actions), rewards=rewards,
                         terminations=terminations, truncations=truncations, infos=numeric_infos(infos))


@contextlib.contextmanager
def _datasets_root(root: str | Path | None) -> Iterator[None]:
    """Minari's datasets folder set to ``root`` for the duration (Minari reads ``MINARI_DATASETS_PATH``)."""
    if root is None:
        yield
        return
    before = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(Path(root).resolve())
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("MINARI_DATASETS_PATH", None)
        else:
            os.environ["MINARI_DATASETS_PATH"] = before


def _write(ds_id: str, buffers: Sequence[Any], env: Any, policy: str, description: str) -> None:
    """Create the Minari dataset ``ds_id`` from ``buffers`` with ``env``'s spec: written in a private temporary
    datasets folder next to its place, then renamed into place complete (a write that fails or is killed midway
    leaves only a hidden ``.vtrack-writing-*`` folder, which never blocks a rerun)."""
    import shutil
    import tempfile

    import minari
    from minari.storage.datasets_root_dir import get_dataset_path

    from vtrack_gym._version import __version__

    final = get_dataset_path(ds_id)
    root = get_dataset_path()
    staging = Path(tempfile.mkdtemp(dir=root, prefix=".vtrack-writing-"))
    try:
        with _datasets_root(staging), warnings.catch_warnings():  # no e-mail: the package is the code permalink
            warnings.filterwarnings("ignore", message=".*author_email.*", category=UserWarning)
            minari.create_dataset_from_buffers(
                ds_id, list(buffers), env=env.spec, algorithm_name=policy, author="vtrack_gym",
                code_permalink="https://github.com/vtrack-gym/vtrack_gym", description=description,
                requirements=[f"vtrack_gym=={__version__}"], eval_env=env.spec)
            written = get_dataset_path(ds_id)
        final.parent.mkdir(parents=True, exist_ok=True)
        os.rename(written, final)   # fails if another process wrote this id meanwhile (never overwritten)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _check_new(ds_ids: Sequence[str]) -> None:
    """``ValueError`` if any of ``ds_ids`` already exists (Minari never overwrites a dataset)."""
    from minari.storage.datasets_root_dir import get_dataset_path

    taken = [i for i in ds_ids if get_dataset_path(i).exists()]
    if taken:
        raise ValueError(f"Minari datasets {', '.join(taken)} already exist in {get_dataset_path()}: choose another "
                         "name= (or delete them with `minari delete`)")


def write_dataset(policy: str, *, suite: str | None = None, env: str | None = None, episodes: int = 1,
                  seed: int = 0, name: str | None = None, root: str | Path | None = None,
                  vehicle: str | None = None, progress: bool = False, trust_code: bool = False,
                  policy_kwargs: dict[str, Any] | None = None) -> list[str]:
    """Record ``policy``'s episodes on ``suite`` or ``env`` (``dataset_episodes``) and write one Minari dataset
    per env id (``dataset_id(env_id, name)``; ``name`` default ``<policy>-<suite or 'env'>``) under ``root``.
    ``policy``: any spec ``make_policy`` takes; ``trust_code``/``policy_kwargs``: a ``MODULE:NAME`` policy of your
    own code and its keyword arguments. Returns the dataset ids. The policy and every dataset id are checked before
    the first episode is driven."""
    import gymnasium as gym

    from vtrack_gym._version import __version__
    from vtrack_gym.baselines.resolve import policy_factory

    if root is not None:
        from vtrack_gym._io import check_output_dir

        check_output_dir(root, "root")
    grouped = dataset_episodes(suite, env, episodes, seed, vehicle)
    make = policy_factory(policy, trust_code=trust_code, policy_kwargs=policy_kwargs)
    name = name if name is not None else f"{policy}-{suite or 'env'}"
    ids = {env_id: dataset_id(env_id, name) for env_id in grouped}
    written = []
    with _datasets_root(root):
        _check_new(list(ids.values()))
        for env_id, eps in grouped.items():
            made = gym.make(env_id, **eps[0].make_kwargs)
            try:
                agent = make(made)
                buffers = [record_episode(made, agent, ep) for ep in _progress(eps, env_id, progress)]
                description = (f"{policy} (deterministic) on {env_id}: {len(eps)} episodes, seeds {eps[0].seed}-"
                               f"{eps[-1].seed}{f', suite {suite}' if suite else ''}; vtrack_gym {__version__}. "
                               f"Observations: {', '.join(made.unwrapped.observation_layout.names)}.")
                _write(ids[env_id], buffers, made, policy, description)
            finally:
                made.close()
            log.info("wrote Minari dataset %s (%d episodes, %d steps)", ids[env_id], len(buffers),
                     sum(len(b.rewards) for b in buffers))
            written.append(ids[env_id])
    return written


def _progress(items: list[Episode], label: str, show: bool) -> Any:
    """``items`` with a tqdm bar when ``show``."""
    if not show:
        return items
    from vtrack_gym._progress import progress_bar

    return progress_bar(items, desc=label, unit="episode")
