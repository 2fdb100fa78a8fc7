"""Polyline validators: self-intersection (uniform-grid bucketing, linear work) and minimum clearance between distant
parts (scipy KD-tree)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


def _orient(ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray, cx: np.ndarray,
            cy: np.ndarray) -> np.ndarray:
    """Signed doubled area of triangle (a, b, c) [m^2] (> 0 counter-clockwise)."""
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def segments_intersect(p: np.ndarray, q: np.ndarray, r: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Whether segment p-q meets segment r-t (arrays of shape (M, 2) [m]); touching and overlapping count."""
    o1 = _orient(p[:, 0], p[:, 1], q[:, 0], q[:, 1], r[:, 0], r[:, 1])
    o2 = _orient(p[:, 0], p[:, 1], q[:, 0], q[:, 1], t[:, 0], t[:, 1])
    o3 = _orient(r[:, 0], r[:, 1], t[:, 0], t[:, 1], p[:, 0], p[:, 1])
    o4 = _orient(r[:, 0], r[:, 1], t[:, 0], t[:, 1], q[:, 0], q[:, 1])
    crossing = (o1 * o2 <= 0.0) & (o3 * o4 <= 0.0)
    # Collinear segments satisfy the test trivially: require overlapping bounding boxes as well.
    box = ((np.minimum(p[:, 0], q[:, 0]) <= np.maximum(r[:, 0], t[:, 0]))
           & (np.minimum(r[:, 0], t[:, 0]) <= np.maximum(p[:, 0], q[:, 0]))
           & (np.minimum(p[:, 1], q[:, 1]) <= np.maximum(r[:, 1], t[:, 1]))
           & (np.minimum(r[:, 1], t[:, 1]) <= np.maximum(p[:, 1], q[:, 1])))
    return crossing & box


class Intersections(NamedTuple):
    """Result of :func:`segment_intersections`."""

    pairs: np.ndarray     # (k, 2) int64 index pairs (i, j), i < j, of non-adjacent segments that meet
    candidates: int       # segment pairs tested exactly (the work done; linear in the points for a road)


class TooDenseError(ValueError):
    """More segments share one grid cell than a road can: ``points`` (i, j) are the first and last segment there."""

    def __init__(self, message: str, points: tuple[int, int]) -> None:
        super().__init__(message)
        self.points = points


def _sorted_unique(a: np.ndarray) -> np.ndarray:
    """Sorted distinct values of a 1-D integer array (a sort and a mask: faster than np.unique's hashing here)."""
    a = np.sort(a)
    return a[np.concatenate(([True], a[1:] != a[:-1]))] if a.size else a


