"""The one gate every map importer's centre line goes through: points with per-point half widths -> a checked
``Path`` (closure, self-crossing, length, what an observation can hold), errors naming the map element.

An importer (OpenDRIVE, Lanelet2, CommonRoad, GPX) turns its map and route into ``MapLine``: centre points x, y
[m], left/right half widths [m] and a ``where(k)`` that names the map element point ``k`` came from (``road 7 at
s = 12.0 m``, ``lanelet 1002``, ``line 57``).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path as FsPath

import numpy as np

from vtrack_gym.tracks.fitting import MAX_LENGTH_M, check_points
from vtrack_gym.tracks.path import DEFAULT_DS_M, MAX_HALF_WIDTH_M, Path

MAX_MAP_POINTS = 400_000
"""Most centre points one route may have (200 km at 0.5 m)."""


@dataclass(frozen=True)
class MapLine:
    """A route's centre line: points ``x, y`` [m] (n,), half ``widths`` [m] (n, 2) left and right of it, and
    ``where(k)`` naming the map element of point k for errors."""

    x: np.ndarray
    y: np.ndarray
    widths: np.ndarray
    where: Callable[[int], str]


def map_path(file: FsPath, data: bytes, line: MapLine, *, closed: bool | None, smoothing_m: float | None,
             allow_self_crossing: bool, name: str | None = None) -> Path:
    """The ``Path`` of ``line`` read from ``file`` (``data``: its bytes, hashed as the path's source).

    ``closed`` None: detected as for a CSV of points (``csv_loader.detect_closed``: an end within 1 m of the start,
    or within 3 point spacings heading on). ``smoothing_m`` [m]: the fit's
    allowed RMS deviation (None: 0, the points are exact geometry). ValueError naming the file and the map element
    for a route too short or long, a half width outside (0, 100] m, a self-crossing (unless allowed) or a kink.
    """
    x, y, widths = (np.asarray(a, dtype=float) for a in (line.x, line.y, line.widths))
    if x.size > MAX_MAP_POINTS:
        raise ValueError(f"{file}: the route has {x.size} centre points, more than {MAX_MAP_POINTS}")
    try:
        check_points(x, y, None)
    except ValueError as exc:
        raise ValueError(f"{file}: the route's centre line: {exc}") from None
    _check_widths(file, widths, line.where)
    from vtrack_gym.tracks.csv_loader import NEAR_DUPLICATE_SHARE, detect_closed

    is_closed = detect_closed(x, y) if closed is None else bool(closed)
    spacing = float(np.median(np.hypot(np.diff(x), np.diff(y))))
    if is_closed and math.hypot(x[-1] - x[0], y[-1] - y[0]) <= max(1e-6, NEAR_DUPLICATE_SHARE * spacing):
        x, y, widths = x[:-1], y[:-1], widths[:-1]   # the end repeats the start
    steps = np.hypot(np.diff(np.append(x, x[0]) if is_closed else x), np.diff(np.append(y, y[0]) if is_closed else y))
    if float(steps.sum()) > MAX_LENGTH_M:
        raise ValueError(f"{file}: the route is {steps.sum() / 1000:.0f} km long; at most {MAX_LENGTH_M / 1000:.0f} km")
    if not allow_self_crossing:
        _check_crossing(file, x, y, is_closed, line.where)
    try:
        path = Path.from_points(x, y, None, is_closed, smoothing_m=smoothing_m or 0.0, ds_m=DEFAULT_DS_M,
                                half_width_m=float(widths.min()), name=name or file.stem, widths_m=widths)
    except ValueError as exc:
        raise ValueError(f"{file}: {exc}") from None
    _check_observable(file, path, x, y, line.where)
    return replace(path, source_sha256=hashlib.sha256(data).hexdigest())


def _check_widths(file: FsPath, widths: np.ndarray, where: Callable[[int], str]) -> None:
    """ValueError naming the element of the first half width outside (0, ``MAX_HALF_WIDTH_M``] m."""
    bad = np.flatnonzero(~((widths > 0.0) & (widths <= MAX_HALF_WIDTH_M)).all(axis=1))
    if bad.size:
        k = int(bad[0])
        left, right = widths[k]
        raise ValueError(f"{file}, {where(k)}: the drivable half widths are {left:.3g} m left and {right:.3g} m "
                         f"right of the driven line; expected both in (0, {MAX_HALF_WIDTH_M:g}] m (a lane with no "
                         "width, or a driven line outside the road?)")


def _check_crossing(file: FsPath, x: np.ndarray, y: np.ndarray, closed: bool, where: Callable[[int], str]) -> None:
    """ValueError naming both elements where the centre line first crosses itself."""
    from vtrack_gym.tracks.geometry import TooDenseError, segment_intersections

    try:
        hits = segment_intersections(np.column_stack((x, y)), closed).pairs
    except TooDenseError as exc:
        i, j = exc.points
        raise ValueError(f"{file}, {where(i)} to {where(j)}: {exc}") from None
    if hits.shape[0]:
        i, j = (int(v) for v in hits[0])
        raise ValueError(f"{file}: the route crosses itself ({where(i)} meets {where(j % x.size)}); if the road "
                         "really crosses itself (a bridge), pass allow_self_crossing=True (CLI: "
                         "--allow-self-crossing)")


def _check_observable(file: FsPath, path: Path, x: np.ndarray, y: np.ndarray, where: Callable[[int], str]) -> None:
    """ValueError naming the element nearest the first curvature (rate) an observation cannot hold."""
    from vtrack_gym.tracks.csv_loader import unobservable
    from vtrack_gym.tracks.table import COL_X, COL_Y

    excess = unobservable(path)
    if excess is not None:
        what, value, limit, unit, row = excess
        k = int(np.argmin(np.hypot(x - path.table[row, COL_X], y - path.table[row, COL_Y])))
        raise ValueError(f"{file}, {where(k)}: the route's {what} reaches {value:.3g} {unit}, beyond the {limit:g} "
                         f"{unit} an observation holds (a kink where two roads or lanelets meet at an angle?)")
