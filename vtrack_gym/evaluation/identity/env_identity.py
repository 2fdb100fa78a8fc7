"""What a row records of an env instance (``env_identity``), one spelling per set-up: an id and its alias are one
id and ``45`` and ``45.0`` one number (``env_names``), a user wrapper's parameters are part of the set-up, and an
env whose configuration cannot be identified is a row of its own. Also the label a row gives a car
(``vehicle_label``) and the check that a track file still holds what an env drove (``check_driven``).
"""

from __future__ import annotations

import hashlib
import secrets
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.identity.env_names import canonical_env_id, normal_numbers

UNIDENTIFIED = " [unidentified configuration"
"""Start of the label appended to the env id of an env instance whose configuration cannot be recorded; the label
ends with a random token of its own (``unidentified``), so such rows never share a leaderboard entry with the
standard env's or with each other's."""


def unidentified(env_id: str) -> str:
    """``env_id`` labelled as an unidentified configuration, with a token of its own (one row per evaluation)."""
    return f"{env_id}{UNIDENTIFIED} {secrets.token_hex(4)}]"


def wrapper_records(env: Any, spec: Any) -> list[dict[str, Any]] | None:
    """The wrappers added around a made env (``spec.additional_wrappers``, innermost first) as row options: a
    wrapper that records its constructor arguments by name and arguments; one that does not (a plain
    ``gymnasium.Wrapper`` subclass) by name, entry point and the digest of its own attributes (its parameters),
    read from the wrapper instance. None when a wrapper cannot be identified (its attributes cannot be read)."""
    from vtrack_gym.evaluation.identity.fingerprint import IncompleteFingerprint, state_digest

    added = list(spec.additional_wrappers or ())
    chain: list[Any] = []
    node = env
    while isinstance(node, gym.Wrapper) and len(chain) < len(added):
        chain.append(node)
        node = node.env
    chain.reverse()          # innermost first, as in the spec
    records: list[dict[str, Any]] = []
    for i, w in enumerate(added):
        if w.kwargs is not None:
            try:
                records.append({"name": w.name, "kwargs": jsonable(w.kwargs)})
            except TypeError:
                return None
            continue
        instance = chain[i] if i < len(chain) else None
        if instance is None or f"{type(instance).__module__}:{type(instance).__name__}" != w.entry_point:
            return None
        try:
            own = {k: v for k, v in vars(instance).items() if k not in ("env", "_cached_spec")}
            digest = state_digest(own, w.name)   # the wrapper's own attributes (an env as a whole is left out)
        except IncompleteFingerprint:
            return None
        records.append({"name": w.name, "entry_point": w.entry_point, "state": digest[:16]})
    return records


_RENDER_KWARGS = frozenset({"render_mode", "render_fps", "render_view"})
"""Make arguments that change how an env is shown, not how it drives."""


def _equal(a: Any, b: Any) -> bool:
    """``a == b`` as one bool (False when the comparison is ambiguous, e.g. two arrays)."""
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


def jsonable(value: Any) -> Any:
    """``value`` as JSON data (dataclasses as dicts, tuples as lists) with numbers normalised (``normal_numbers``);
    ``TypeError`` when it cannot be written."""
    import dataclasses
    import json

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    return normal_numbers(json.loads(json.dumps(value, allow_nan=False, default=_no_json)))


def _no_json(value: Any) -> Any:
    raise TypeError(f"{type(value).__name__} is not JSON data")


def _vehicle_of(config: Any, make_vehicle: Any) -> str | None:
    """What a row records of an env's car (``vehicle_label``): from the make argument when it is a name or
    a file, else from the parameters (a shipped car's name, or ``params-<sha256[:10]>`` of them)."""
    import json
    import os

    from vtrack_gym.vehicle.catalog import VehicleFile, list_vehicles, load_vehicle
    from vtrack_gym.vehicle.params import VehicleParams

    if isinstance(make_vehicle, VehicleFile):
        return vehicle_label(make_vehicle)
    if isinstance(make_vehicle, (str, os.PathLike)):
        return vehicle_label(str(make_vehicle))
    params = config.vehicle
    if params == VehicleParams():
        return None
    for name in list_vehicles():
        if load_vehicle(name) == params:
            return name
    text = json.dumps(jsonable(params), sort_keys=True)
    return f"params-{hashlib.sha256(text.encode()).hexdigest()[:10]}"


