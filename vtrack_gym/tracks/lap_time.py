"""A quasi-steady-state lap-time bound: the fastest speed profile a car's g-g-v limits allow along a line, and its
lap time.

Along a line (a track's centre line or its racing line, ``tracks.raceline``) with the car's limits
(``tracks.gg_limits``: lateral A_y(v), forward A_x(v), braking A_b(v), top speed), the speed obeys everywhere

    (a_x / A(v))^2 + (v^2 kappa / A_y(v))^2 <= 1,   A = A_x when speeding up, A_b when braking,  v <= top speed,

a friction ellipse whose axes change with speed. The profile is the largest one inside it, by the usual passes on
the line's rows (v^2 linear in s between rows, so a_x is constant on a row interval): the lateral limit at each row
(v^2 |kappa| = A_y(v), solved for v, |kappa| the larger of its two intervals' largest sampled value), then a
forward pass, u_{i+1} - u_i = 2 ds A_x(v_{i+1}) sqrt(1 - (u_{i+1} kappa / A_y(v_{i+1}))^2) with u = v^2 and the
interval's largest |kappa|, and a backward pass with A_b, each step solved to round-off (the quadratic of the
ellipse with the limits at the faster end, repeated until the limits stop changing). The ellipse then holds at
every row and, with the interval's largest curvature, between rows. A closed line's passes start at the slowest
point of the lateral limit and run once around (a flying lap); an open line's start and end are free (a flying
start). The lap time is the exact time of the table (``tracks.time_law``).
"""

from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass

import numpy as np

from vtrack_gym.tracks.gg_limits import GGLimits
from vtrack_gym.tracks.path import Path
from vtrack_gym.tracks.speed_profiles import SpeedTable

SUBSTEPS = 16              # curvature samples per row interval
KAPPA_FLOOR_PER_M = 1e-12  # |kappa| below this is straight
_STEP_ITERATIONS = 50      # limit re-evaluations of one pass step (converges in 2-4)
LINES = ("raceline", "centreline")
"""The lines :func:`lap_time_bound` drives: the minimum-curvature racing line or the track's centre line."""


def interval_curvature(path: Path) -> np.ndarray:
    """Largest |kappa| [1/m] on each of the n - 1 row intervals of ``path`` (``SUBSTEPS`` samples each, ends
    included)."""
    n = path.n_samples
    s = np.arange((n - 1) * SUBSTEPS + 1) * (path.ds_m / SUBSTEPS)
    s[-1] = min(s[-1], path.length_m)
    k = np.abs(path.sample(s).kappa)
    return np.maximum(k[:-1].reshape(n - 1, SUBSTEPS).max(axis=1), k[SUBSTEPS::SUBSTEPS])


def lateral_speed_limit(limits: GGLimits, kappa_per_m: np.ndarray) -> np.ndarray:
    """Largest speed [m/s] with v^2 |kappa| <= A_y(v) and v <= the top speed, for each curvature [1/m]
    (bisection to round-off; v^2 |kappa| - A_y(v) is increasing in v where the limit falls with speed)."""
    k = np.maximum(np.abs(np.asarray(kappa_per_m, dtype=float)), KAPPA_FLOOR_PER_M)
    lo = np.zeros(k.shape)
    hi = np.full(k.shape, limits.top_speed_mps)
    ok = hi * hi * k <= limits.at(hi)[0]
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        inside = mid * mid * k <= limits.at(mid)[0]
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    return np.where(ok, limits.top_speed_mps, lo)


class _Tables:
    """The limits as Python lists (fast scalar interpolation inside the passes)."""

    def __init__(self, limits: GGLimits) -> None:
        self.speeds = limits.speeds_mps.tolist()
        self.last = len(self.speeds) - 1
        self.lateral = limits.lateral_mps2.tolist()
        self.forward = limits.forward_mps2.tolist()
        self.brake = limits.brake_mps2.tolist()

    def pair(self, speed: float, braking: bool) -> tuple[float, float]:
        """(A_x or A_b, A_y) [m/s^2] at ``speed`` [m/s]."""
        i = min(bisect.bisect_right(self.speeds, speed) - 1, self.last - 1)
        t = min((speed - self.speeds[i]) / (self.speeds[i + 1] - self.speeds[i]), 1.0)
        along = self.brake if braking else self.forward
        return (along[i] + t * (along[i + 1] - along[i]),
                self.lateral[i] + t * (self.lateral[i + 1] - self.lateral[i]))


def _step(tables: _Tables, u_from: float, kappa: float, two_ds: float, braking: bool) -> float:
    """Largest u = v^2 [m^2/s^2] reachable from ``u_from`` over one interval of curvature ``kappa`` [1/m] inside
    the ellipse with the limits at the end reached (fixed point of the ellipse's quadratic)."""
    k = max(kappa, KAPPA_FLOOR_PER_M)
    u = u_from
    for _ in range(_STEP_ITERATIONS):
        a_x, a_y = tables.pair(math.sqrt(u), braking)
        reach = two_ds * a_x
        q = (reach * k / a_y) ** 2
        disc = reach * reach * (1.0 + q) - q * u_from * u_from
        u_new = (u_from + math.sqrt(max(disc, 0.0))) / (1.0 + q)
        if abs(u_new - u) <= 1e-13 * (1.0 + u):
            return min(u_new, u)
        u = u_new
    return u


