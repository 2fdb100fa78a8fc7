"""The one registry of track file formats, and how a file is read (``TrackRead``).

``FORMATS`` maps a format name to its ``TrackFormat``: the file suffixes it claims and the module whose
``load(file, read) -> Path`` reads it (imported on first use, so an optional package is needed only by its own
format). Adding a format is one module and one line here. A file's format is ``TrackRead.format`` when given, else
the one its suffix names; where two formats share a suffix, the first whose module's ``sniff(head: bytes)`` accepts
the file's first bytes wins, else the first without ``sniff``. A suffix no format claims is read as
``DEFAULT_FORMAT`` (a CSV of points, as every track file was before the map formats).
"""

from __future__ import annotations

import importlib
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path as FsPath
from typing import Any

SNIFF_BYTES = 4096
"""Bytes of a file a format's ``sniff`` sees."""
MAX_ROUTE_IDS = 10_000
"""Most ids one route may name."""
MIN_ROAD_WIDTH_M = 1.0
"""Narrowest ``road_width_m`` accepted [m] (narrower than any car)."""
MAX_ROAD_WIDTH_M = 100.0
"""Widest ``road_width_m`` accepted [m]."""


@dataclass(frozen=True)
class TrackFormat:
    """A track file format: ``suffixes`` it claims (lower case, with the dot), ``module`` with its ``load``, the
    optional ``extra`` (pip extra) it needs and a one-line ``doc``."""

    suffixes: tuple[str, ...]
    module: str
    doc: str
    extra: str | None = None


FORMATS: dict[str, TrackFormat] = {
    "cones": TrackFormat((".csv",), "vtrack_gym.tracks.cones",
                         "Formula Student cone map tag,x,y (blue left, yellow right, orange start)"),
    "csv": TrackFormat((".csv",), "vtrack_gym.tracks.csv_loader", "centre-line points x_m, y_m [, widths]"),
    "opendrive": TrackFormat((".xodr",), "vtrack_gym.tracks.opendrive", "ASAM OpenDRIVE roads (route: road ids)"),
    "lanelet2": TrackFormat((".osm",), "vtrack_gym.tracks.lanelet2_map", "Lanelet2 map (route: lanelet ids)",
                            "lanelet2"),
    "commonroad": TrackFormat((".xml",), "vtrack_gym.tracks.commonroad_map",
                              "CommonRoad scenario (route: lanelet ids or the planning problem's)", "commonroad"),
    "gpx": TrackFormat((".gpx",), "vtrack_gym.tracks.gpx", "GPX recorded track (road_width_m)"),
}
"""Format name -> ``TrackFormat``: the one registry of track file formats."""
DEFAULT_FORMAT = "csv"
"""The format of a file whose suffix no format claims."""


def _route(value: Any) -> tuple[str, ...]:
    """A route as a tuple of ids: from ``"1,2,3"`` or a sequence of ids (str or int)."""
    if value is None:
        return ()
    items = value.split(",") if isinstance(value, str) else list(value) if isinstance(value, Sequence) else None
    if items is None or not all(isinstance(i, (str, int)) and not isinstance(i, bool) for i in items):
        raise ValueError("TrackRead.route must be ids separated by commas ('1,2,3') or a list of ids "
                         f"(got {value!r:.80})")
    ids = tuple(str(i).strip() for i in items)
    if any(not i or len(i) > 64 for i in ids) or len(ids) > MAX_ROUTE_IDS:
        raise ValueError(f"TrackRead.route: 1 to {MAX_ROUTE_IDS} ids of 1-64 characters each (got {value!r:.80})")
    return ids