def _track_provenance(scenario: Any) -> tuple[str | None, dict[str, Any]] | None:
    """(env id or None, options) recording a scenario's own track, speed profile and half width, as
    ``vtrack eval --track`` does for a track file; None when the track cannot be identified."""
    import os

    from vtrack_gym.tracks import Path as TrackPath
    from vtrack_gym.tracks.sources import path_digest
    from vtrack_gym.tracks.speed_profiles import profile_parameters

    options: dict[str, Any] = {}
    env_id = None
    source = scenario.track
    track = source.track
    profile = scenario.speed_profile
    params = None if profile is None else {"kind": type(profile).__name__, **profile_parameters(profile)}
    if isinstance(track, (str, os.PathLike)) and Path(track).is_file():
        from vtrack_gym.envs.registration import register_track

        env_id, options = register_track(track, profile, source.closed, source.smoothing_m,
                                         allow_self_crossing=source.allow_self_crossing,
                                         track_options=source.track_options)
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
    scenario and config: the car as ``options["vehicle"]`` (``vehicle_label``), a track file as
    ``vtrack eval --track`` records it (its registered id, SHA-256 and speed profile), another track by name or
    path digest, a control mode other than ``steer`` as ``options["control"]``, config fields that differ from the
    defaults as ``options["env_config"]``, a changed time limit,
    added wrappers. An env whose configuration cannot be recorded gets ``<id> [unidentified configuration <token>]``, a
    label of its own (``unidentified``). Aliases are resolved and numbers normalised (see the module docstring).
    """
    from gymnasium.envs.registration import registry

    spec = getattr(env, "spec", None)
    unwrapped = env.unwrapped
    if spec is None or spec.id not in registry:
        return unidentified(spec.id if spec is not None else type(unwrapped).__name__), {}
    registered = registry[spec.id]
    env_id = canonical_env_id(spec.id)
    options: dict[str, Any] = {}
    if spec.max_episode_steps != registered.max_episode_steps:
        options["max_episode_steps"] = spec.max_episode_steps
    if spec.additional_wrappers:
        wrappers = wrapper_records(env, spec)
        if wrappers is None:
            return unidentified(env_id), {}
        options["wrappers"] = wrappers
    from vtrack_gym.envs.tracking_env import TrackingEnv

    if not isinstance(unwrapped, TrackingEnv):
        extra = {k: v for k, v in spec.kwargs.items()
                 if k not in _RENDER_KWARGS and not (k in registered.kwargs and _equal(registered.kwargs[k], v))}
        try:
            if extra:
                options["env_kwargs"] = jsonable(extra)
        except TypeError:
            return unidentified(env_id), {}
        return env_id, options
    return _tracking_identity(unwrapped, spec, env_id, options)


def _tracking_identity(unwrapped: Any, spec: Any, env_id: str,
                       options: dict[str, Any]) -> tuple[str, dict[str, Any]]:
    """``env_identity`` of this package's ``TrackingEnv``: scenario, track, car and config against the defaults."""
    import dataclasses

    from vtrack_gym.envs.config import EnvConfig
    from vtrack_gym.envs.scenarios import resolve_scenario, with_protocol
    from vtrack_gym.envs.track_sources import READ_KWARGS
    from vtrack_gym.tracks.sources import source_digest

    scenario_arg = spec.kwargs.get("scenario")
    if not isinstance(scenario_arg, str):  # a Scenario object: not recorded
        return unidentified(env_id), {}
    scenario = resolve_scenario(scenario_arg, spec.kwargs.get("track"), spec.kwargs.get("speed_profile"),
                                spec.kwargs.get("half_width_m"), spec.kwargs.get("closed"),
                                spec.kwargs.get("smoothing_m"), {k: spec.kwargs.get(k) for k in READ_KWARGS})
    base = resolve_scenario(scenario.name)
    protocol = {k: spec.kwargs[k] for k in ("entry_speed_kmh", "reference", "track_limits", "launch")
                if spec.kwargs.get(k) is not None}
    if protocol:   # entry speed / reference line / track-limit rule / launch: recorded, so two never share a row
        control = unwrapped.config.control
        scenario = with_protocol(scenario, unwrapped.config.vehicle, **protocol, control=control)
        applied = with_protocol(base, unwrapped.config.vehicle, **protocol, control=control)
        if not _equal(applied, base):
            options["protocol"] = jsonable(protocol)
        base = applied
    track_fields = ("track", "speed")   # the parts make kwargs replace (track=, speed_profile=, ...)
    for f in dataclasses.fields(scenario):
        if f.name not in track_fields and not _equal(getattr(scenario, f.name), getattr(base, f.name)):
            return unidentified(env_id), {}
    if not all(_equal(getattr(scenario, f), getattr(base, f)) for f in track_fields):
        found = _track_provenance(scenario)
        if found is None:
            return unidentified(env_id), {}
        check_driven(source_digest(tuple(unwrapped.paths)), found[1])   # the file still holds what the env drives
        env_id = found[0] or env_id
        options.update(found[1])
    config = unwrapped.config
    default = EnvConfig(control=config.control)   # the mode's own layout is part of the mode, not a change
    if config.control != "steer":   # control modes are different set-ups (envs.control); steer rows unchanged
        options["control"] = config.control
    label = _vehicle_of(config, spec.kwargs.get("vehicle", getattr(config, "vehicle", None)))
    changed: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if f.name in ("vehicle", "control") or _equal(value, getattr(default, f.name)):
            continue
        try:
            changed[f.name] = jsonable(value)
        except TypeError:
            return unidentified(env_id), {}
    if changed:
        options["env_config"] = changed
    if label is not None:
        options["vehicle"] = label
    return env_id, options


