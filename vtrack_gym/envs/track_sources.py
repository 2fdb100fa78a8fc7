"""The track source of a scenario (a scenario part).

``TRACKS`` maps every name a scenario may give as its track to a builder ``(source, vehicle_width_m) -> paths``:
the built-in tracks of the one track registry (``tracks.track_registry``: the paper's handling course and double
lane change, the standard manoeuvres, a gated one sized for the driven car's body width, as ISO 3888 sizes its
lanes) and the two banks, the procedural bank and the RL training mix. Anything else is a CSV file path or a
``tracks.Path``. Imports only the manoeuvre table (numpy); builders import the rest of ``tracks`` lazily.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.tracks.maneuvers import MANEUVERS
from vtrack_gym.tracks.track_registry import build_track, track_names

MAX_TRACK_SMOOTHING_M = 50.0
"""Largest ``smoothing_m`` [m] (RMS deviation of the fit from a CSV file's points) a track source accepts."""
MIN_TRACK_LENGTH_FACTOR = 4.0
"""A user's track is at least this x ``end_margin_m`` long (20 m by default): a 3 m road would count as completed
at the first step."""
PROCEDURAL_MAX_CURVATURE: tuple[float, float] = (1.0 / 18.0, 1.0 / 120.0)
"""Curvature bounds [1/m] of the twisty and the highway-like half of the procedural track bank: wider than the
evaluation courses need (handling course: R >= 20 m; DLC120-v0: R >= 140 m), so that a policy trained on the bank
never meets a curvature it has not seen."""
PROCEDURAL_MAX_DKAPPA: tuple[float, float] = (0.008, 0.004)
"""Curvature-rate bounds [1/m^2] of the two halves (handling course: 0.0063; DLC120-v0: 0.0020)."""
READ_KWARGS: tuple[str, ...] = ("allow_self_crossing", "track_options")
"""Make kwargs (and ``TrackSource`` fields) saying how a track file is read, besides ``closed`` and ``smoothing_m``:
they travel with the track source into a row's identity."""
MANEUVER_TRACK_NAMES: tuple[str, ...] = tuple(MANEUVERS)
"""The standard manoeuvres as track names: the keys of ``tracks.maneuvers.MANEUVERS``, in its order."""


@documented
@dataclass(frozen=True, kw_only=True)
class TrackSource:
    """Where a scenario's paths come from: ``track`` is a name of ``TRACKS``, a track file path (any format of
    ``tracks.formats.FORMATS``) or a ``tracks.Path``.

    ``half_width_m``: a constant drivable half width either side [m] replacing the path's own (per-station)
    widths, ``None`` keeps them. ``closed`` / ``smoothing_m`` [m] / ``allow_self_crossing`` / ``track_options``
    (format, route, lane, road_width_m): how a track file is read (``tracks.load_track``; a file only).
    ``end_margin_m``: an open path counts as completed this far before its end [m]. The bank fields size the
    ``procedural`` and ``training_mix`` banks (paths drawn per episode).
    """

    track: Any = "handling_course"           # str | os.PathLike | tracks.Path
    half_width_m: float | None = ranged(None, gt=0.0, le=50.0, unit="m")
    closed: bool | None = None
    smoothing_m: float | None = ranged(None, ge=0.0, le=MAX_TRACK_SMOOTHING_M, unit="m")
    end_margin_m: float = ranged(5.0, gt=0.0, le=100.0, unit="m")
    bank_size: int = ranged(16, ge=1, integer=True)
    bank_seed: int = 12345
    bank_length_m: float = ranged(800.0, gt=0.0, unit="m")
    allow_self_crossing: bool = False
    track_options: Any = None                # Mapping: format, route, lane, road_width_m (tracks.formats.TrackRead)

    def __post_init__(self) -> None:
        track = self.track
        if isinstance(track, str) and not track:
            raise ValueError("TrackSource.track must not be empty")
        if not isinstance(track, (str, os.PathLike)):
            from vtrack_gym.tracks.path import Path

            if not isinstance(track, Path):
                raise ValueError(f"TrackSource.track must be one of {', '.join(TRACKS)}, a CSV file path or a "
                                 f"tracks.Path (got {type(track).__name__})")
        if self.closed is not None and not isinstance(self.closed, bool):
            raise ValueError(f"TrackSource.closed must be True, False or None (got {self.closed!r})")
        if (self.closed is not None or self.smoothing_m is not None) and (
                not isinstance(track, (str, os.PathLike)) or self.is_builtin):
            raise ValueError("closed= and smoothing_m= apply to a CSV track file only (got track "
                             f"{track if isinstance(track, str) else type(track).__name__!r}); a tracks.Path or a "
                             "built-in track is used as it is")
        self._check_read_options()
        validate(self)

    def _check_read_options(self) -> None:
        """``allow_self_crossing`` and ``track_options`` checked (``tracks.formats.TrackRead``), for a file only."""
        if not isinstance(self.allow_self_crossing, bool):
            raise ValueError("TrackSource.allow_self_crossing must be True or False (got "
                             f"{self.allow_self_crossing!r})")
        options = self.track_options
        if options is None and not self.allow_self_crossing:
            return
        if options is not None and not isinstance(options, Mapping):
            raise ValueError(f"track_options must be a dict of format, route, lane, road_width_m (got "
                             f"{type(options).__name__})")
        if not isinstance(self.track, (str, os.PathLike)) or self.is_builtin:
            raise ValueError("allow_self_crossing= and track_options= apply to a track file only (got track "
                             f"{self.track if isinstance(self.track, str) else type(self.track).__name__!r})")
        from vtrack_gym.tracks.formats import TrackRead

        given = dict(options or {})
        shared = sorted(set(given) & {"closed", "smoothing_m", "allow_self_crossing"})
        if shared:
            raise ValueError(f"track_options: give {', '.join(shared)} as their own keyword, not in track_options")
        read = TrackRead.of(given)   # names an unknown key or a value out of range
        object.__setattr__(self, "track_options", read.identity() or None)

    @property
    def is_builtin(self) -> bool:
        """True when the track is a name of ``TRACKS`` (not a file or a Path)."""
        return isinstance(self.track, str) and self.track in TRACKS

    def paths(self, vehicle_width_m: float) -> tuple:
        """The paths (built-in ones built once per process; a CSV file read at every call; a Path as is), with
        the constant half width if one is set."""
        if self.is_builtin:
            paths = _builtin(self.track, vehicle_width_m, self.bank_seed, self.bank_length_m, self.bank_size)
        else:
            paths = (self._user_path(),)
        if self.half_width_m is not None:
            paths = tuple(replace(p, half_width_m=self.half_width_m, widths_m=None) for p in paths)
        return paths

    def planned_paths(self, vehicle: Any, margin_m: float, planner_version: int = 1) -> tuple:
        """The planned line of this source's cone-lined manoeuvre for the driven car ``vehicle`` (``VehicleParams``),
        ``margin_m`` [m] clear of every cone line (``tracks.feasibility.planned_maneuver``, by its
        ``planner_version``), with the constant half
        width if one is set. ValueError for any other track, or a car too wide for the manoeuvre's lanes (naming
        the field, the limit and the car)."""
        from vtrack_gym.tracks.feasibility import GATED_MANEUVERS, planned_maneuver

        if not (self.is_builtin and self.track in GATED_MANEUVERS):
            name = self.track if isinstance(self.track, str) else type(self.track).__name__
            raise ValueError(f"a planned reference line needs a cone-lined manoeuvre track "
                             f"({', '.join(GATED_MANEUVERS)}); got track {name!r}")
        path = (planned_maneuver(self.track, vehicle, margin_m) if planner_version == 1 else
                planned_maneuver(self.track, vehicle, margin_m, planner_version)).path
        if self.half_width_m is not None:
            path = replace(path, half_width_m=self.half_width_m, widths_m=None)
        return (path,)

    def _user_path(self) -> Any:
        from vtrack_gym.tracks import load_track

        path = load_track(self.track, closed=self.closed, smoothing_m=self.smoothing_m,
                          allow_self_crossing=self.allow_self_crossing, **(self.track_options or {}))
        min_length_m = MIN_TRACK_LENGTH_FACTOR * self.end_margin_m
        if path.length_m < min_length_m:
            raise ValueError(f"track {path.name!r} is {path.length_m:.3g} m long: a track needs at least "
                             f"{min_length_m:g} m ({MIN_TRACK_LENGTH_FACTOR:g} x end_margin_m, the distance before "
                             "an open road's end at which it counts as completed)")
        return path


def _procedural(source: TrackSource, vehicle_width_m: float) -> tuple:
    """Half the bank twisty (radii down to 18 m), half highway-like (down to 120 m), so that every target speed
    of a randomised range has drivable tracks."""
    import vtrack_gym.tracks as tracks

    return tuple(tracks.procedural_track_from_config(
        source.bank_seed + k,
        tracks.ProceduralTrackConfig(length_m=source.bank_length_m,
                                     max_curvature_per_m=PROCEDURAL_MAX_CURVATURE[k % 2],
                                     max_dkappa_per_m2=PROCEDURAL_MAX_DKAPPA[k % 2]))
        for k in range(source.bank_size))


def _training_mix(source: TrackSource, vehicle_width_m: float) -> tuple:
    from vtrack_gym.tracks.training_mix import training_bank

    return training_bank(source.bank_seed, source.bank_size, vehicle_width_m)


BANKS: dict[str, Callable[[TrackSource, float], tuple]] = {"procedural": _procedural, "training_mix": _training_mix}
"""Track banks (several paths, drawn per episode) by name; sized by a source's ``bank_*`` fields."""


def maneuver_path(name: str, vehicle_width_m: float) -> Any:
    """The reference path of manoeuvre ``name``; gated manoeuvres are sized for ``vehicle_width_m`` [m]."""
    return build_track(name, vehicle_width_m)


class _EnvTracks(Mapping[str, Callable[[TrackSource, float], tuple]]):
    """Every track name a scenario may give: the built-in tracks of ``tracks.track_registry`` (read at each
    lookup, so a track registered later is known) and the ``BANKS``; name -> builder ``(source, width) -> paths``."""

    def _names(self) -> tuple[str, ...]:
        return (*track_names(), *BANKS)

    def __getitem__(self, name: str) -> Callable[[TrackSource, float], tuple]:
        if name in BANKS:
            return BANKS[name]
        if name not in track_names():
            raise KeyError(name)
        return lambda source, vehicle_width_m: (build_track(name, vehicle_width_m),)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())


TRACKS: Mapping[str, Callable[[TrackSource, float], tuple]] = _EnvTracks()
"""Built-in track name -> builder ``(source, vehicle_width_m) -> paths``: the tracks registry and the banks."""


@lru_cache(maxsize=8)
def _builtin(track: str, vehicle_width_m: float, bank_seed: int, bank_length_m: float, bank_size: int) -> tuple:
    """The paths of a built-in track (cached per car width and bank)."""
    source = TrackSource(track=track, bank_seed=bank_seed, bank_length_m=bank_length_m, bank_size=bank_size)
    return TRACKS[track](source, vehicle_width_m)
