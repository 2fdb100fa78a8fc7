"""One entry point from "a track" as a user names it (a built-in name, a track file of any format, or a Path) to
a ``Path``, and a content digest for provenance (two files with the same name but different points never mix)."""

from __future__ import annotations

import hashlib
import os
from dataclasses import replace
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks.csv_loader import load_track_csv, unobservable
from vtrack_gym.tracks.formats import TrackRead, format_of, read_track_file
from vtrack_gym.tracks.path import Path
from vtrack_gym.tracks.track_registry import build_track, track_names

TrackSource = str | os.PathLike[str] | Path


def load_track(track: TrackSource, *, closed: bool | None = None, half_width_m: float | None = None,
               smoothing_m: float | None = None, allow_self_crossing: bool = False, **map_options: Any) -> Path:
    """The ``Path`` of ``track``: a ``Path`` (returned as is), a built-in name (``track_registry.track_names()``,
    gated ones sized for the paper's car) or a track file of any format of ``tracks.formats.FORMATS`` (a CSV of
    points, a cone map, OpenDRIVE, Lanelet2, CommonRoad, GPX; the keyword options apply to files only).
    ``map_options``: the other ``tracks.formats.TrackRead`` fields (``format``, ``route``, ``lane``,
    ``road_width_m``). ``half_width_m`` [m] replaces the file's widths. ValueError naming the
    choices otherwise."""
    if isinstance(track, Path):
        return track
    if isinstance(track, str) and track in track_names():
        return build_track(track)
    if not isinstance(track, (str, os.PathLike)):
        raise ValueError(f"track must be a CSV file path or a map file path, a tracks.Path or one of "
                         f"{', '.join(track_names())} (got {type(track).__name__})")
    if FsPath(track).is_dir():
        raise ValueError(f"{track}: is a folder, not a track file (give a track file in it)")
    if not FsPath(track).is_file():
        raise ValueError(f"{track}: track file not found (built-in tracks: {', '.join(track_names())})")
    read = TrackRead.of(map_options, closed=closed, smoothing_m=smoothing_m, allow_self_crossing=allow_self_crossing)
    if format_of(track, read.format) == "csv" and half_width_m is not None:
        return load_track_csv(track, closed=closed, half_width_m=half_width_m, smoothing_m=smoothing_m,
                              allow_self_crossing=allow_self_crossing)
    path = read_track_file(track, read)
    return path if half_width_m is None else replace(path, half_width_m=float(half_width_m), widths_m=None)


def is_cone_file(track: str | os.PathLike[str]) -> bool:
    """A cone-lined track file (``tracks.cones``): the format ``tracks.formats.format_of`` finds for it."""
    return format_of(track) == "cones"


def file_digest(file: str | os.PathLike[str]) -> str:
    """SHA-256 hex digest of a track file's bytes (for provenance of results on a user's track)."""
    from vtrack_gym._io import read_regular_file
    from vtrack_gym.tracks.csv_loader import MAX_FILE_BYTES

    return hashlib.sha256(read_regular_file(file, MAX_FILE_BYTES, "track file")).hexdigest()


def path_digest(path: Path) -> str:
    """SHA-256 hex digest of what a Path drives like: table, spacing, closure, widths and speed column."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(path.table).tobytes())
    h.update(f"{path.ds_m!r}|{path.closed}|{path.half_width_m!r}".encode())
    for extra in (path.widths_m, path.v_ref_mps, path.cones_m):
        h.update(b"-" if extra is None else np.ascontiguousarray(extra).tobytes())
    return h.hexdigest()


def check_observable(paths: tuple) -> tuple:
    """``paths`` unchanged if an observation holds every one of them (curvature as the env interpolates it <=
    ``MAX_CURVATURE_PER_M`` [1/m], curvature rate <= ``MAX_CURVATURE_RATE_PER_M2`` [1/m^2]); else ValueError naming
    the path, the station [m], the value and the limit. The env calls it on every path it receives (a file, a
    ``Path``, a built-in or procedural track), so no track puts an observation outside its space."""
    for path in paths:
        excess = unobservable(path)
        if excess is not None:
            what, value, limit, unit, row = excess
            raise ValueError(f"track {path.name!r}: its {what} reaches {value:.4g} {unit} at s = "
                             f"{row * path.ds_m:.1f} m, beyond the {limit:g} {unit} an observation holds (a kink, "
                             "not a road); fix: smooth the path (Path.from_points with smoothing_m > 0) or remove "
                             "the kink")
    return paths


def source_digest(paths: tuple) -> str | None:
    """The SHA-256 of the file bytes a one-path track was read from (``Path.source_sha256``), or None (a built-in,
    procedural or hand-made track, or a bank): what a result row records as the content it drove."""
    return paths[0].source_sha256 if len(paths) == 1 and isinstance(paths[0], Path) else None
