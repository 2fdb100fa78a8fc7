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

from vtrack_gym.evaluation.benchmark import episode_scorer
from vtrack_gym.evaluation.fingerprint import named_policy_hash, policy_hash
from vtrack_gym.evaluation.rollout import policy_id_of
from vtrack_gym.evaluation.store import ResultRow, ResultStore, StoreError
from vtrack_gym.evaluation.suites import SUITES, Episode, suite_episodes, suite_label, with_vehicle

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
        return suite_episodes(suite_or_env, seeds=seeds), suite_label(suite_or_env, seeds=seeds)
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


UNIDENTIFIED = " [unidentified configuration]"
"""Appended to the env id of an env instance whose configuration cannot be recorded: its rows never share a
leaderboard entry with the standard env's."""
_RENDER_KWARGS = frozenset({"render_mode", "render_fps", "render_view"})
"""Make arguments that change how an env is shown, not how it drives."""


def _equal(a: Any, b: Any) -> bool:
    """``a == b`` as one bool (False when the comparison is ambiguous, e.g. two arrays)."""
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


def _jsonable(value: Any) -> Any:
    """``value`` as JSON data (dataclasses as dicts, tuples as lists); ``TypeError`` when it cannot be written."""
    import dataclasses
    import json

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    return json.loads(json.dumps(value, allow_nan=False, default=_no_json))


def _no_json(value: Any) -> Any:
    raise TypeError(f"{type(value).__name__} is not JSON data")


def _vehicle_of(config: Any, make_vehicle: Any) -> str | None:
    """What a row records of an env's car (``benchmark.vehicle_label``): from the make argument when it is a name or
    a file, else from the parameters (a shipped car's name, or ``params-<sha256[:10]>`` of them)."""
    import hashlib
    import json
    import os

    from vtrack_gym.evaluation.benchmark import vehicle_label
    from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle
    from vtrack_gym.vehicle.params import VehicleParams

    if isinstance(make_vehicle, (str, os.PathLike)):
        return vehicle_label(str(make_vehicle))
    params = config.vehicle
    if params == VehicleParams():
        return None
    for name in list_vehicles():
        if load_vehicle(name) == params:
            return name
    text = json.dumps(_jsonable(params), sort_keys=True)
    return f"params-{hashlib.sha256(text.encode()).hexdigest()[:10]}"


def _track_provenance(scenario: Any) -> tuple[str | None, dict[str, Any]] | None:
    """(env id or None, options) recording a scenario's own track, speed profile and half width, as
    ``vtrack eval --track`` does for a track file; None when the track cannot be identified."""
    import dataclasses
    import os

    from vtrack_gym.tracks import Path as TrackPath
    from vtrack_gym.tracks.sources import path_digest

    options: dict[str, Any] = {}
    env_id = None
    source = scenario.track
    track = source.track
    profile = scenario.speed_profile
    params = None if profile is None else {"kind": type(profile).__name__, **dataclasses.asdict(profile)}
    if isinstance(track, (str, os.PathLike)) and Path(track).is_file():
        from vtrack_gym.envs.registration import register_track

        env_id, options = register_track(track, profile, source.closed, source.smoothing_m,
                                         source.allow_self_crossing, source.track_options)
    elif isinstance(track, str):
        options = {"track": track, "speed_profile": params}
    elif isinstance(track, TrackPath):
        options = {"track_path_sha256": path_digest(track), "speed_profile": params}
    else:
        return None
    if source.half_width_m is not None:
        options["half_width_m"] = float(source.half_width_m)
    return env_id, options


def env_identity(env: gym.Env) -> tuple[str, dict[str, Any]]:
    """The env id and options a row of ``env`` (an instance) records, so different cars, tracks, speed profiles
    and configurations never share a leaderboard entry.

    Read from ``env.spec`` (id, make arguments, time limit, wrappers) and, for this package's envs, the resolved
    scenario and config: the car as ``options["vehicle"]`` (``benchmark.vehicle_label``), a track file as
    ``vtrack eval --track`` records it (its registered id, SHA-256 and speed profile), another track by name or
    path digest, config fields that differ from the defaults as ``options["env_config"]``, a changed time limit,
    added wrappers. An env whose configuration cannot be recorded gets ``<id> [unidentified configuration]``.
    """
    from gymnasium.envs.registration import registry

    spec = getattr(env, "spec", None)
    unwrapped = env.unwrapped
    if spec is None or spec.id not in registry:
        return (spec.id if spec is not None else type(unwrapped).__name__) + UNIDENTIFIED, {}
    registered = registry[spec.id]
    env_id = spec.id
    options: dict[str, Any] = {}
    if spec.max_episode_steps != registered.max_episode_steps:
        options["max_episode_steps"] = spec.max_episode_steps
    try:
        if spec.additional_wrappers:
            options["wrappers"] = [{"name": w.name, "kwargs": _jsonable(w.kwargs or {})}
                                   for w in spec.additional_wrappers]
    except TypeError:
        return env_id + UNIDENTIFIED, {}
    from vtrack_gym.envs.tracking_env import TrackingEnv

    if not isinstance(unwrapped, TrackingEnv):
        extra = {k: v for k, v in spec.kwargs.items()
                 if k not in _RENDER_KWARGS and not (k in registered.kwargs and _equal(registered.kwargs[k], v))}
        try:
            if extra:
                options["env_kwargs"] = _jsonable(extra)
        except TypeError:
            return env_id + UNIDENTIFIED, {}
        return env_id, options
    return _tracking_identity(unwrapped, spec, env_id, options)


