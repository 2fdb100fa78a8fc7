"""Heuristics that tell a noisy or misread track file from a real road: the curvature of a spline through noisy
points changes sign at nearly every point, and a misread elevation column gives grades no public road has."""

from __future__ import annotations

import math

import numpy as np

from vtrack_gym.tracks.path import Path
from vtrack_gym.tracks.table import COL_GRADE

NOISE_SIGN_CHANGE_SHARE = 0.25  # noisy: the curvature changes sign in more than this share of the point intervals,
NOISE_REVERSAL_M = 8.0          # ... more often than once per this distance [m] (a slalom: 18 m) ...
NOISE_MIN_SIGN_CHANGES = 10     # ... and at least this many times
NOISE_KAPPA_ZERO = 1e-4         # |kappa| below this [1/m] (R > 10 km) counts as straight, without a sign,
NOISE_KAPPA_ZERO_SHARE = 0.05   # ... as does |kappa| below this x the largest |kappa| (a spline's ripple on the
                                # straights next to a 6 m hairpin is no noise)
NOISE_HINT_FACTOR = 2.0         # suggested smoothing_m: this x the points' estimated RMS noise (2-D)
MAX_PLAUSIBLE_GRADE = 0.35     # |dz/ds| beyond this (the steepest public streets) warns of a noisy or misread z,
NOISE_GRADE_ZERO = 0.01         # ... as does a grade whose sign (where |dz/ds| >= this) flips like noise


def point_noise_m(x: np.ndarray, y: np.ndarray) -> float:
    """Robust estimate [m] of the points' RMS 2-D deviation from a smooth line: third differences of independent
    noise of standard deviation sigma per coordinate have variance 20 sigma^2, while a smooth road's are ~kappa'
    h^3 (negligible), so sigma = 1.4826 median|diff^3| / sqrt(20) (MAD), times sqrt(2) for x and y together."""
    d3 = np.concatenate((np.diff(x, 3), np.diff(y, 3)))
    return float(1.4826 * np.median(np.abs(d3)) / math.sqrt(20.0) * math.sqrt(2.0)) if d3.size else 0.0


def _point_intervals(path: Path, x: np.ndarray, y: np.ndarray) -> int:
    """How many median point spacings of the points x, y [m] fit along ``path`` (0 for coincident points)."""
    h = float(np.median(np.hypot(np.diff(x), np.diff(y))))
    return int(path.length_m // h) if h > 0.0 else 0


def _sign_changes(values: np.ndarray, zero: float) -> int:
    """Sign changes along ``values``, skipping those with |value| < ``zero`` (no sign)."""
    signs = np.sign(values[np.abs(values) >= zero])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def noisy_curvature_hint(path: Path, x: np.ndarray, y: np.ndarray) -> tuple[int, int, float] | None:
    """(curvature sign changes, point intervals, suggested smoothing_m [m]) if the fit of points x, y [m] has the
    curvature of noise, else None.

    The curvature is sampled once per median point spacing h; a real road changes the sign of its curvature only
    at its S-bends, a few points apart at least, while a spline interpolating noisy points bends back and forth
    at every other point. Noisy: the sign (where |kappa| >= NOISE_KAPPA_ZERO and NOISE_KAPPA_ZERO_SHARE x the
    largest |kappa|) changes in more than
    NOISE_SIGN_CHANGE_SHARE of the intervals, more often than once per NOISE_REVERSAL_M and at least
    NOISE_MIN_SIGN_CHANGES times. The suggestion is NOISE_HINT_FACTOR x :func:`point_noise_m` (on a 1 m-spaced
    circle with 2 cm of noise it gives curvature within 2 %).
    """
    n = _point_intervals(path, x, y)
    if n < 2 * NOISE_MIN_SIGN_CHANGES:
        return None
    kappa = path.sample(np.arange(n + 1) * (path.length_m / n)).kappa
    changes = _sign_changes(kappa, max(NOISE_KAPPA_ZERO, NOISE_KAPPA_ZERO_SHARE * float(np.max(np.abs(kappa)))))
    if (changes < NOISE_MIN_SIGN_CHANGES or changes <= NOISE_SIGN_CHANGE_SHARE * n
            or changes * NOISE_REVERSAL_M <= path.length_m):
        return None
    hint = NOISE_HINT_FACTOR * point_noise_m(x, y)
    return changes, n, float(f"{max(hint, 1e-3):.2g}")


def implausible_grade(path: Path, x: np.ndarray, y: np.ndarray) -> str | None:
    """What is implausible about the fitted road grade dz/ds of ``path`` (from points x, y [m]), else None: a grade
    steeper than ``MAX_PLAUSIBLE_GRADE``, or one whose sign (where |grade| >= ``NOISE_GRADE_ZERO``) changes in more
    than ``NOISE_SIGN_CHANGE_SHARE`` of the point intervals, at least ``NOISE_MIN_SIGN_CHANGES`` times (a road
    climbs and falls over hills, not from one point to the next)."""
    grade = path.table[:, COL_GRADE]
    k = int(np.argmax(np.abs(grade)))
    if abs(float(grade[k])) > MAX_PLAUSIBLE_GRADE:
        return (f"the fitted road grade reaches {100.0 * float(grade[k]):+.0f} % at s = {k * path.ds_m:.0f} m, "
                f"steeper than public roads ({100 * MAX_PLAUSIBLE_GRADE:.0f} %)")
    n = _point_intervals(path, x, y)
    if n < 2 * NOISE_MIN_SIGN_CHANGES:
        return None
    sampled = np.interp(np.arange(n + 1) * (path.length_m / n), np.arange(grade.size) * path.ds_m, grade)
    changes = _sign_changes(sampled, NOISE_GRADE_ZERO)
    if changes >= NOISE_MIN_SIGN_CHANGES and changes > NOISE_SIGN_CHANGE_SHARE * n:
        return (f"the fitted road grade changes sign in {changes} of {n} point intervals (up to "
                f"{100.0 * float(np.max(np.abs(grade))):.0f} %)")
    return None
