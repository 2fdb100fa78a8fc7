"""Cone-lined lane sequences (the ISO 3888 style of test track) and their smooth centre-line.

A test track is a straight approach, then lane sections (cone gates: a length, a width and the global Y of the lane
centre) joined by lateral transitions, then a straight run-out. The centre-line is straight at the lane centres
inside every lane section (so a gate's boundaries, kept as lateral offsets from the centre-line, are the straight
cone lines) and moves sideways only between lanes. A transition is a trapezoidal curvature pulse
(0 -> +K -> -K -> 0, smootherstep blends over ``ramp_fraction`` of its length at the ends and twice that at the
reversal), antisymmetric so the heading returns exactly to 0; K and its arc length are solved so that it spans
exactly the gap length in X and the lane offset in Y. The path is built with ``Path.from_curvature`` (C^2: exact
kappa and dkappa/ds), starts at (0, 0) heading +X.

Lower bound worth knowing when choosing a speed: any such transition that moves dy [m] sideways over dx [m] with
zero heading at both ends needs a peak curvature of at least 4 dy / dx^2 [1/m] (the bang-bang limit), i.e. a peak
lateral acceleration of at least 4 v^2 dy / dx^2 on the centre-line.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vtrack_gym.tracks.path import Gate, Path
from vtrack_gym.tracks.profiles import CurvatureProfile


@dataclass(frozen=True)
class LaneSection:
    """A cone-lined lane: ``length_m`` [m] along X, ``width_m`` [m] between the cone lines, centre at global
    ``centre_y_m`` [m] (left-positive)."""

    length_m: float
    width_m: float
    centre_y_m: float
    name: str = ""

    def __post_init__(self) -> None:
        for field_name in ("length_m", "width_m", "centre_y_m"):
            value = getattr(self, field_name)
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"LaneSection.{field_name} must be a finite number (got {value!r})")
        if self.length_m <= 0.0 or self.width_m <= 0.0:
            raise ValueError(f"LaneSection.length_m and width_m must be > 0 m (got {self.length_m}, {self.width_m})")


def _unit_pulse(ramp: float) -> CurvatureProfile:
    """Antisymmetric curvature pulse on u in [0, 1]: 0 -> 1 -> 1 -> -1 -> -1 -> 0."""
    return CurvatureProfile((0.0, ramp, 0.5 - ramp, 0.5 + ramp, 1.0 - ramp, 1.0), (0.0, 1.0, 1.0, -1.0, -1.0, 0.0))


def transition(dy_m: float, dx_m: float, ramp: float) -> tuple[float, float]:
    """Peak curvature K [1/m] and arc length L [m] of the pulse that moves dy_m [m] sideways over dx_m [m] of X."""
    if not (0.0 < ramp < 0.25):
        raise ValueError(f"ramp_fraction must be in (0, 0.25) (got {ramp})")
    if not dx_m > 0.0:
        raise ValueError(f"transition length dx_m must be > 0 m (got {dx_m})")
    pulse = _unit_pulse(ramp)
    xi, om = np.polynomial.legendre.leggauss(32)
    knots = np.asarray(pulse.knots_m)
    width = np.diff(knots)
    u = (knots[:-1, None] + width[:, None] * 0.5 * (xi + 1.0)).ravel()
    w = (width[:, None] * 0.5 * om).ravel()
    heading = pulse.heading(u)                      # psi(u) / (K L)

    def excess(a: float) -> float:                  # sign of (dy/dx of the pulse with K L = a) - target
        return float(w @ np.sin(a * heading)) * dx_m - float(w @ np.cos(a * heading)) * dy_m

    lo, hi = 0.0, math.copysign(8.0, dy_m)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if excess(mid) * math.copysign(1.0, dy_m) > 0.0:
            hi = mid
        else:
            lo = mid
        if lo == mid == hi:
            break
    a = 0.5 * (lo + hi)
    length = dx_m / float(w @ np.cos(a * heading))
    return a / length, length


def pulse_segments(k_peak: float, length: float, ramp: float) -> list[tuple[float, float]]:
    """Curvature segments (length_m, kappa_end) of a pulse with peak k_peak [1/m] and arc length ``length`` [m]."""
    hold = (0.5 - 2.0 * ramp) * length
    return [(ramp * length, k_peak), (hold, k_peak), (2.0 * ramp * length, -k_peak), (hold, -k_peak),
            (ramp * length, 0.0)]


def lane_sequence_path(lanes: Sequence[LaneSection], gaps_m: Sequence[float], *, approach_m: float,
                       run_out_m: float, ramp_fraction: float, half_width_m: float, ds_m: float, name: str,
                       version: str, overlap_m: float = 0.0) -> Path:
    """Path through ``lanes`` with ``gaps_m[i]`` [m] of X between lane i and lane i + 1, ``approach_m`` [m] of
    straight before the first lane and ``run_out_m`` [m] after the last; it starts at (0, lanes[0].centre_y_m)
    heading +X. One ``Gate`` per lane (named like the lane).

    ``overlap_m`` = 0: the centre-line is straight inside every lane and the gates are centre-line offsets (see
    the module docstring). ``overlap_m`` > 0 [m]: every transition starts ``overlap_m`` before the end of its lane
    and ends ``overlap_m`` after the start of the next (it spans gap + 2 overlap of X, so it is gentler), and the
    gates are anchored rectangles (``Gate.anchor``) at the lanes' fixed positions."""
    if len(lanes) < 1 or len(gaps_m) != len(lanes) - 1:
        raise ValueError(f"need >= 1 lane and one gap between consecutive lanes (got {len(lanes)} lanes, "
                         f"{len(gaps_m)} gaps)")
    if approach_m < 0.0 or run_out_m < 0.0 or overlap_m < 0.0:
        raise ValueError(f"approach_m, run_out_m and overlap_m must be >= 0 m (got {approach_m}, {run_out_m}, "
                         f"{overlap_m})")
    segs: list[tuple[float, float]] = []
    if approach_m > 0.0:
        segs.append((approach_m, 0.0))
    gates: list[Gate] = []
    s = approach_m
    last = len(lanes) - 1
    for k, lane in enumerate(lanes):
        straight = lane.length_m - overlap_m * ((k > 0) + (k < last)) + (run_out_m if k == last else 0.0)
        if straight < 0.0 or (straight == 0.0 and k == last):
            raise ValueError(f"overlap_m = {overlap_m} m leaves no straight in {lane.name or f'lane {k}'} "
                             f"({lane.length_m} m long)")
        if straight > 0.0:
            segs.append((straight, 0.0))
        gates.append(Gate(s, s + lane.length_m, 0.5 * lane.width_m, -0.5 * lane.width_m, lane.name))
        s += lane.length_m
        if k < last:
            k_peak, length = transition(lanes[k + 1].centre_y_m - lane.centre_y_m, float(gaps_m[k]) + 2.0 * overlap_m,
                                        ramp_fraction)
            segs += pulse_segments(k_peak, length, ramp_fraction)
            s += length - 2.0 * overlap_m
    path = Path.from_curvature(CurvatureProfile.from_segments(0.0, segs), ds_m=ds_m, closed=False,
                               y0_m=lanes[0].centre_y_m, half_width_m=half_width_m, name=name, version=version,
                               gates=tuple(gates) if overlap_m == 0.0 else ())
    if overlap_m == 0.0:
        return path
    steps = [ln.length_m + g for ln, g in zip(lanes, gaps_m, strict=False)]   # lane k start -> lane k + 1 start
    x_start = approach_m + np.concatenate(([0.0], np.cumsum(steps)))
    return anchored_gates(path, lanes, x_start)


def anchored_gates(path: Path, lanes: Sequence[LaneSection], x_start_m: Sequence[float]) -> Path:
    """``path`` with one anchored gate per lane (``Gate.anchor``): lane k is the fixed rectangle from X =
    ``x_start_m[k]`` [m] over its length, centred on its ``centre_y_m``, heading +X; the gate's stations are where
    the path's X crosses the lane's ends (the path's X must increase along it)."""
    x_rows = path.table[:, 0]                                   # increasing: every heading stays within +-90 deg
    anchored = []
    for lane, x0 in zip(lanes, x_start_m, strict=False):
        s0, s1 = np.interp([x0, x0 + lane.length_m], x_rows, path.s_m)
        anchored.append(Gate(float(s0), float(s1), 0.5 * lane.width_m, -0.5 * lane.width_m, lane.name,
                             anchor=(float(x0), lane.centre_y_m, 0.0), length_m=lane.length_m))
    return dataclasses.replace(path, gates=tuple(anchored))
