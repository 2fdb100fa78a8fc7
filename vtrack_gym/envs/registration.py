"""Registration of the env ids with Gymnasium (called by ``import vtrack_gym``; imports nothing heavy).

The ids are generated from the scenario registry (``envs.scenarios.SCENARIOS``): ``vtrack/<name>`` per scenario,
plus the historical un-namespaced ids (``LEGACY_IDS``) as aliases with the same entry points and arguments, so
``gym.make("DLC120-v0")`` and ``gym.make("vtrack/DLC120-v0")`` give identical episodes.

``spec.max_episode_steps`` is the scenario's time limit in steps of its control period part (``None`` for
Track-v0, whose limit depends on the track). ``register_scenario`` adds a scenario of your own and
registers its id. The env truncates itself at the same step, so Gymnasium's
``TimeLimit`` wrapper never changes an episode; an env made with a shorter ``control_period_s`` should be made
with ``max_episode_steps=`` scaled accordingly (or ``None`` to leave the truncation to the env).
"""

from __future__ import annotations

import os
from typing import Any

from vtrack_gym.envs.circuits import CIRCUIT_IDS, circuit_setups
from vtrack_gym.envs.scenarios import LEGACY_IDS, SCENARIOS, Scenario

ENV_IDS: tuple[str, ...] = LEGACY_IDS
"""The paper scenarios' historical ids (aliases of ``vtrack/<id>``)."""
NAMESPACED_IDS: tuple[str, ...] = tuple(s.env_id for s in SCENARIOS.values())
"""Every registered ``vtrack/`` id, one per scenario (``vtrack/Track-v0`` takes ``track=``, ``speed_profile=``)."""
RECIPE_IDS: dict[str, tuple[str, dict[str, Any]]] = {
    "vtrack/TrainingMix20Hz-v0": ("TrainingMix-v0", {"control_period_s": 0.05})}
"""Training setups as ids: id -> (scenario, env settings). ``vtrack/TrainingMix20Hz-v0`` is the training mix at a
50 ms decision period (20 Hz), what the shipped ``ppo`` and ``sac`` agents were trained on."""
RACE_IDS: dict[str, dict[str, Any]] = {"vtrack/Race-v0": {}, "vtrack/RaceRing-v0": {"track": "ring.gpx"}}
"""Ids of the race (``envs.race_env.RaceEnv``) -> their make kwargs: N laps within track limits, the agent on the
pedals too; ``Race-v0`` on the handling course (or any closed track given as ``track=``), ``RaceRing-v0`` on the
shipped example ring (``tracks.example_maps``)."""
ALL_ENV_IDS: tuple[str, ...] = NAMESPACED_IDS + ENV_IDS + tuple(RECIPE_IDS) + CIRCUIT_IDS + tuple(RACE_IDS)
"""Every id this package registers for its own envs."""


def register_envs() -> None:
    """Register every id (idempotent)."""
    from gymnasium.envs.registration import register, registry

    by_id = {s.env_id: s for s in SCENARIOS.values()}
    by_id.update({name: SCENARIOS[name] for name in LEGACY_IDS})
    for env_id, scenario in by_id.items():
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point="vtrack_gym.envs.tracking_env:TrackingEnv",
            vector_entry_point="vtrack_gym.envs.vector_env:TrackingVectorEnv",
            kwargs={"scenario": scenario.name},
            max_episode_steps=scenario.max_episode_steps,
            disable_env_checker=False,
        )
    setups = dict(RECIPE_IDS) if all(c in registry for c in CIRCUIT_IDS) else {**RECIPE_IDS, **circuit_setups()}
    for env_id, (name, settings) in setups.items():
        if env_id not in registry:
            limit_s = SCENARIOS[name].time_limit_s
            period = settings.get("control_period_s", SCENARIOS[name].control_period_s)
            register(id=env_id, entry_point="vtrack_gym.envs.tracking_env:TrackingEnv",
                     vector_entry_point="vtrack_gym.envs.vector_env:TrackingVectorEnv",
                     kwargs={"scenario": name, **settings}, disable_env_checker=False,
                     max_episode_steps=None if limit_s is None else round(limit_s / period))
    for env_id, kwargs in RACE_IDS.items():
        if env_id not in registry:    # the time limit depends on the track and the car: the env truncates itself
            register(id=env_id, entry_point="vtrack_gym.envs.race_env:RaceEnv", kwargs=dict(kwargs),
                     max_episode_steps=None, disable_env_checker=False)


def register_scenario(scenario: Scenario) -> str:
    """Add ``scenario`` to the registry and register ``vtrack/<name>`` with Gymnasium; returns the id.

    ``ValueError`` when another scenario already has the name (a registered id's behaviour never changes)."""
    if not isinstance(scenario, Scenario):
        raise ValueError(f"register_scenario needs a Scenario (got {type(scenario).__name__})")
    known = SCENARIOS.get(scenario.name)
    if known is not None and known != scenario:
        raise ValueError(f"scenario {scenario.name!r} is already registered with other parts; give it a new name "
                         "or the next version (-v1)")
    SCENARIOS[scenario.name] = scenario
    register_envs()
    return scenario.env_id