def _passes(u: np.ndarray, k_interval: np.ndarray, ds_m: float, tables: _Tables) -> None:
    """Forward (driving) then backward (braking) pass on squared speeds u, in place."""
    two_ds = 2.0 * ds_m
    values, kap = u.tolist(), k_interval.tolist()
    for i in range(1, len(values)):
        values[i] = min(values[i], _step(tables, values[i - 1], kap[i - 1], two_ds, False))
    for i in range(len(values) - 2, -1, -1):
        values[i] = min(values[i], _step(tables, values[i + 1], kap[i], two_ds, True))
    u[:] = values


@dataclass(frozen=True)
class QuasiSteadyState:
    """A speed profile (``tracks.SpeedProfile``): the fastest speeds inside the friction ellipse of ``limits``
    (see the module docstring); usable as any env's ``speed_profile``."""

    limits: GGLimits

    def row_speeds(self, path: Path) -> np.ndarray:
        """Speed at every row of ``path`` [m/s]."""
        k_int = interval_curvature(path)
        tables = _Tables(self.limits)
        if path.closed:
            k_row = np.maximum(k_int, np.roll(k_int, 1))
            u = lateral_speed_limit(self.limits, k_row) ** 2
            start = int(np.argmin(u))
            u = np.append(np.roll(u, -start), u[start])
            _passes(u, np.roll(k_int, -start), path.ds_m, tables)
            u = np.roll(u[:-1], start)
            u = np.append(u, u[0])
        else:
            k_row = np.maximum(np.append(k_int, k_int[-1]), np.insert(k_int, 0, k_int[0]))
            u = lateral_speed_limit(self.limits, k_row) ** 2
            _passes(u, k_int, path.ds_m, tables)
        return np.sqrt(u)


@dataclass(frozen=True, eq=False)
class LapTimeBound:
    """The lap-time bound of one line: ``lap_time_s`` [s] (a closed line's flying lap; an open one's run from
    start to end), the ``line`` driven ("raceline" or "centreline"), its ``path``, the ``speed_table`` (v at every
    row, v^2 linear between), the car's ``limits``, ``top_speed_reached_mps`` [m/s], the largest ``ellipse_usage``
    [-] (1 = on the limit) and ``solve_time_s`` [s] (line and profile)."""

    lap_time_s: float
    line: str
    path: Path
    speed_table: SpeedTable
    limits: GGLimits
    top_speed_reached_mps: float
    ellipse_usage: float
    solve_time_s: float


def ellipse_usage(table: SpeedTable, path: Path, limits: GGLimits) -> np.ndarray:
    """(a_x / A)^2 + (a_y / A_y)^2 [-] on every row interval: a_x the interval's constant acceleration, a_y its
    largest v^2 |kappa| (the faster end, the largest sampled curvature), the limits at the faster end."""
    u = table.v_mps ** 2
    a_x = np.diff(u) / (2.0 * table.ds_m)
    v_fast = np.sqrt(np.maximum(u[:-1], u[1:]))
    a_y_lim, a_fwd, a_brk = limits.at(v_fast)
    along = np.where(a_x >= 0.0, a_fwd, a_brk)
    ratio_x = np.divide(a_x, along, out=np.where(a_x == 0.0, 0.0, np.inf), where=along > 0.0)
    return ratio_x ** 2 + (v_fast ** 2 * interval_curvature(path) / a_y_lim) ** 2


def line_lap_time(path: Path, limits: GGLimits, line: str = "centreline") -> LapTimeBound:
    """The quasi-steady-state lap time of ``path`` driven as it is (no line optimisation)."""
    from vtrack_gym.tracks.time_law import time_law

    start = time.perf_counter()
    profile = QuasiSteadyState(limits)
    table = SpeedTable(profile.row_speeds(path), path.ds_m, path.closed, profile)
    lap = time_law(table).total_time_s
    usage = float(np.max(ellipse_usage(table, path, limits)))
    return LapTimeBound(lap, line, path, table, limits, float(table.v_mps.max()), usage,
                        time.perf_counter() - start)


def lap_time_bound(track: object, vehicle: object = None, line: str = "raceline", *, margin_m: float = 0.2,
                   step_m: float = 1.0, limits: GGLimits | None = None) -> LapTimeBound:
    """The car's physical lap-time bound on ``track`` (a ``Path``, a built-in name or a track file) along
    ``line``: "raceline" (the minimum-curvature line, ``tracks.raceline``, ``margin_m`` [m] from the edges, nodes
    every ``step_m`` [m]) or "centreline" (the track's centre line), at the g-g-v limits of ``vehicle``
    (``tracks.gg_limits``; ``limits`` replaces them)."""
    from vtrack_gym.tracks.gg_limits import gg_limits
    from vtrack_gym.tracks.raceline import RacingLineSpec, solve_racing_line
    from vtrack_gym.tracks.sources import load_track

    if line not in LINES:
        raise ValueError(f"line must be one of {', '.join(LINES)} (got {line!r})")
    start = time.perf_counter()
    path = load_track(track)
    limits = gg_limits(vehicle) if limits is None else limits
    if line == "raceline":
        path = solve_racing_line(path, vehicle, RacingLineSpec(margin_m=margin_m, step_m=step_m)).path
    bound = line_lap_time(path, limits, line)
    return LapTimeBound(bound.lap_time_s, line, path, bound.speed_table, limits, bound.top_speed_reached_mps,
                        bound.ellipse_usage, time.perf_counter() - start)


__all__ = ["LINES", "LapTimeBound", "QuasiSteadyState", "ellipse_usage", "interval_curvature", "lap_time_bound",
           "lateral_speed_limit", "line_lap_time"]
