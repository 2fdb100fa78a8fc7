"""One entry point from "a track" as a user names it (a built-in name, a CSV file, or a Path) to a ``Path``, and a
content digest for provenance (two files with the same name but different points never mix)."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from pathlib import Path as FsPath

import numpy as np

from vtrack_gym.tracks.csv_loader import load_track_csv
from vtrack_gym.tracks.dlc import double_lane_change
from vtrack_gym.tracks.handling_course import handling_course
from vtrack_gym.tracks.path import Path

BUILTIN_TRACKS: dict[str, Callable[[], Path]] = {
    "handling_course": handling_course,
    "double_lane_change": double_lane_change,
}
"""Built-in track name -> builder (default arguments)."""

TrackSource = str | os.PathLike[str] | Path


def load_track(track: TrackSource, *, closed: bool | None = None, half_width_m: float | None = None,
               smoothing_m: float | None = None, allow_self_crossing: bool = False) -> Path:
    """The ``Path`` of ``track``: a ``Path`` (returned as is), a built-in name (``BUILTIN_TRACKS``) or a CSV file
    (see ``csv_loader``; the keyword options apply to files only). ValueError naming the choices otherwise."""
    if isinstance(track, Path):
        return track
    if isinstance(track, str) and track in BUILTIN_TRACKS:
        return BUILTIN_TRACKS[track]()
    if not isinstance(track, (str, os.PathLike)):
        raise ValueError(f"track must be a CSV file path, a tracks.Path or one of {sorted(BUILTIN_TRACKS)} "
                         f"(got {type(track).__name__})")
    if FsPath(track).is_dir():
        raise ValueError(f"{track}: is a folder, not a track file (give a CSV file in it)")
    if not FsPath(track).is_file():
        raise ValueError(f"{track}: track file not found (built-in tracks: {', '.join(sorted(BUILTIN_TRACKS))})")
    return load_track_csv(track, closed=closed, half_width_m=half_width_m, smoothing_m=smoothing_m,
                          allow_self_crossing=allow_self_crossing)


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
    for extra in (path.widths_m, path.v_ref_mps):
        h.update(b"-" if extra is None else np.ascontiguousarray(extra).tobytes())
    return h.hexdigest()