def _pairs_within_groups(keys: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All (ids[p], ids[q]) with p < q inside each run of equal ``keys`` (keys sorted)."""
    n = keys.size
    start = np.flatnonzero(np.concatenate(([True], keys[1:] != keys[:-1])))
    end = np.append(start[1:], n)
    size = end - start
    group_end = np.repeat(end, size)
    count = group_end - np.arange(n) - 1
    first = np.repeat(np.arange(n), count)
    offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    return ids[first], ids[first + 1 + offset]


def segment_intersections(xy: np.ndarray, closed: bool, max_candidates_per_segment: int = 64) -> Intersections:
    """Non-adjacent segments xy[i]-xy[i+1], xy[j]-xy[j+1] of a polyline that meet (touching counts).

    Uniform-grid bucketing: the cell size is the median segment length (at least total length / (4 n)), segments
    longer than a cell are split into cell-sized pieces, and only segments sharing a cell are tested exactly, so
    the work is linear in the points for a road-like line. A cluster that would need more than
    ``max_candidates_per_segment`` x n tests (thousands of points on a few centimetres) raises
    :class:`TooDenseError` instead of going quadratic. For a closed polyline the last point is expected to repeat
    the first (segment n-2 then touches segment 0).
    """
    xy = np.asarray(xy, dtype=float)
    n_seg = xy.shape[0] - 1
    empty = np.zeros((0, 2), dtype=np.int64)
    if n_seg < 3:
        return Intersections(empty, 0)
    a = xy[:-1]
    b = xy[1:]
    seg_len = np.hypot(*(b - a).T)
    scale = max(1.0, float(np.max(np.abs(xy))))
    cell = max(float(np.median(seg_len)), float(seg_len.sum()) / (4.0 * n_seg), 1e-9 * scale)
    pieces = np.maximum(1, np.ceil(seg_len / cell)).astype(np.int64)
    seg = np.repeat(np.arange(n_seg), pieces)
    k = np.arange(seg.size) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    t0 = (k / pieces[seg])[:, None]
    t1 = ((k + 1) / pieces[seg])[:, None]
    d = b[seg] - a[seg]
    p0 = a[seg] + t0 * d
    p1 = a[seg] + t1 * d
    eps = 1e-9 * scale
    lo = np.floor((np.minimum(p0, p1) - eps) / cell).astype(np.int64)
    hi = np.floor((np.maximum(p0, p1) + eps) / cell).astype(np.int64)
    keys_list = []
    ids_list = []
    origin = lo.min(axis=0)
    span_y = int(hi[:, 1].max() - origin[1]) + 1
    for dx in range(3):
        for dy in range(3):
            cx = lo[:, 0] + dx
            cy = lo[:, 1] + dy
            ok = (cx <= hi[:, 0]) & (cy <= hi[:, 1])
            keys_list.append((cx[ok] - origin[0]) * span_y + (cy[ok] - origin[1]))
            ids_list.append(seg[ok])
    # one entry per (cell, segment); cells <= (4 n + 3)^2, so cell * n_seg + segment fits in int64
    entry = _sorted_unique(np.concatenate(keys_list) * n_seg + np.concatenate(ids_list))
    keys, ids = entry // n_seg, entry % n_seg
    start = np.flatnonzero(np.concatenate(([True], keys[1:] != keys[:-1])))
    size = np.diff(np.append(start, keys.size))
    work = int(np.sum(size * (size - 1) // 2))
    budget = max_candidates_per_segment * n_seg + 100_000
    if work > budget:
        g = int(np.argmax(size))
        members = ids[start[g]:start[g] + size[g]]
        raise TooDenseError(f"{int(size[g])} segments (points {int(members.min())}-{int(members.max()) + 1}) pass "
                            f"through one {cell:.3g} m cell: the points cluster or double back on themselves",
                            (int(members.min()), int(members.max()) + 1))
    i, j = _pairs_within_groups(keys, ids)
    i, j = np.minimum(i, j), np.maximum(i, j)
    keep = (j - i) > 1
    if closed:
        keep &= ~((i == 0) & (j == n_seg - 1))
    i, j = i[keep], j[keep]
    if i.size:
        uniq = _sorted_unique(i * n_seg + j)
        i, j = uniq // n_seg, uniq % n_seg
    hit = segments_intersect(a[i], b[i], a[j], b[j])
    return Intersections(np.column_stack((i[hit], j[hit])).astype(np.int64), int(i.size))


def first_crossing(x: np.ndarray, y: np.ndarray, closed: bool) -> tuple[str | None, int, int] | None:
    """The first self-crossing of the polyline x, y [m] as (None, i, j): segment i meets segment j; or (why, i, j)
    when the points i..j are too dense to check (``TooDenseError``); None when it does not cross."""
    try:
        hits = segment_intersections(np.column_stack((x, y)), closed).pairs
    except TooDenseError as exc:
        return str(exc), int(exc.points[0]), int(exc.points[1])
    return (None, int(hits[0][0]), int(hits[0][1])) if hits.shape[0] else None


def self_intersection_pairs(xy: np.ndarray, closed: bool) -> np.ndarray:
    """Index pairs (i, j), i < j, of non-adjacent segments xy[i]-xy[i+1] and xy[j]-xy[j+1] that meet.

    For a closed polyline the last point is expected to repeat the first (segment n-2 then touches segment 0).
    """
    return segment_intersections(xy, closed).pairs


def polyline_self_intersects(xy: np.ndarray, closed: bool) -> bool:
    """True if any two non-adjacent segments of the polyline xy (n, 2) [m] meet."""
    return bool(self_intersection_pairs(xy, closed).shape[0] > 0)


def polyline_min_gap_violated(xy: np.ndarray, s: np.ndarray, period_m: float | None, clearance_m: float) -> bool:
    """True if two points closer than clearance_m [m] lie more than (pi/2) clearance_m apart along the path.

    ``s`` [m] is the arc length of every point; ``period_m`` [m] the length of a closed path (None if open).
    """
    from scipy.spatial import cKDTree

    pairs = cKDTree(np.asarray(xy, dtype=float)).query_pairs(clearance_m, output_type="ndarray")
    if pairs.size == 0:
        return False
    gap = np.abs(s[pairs[:, 0]] - s[pairs[:, 1]])
    if period_m is not None:
        gap = np.minimum(gap, period_m - gap)
    return bool(np.any(gap > 0.5 * math.pi * clearance_m))
