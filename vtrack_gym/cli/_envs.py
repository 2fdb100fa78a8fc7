"""Which env a command drives: ``--env ID`` or ``--track FILE`` (registered with its speed profile), the car."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

from vtrack_gym.cli._terminal import err

SPEED_OPTIONS = {"kind": "--speed-profile", "max_speed_kmh": "--max-speed-kmh", "max_lateral_g": "--max-lateral-g"}
"""How the speed-profile parameters are spelt on the command line (named in their errors)."""


def speed_profile(args: argparse.Namespace) -> Any:
    """The speed profile of --speed-profile / --max-speed-kmh / --max-lateral-g, its lateral limit checked against
    the --vehicle's own (errors name the option; the env warns near the limit)."""
    import warnings

    from vtrack_gym.tracks.speed_limits import check_profile_for_car, speed_profile_from_limits
    from vtrack_gym.vehicle.catalog import resolve_vehicle

    profile = speed_profile_from_limits(args.speed_profile, args.max_speed_kmh, args.max_lateral_g,
                                        names=SPEED_OPTIONS)
    name = getattr(args, "vehicle", None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the env warns once, where it meets the car
        check_profile_for_car(profile, resolve_vehicle(name),
                              SPEED_OPTIONS["max_lateral_g"])
    return profile


def track_read(args: argparse.Namespace) -> dict[str, Any]:
    """``register_track`` options of --track-closed / --track-smoothing-m / --allow-self-crossing and the map
    options --track-format / --track-route / --track-lane / --road-width-m (as ``track_options``; only those
    given). Errors name the option."""
    from vtrack_gym.envs.track_sources import MAX_TRACK_SMOOTHING_M

    read: dict[str, Any] = {}
    if args.track_closed != "auto":
        read["closed"] = args.track_closed == "yes"
    m = args.track_smoothing_m
    if m is not None:
        if not 0.0 <= m <= MAX_TRACK_SMOOTHING_M:
            raise ValueError(f"--track-smoothing-m must be in [0, {MAX_TRACK_SMOOTHING_M:g}] m (got {m})")
        read["smoothing_m"] = float(m)
    if args.allow_self_crossing:
        read["allow_self_crossing"] = True
    options = {k: v for k, v in (("format", args.track_format), ("route", args.track_route),
                                 ("lane", args.track_lane), ("road_width_m", args.road_width_m)) if v is not None}
    if options:
        from vtrack_gym.tracks.formats import TrackRead

        spelt = {"format": "--track-format", "route": "--track-route", "lane": "--track-lane",
                 "road_width_m": "--road-width-m"}
        try:
            read["track_options"] = TrackRead.of(options).identity()
        except ValueError as exc:
            text = str(exc)
            for field, option in spelt.items():
                text = text.replace(f"TrackRead.{field}", option)
            raise ValueError(text) from None
    return read


def track_limits(args: argparse.Namespace) -> str | None:
    """The track-limit rule of --track-limits (None when not given: vtrack/Track-v0's own rule)."""
    return getattr(args, "track_limits", None)


def describe_track(file: Path, read: dict[str, Any]) -> str:
    """One line saying how --track was read: closed loop or open road, its length and point count (a map: its
    format, closure, length, minimum radius and half-width range)."""
    from vtrack_gym.tracks import load_track
    from vtrack_gym.tracks.csv_loader import read_track_columns
    from vtrack_gym.tracks.formats import describe_path, format_of

    options = dict(read.get("track_options") or {})
    path = load_track(file, **{k: v for k, v in read.items() if k != "track_options"}, **options)
    fmt = format_of(file, options.get("format"))
    if fmt != "csv":
        return f"--track {file}: {describe_path(path, fmt)}"
    n_points = len(read_track_columns(Path(file))[1])
    how = "forced by --track-closed" if "closed" in read else "detected; --track-closed yes/no forces it"
    kind = "a closed loop" if path.closed else "an open road"
    return f"--track {file}: read as {kind} ({how}), {path.length_m:.1f} m, {n_points} points"


def check_vehicle(args: argparse.Namespace) -> None:
    """Read ``--vehicle`` once before any work (a clear error for an unknown name or a bad file): a vehicle file
    becomes the ``VehicleFile`` of the bytes read, which the command's envs and rows then use."""
    if getattr(args, "vehicle", None) is not None:
        from vtrack_gym.vehicle.catalog import read_vehicle_once

        args.vehicle = read_vehicle_once(args.vehicle)


def known_env(env_id: str) -> str:
    """``env_id`` if Gymnasium knows it (vtrack ids, the highway adapter), else a ValueError listing ours."""
    from gymnasium.envs.registration import registry

    import vtrack_gym

    if env_id not in registry:
        raise ValueError(f"unknown --env {env_id!r}; vtrack envs: {', '.join(vtrack_gym.ENV_IDS)}, "
                         "highway-env:lane-keeping-v0")
    return env_id


def env_or_track(args: argparse.Namespace, default: str | None = None) -> tuple[str, dict[str, Any]]:
    """The env id of ``--env`` or ``--track`` (registered for this track file and profile) and the provenance to
    record in the rows' options (empty for ``--env``)."""
    from vtrack_gym.interop import resolve_env_id

    if args.track is not None:
        if getattr(args, "env", None) is not None:
            raise ValueError("give --env or --track, not both")
        from vtrack_gym.envs.registration import register_track

        profile, read = speed_profile(args), track_read(args)
        err(describe_track(args.track, read))
        return register_track(args.track, profile, **read, track_limits=track_limits(args))
    if getattr(args, "track_limits", None) is not None:
        raise ValueError("--track-limits applies to --track FILE (with --env ID, make the env with "
                         "track_limits= in Python)")
    env = args.env if args.env is not None else default
    if env is None:
        raise ValueError("give --env ID (e.g. DLC120-v0) or --track FILE")
    return known_env(resolve_env_id(env)), {}


def announce_kernels() -> None:
    """Say that the first rollout compiles the numba kernels when no compiled cache exists yet."""
    from vtrack_gym._jit import kernel_cache_dir

    cache = kernel_cache_dir()  # the directory of the current kernel sources' hash
    log = logging.getLogger("vtrack_gym.cli")
    if cache is None or not any(cache.glob("**/*.nbi")):
        log.info("compiling the kernels (first run only, ~30 s)")
    else:
        log.debug("loading the compiled kernels from the numba cache")
