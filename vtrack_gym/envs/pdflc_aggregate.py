"""The Mamdani aggregation of the PD-FLC, compiled: the clipped output triangles' max on the centroid grid.

``pdflc.mamdani_direct`` clips each of the seven output triangles at its rule height (min implication) and takes
their pointwise max (max aggregation) before the centroid. Neighbouring triangles are one half-width apart, so at
most two of them are non-zero at a point of the centroid grid: ``grid_cover`` lists them per point, and
``aggregate`` fills the aggregated membership ``mu[p, m] = max(0, min(h_a, t_a), min(h_b, t_b))`` in one pass.
min and max are exact, so this gives the same bits as the level-by-level numpy loop it replaces (numba imported
lazily by ``pdflc``; the numpy module stays importable without it).
"""

from __future__ import annotations

import numpy as np

from vtrack_gym._jit import kernel

COVER = 2
"""Output triangles that can be non-zero at one point of the centroid grid (half-width = peak spacing)."""


def grid_cover(tri: np.ndarray, support: tuple[tuple[int, int], ...]) -> tuple[np.ndarray, np.ndarray]:
    """Per centroid-grid point, the levels (index 0..6) of the triangles over it and their memberships there,
    both shape (points, ``COVER``); a point under one triangle repeats its level with membership 0."""
    points = tri.shape[1]
    levels = np.zeros((points, COVER), dtype=np.int64)
    tops = np.zeros((points, COVER))
    count = np.zeros(points, dtype=np.int64)
    for k, (lo, hi) in enumerate(support):
        if (count[lo:hi] >= COVER).any():
            raise ValueError(f"more than {COVER} output triangles overlap on the centroid grid")
        cols = np.arange(lo, hi)
        levels[cols, count[lo:hi]] = k
        tops[cols, count[lo:hi]] = tri[k, lo:hi]
        count[lo:hi] += 1
    single = count == 1
    levels[single, 1] = levels[single, 0]
    return levels, tops


@kernel
def aggregate(heights: np.ndarray, levels: np.ndarray, tops: np.ndarray, mu: np.ndarray) -> None:
    """Fill ``mu`` (P, points) with the aggregated membership for the rule heights ``heights`` (P, 7) and the
    grid cover ``levels`` / ``tops`` (``grid_cover``); all dimensionless."""
    n, points = mu.shape
    for p in range(n):
        for m in range(points):
            a = heights[p, levels[m, 0]]
            b = heights[p, levels[m, 1]]
            ta = tops[m, 0]
            tb = tops[m, 1]
            va = a if a < ta else ta
            vb = b if b < tb else tb
            v = va if va > 0.0 else 0.0
            mu[p, m] = vb if vb > v else v