def register_track(track_file: str | os.PathLike[str], speed_profile: Any, closed: bool | None = None,
                   smoothing_m: float | None = None, *, track_limits: str | None = None,
                   allow_self_crossing: bool = False,
                   track_options: dict[str, Any] | None = None) -> tuple[str, dict[str, Any]]:
    """Register ``vtrack/Track-<stem>-<key>-v0`` driving a track file with a speed profile (idempotent).

    ``key`` hashes the file's content and the profile's parameters (and ``closed`` / ``smoothing_m`` [m] /
    ``allow_self_crossing`` / ``track_options`` (format, route, lane, road_width_m), how the file is read, and
    ``track_limits``, where given), so two tracks with the same file name (or one track with two profiles or rules)
    get two ids and never mix on a leaderboard. Returns the id and the provenance to record with results:
    ``{"track_file", "track_sha256", "speed_profile": {"kind", parameters...}}`` plus ``"track_read": {"closed",
    "smoothing_m", ...}`` where any is given. ``track_limits``: the track-limit rule the env judges by (``"wheels"``,
    ``"body"`` or ``"centre"``; None: Track-v0's, the centre), in the key and the make kwargs; the provenance records
    it as ``"protocol": {"track_limits": rule}``. The id is registered in this process only (``make_vec`` in other
    processes needs ``Track-v0`` with ``track=``).
    """
    import hashlib
    import json
    import re
    from pathlib import Path as FsPath

    from vtrack_gym.tracks.formats import TrackRead
    from vtrack_gym.tracks.sources import file_digest
    from vtrack_gym.tracks.speed_profiles import as_speed_profile, profile_parameters

    file = FsPath(track_file)
    if not file.is_file():
        raise ValueError(f"--track {track_file}: track file not found")
    profile = as_speed_profile(speed_profile)
    params = {"kind": type(profile).__name__, **profile_parameters(profile)}
    file_sha = file_digest(file)
    options = TrackRead.of(track_options).identity() or None    # checked and normalised ("1,2" -> ["1", "2"])
    read = {k: v for k, v in (("closed", closed), ("smoothing_m", smoothing_m),
                              ("allow_self_crossing", allow_self_crossing or None), ("track_options", options))
            if v is not None}
    rule = {} if track_limits is None else {"track_limits": track_limits}
    if rule:
        from vtrack_gym.envs.criteria import TrackLimits

        TrackLimits(rule=track_limits)   # ValueError naming the rules
    key = hashlib.sha256(json.dumps([file_sha, params] + ([read] if read else []) + ([rule] if rule else []),
                                    sort_keys=True).encode()).hexdigest()[:10]
    stem = re.sub(r"[^A-Za-z0-9_.]", "_", file.stem)[:40] or "track"
    env_id = f"{TRACK_ID_PREFIX}{stem}-{key}-v0"
    register_track_id(env_id, file, profile, {**read, **rule})
    provenance = {"track_file": file.name, "track_sha256": file_sha, "speed_profile": params}
    if read:
        provenance["track_read"] = read
    if rule:
        provenance["protocol"] = rule     # as api.env_identity records a make kwarg of the protocol
    return env_id, provenance


def register_track_id(env_id: str, track_file: str | os.PathLike[str], speed_profile: Any,
                      read: dict[str, Any] | None = None) -> str:
    """Register ``env_id`` (an id ``register_track`` made) driving ``track_file`` with ``speed_profile`` and the
    make kwargs ``read`` (how the file is read, the track-limit rule), if this process does not know it yet; returns
    ``env_id``. A worker process (Ray) registers the parent's id this way, whatever the file holds now: an env made
    from an edited file then records the hash of what it read, and the parent refuses that row
    (``track_benchmark.merge_provenance``), as it does for a local run."""
    from pathlib import Path as FsPath

    from gymnasium.envs.registration import register, registry

    from vtrack_gym.tracks.speed_profiles import as_speed_profile

    if env_id not in registry:
        register(id=env_id, entry_point="vtrack_gym.envs.tracking_env:TrackingEnv",
                 vector_entry_point="vtrack_gym.envs.vector_env:TrackingVectorEnv",
                 kwargs={"scenario": "Track-v0", "track": str(FsPath(track_file).resolve()),
                         "speed_profile": as_speed_profile(speed_profile), **dict(read or {})},
                 max_episode_steps=None, disable_env_checker=False)
    return env_id


def track_id_setup(env_id: str, track_file: str | os.PathLike[str], speed_profile: Any) -> Any:
    """A picklable call that registers ``env_id`` (registered here by ``register_track``) in another process with
    the same make kwargs (``register_track_id``)."""
    import functools

    from gymnasium.envs.registration import registry

    read = {k: v for k, v in registry[env_id].kwargs.items() if k not in ("scenario", "track", "speed_profile")}
    return functools.partial(register_track_id, env_id, str(track_file), speed_profile, read)


TRACK_ID_PREFIX = "vtrack/Track-"
"""Prefix of the ids ``register_track`` generates (and of ``vtrack/Track-v0``)."""
