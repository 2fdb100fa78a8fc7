"""The one registry of built-in track names: name -> builder ``(vehicle_width_m) -> Path``.

The paper's handling course and double lane change and the standard manoeuvres (``tracks.maneuvers.MANEUVERS``; a
gated one is sized for the driven car's body width, as ISO 3888 sizes its lanes). ``tracks.load_track(name)`` and
the envs' track sources (``envs.track_sources.TRACKS``, which adds the procedural and training banks) read it; a
track of your own is one ``register_track`` call. Builders import the geometry modules lazily.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from vtrack_gym.tracks.maneuvers import MANEUVERS

DEFAULT_VEHICLE_WIDTH_M = 1.916
"""Body width [m] a gated track is sized for when no car is given (the paper's hatchback)."""

TrackBuilder = Callable[[float], Any]
"""``build(vehicle_width_m) -> tracks.Path``."""


def _handling_course(vehicle_width_m: float) -> Any:
    from vtrack_gym.tracks.handling_course import handling_course

    return handling_course()


def _double_lane_change(vehicle_width_m: float) -> Any:
    from vtrack_gym.tracks.dlc import double_lane_change

    return double_lane_change(vehicle_width_m=vehicle_width_m)


def _maneuver(name: str) -> TrackBuilder:
    def build(vehicle_width_m: float) -> Any:
        from dataclasses import fields

        from vtrack_gym.tracks.maneuvers import build_maneuver

        has_width = any(f.name == "vehicle_width_m" for f in fields(MANEUVERS[name][1]))
        return build_maneuver(name, **({"vehicle_width_m": float(vehicle_width_m)} if has_width else {})).path

    return build


_TRACKS: dict[str, TrackBuilder] = {"handling_course": _handling_course, "double_lane_change": _double_lane_change,
                                    **{name: _maneuver(name) for name in MANEUVERS}}


def register_track(name: str, build: TrackBuilder, replace: bool = False) -> None:
    """Add the built-in track ``name`` (a lowercase identifier) built by ``build(vehicle_width_m) -> Path``."""
    if not isinstance(name, str) or not name.isidentifier() or name != name.lower():
        raise ValueError(f"track name must be a lowercase identifier such as my_track (got {name!r})")
    if not callable(build):
        raise ValueError(f"track builder must be callable: vehicle_width_m -> Path (got {build!r})")
    if name in _TRACKS and not replace:
        raise ValueError(f"a track named {name!r} is registered already; pass replace=True")
    _TRACKS[name] = build


def unregister_track(name: str) -> None:
    """Remove the track ``name`` (a no-op for an unknown name)."""
    _TRACKS.pop(name, None)


def track_names() -> tuple[str, ...]:
    """Every built-in track name, in registry order."""
    return tuple(_TRACKS)


def build_track(name: str, vehicle_width_m: float = DEFAULT_VEHICLE_WIDTH_M) -> Any:
    """The ``Path`` of the built-in track ``name`` (``ValueError`` listing the names otherwise)."""
    if name not in _TRACKS:
        raise ValueError(f"unknown track {name!r}; built-in tracks: {', '.join(_TRACKS)}")
    return _TRACKS[name](vehicle_width_m)
