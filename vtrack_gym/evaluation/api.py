"""``evaluate``: score any policy (an object with SB3's ``predict``, or a factory) on a suite or an env.

This is ``vtrack_gym.evaluate`` and what ``vtrack eval`` runs, so both give the same rows.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.evaluation.benchmark import score_episode
from vtrack_gym.evaluation.rollout import policy_id_of
from vtrack_gym.evaluation.store import ResultRow, ResultStore
from vtrack_gym.evaluation.suites import SUITES, Episode, suite_episodes, with_vehicle

log = logging.getLogger(__name__)

CUSTOM_SUITE = "custom"
"""Suite label of rows scored on an env (not on a named suite)."""


class NormalisedPolicy:
    """``policy`` fed observations normalised by SB3 ``VecNormalize`` statistics (``vecnormalize.normalize_obs``)."""

    def __init__(self, policy: Any, vecnormalize: Any) -> None:
        if not hasattr(vecnormalize, "normalize_obs"):
            raise ValueError(f"vecnormalize must have normalize_obs (an SB3 VecNormalize; got "
                             f"{type(vecnormalize).__name__})")
        self.policy = policy
        self.vecnormalize = vecnormalize
        self.policy_id = policy_id_of(policy)

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, Any]:
        obs = self.vecnormalize.normalize_obs(np.asarray(observation))
        return self.policy.predict(obs, state=state, episode_start=episode_start, deterministic=deterministic)


def _episodes(suite_or_env: str, seeds: Sequence[int] | None) -> tuple[list[Episode], str]:
    if suite_or_env in SUITES:
        return suite_episodes(suite_or_env, seeds=seeds), suite_or_env
    from gymnasium.envs.registration import registry

    from vtrack_gym.interop import resolve_env_id

    env_id = resolve_env_id(suite_or_env)
    if env_id not in registry:
        import vtrack_gym.envs.registration as reg

        raise ValueError(f"unknown suite or env {suite_or_env!r}; suites: {', '.join(SUITES)}; vtrack envs: "
                         f"{', '.join(reg.ENV_IDS)}, highway-env:lane-keeping-v0")
    return [Episode(env_id, int(s)) for s in (seeds if seeds is not None else (0,))], CUSTOM_SUITE


def _check_seeds(seeds: Sequence[int] | None) -> None:
    if seeds is None:
        return
    if isinstance(seeds, (int, np.integer)):
        raise ValueError(f"seeds must be a sequence of ints, e.g. seeds=[{seeds}] (got {seeds!r})")
    if not seeds or not all(isinstance(s, (int, np.integer)) and not isinstance(s, bool) and s >= 0 for s in seeds):
        raise ValueError(f"seeds must be a non-empty sequence of ints >= 0 (got {seeds!r})")


def evaluate(policy_or_factory: Any, suite_or_env: str | gym.Env = "paper", seeds: Sequence[int] | None = None,
             *, store: str | Path | ResultStore | None = None, vecnormalize: Any = None,
             policy_id: str | None = None, vehicle: str | None = None) -> list[ResultRow]:
    """Score a policy; one ``ResultRow`` per episode (``row.metrics``: the leaderboard's metrics).

    ``policy_or_factory``: an object with ``predict(obs, state=None, episode_start=None, deterministic=True)``
    (any vtrack policy, an SB3 model, your own class), or a callable ``make(env) -> policy`` called once per
    episode. ``suite_or_env``: a suite name (``paper``, ``robust``, ``highway``: its episodes, or the suite's
    envs at ``seeds``), an env id (``seeds``, default ``[0]``) or a Gymnasium env instance (driven as given).
    ``vecnormalize``: SB3 ``VecNormalize`` statistics the policy was trained with (observations are normalised
    with them before ``predict``). ``store``: a leaderboard file (or ``ResultStore``) the rows are added to.
    ``policy_id``: the name in the rows (default: ``policy.policy_id`` or the class name). ``vehicle``: the car of
    a suite's or an env id's episodes (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's
    car), recorded in the rows' ``options`` (an env instance is driven with its own car).
    """
    _check_seeds(seeds)
    if hasattr(policy_or_factory, "predict") and not isinstance(policy_or_factory, type):
        make: Callable[[Any], Any] = lambda env: policy_or_factory  # noqa: E731
    elif callable(policy_or_factory):
        make = policy_or_factory
    else:
        raise ValueError(f"policy_or_factory must have a predict method or be a callable make(env) -> policy "
                         f"(got {type(policy_or_factory).__name__})")
    if vecnormalize is not None:
        inner = make
        make = lambda env: NormalisedPolicy(inner(env), vecnormalize)  # noqa: E731
    rows: list[ResultRow] = []
    if isinstance(suite_or_env, str):
        episodes, suite = _episodes(suite_or_env, seeds)
        for ep in with_vehicle(episodes, vehicle):
            env = gym.make(ep.env_id, **ep.make_kwargs)
            try:
                rows.append(_row(make, env, ep, suite, policy_id))
            finally:
                env.close()
    elif isinstance(suite_or_env, gym.Env):
        if vehicle is not None:
            raise ValueError("vehicle applies to a suite name or an env id; an env instance drives its own car")
        spec = getattr(suite_or_env, "spec", None)
        env_id = spec.id if spec is not None else type(suite_or_env.unwrapped).__name__
        for s in seeds if seeds is not None else (0,):
            rows.append(_row(make, suite_or_env, Episode(env_id, int(s)), CUSTOM_SUITE, policy_id))
    else:
        raise ValueError(f"suite_or_env must be a suite name ({', '.join(SUITES)}), an env id or a gymnasium.Env "
                         f"(got {type(suite_or_env).__name__})")
    if store is not None:
        (store if isinstance(store, ResultStore) else ResultStore(store)).add(rows)
    return rows


def _row(make: Callable[[Any], Any], env: gym.Env, ep: Episode, suite: str, policy_id: str | None) -> ResultRow:
    policy = make(env)
    if not hasattr(policy, "predict"):
        raise ValueError(f"the factory returned {type(policy).__name__}, which has no predict method")
    name = policy_id or policy_id_of(policy)
    row, _ = score_episode(name, policy, env, ep, suite)
    log.debug("%s on %s seed %s: %s, max |e_y| %.4g m", name, ep.env_id, ep.seed, row.termination,
             row.metrics.get("max_e_y_m", float("nan")))
    return row
