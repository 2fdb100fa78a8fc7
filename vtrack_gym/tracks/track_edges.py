"""The edges of a track as polylines, and how far points lie from them.

A track's edges are the centre line's rows offset along their left normals by the drivable half widths
(``Path.half_widths_rows``): left edge r + w_left n, right edge r - w_right n. ``edge_clearance`` gives every
point's Euclidean distance to each edge polyline (exact distance to the nearest segment), signed: negative beyond
that edge (the point's lateral offset from the centre line, ``Path.project``, past the half width). Used by
``tracks.raceline`` to keep a racing line clear of the edges and to give it its own half widths.
"""

from __future__ import annotations

import numpy as np

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.path import Path

NEAREST_VERTICES = 8
"""Edge vertices (the nearest by a KD-tree) whose two adjacent segments are measured for each point."""


def edge_polylines(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) edge vertices [m], each (n, 2): the rows offset by their half widths along the normal."""
    psi = path.table[:, tb.COL_PSI]
    normal = np.column_stack((-np.sin(psi), np.cos(psi)))
    xy = path.table[:, [tb.COL_X, tb.COL_Y]]
    widths = path.half_widths_rows()
    return xy + widths[:, :1] * normal, xy - widths[:, 1:] * normal


def polyline_distance(vertices: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance [m] from each point (m, 2) to the polyline through ``vertices`` (n, 2): the least distance to the
    segments next to the ``NEAREST_VERTICES`` nearest vertices."""
    from scipy.spatial import cKDTree

    n = vertices.shape[0]
    k = min(NEAREST_VERTICES, n)
    _, idx = cKDTree(vertices).query(points, k=k)
    idx = idx.reshape(points.shape[0], k)
    best = np.full(points.shape[0], np.inf)
    for a_idx in (np.maximum(idx - 1, 0), idx):
        b_idx = np.minimum(a_idx + 1, n - 1)
        a, b = vertices[a_idx], vertices[b_idx]
        ab = b - a
        length2 = np.maximum(np.einsum("mkj,mkj->mk", ab, ab), 1e-300)
        t = np.clip(np.einsum("mkj,mkj->mk", points[:, None, :] - a, ab) / length2, 0.0, 1.0)
        gap = points[:, None, :] - (a + t[..., None] * ab)
        best = np.minimum(best, np.sqrt(np.einsum("mkj,mkj->mk", gap, gap)).min(axis=1))
    return best


def edge_clearance(path: Path, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(left, right) distances [m] of the points (x, y) [m] to the track's left and right edges, negative for a
    point beyond that edge (its offset from the centre line past the half width there)."""
    points = np.column_stack((np.ravel(x), np.ravel(y)))
    left, right = edge_polylines(path)
    d_left = polyline_distance(left, points)
    d_right = polyline_distance(right, points)
    proj = path.project(points[:, 0], points[:, 1])
    w_left, w_right = path.half_widths(proj.s)
    d_left = np.where(proj.e_y > w_left, -d_left, d_left)
    d_right = np.where(-proj.e_y > w_right, -d_right, d_right)
    return d_left, d_right


__all__ = ["edge_clearance", "edge_polylines", "polyline_distance"]
