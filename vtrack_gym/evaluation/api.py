"""``evaluate``: score any policy (an object with SB3's ``predict``, or a factory) on a suite or an env.

This is ``vtrack_gym.evaluate`` and what ``vtrack eval`` runs, so both give the same rows.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from vtrack_gym.evaluation.benchmarking.benchmark import episode_scorer
from vtrack_gym.evaluation.identity.env_identity import UNIDENTIFIED, env_identity
from vtrack_gym.evaluation.identity.env_names import canonical_env_id
from vtrack_gym.evaluation.identity.fingerprint import named_policy_hash, policy_hash
from vtrack_gym.evaluation.rollouts.episode_failure import in_episode
from vtrack_gym.evaluation.rollouts.rollout import policy_id_of
from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.storage.commit import RowCommit, raise_if_not_stored
from vtrack_gym.evaluation.storage.store import ResultStore, StoreError
from vtrack_gym.evaluation.suite.suites import (
    Episode,
    suite_episodes,
    suite_label,
    suite_names,
    with_control,
    with_latency,
    with_launch,
    with_numerics,
    with_vehicle,
)

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
    if suite_or_env in suite_names():
        return suite_episodes(suite_or_env, seeds=seeds), suite_label(suite_or_env, seeds=seeds)
    from gymnasium.envs.registration import registry

    from vtrack_gym.interop import resolve_env_id

    env_id = resolve_env_id(suite_or_env)
    if env_id not in registry:
        import vtrack_gym.envs.registration as reg

        raise ValueError(f"unknown suite or env {suite_or_env!r}; suites: {', '.join(suite_names())}; vtrack envs: "
                         f"{', '.join(reg.ENV_IDS)}, highway-env:lane-keeping-v0")
    env_id = canonical_env_id(env_id)   # an alias is one scenario with its id: one row
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
             policy_id: str | None = None, vehicle: str | None = None, workers: int | None = 1,
             backend: str = "local", latency: str | float | None = None,
             control: str | None = None, launch: str | None = None, numerics: str | None = None,
             finish: Callable[[ResultRow], ResultRow] | None = None) -> list[ResultRow]:
    """Score a policy; one ``ResultRow`` per episode (``row.metrics``: the leaderboard's metrics).

    ``policy_or_factory``: an object with ``predict(obs, state=None, episode_start=None, deterministic=True)``
    (any vtrack policy, an SB3 model, your own class), or a callable ``make(env) -> policy`` called once per
    episode. ``suite_or_env``: a registered suite's name (``suites.suite_names()``: its episodes, or its episodes at
    ``seeds``), an env id (``seeds``, default ``[0]``) or a Gymnasium env instance (driven as given).
    ``vecnormalize``: SB3 ``VecNormalize`` statistics the policy was trained with (observations are normalised
    with them before ``predict``). ``store``: a leaderboard file (or ``ResultStore``) the rows are added to, each as its
    episode ends (``storage.commit.RowCommit``, the path ``vtrack eval`` and ``vtrack benchmark`` use; also with
    ``workers``/``backend``: the policy's fingerprint is taken before the first episode starts, so an episode that
    finished is stored whatever happens to the later ones). An error in an episode ends the run with its own type,
    marked with its episode (``episode_failure.episode_of``) and with what was stored (``commit.stored_line_of``).
    A store that fails during the run (a full disk) stops the storing, not the run: the remaining episodes run and
    ``commit.RowsNotStored`` (a ``StoreError`` holding every row) is raised at the end.
    ``policy_id``: the name in the rows (default: ``policy.policy_id`` or the class name). ``vehicle``: the car of
    a suite's or an env id's episodes (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's
    car), recorded in the rows' ``options`` (an env instance is driven with its own car, track and config, recorded
    by ``env_identity``). ``workers`` / ``backend``: run a suite's or an env id's episodes in local processes or on
    Ray (``vtrack_gym.evaluation.rollouts.parallel.run_tasks``; the same rows as ``workers=1``; the factory must be
    picklable for Ray). ``latency``: charge each decision's compute in the loop (``envs.latency``: ``"measured"``,
    the policy call's time, or a fixed budget in seconds), recorded in the rows' options and ranked apart from the
    ideal rows. ``control``: the control mode of a suite's or an env id's episodes (``envs.control``; default
    ``steer``), recorded in the rows' ``options["control"]`` (an env instance drives in its own mode, recorded by
    ``env_identity``). ``launch``: how the reference of an env id's episodes leaves a standing start
    (``envs.launch``: ``"powertrain"`` in a longitudinal mode), recorded in the rows' options. ``numerics``: the
    plant kernel of a suite's or an env id's episodes (``vehicle.numerics``: ``"default"``, pinned, or ``"fast"``,
    SIMD), recorded in the rows' ``options["env_config"]`` when not the default, so the modes rank apart.
    ``finish``: applied to each row as its episode ends, before it is stored and returned (e.g.
    ``track_benchmark.merge_provenance`` with a track file's provenance; an error it raises ends the run, the rows
    stored before it stay). Rank the rows with ``leaderboard(rows)``, alone or with other rows of the same suite.
    """
    _check_seeds(seeds)
    from vtrack_gym.evaluation.rollouts.parallel import check_workers

    check_workers(workers, backend)
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
    episodes: list[Episode] = []      # what to run, all checked before the store is opened or created
    env, identity = None, None
    if isinstance(suite_or_env, str):
        from vtrack_gym.vehicle.catalog import read_vehicle_once

        found, suite = _episodes(suite_or_env, seeds)
        episodes = with_numerics(with_launch(with_control(
            with_latency(with_vehicle(found, read_vehicle_once(vehicle)), latency), control), launch), numerics)
    elif isinstance(suite_or_env, gym.Env):
        if vehicle is not None or control is not None or launch is not None or numerics is not None:
            raise ValueError("vehicle, control, launch and numerics apply to a suite name or an env id; an env "
                             "instance drives its own car in its own control mode with its own plant "
                             "(gym.make(..., vehicle=..., control=..., numerics=...))")
        if workers != 1 or backend != "local":
            raise ValueError("workers and backend apply to a suite name or an env id; an env instance is driven "
                             "in this process")
        env, suite = suite_or_env, CUSTOM_SUITE
        env_id, identity = env_identity(env)
        if UNIDENTIFIED in env_id:
            log.warning("the configuration of this env instance cannot be recorded; its rows are stored as %r, "
                        "apart from the standard env's", env_id)
        episodes = [with_latency([Episode(env_id, int(s))], latency)[0] for s in (seeds if seeds is not None else (0,))]
    else:
        raise ValueError(f"suite_or_env must be a suite name ({', '.join(suite_names())}), an env id or a "
                         f"gymnasium.Env (got {type(suite_or_env).__name__})")
    commit = RowCommit(_open_store(store), finish, len(episodes))  # the store checked before the first rollout
    try:
        if env is not None:
            _env_rows(make, env, episodes, identity, policy_id, commit)
        elif workers != 1 or backend != "local":
            _parallel_rows(make, episodes, suite, policy_id, workers, backend, commit)
        else:
            _serial_rows(make, episodes, suite, policy_id, commit)
    except BaseException as exc:   # what was stored, for whoever reports the failure
        commit.mark_stopped(exc)
        raise
    raise_if_not_stored(commit)
    return commit.ordered()


def _first_hash(commit: RowCommit) -> str | None:
    """The fingerprint every row of one call records: the first episode's (None before it ends)."""
    return commit.rows[0].policy_hash if commit.rows else None