@dataclass(frozen=True, kw_only=True)
class TrackRead:
    """How a track file is read. ``format``: a name of ``FORMATS`` (None: from the file). ``closed``: force a loop
    (True) or an open road (False), None detects it. ``smoothing_m`` [m]: RMS deviation the fit may make from the
    points. ``allow_self_crossing``: accept a centre line that crosses itself (a bridge). ``route``: the road
    (OpenDRIVE) or lanelet (Lanelet2, CommonRoad) ids to drive, in order (``"1,2,3"`` or a list). ``lane``: the
    OpenDRIVE lane to drive (-1: the first right of the reference line in the direction of travel; None: the middle
    of the drivable carriageway). ``road_width_m`` [m]: the full road width of a GPX track (default 7 m)."""

    format: str | None = None
    closed: bool | None = None
    smoothing_m: float | None = None
    allow_self_crossing: bool = False
    route: Any = ()
    lane: int | None = None
    road_width_m: float | None = None

    def __post_init__(self) -> None:
        if self.format is not None and self.format not in FORMATS:
            raise ValueError(f"TrackRead.format must be one of {', '.join(FORMATS)} (got {self.format!r:.40})")
        for name in ("closed", "allow_self_crossing"):
            value = getattr(self, name)
            if not (isinstance(value, bool) or (name == "closed" and value is None)):
                raise ValueError(f"TrackRead.{name} must be True or False (got {value!r:.40})")
        object.__setattr__(self, "route", _route(self.route))
        lane = self.lane
        if lane is not None and (isinstance(lane, bool) or not isinstance(lane, int) or not 1 <= abs(lane) <= 100):
            raise ValueError(f"TrackRead.lane must be a lane id in [-100, -1] or [1, 100] (got {lane!r:.40})")
        for name, low, high in (("smoothing_m", 0.0, 50.0), ("road_width_m", MIN_ROAD_WIDTH_M, MAX_ROAD_WIDTH_M)):
            value = getattr(self, name)
            ok = value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)
                                   and math.isfinite(value) and low <= value <= high)
            if not ok:
                raise ValueError(f"TrackRead.{name} must be in [{low:g}, {high:g}] m (got {value!r:.40})")

    @classmethod
    def of(cls, options: Mapping[str, Any] | None = None, **given: Any) -> TrackRead:
        """A ``TrackRead`` of ``options`` (e.g. a make kwarg ``track_options``) and ``given`` (None values dropped);
        ValueError naming an unknown option and the known ones."""
        merged = {**dict(options or {}), **{k: v for k, v in given.items() if v is not None}}
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(merged) - known)
        if unknown:
            raise ValueError(f"unknown track option(s) {', '.join(map(repr, unknown))}; known: "
                             f"{', '.join(sorted(known))}")
        return cls(**merged)

    def identity(self) -> dict[str, Any]:
        """The options that differ from the defaults (what a result row records), JSON-ready."""
        out: dict[str, Any] = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if value != f.default:
                out[f.name] = list(value) if isinstance(value, tuple) else value
        return out


def format_of(file: str | os.PathLike[str], given: str | None = None) -> str:
    """The format name of ``file``: ``given`` if set, else from its suffix (and content where two formats share
    it; ``DEFAULT_FORMAT`` for a suffix none claims). ValueError naming an unknown ``given`` and the known ones."""
    if given is not None:
        if given not in FORMATS:
            raise ValueError(f"unknown track format {given!r}; known: {', '.join(FORMATS)}")
        return given
    suffix = FsPath(file).suffix.lower()
    names = [n for n, f in FORMATS.items() if suffix in f.suffixes]
    if not names:
        return DEFAULT_FORMAT
    if len(names) > 1:
        with open(file, "rb") as fh:
            head = fh.read(SNIFF_BYTES)
        for name in names:
            sniff = getattr(_module(name), "sniff", None)
            if sniff is not None and sniff(head):
                return name
        return next((n for n in names if getattr(_module(n), "sniff", None) is None), names[0])
    return names[0]


def _module(name: str) -> Any:
    """The loader module of format ``name``; ImportError naming the extra that installs its package."""
    fmt = FORMATS[name]
    try:
        return importlib.import_module(fmt.module)
    except ImportError as exc:
        if fmt.extra is None:
            raise
        raise ImportError(f"reading a {name} track needs the optional package of the '{fmt.extra}' extra: "
                          f"pip install 'vtrack_gym[{fmt.extra}]' ({exc})") from exc


def read_track_file(file: str | os.PathLike[str], read: TrackRead) -> Any:
    """The ``tracks.Path`` of a track file in any format of ``FORMATS``, read as ``read`` says."""
    name = format_of(file, read.format)
    return _module(name).load(FsPath(file), read)


def describe_path(path: Any, format_name: str) -> str:
    """One line on a track: format, closed or open, length [m], minimum radius [m], half-width range [m]."""
    import numpy as np

    from vtrack_gym.tracks.table import COL_KAPPA

    kappa = float(np.max(np.abs(path.table[:, COL_KAPPA])))
    radius = "inf" if kappa == 0.0 else f"{1.0 / kappa:.1f}"
    widths = path.widths_m if path.widths_m is not None else np.full((1, 2), path.half_width_m)
    return (f"{format_name}, {'closed' if path.closed else 'open'}, {path.length_m:.1f} m, min radius {radius} m, "
            f"half widths {float(widths.min()):.2f}-{float(widths.max()):.2f} m")
