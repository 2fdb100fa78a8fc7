"""Whether a polyline of points is a loop that ends short of its start (the CSV loader's ``closed`` detection)."""

from __future__ import annotations

import math

import numpy as np

CLOSED_GAP_M = 1.0          # first and last points closer than this [m] always close the loop (auto-detection)
CLOSED_GAP_SPACINGS = 3.0   # ... or an end gap up to this x the median point spacing,
CLOSED_GAP_TURN_DEG = 45.0  # ... with the closing chord turning at most this from the end and start directions,
CLOSED_TURN_RATIO = 1.5     # ... or at most this x the turn at the neighbouring point (sparse polygons turn a lot)


def _turn_rad(a: np.ndarray, b: np.ndarray) -> float:
    """Angle [rad] between the directions of the 2-vectors a and b, in [0, pi]."""
    return abs(math.atan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1]))


def detect_closed(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether points x, y [m] describe a loop that ends short of its start (see the CLOSED_GAP_* constants).

    The end gap must be within 1 m, or within 3 median point spacings with the closing chord heading on: at the
    last and at the first point it turns at most 45 deg, or at most 1.5 x the turn at the neighbouring point
    (the second-last and the second), so that a loop of a few points (a square of 4) closes like a dense one while
    an open U whose legs end straight stays open. Everything is relative to the point spacing, never to the
    polyline length, so sparse loops close too.
    """
    gap = math.hypot(x[-1] - x[0], y[-1] - y[0])
    if gap <= CLOSED_GAP_M:
        return True
    d = np.column_stack((np.diff(x), np.diff(y)))
    if gap > CLOSED_GAP_SPACINGS * float(np.median(np.hypot(d[:, 0], d[:, 1]))):
        return False
    chord = np.array([x[0] - x[-1], y[0] - y[-1]])
    floor = math.radians(CLOSED_GAP_TURN_DEG)
    end_ok = _turn_rad(d[-1], chord) <= max(floor, CLOSED_TURN_RATIO * _turn_rad(d[-2], d[-1]))
    start_ok = _turn_rad(chord, d[0]) <= max(floor, CLOSED_TURN_RATIO * _turn_rad(d[0], d[1]))
    return bool(end_ok and start_ok)
