"""The one gate every map importer's centre line goes through: points with per-point half widths -> a checked
``Path`` (closure, self-crossing, length, what an observation can hold), errors naming the map element.

An importer (OpenDRIVE, Lanelet2, CommonRoad, GPX) turns its map and route into ``MapLine``: centre points x, y
[m], left/right half widths [m] and a ``where(k)`` that names the map element point ``k`` came from (``road 7 at
s = 12.0 m``, ``lanelet 1002``, ``line 57``).
"""

from __future__ import annotations

import hashlib
import itertools
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
    allowed RMS deviation (None: ``NOISE_HINT_FACTOR`` x the points' noise estimated from their third differences,
    for polylines such as a lanelet's centre or a recording; 0 interpolates exact geometry). ValueError naming the
    file and the map element for a route too short or long, a half width outside (0, 100] m, a self-crossing
    (unless allowed) or a kink.
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
    if smoothing_m is None:
        from vtrack_gym.tracks.track_noise import NOISE_HINT_FACTOR, point_noise_m

        smoothing_m = NOISE_HINT_FACTOR * point_noise_m(x, y)
    try:
        path = Path.from_points(x, y, None, is_closed, smoothing_m=smoothing_m, ds_m=DEFAULT_DS_M,
                                half_width_m=float(widths.min()), name=name or file.stem, widths_m=widths)
    except ValueError as exc:
        raise ValueError(f"{file}: {exc}") from None
    if not allow_self_crossing and path.self_intersects():
        raise ValueError(f"{file}: the fitted centre line crosses itself (a route that touches itself?); if the road "
                         "really crosses itself, pass allow_self_crossing=True (CLI: --allow-self-crossing)")
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
    from vtrack_gym.tracks.geometry import first_crossing

    found = first_crossing(x, y, closed)
    if found is not None:
        why, i, j = found
        if why is not None:
            raise ValueError(f"{file}, {where(i)} to {where(j)}: {why}")
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


def nearest_on(points: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """The point of the polyline ``bound`` (m, 2) nearest each of ``points`` (n, 2), (n, 2) [m]."""
    a, b = bound[:-1], bound[1:]
    d = b - a
    length2 = np.maximum((d * d).sum(axis=1), 1e-18)
    out = np.empty_like(points)
    for start in range(0, points.shape[0], 256):   # bounded memory: 256 x m segments at a time
        p = points[start:start + 256, None, :]
        t = np.clip(((p - a[None]) * d[None]).sum(axis=2) / length2[None], 0.0, 1.0)
        near = a[None] + t[..., None] * d[None]
        best = ((p - near) ** 2).sum(axis=2).argmin(axis=1)
        out[start:start + 256] = near[np.arange(best.size), best]
    return out


def bound_distance(points: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """Distance [m] from each of ``points`` (n, 2) to the polyline ``bound`` (m, 2): a lanelet's half width."""
    return np.hypot(*(points - nearest_on(points, bound)).T)


def lanelet_line(parts: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]) -> MapLine:
    """The centre line of a lanelet sequence: ``parts`` of (lanelet id, centre (n, 2), left bound, right bound) in
    driving order; a lanelet's first point is dropped where it repeats the previous lanelet's last."""
    xs, ws, names = [], [], []
    for lanelet_id, centre, left, right in parts:
        if xs and float(np.hypot(*(centre[0] - xs[-1][-1]))) < 1e-3:
            centre = centre[1:]
        widths = np.column_stack((bound_distance(centre, left), bound_distance(centre, right)))
        xs.append(centre)
        ws.append(widths)
        names += [lanelet_id] * centre.shape[0]
    xy = np.concatenate(xs)

    def where(k: int) -> str:
        return f"lanelet {names[min(k, len(names) - 1)]}"

    return MapLine(xy[:, 0], xy[:, 1], np.concatenate(ws), where)


def successor_path(successors: dict[str, list[str]], start: str, goal: str, limit: int = 100_000) -> list[str] | None:
    """The fewest-lanelet path ``start`` -> ``goal`` (both included) along ``successors``, or None (breadth-first,
    at most ``limit`` lanelets visited)."""
    from collections import deque

    previous: dict[str, str | None] = {start: None}
    queue = deque([start])
    while queue and len(previous) <= limit:
        node = queue.popleft()
        if node == goal:
            break
        for nxt in successors.get(node, []):
            if nxt not in previous:
                previous[nxt] = node
                queue.append(nxt)
    if goal not in previous:
        return None
    path, node = [], goal
    while node is not None:
        path.append(node)
        node = previous[node]
    return path[::-1]


def expand_route(file: FsPath, route: tuple[str, ...],
                 path_between: Callable[[str, str], list[str] | None]) -> list[str]:
    """``route`` with the lanelets between two consecutive ids that do not follow each other filled in by
    ``path_between(a, b)`` (the ids from a to b, or None); ValueError naming the two ids when no path joins them."""
    out = [route[0]]
    for a, b in itertools.pairwise(route):
        between = path_between(a, b)
        if between is None:
            raise ValueError(f"{file}: route: no lanelet sequence leads from lanelet {a} to lanelet {b} (expected "
                             "each next id reachable along the lanelets' successors)")
        out += between[1:]
    return out


def no_route_error(file: FsPath, ids: list[str], what: str) -> ValueError:
    """The error for a map of several lanelets and no route, listing some ids."""
    shown = ", ".join(ids[:12]) + (", ..." if len(ids) > 12 else "")
    return ValueError(f"{file}: the map has {len(ids)} lanelets ({shown}); give the lanelets to drive: route="
                      f"'first,...,last' (CLI --track-route; consecutive ids are joined {what})")


def centre_of_bounds(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """A lanelet's centre line (n, 2): midway between each vertex of its denser bound (m, 2) and the nearest point
    of the other bound (no zig-zag from walking both bounds' vertices in turn); its ends midway between the
    bounds' ends."""
    dense, other = (left, right) if left.shape[0] >= right.shape[0] else (right, left)
    centre = 0.5 * (dense + nearest_on(dense, other))
    centre[0], centre[-1] = 0.5 * (left[0] + right[0]), 0.5 * (left[-1] + right[-1])
    return centre
