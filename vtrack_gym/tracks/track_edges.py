"""The edges of a track as polylines, and how far points lie from them.

A track's edges are the centre line offset along its left normals by the drivable half widths
(``Path.half_widths``): left edge r + w_left n, right edge r - w_right n, as polylines through points every
``EDGE_SPACING_M`` or less. ``edge_clearance`` gives every point's Euclidean distance to each edge polyline (exact
distance to the nearest segment), signed: negative beyond that edge (the point's lateral offset from the centre
line, ``Path.project``, past the half width). Used by ``tracks.raceline`` to keep a racing line clear of the edges
and to give it its own half widths.
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.tracks.path import Path

EDGE_SPACING_M = 0.05
"""Largest station spacing of the edge vertices [m]: the polyline then lies within about 0.1 mm of the smooth edge
even on a 2 m radius."""
NEAREST_VERTICES = 16
"""Edge vertices (the nearest by a KD-tree) whose two adjacent segments are measured for each point."""
MIN_WINDOW_M = 10.0
"""Least station window [m] either side of a point's own station within which its edges are sought (also at least
3 x the widest half width), so that another part of the track passing close (or over: a figure eight, the laps of a
circle) is not taken for this part's edge."""


def edge_spacing_m(path: Path) -> float:
    """Station spacing [m] of the edge vertices: the rows' spacing divided until at most ``EDGE_SPACING_M``."""
    return path.ds_m / max(1, int(np.ceil(path.ds_m / EDGE_SPACING_M - 1e-9)))


def edge_polylines(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) edge vertices [m], each (n, 2): the centre line every ``edge_spacing_m`` (interpolated
    between rows) offset by its half widths along the normal."""
    spacing = edge_spacing_m(path)
    s = np.minimum(np.arange(round(path.length_m / spacing) + 1) * spacing, path.length_m)
    row = path.sample(s)
    normal = np.column_stack((-np.sin(row.psi), np.cos(row.psi)))
    xy = np.column_stack((row.x, row.y))
    w_left, w_right = path.half_widths(s)
    return xy + w_left[:, None] * normal, xy - w_right[:, None] * normal


def _segment_distance(vertices: np.ndarray, points: np.ndarray, a_idx: np.ndarray) -> np.ndarray:
    """Distance [m] from each point (m, 2) to the segments a_idx -> a_idx + 1 (m, k) of the polyline: (m, k)."""
    a = vertices[a_idx]
    ab = vertices[a_idx + 1] - a
    length2 = np.maximum(np.einsum("mkj,mkj->mk", ab, ab), 1e-300)
    t = np.clip(np.einsum("mkj,mkj->mk", points[:, None, :] - a, ab) / length2, 0.0, 1.0)
    gap = points[:, None, :] - (a + t[..., None] * ab)
    return np.sqrt(np.einsum("mkj,mkj->mk", gap, gap))


def polyline_distance(vertices: np.ndarray, points: np.ndarray, rows: np.ndarray | None = None,
                      window: int = 0, closed: bool = False) -> np.ndarray:
    """Distance [m] from each point (m, 2) to the polyline through ``vertices`` (n, 2): the least distance to the
    segments next to the ``NEAREST_VERTICES`` nearest vertices. With ``rows`` (m,) (each point's own vertex index)
    only vertices within ``window`` indices of it count (cyclic when ``closed``), measured on the whole window
    where none of the nearest is in it."""
    from scipy.spatial import cKDTree

    n = vertices.shape[0]
    k = min(NEAREST_VERTICES, n)
    _, idx = cKDTree(vertices).query(points, k=k)
    idx = idx.reshape(points.shape[0], k)
    segments = np.concatenate((np.maximum(idx - 1, 0), np.minimum(idx, n - 2)), axis=1)
    dist = _segment_distance(vertices, points, segments)
    if rows is None:
        return dist.min(axis=1)
    gap = np.abs(segments - rows[:, None])
    if closed:
        gap = np.minimum(gap, (n - 1) - gap)
    dist = np.where(gap <= window, dist, np.inf)
    best = dist.min(axis=1)
    lost = np.flatnonzero(~np.isfinite(best))
    if lost.size:
        span = rows[lost, None] + np.arange(-window, window + 1)[None, :]
        span = span % (n - 1) if closed else np.clip(span, 0, n - 2)
        best[lost] = _segment_distance(vertices, points[lost], span).min(axis=1)
    return best


def edge_clearance(path: Path, x: np.ndarray, y: np.ndarray,
                   s_guess: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) distances [m] of the points (x, y) [m] to the track's left and right edges near each point's
    own station (``MIN_WINDOW_M``), negative for a point beyond that edge (its offset from the centre line past the
    half width there). ``s_guess`` [m]: the points' approximate stations (else the nearest centre-line sample's:
    give them where the track overlaps itself)."""
    points = np.column_stack((np.ravel(x), np.ravel(y)))
    proj = path.project(points[:, 0], points[:, 1], None if s_guess is None else np.ravel(s_guess))
    left, right = edge_polylines(path)
    spacing = edge_spacing_m(path)
    rows = np.clip(np.rint(proj.s / spacing).astype(np.int64), 0, left.shape[0] - 1)
    window = int(np.ceil(max(MIN_WINDOW_M, 3.0 * float(path.half_widths_rows().max())) / spacing))
    d_left = polyline_distance(left, points, rows, window, path.closed)
    d_right = polyline_distance(right, points, rows, window, path.closed)
    w_left, w_right = path.half_widths(proj.s)
    d_left = np.where(proj.e_y > w_left, -d_left, d_left)
    d_right = np.where(-proj.e_y > w_right, -d_right, d_right)
    return d_left, d_right


__all__ = ["edge_clearance", "edge_polylines", "polyline_distance"]