def _serial_rows(make: Callable[[Any], Any], episodes: Sequence[Episode], suite: str, policy_id: str | None,
                 commit: RowCommit) -> None:
    """``episodes`` in this process, each row handed to ``commit`` (finished, stored) as its episode ends."""
    for ep in episodes:
        env = gym.make(ep.env_id, **ep.make_kwargs)
        try:
            commit(_row(make, env, ep, suite, policy_id, _first_hash(commit)))
        finally:
            env.close()


def _env_rows(make: Callable[[Any], Any], env: gym.Env, episodes: Sequence[Episode], identity: Any,
              policy_id: str | None, commit: RowCommit) -> None:
    """``episodes`` (one per seed) driven on the env instance ``env``, each row with the env's identity
    (``identity``) and handed to ``commit`` as its episode ends."""
    from vtrack_gym.evaluation.benchmarking.track_benchmark import merge_provenance

    for ep in episodes:
        row = _row(make, env, ep, CUSTOM_SUITE, policy_id, _first_hash(commit))
        commit(merge_provenance(row, identity))   # refuses a row that drove other content


def _open_store(store: str | Path | ResultStore | None) -> ResultStore | None:
    """The store ``evaluate`` adds its rows to, opened and checked writable now (``StoreError`` if it cannot be:
    a directory, a file that is not a store, a read-only file or folder)."""
    if store is None:
        return None
    if isinstance(store, ResultStore):
        if store.read_only:
            raise StoreError(f"the store {store.path} was opened read-only; pass ResultStore(path) or a path")
        return store
    if not isinstance(store, (str, Path)):
        raise ValueError(f"store must be a path or a ResultStore (got {type(store).__name__})")
    return ResultStore(store)


