"""Polyline validators: self-intersection and minimum clearance between distant parts (numpy + scipy KD-tree)."""

from __future__ import annotations

import math

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


def self_intersection_pairs(xy: np.ndarray, closed: bool) -> np.ndarray:
    """Index pairs (i, j), i < j, of non-adjacent segments xy[i]-xy[i+1] and xy[j]-xy[j+1] that meet.

    For a closed polyline the last point is expected to repeat the first (segment n-2 then touches segment 0).
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(xy, dtype=float)
    n_seg = xy.shape[0] - 1
    if n_seg < 3:
        return np.zeros((0, 2), dtype=np.int64)
    a = xy[:-1]
    b = xy[1:]
    seg_len = np.hypot(*(b - a).T)
    mid = 0.5 * (a + b)
    radius = float(seg_len.max()) * (1.0 + 1e-9) + 1e-12
    pairs = cKDTree(mid).query_pairs(radius, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i, j = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    keep = (j - i) > 1
    if closed:
        keep &= ~((i == 0) & (j == n_seg - 1))
    i, j = i[keep], j[keep]
    hit = segments_intersect(a[i], b[i], a[j], b[j])
    return np.column_stack((i[hit], j[hit]))


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
