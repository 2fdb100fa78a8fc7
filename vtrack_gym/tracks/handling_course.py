"""Case 1 of the paper: a closed two-lane handling course with the statistics of CarSim's "Handling Course Left Edge".

The CarSim geometry is not public, so this is our own course (CHOICE, reference-data section 4) built from the
hard-coded curvature layout below: a counter-clockwise loop of ~2328 m inside ~446 m x 351 m (centre-line; the
paper: 2328 m inside 470 m x 360 m) with a decreasing-radius corner (R 60 m -> 28 m), two identical S-bend
sequences (R 35 m, "repetitive patterns"), a hairpin (R 20 m, the minimum radius: 0.63 g at 40 km/h), a 180 deg
right-hander (R 30 m), an infield hairpin (R 25 m), a chicane (R 45 m), 90 deg corners and straights. Every change
of curvature is a smootherstep blend over 15-25 m (clothoid-like; kappa and dkappa/ds continuous, also across the
closure). Elevation is a periodic sum of four harmonics of the lap length, scaled and phased so that it spans
-2.5 m .. +5.2 m relative to the start (max grade 2.1 %).

Closure is solved deterministically at construction: total turning is made exactly 2 pi by the angle of the
last corner, and the end position, which is affine in the lengths of two straights running north and east, is
closed by one 2x2 linear solve. Start: s = 0 on the main straight at (0, 0), heading +X, 60 m before the first
corner. ``version`` changes whenever the geometry changes.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from vtrack_gym.tracks.path import DEFAULT_DS_M, Path
from vtrack_gym.tracks.profiles import CurvatureProfile, SineElevation

VERSION = "1"
NAME = "handling_course"
HALF_WIDTH_M = 3.5            # two-lane road, reference = centre line
ELEVATION_MIN_M = -2.5        # relative to the start (paper)
ELEVATION_MAX_M = 5.2
# Elevation shape: harmonics (k = lap / wavelength), relative amplitudes and phases [rad].
_ELEV_HARMONICS = (1, 2, 3, 5)
_ELEV_AMPLITUDES = (1.0, 0.45, 0.3, 0.12)
_ELEV_PHASES = (0.0, 1.3, 2.9, 0.7)

Segments = list[tuple[float, float]]


def turn_segments(radius_m: float, angle_deg: float, blend_in_m: float, blend_out_m: float) -> Segments:
    """Corner from and back to a straight: blend 0 -> 1/R, hold, blend 1/R -> 0; turns by angle_deg (left > 0)."""
    k = math.copysign(1.0 / radius_m, angle_deg)
    hold = (math.radians(angle_deg) - 0.5 * k * (blend_in_m + blend_out_m)) / k
    if hold <= 0.0:
        raise ValueError(f"corner R = {radius_m} m, {angle_deg} deg is too short for its blends")
    return [(blend_in_m, k), (hold, k), (blend_out_m, 0.0)]


def _s_bends(radius_m: float, hold_m: float) -> Segments:
    """Right-left-right S-bend sequence with zero net heading change (blends 15 m in/out, 25 m reversals)."""
    k = 1.0 / radius_m
    mid = 2.0 * (7.5 + hold_m)
    return [(15.0, -k), (hold_m, -k), (25.0, k), (mid, k), (25.0, -k), (hold_m, -k), (15.0, 0.0)]


def _decreasing_radius_left() -> Segments:
    """90 deg left corner tightening from R 60 m to R 28 m."""
    k1, k2 = 1.0 / 60.0, 1.0 / 28.0
    head = 20.0 * k1 / 2.0 + 15.0 * k1 + 20.0 * (k1 + k2) / 2.0 + 18.0 * k2 / 2.0
    return [(20.0, k1), (15.0, k1), (20.0, k2), ((0.5 * math.pi - head) / k2, k2), (18.0, 0.0)]


def _layout(north_m: float, east_m: float) -> tuple[Segments, int, int]:
    """The lap as (length_m, kappa_end_per_m) segments from kappa = 0, and the indices of the two free straights."""
    segs: Segments = [(60.0, 0.0)]                       # main straight (start)
    segs += _decreasing_radius_left()                    # -> north
    i_north = len(segs)
    segs += [(north_m, 0.0)]
    segs += _s_bends(35.0, 10.0)
    segs += [(20.0, 0.0)]
    segs += turn_segments(40.0, 90.0, 20.0, 20.0)        # -> west
    segs += [(305.0, 0.0)]
    segs += turn_segments(20.0, 180.0, 15.0, 15.0)       # hairpin -> east
    segs += [(275.0, 0.0)]
    segs += turn_segments(30.0, -180.0, 15.0, 15.0)      # right-hander -> west
    segs += [(115.0, 0.0)]
    k = 1.0 / 45.0                                       # chicane (left-right), lateral offset ~ -33 m
    segs += [(15.0, k), (20.0, k), (25.0, -k), (20.0, -k), (15.0, 0.0)]
    segs += [(80.0, 0.0)]
    segs += turn_segments(30.0, 90.0, 15.0, 15.0)        # -> south
    segs += [(4.0, 0.0)]
    segs += _s_bends(35.0, 10.0)
    segs += [(4.0, 0.0)]
    turned = CurvatureProfile.from_segments(0.0, segs).total_turn_rad
    segs += turn_segments(40.0, math.degrees(2.0 * math.pi - turned), 20.0, 20.0)   # -> east, closes heading
    i_east = len(segs)
    segs += [(east_m, 0.0)]
    segs += turn_segments(25.0, 90.0, 15.0, 15.0)        # infield finger
    segs += [(84.0, 0.0)]
    segs += turn_segments(25.0, -180.0, 15.0, 15.0)
    segs += [(84.0, 0.0)]
    segs += turn_segments(25.0, 90.0, 15.0, 15.0)
    segs += [(50.0, 0.0)]                                # back to the start
    return segs, i_north, i_east


def _end_point(segs: Segments) -> np.ndarray:
    """End position [m] of the open curve of a segment list (start at the origin, heading +X)."""
    return Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), ds_m=1.0).table[-1, :2]


def _closed_profile() -> CurvatureProfile:
    """Curvature profile whose two free straights close the lap exactly (one affine 2x2 solve)."""
    north0, east0 = 100.0, 100.0
    segs, i_north, i_east = _layout(north0, east0)
    prof = CurvatureProfile.from_segments(0.0, segs)
    knots = prof.knots_m
    dirs = [prof.heading(np.array([knots[i]]))[0] for i in (i_north, i_east)]
    basis = np.array([[math.cos(d) for d in dirs], [math.sin(d) for d in dirs]])
    delta = np.linalg.solve(basis, -_end_point(segs))
    segs, _, _ = _layout(north0 + float(delta[0]), east0 + float(delta[1]))
    return CurvatureProfile.from_segments(0.0, segs)


def _elevation(length_m: float) -> SineElevation:
    """Periodic elevation spanning ELEVATION_MIN_M .. ELEVATION_MAX_M with z(0) = 0 [m]."""
    waves = tuple(length_m / k for k in _ELEV_HARMONICS)
    shape = SineElevation(_ELEV_AMPLITUDES, waves, _ELEV_PHASES)
    s = np.linspace(0.0, length_m, 20001)
    g = shape.z(s)
    g_min, g_max = float(g.min()), float(g.max())
    level = g_min + (g_max - g_min) * (-ELEVATION_MIN_M) / (ELEVATION_MAX_M - ELEVATION_MIN_M)
    j = int(np.flatnonzero((g[:-1] - level) * (g[1:] - level) <= 0.0)[0])
    lo, hi = s[j], s[j + 1]
    f_lo = g[j] - level
    for _ in range(80):                      # bisection for the start phase s0 with g(s0) = level
        mid = 0.5 * (lo + hi)
        f_mid = float(shape.z(np.array([mid]))[0]) - level
        if f_mid * f_lo <= 0.0:
            hi = mid
        else:
            lo, f_lo = mid, f_mid
    s0 = 0.5 * (lo + hi)
    scale = (ELEVATION_MAX_M - ELEVATION_MIN_M) / (g_max - g_min)
    return SineElevation(tuple(scale * a for a in _ELEV_AMPLITUDES), waves,
                         tuple(p + 2.0 * math.pi * s0 / w for p, w in zip(_ELEV_PHASES, waves, strict=True)),
                         -scale * level)


@lru_cache(maxsize=4)
def handling_course(ds_m: float = DEFAULT_DS_M) -> Path:
    """The Case-1 handling course (closed, ~2328 m, version ``VERSION``), sampled every <= ds_m [m]. Cached."""
    prof = _closed_profile()
    return Path.from_curvature(prof, elevation=_elevation(prof.length_m), ds_m=ds_m, closed=True,
                               half_width_m=HALF_WIDTH_M, name=NAME, version=VERSION)
