"""Lap timing on a closed track from the per-step progress along it.

A lap ends when the car's progress since the reset (``info["progress_m"]``, the arc length driven along the path,
laps counted) first reaches a whole multiple k L of the path's length L. The crossing time is interpolated linearly
between the two control steps around it (the reset, progress 0 at time 0, is the first sample), so a lap time is
accurate to within a control step's speed change, not to the control period: at constant speed it is exact. Lap k
lasts from crossing k - 1 (crossing 0: the reset, a standing or flying start as the episode began) to crossing k.

Used for every episode on a closed path (one lap ends a ``Track-v0`` episode, so one lap there) and for any env
that drives several laps.
"""

from __future__ import annotations

import math

import numpy as np


def lap_crossing_times(time_s: np.ndarray, progress_m: np.ndarray, lap_length_m: float) -> np.ndarray:
    """Times [s] at which ``progress_m`` [m] first reaches L, 2 L, ... (L = ``lap_length_m`` > 0), interpolated
    linearly between the samples; the samples are the control steps after the reset (the reset itself, time 0 and
    progress 0, is prepended). Empty when no lap is driven. ``ValueError`` naming the argument for a bad input."""
    length = float(lap_length_m)
    if not (math.isfinite(length) and length > 0.0):
        raise ValueError(f"lap_length_m must be a finite number > 0 m (got {lap_length_m!r})")
    t = np.concatenate(([0.0], np.asarray(time_s, dtype=np.float64).ravel()))
    p = np.concatenate(([0.0], np.asarray(progress_m, dtype=np.float64).ravel()))
    if t.size != p.size:
        raise ValueError(f"time_s and progress_m must have the same length (got {t.size - 1} and {p.size - 1})")
    if not (np.isfinite(t).all() and np.isfinite(p).all()):
        raise ValueError("time_s and progress_m must be finite")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("time_s must increase strictly (from above 0, the reset's time)")
    reached = np.maximum.accumulate(p)   # a car that backs up crosses a line once, the first time
    n_laps = int(np.floor(reached[-1] / length))
    if n_laps < 1:
        return np.zeros(0)
    lines = length * np.arange(1, n_laps + 1)
    after = np.searchsorted(reached, lines, side="left")   # first sample at or beyond each line (never the reset)
    before = after - 1
    frac = (lines - p[before]) / (p[after] - p[before])
    return t[before] + frac * (t[after] - t[before])


def lap_times(time_s: np.ndarray, progress_m: np.ndarray, lap_length_m: float) -> np.ndarray:
    """Duration of each completed lap [s] (``lap_crossing_times``: lap 1 from the reset to the first crossing)."""
    crossings = lap_crossing_times(time_s, progress_m, lap_length_m)
    return np.diff(np.concatenate(([0.0], crossings))) if crossings.size else crossings


def lap_metrics(time_s: np.ndarray, progress_m: np.ndarray, lap_length_m: float) -> dict[str, object]:
    """A row's lap figures: ``lap_times_s`` (a list, one entry per completed lap [s]), ``best_lap_s`` and
    ``mean_lap_s`` [s] (NaN before the first lap is completed)."""
    laps = lap_times(time_s, progress_m, lap_length_m)
    return {"lap_times_s": [float(x) for x in laps],
            "best_lap_s": float(laps.min()) if laps.size else math.nan,
            "mean_lap_s": float(laps.mean()) if laps.size else math.nan}