def _tracking_identity(unwrapped: Any, spec: Any, env_id: str,
                       options: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """``env_identity`` of this package's ``TrackingEnv``: scenario, track, car and config against the defaults."""
    import dataclasses

    from vtrack_gym.envs.config import EnvConfig
    from vtrack_gym.envs.scenarios import resolve_scenario, with_protocol
    from vtrack_gym.envs.track_sources import READ_KWARGS
    from vtrack_gym.evaluation.track_benchmark import check_driven
    from vtrack_gym.tracks.sources import source_digest

    scenario_arg = spec.kwargs.get("scenario")
    if not isinstance(scenario_arg, str):  # a Scenario object: not recorded
        return env_id + UNIDENTIFIED, {}
    scenario = resolve_scenario(scenario_arg, spec.kwargs.get("track"), spec.kwargs.get("speed_profile"),
                                spec.kwargs.get("half_width_m"), spec.kwargs.get("closed"),
                                spec.kwargs.get("smoothing_m"), {k: spec.kwargs.get(k) for k in READ_KWARGS})
    base = resolve_scenario(scenario.name)
    protocol = {k: spec.kwargs[k] for k in ("entry_speed_kmh", "reference") if spec.kwargs.get(k) is not None}
    if protocol:   # the standard ids' entry speed / reference line: recorded, so two settings never share a row
        scenario = with_protocol(scenario, unwrapped.config.vehicle, **protocol)
        applied = with_protocol(base, unwrapped.config.vehicle, **protocol)
        if not _equal(applied, base):
            options["protocol"] = _jsonable(protocol)
        base = applied
    track_fields = ("track", "speed")   # the parts make kwargs replace (track=, speed_profile=, ...)
    for f in dataclasses.fields(scenario):
        if f.name not in track_fields and not _equal(getattr(scenario, f.name), getattr(base, f.name)):
            return env_id + UNIDENTIFIED, {}
    if not all(_equal(getattr(scenario, f), getattr(base, f)) for f in track_fields):
        found = _track_provenance(scenario)
        if found is None:
            return env_id + UNIDENTIFIED, {}
        check_driven(source_digest(tuple(unwrapped.paths)), found[1])   # the file still holds what the env drives
        env_id = found[0] or env_id
        options.update(found[1])
    config, default = unwrapped.config, EnvConfig()
    label = _vehicle_of(config, spec.kwargs.get("vehicle", getattr(config, "vehicle", None)))
    changed: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if f.name == "vehicle" or _equal(value, getattr(default, f.name)):
            continue
        try:
            changed[f.name] = _jsonable(value)
        except TypeError:
            return env_id + UNIDENTIFIED, {}
    if changed:
        options["env_config"] = changed
    if label is not None:
        options["vehicle"] = label
    return env_id, options


def evaluate(policy_or_factory: Any, suite_or_env: str | gym.Env = "paper", seeds: Sequence[int] | None = None,
             *, store: str | Path | ResultStore | None = None, vecnormalize: Any = None,
             policy_id: str | None = None, vehicle: str | None = None, workers: int | None = 1,
             backend: str = "local") -> list[ResultRow]:
    """Score a policy; one ``ResultRow`` per episode (``row.metrics``: the leaderboard's metrics).

    ``policy_or_factory``: an object with ``predict(obs, state=None, episode_start=None, deterministic=True)``
    (any vtrack policy, an SB3 model, your own class), or a callable ``make(env) -> policy`` called once per
    episode. ``suite_or_env``: a suite name (``paper``, ``robust``, ``highway``: its episodes, or the suite's
    envs at ``seeds``), an env id (``seeds``, default ``[0]``) or a Gymnasium env instance (driven as given).
    ``vecnormalize``: SB3 ``VecNormalize`` statistics the policy was trained with (observations are normalised
    with them before ``predict``). ``store``: a leaderboard file (or ``ResultStore``) the rows are added to.
    ``policy_id``: the name in the rows (default: ``policy.policy_id`` or the class name). ``vehicle``: the car of
    a suite's or an env id's episodes (a name of ``vehicle.list_vehicles()`` or a vehicle file; default the paper's
    car), recorded in the rows' ``options`` (an env instance is driven with its own car, track and config, recorded
    by ``env_identity``). ``workers`` / ``backend``: run a suite's or an env id's episodes in local processes or on
    Ray (``vtrack_gym.evaluation.parallel.run_tasks``; the same rows as ``workers=1``; the factory must be
    picklable for Ray). Rank the rows with ``leaderboard(rows)``, alone or with other rows of the same suite.
    """
    _check_seeds(seeds)
    from vtrack_gym.evaluation.parallel import check_workers

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
    if isinstance(suite_or_env, str):
        found, suite = _episodes(suite_or_env, seeds)
        episodes = list(with_vehicle(found, vehicle))
    elif isinstance(suite_or_env, gym.Env):
        if vehicle is not None:
            raise ValueError("vehicle applies to a suite name or an env id; an env instance drives its own car")
        env_id, identity = env_identity(suite_or_env)
        if UNIDENTIFIED in env_id:
            log.warning("the configuration of this env instance cannot be recorded; its rows are stored as %r, "
                        "apart from the standard env's", env_id)
    else:
        raise ValueError(f"suite_or_env must be a suite name ({', '.join(SUITES)}), an env id or a gymnasium.Env "
                         f"(got {type(suite_or_env).__name__})")
    result_store = _open_store(store)  # checked before the first rollout: a bad store loses no results
    from vtrack_gym.evaluation.track_benchmark import merge_provenance
    rows: list[ResultRow] = []
    if isinstance(suite_or_env, str) and (workers != 1 or backend != "local"):
        rows = _parallel_rows(make, episodes, suite, policy_id, workers, backend)
    elif isinstance(suite_or_env, str):
        for ep in episodes:
            env = gym.make(ep.env_id, **ep.make_kwargs)
            try:   # one policy per call: every row gets the first episode's fingerprint
                rows.append(_row(make, env, ep, suite, policy_id, rows[0].policy_hash if rows else None))
            finally:
                env.close()
    else:
        if workers != 1 or backend != "local":
            raise ValueError("workers and backend apply to a suite name or an env id; an env instance is driven "
                             "in this process")
        for s in seeds if seeds is not None else (0,):
            row = _row(make, suite_or_env, Episode(env_id, int(s)), CUSTOM_SUITE, policy_id,
                       rows[0].policy_hash if rows else None)
            rows.append(merge_provenance(row, identity))   # refuses a row that drove other content
    if result_store is not None:
        result_store.add(rows)
    return rows


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
    """One episode's row; ``digest``: the policy hash to record (None: the policy's own fingerprint)."""
    policy = make(env)
    if not hasattr(policy, "predict"):
        raise ValueError(f"the factory returned {type(policy).__name__}, which has no predict method")
    name = policy_id or policy_id_of(policy)
    if digest is None:   # a policy whose state cannot be read completely needs a policy_id naming it
        digest = named_policy_hash(policy, policy_id) if policy_id else policy_hash(policy)
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


def _parallel_rows(make: Callable[[Any], Any], episodes: Sequence[Episode], suite: str, policy_id: str | None,
                   workers: int | None, backend: str) -> list[ResultRow]:
    """``episodes`` scored by ``parallel.run_tasks``; every row gets the first episode's fingerprint, as in the
    serial loop. The rows' policy id is ``policy_id`` or that of a policy built once here for the first env."""
    import functools

    from vtrack_gym.evaluation.parallel import EpisodeTask, run_tasks

    checked = functools.partial(_checked_policy, make)
    name = policy_id
    if name is None:
        env = gym.make(episodes[0].env_id, **episodes[0].make_kwargs)
        try:
            name = policy_id_of(checked(env))
        finally:
            env.close()
    score = episode_scorer(suite, checked)
    results = run_tasks([EpisodeTask(name, checked, ep, suite, score) for ep in episodes], workers, backend)
    rows = [row for row, _ in results]
    return [dataclasses.replace(r, policy_hash=rows[0].policy_hash) for r in rows]


@dataclasses.dataclass(frozen=True)
class Board:
    """A ranked board (``entries``: ``evaluation.board`` entries with ``Estimate`` means), the rows it aggregates
    (``rows``) and every row of its suite (``suite_rows``; ``figure_runs`` compares the two)."""

    suite: str
    entries: list[dict[str, Any]]
    rows: list[dict[str, Any]]
    suite_rows: list[dict[str, Any]]


def _as_records(rows: Sequence[Any], suite: str | None) -> tuple[str, list[dict[str, Any]]]:
    """(suite, records) of result rows (``ResultRow`` or stored dicts); ``suite`` selects one when they mix."""
    from vtrack_gym.evaluation.benchmark import row_record

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
    from vtrack_gym.evaluation.benchmark import suite_columns
    from vtrack_gym.evaluation.board import build_board
    from vtrack_gym.evaluation.suites import primary_metric
    from vtrack_gym.evaluation.track_benchmark import is_track_set, track_set_board

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
    entries = track_set_board(rows, cols, primary) if is_track_set(suite) else build_board(rows, cols, primary)
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
    from vtrack_gym.evaluation.report_formats import expand_estimates

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