def _row(make: Callable[[Any], Any], env: gym.Env, ep: Episode, suite: str, policy_id: str | None,
         digest: str | None = None) -> ResultRow:
    """One episode's row; ``digest``: the policy hash to record (None: the policy's own fingerprint). An error
    raised on the way names the episode (``episode_failure.in_episode``)."""
    with in_episode(policy_id or "the factory's policy", ep.env_id, ep.seed):
        policy = make(env)
        if not hasattr(policy, "predict"):
            raise ValueError(f"the factory returned {type(policy).__name__}, which has no predict method")
    name = policy_id or policy_id_of(policy)
    digest = digest or _fingerprint(policy, policy_id, env)   # before the episode: its refusal is no episode's
    with in_episode(name, ep.env_id, ep.seed):
        row, _ = episode_scorer(suite, make)(name, policy, env, ep, suite, digest)
    log.debug("%s on %s seed %s: %s, max |e_y| %.4g m", name, ep.env_id, ep.seed, row.termination,
              row.metrics.get("max_e_y_m", float("nan")))
    return row


def _checked_policy(make: Callable[[Any], Any], env: gym.Env) -> Any:
    """``make(env)``, refused when it has no ``predict`` (a module-level function: picklable for Ray)."""
    policy = make(env)
    if not hasattr(policy, "predict"):
        raise ValueError(f"the factory returned {type(policy).__name__}, which has no predict method")
    return policy


def _fingerprint(policy: Any, policy_id: str | None, env: gym.Env) -> str:
    """The policy hash a row records; a policy whose state cannot be read completely needs a ``policy_id``."""
    return named_policy_hash(policy, policy_id, env) if policy_id else policy_hash(policy, env)


def _first_identity(make: Callable[[Any], Any], episode: Episode, policy_id: str | None) -> tuple[str, str]:
    """``(policy id, policy hash)`` of the policy ``make`` builds for ``episode``'s env, taken before any episode
    runs, as the serial loop takes them from its first episode (a fresh env and a fresh policy)."""
    env = gym.make(episode.env_id, **episode.make_kwargs)
    try:
        policy = make(env)
        return policy_id or policy_id_of(policy), _fingerprint(policy, policy_id, env)
    finally:
        env.close()


def _parallel_rows(make: Callable[[Any], Any], episodes: Sequence[Episode], suite: str, policy_id: str | None,
                   workers: int | None, backend: str, commit: RowCommit) -> None:
    """``episodes`` scored by ``parallel.run_tasks``, each row handed to ``commit`` (finished, stored) as its
    episode ends, under its episode's index. Every row records the name and fingerprint taken before the first
    episode starts (``_first_identity``), so a row is complete when its episode ends and a later failure cannot
    lose it."""
    import functools

    from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask, run_tasks

    checked = functools.partial(_checked_policy, make)
    name, digest = _first_identity(checked, episodes[0], policy_id)
    score = functools.partial(episode_scorer(suite, checked), digest=digest)
    run_tasks([EpisodeTask(name, checked, ep, suite, score) for ep in episodes], workers, backend,
              on_result=lambda index, result: commit(result[0], index))   # a lost episode was logged
    if not commit.rows:
        raise ValueError(f"every episode of {name} was lost: its worker processes died (see the log)")


@dataclasses.dataclass(frozen=True)
class Board:
    """A ranked board (``entries``: ``evaluation.leaderboard.board`` entries with ``Estimate`` means), the rows it
    aggregates (``rows``) and every row of its suite (``suite_rows``; ``figure_runs`` compares the two)."""

    suite: str
    entries: list[dict[str, Any]]
    rows: list[dict[str, Any]]
    suite_rows: list[dict[str, Any]]