def vehicle_label(vehicle: Any) -> str | None:
    """What a row records of the car in ``options["vehicle"]``: ``None`` for the default car (or a vehicle equal to
    it), a shipped vehicle's name, or ``<file stem>-<sha256[:10]>`` of a vehicle file (two files never mix; a
    ``vehicle.catalog.VehicleFile`` is labelled from the bytes it was read from, the file is not read again)."""
    if vehicle is None:
        return None
    from vtrack_gym.vehicle.catalog import VehicleFile, list_vehicles, load_vehicle
    from vtrack_gym.vehicle.params import VehicleParams

    if isinstance(vehicle, VehicleFile):
        return None if vehicle.params == VehicleParams() else vehicle.label
    if load_vehicle(vehicle) == VehicleParams():
        return None
    if str(vehicle) in list_vehicles():
        return str(vehicle)
    file = Path(vehicle)
    return f"{file.stem}-{hashlib.sha256(file.read_bytes()).hexdigest()[:10]}"


def check_driven(driven: str | None, provenance: Mapping[str, Any]) -> None:
    """ValueError naming the track file when ``driven`` (the SHA-256 of the bytes an env read and drove, None: not
    a file) differs from the ``track_sha256`` the provenance would record."""
    named = provenance.get("track_sha256")
    if driven is not None and named is not None and driven != named:
        file = provenance.get("track_file", "the track file")
        raise ValueError(f"track file {file!r} changed while it was used: an env drove the content with SHA-256 "
                         f"{driven[:16]}..., the result would record {named[:16]}...; no result is recorded: run "
                         "again with the file left unchanged (after editing a track file, make a new env)")