def _as_records(rows: Sequence[Any], suite: str | None) -> tuple[str, list[dict[str, Any]]]:
    """(suite, records) of result rows (``ResultRow`` or stored dicts); ``suite`` selects one when they mix."""
    from vtrack_gym.evaluation.benchmarking.benchmark import row_record

    records = [row_record(r) if isinstance(r, ResultRow) else dict(r) for r in rows]
    suites = sorted({str(r.get("suite")) for r in records})
    if suite is None:
        if len(suites) != 1:
            raise ValueError(f"the rows are of {len(suites)} suites ({', '.join(suites) or 'none'}); pass "
                             "suite=NAME to rank one of them")
        suite = suites[0]
    chosen = [r for r in records if r.get("suite") == suite]
    if not chosen:
        raise ValueError(f"no row of suite {suite!r}; the rows' suites: {', '.join(suites) or 'none'}")
    return suite, chosen


def board_of(source: Any, suite: str | None = None, latest_only: bool = True,
             columns: Sequence[str] | None = None) -> Board:
    """The ranked board of ``suite`` from a store (a path or ``ResultStore``, opened read-only from a path) or
    from result rows (``evaluate``'s ``ResultRow``s, or dicts); ``suite`` defaults to ``paper`` for a store and to
    the rows' one suite. A track set's suite (``tracks[...]``) ranks across all tracks first, then per track."""
    from vtrack_gym.evaluation.benchmarking.benchmark import suite_columns
    from vtrack_gym.evaluation.benchmarking.track_benchmark import is_track_set, track_set_board
    from vtrack_gym.evaluation.leaderboard.board import build_board
    from vtrack_gym.evaluation.suite.suites import primary_metric, then_metrics

    if isinstance(source, (str, Path, ResultStore)):
        store = source if isinstance(source, ResultStore) else _read_store(Path(source))
        suite = suite or "paper"
        present = store.suites()
        if suite not in present:
            raise ValueError(f"no suite {suite!r} in {store.path}; suites present: {', '.join(present) or 'none'}")
        suite_rows = store.rows(suite)
        rows = store.board_rows(suite, latest_only)
    elif isinstance(source, Sequence) and not isinstance(source, (bytes, bytearray)):
        suite, rows = _as_records(source, suite)
        suite_rows = rows
    else:
        raise ValueError(f"source must be a store (path or ResultStore) or a list of result rows (got "
                         f"{type(source).__name__})")
    cols = tuple(columns) if columns is not None else suite_columns(suite)
    primary = primary_metric(suite)
    entries = track_set_board(rows, cols, primary) if is_track_set(suite) else \
        build_board(rows, cols, primary, then_metrics(suite))
    return Board(suite, entries, rows, suite_rows)


def _read_store(path: Path) -> ResultStore:
    if not path.exists():
        raise ValueError(f"no store at {path}: run `vtrack benchmark` or evaluate(..., store=PATH) first")
    return ResultStore(path, read_only=True)


def leaderboard(source: Any, suite: str | None = None, *, columns: Sequence[str] | None = None,
                latest_only: bool = True, as_frame: bool = False) -> Any:
    """The ranked rows of ``suite``: a list of dicts with the columns of ``vtrack leaderboard --format json``
    (every mean ``name`` with its 95 % interval ``name_lo``, ``name_hi``; NaN where undefined), best first within
    each env; a pandas ``DataFrame`` of the same with ``as_frame=True`` (pandas must be installed).

    ``source``: a store file or ``ResultStore`` (opened read-only from a path; ``suite`` defaults to ``paper``;
    ``latest_only`` as ``ResultStore.leaderboard``), or result rows, e.g. ``evaluate(...)``'s, alone or joined
    with others of the same suite (``suite`` defaults to theirs). ``columns``: the metrics to aggregate (default:
    the suite's leaderboard columns).
    """
    from vtrack_gym.evaluation.leaderboard.report_formats import expand_estimates

    board = board_of(source, suite, latest_only, columns)
    rows = [{k: (float(v) if isinstance(v, float) else v) for k, v in expand_estimates(e).items()}
            for e in board.entries]
    if not as_frame:
        return rows
    try:
        import pandas as pd
    except ImportError as exc:
        raise ImportError("as_frame=True needs pandas: pip install pandas") from exc
    return pd.DataFrame(rows)
