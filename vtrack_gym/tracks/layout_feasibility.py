"""Can a car drive a track at all, and how fast at best: the full-lock radius against the track's tightest line, the
body against the narrowest width, and the lap-time bound.

A car fits a track when its body plus ``margin_m`` on each side is narrower than the track everywhere (the
track's widths, e.g. between a cone file's cone lines). It turns when its minimum turning radius
(``vehicle.turning.min_turning_radius_m``: the plant at full lock, walking pace) is at most the tightest radius of
the track's minimum-curvature racing line for that car (``tracks.raceline``, the line that keeps the body
``margin_m`` from the edges and bends least; a tighter radius than the track's width allows is never needed, a
wider one never possible along that line). Drivable = fits and turns. The lap-time bound is the car's flying lap
along that line at its own g-g-v limits (``tracks.lap_time``), NaN when the car does not fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class LayoutFeasibility:
    """One car on one track (module docstring); lengths [m], times [s]."""

    vehicle: str
    track: str
    min_turning_radius_m: float
    line_min_radius_m: float          # tightest radius of the car's racing line (NaN: the car does not fit)
    body_width_m: float
    min_track_width_m: float
    margin_m: float
    lap_time_bound_s: float           # flying lap on the racing line (NaN: the car does not fit)

    @property
    def fits(self) -> bool:
        """The body plus the margin on both sides is narrower than the narrowest part of the track."""
        return self.body_width_m + 2.0 * self.margin_m < self.min_track_width_m

    @property
    def turns(self) -> bool:
        """The car's full-lock circle is no wider than the racing line's tightest bend."""
        return self.fits and self.min_turning_radius_m <= self.line_min_radius_m

    @property
    def drivable(self) -> bool:
        """It fits and it turns."""
        return self.fits and self.turns


def layout_feasibility(track: Any, vehicle: Any = None, margin_m: float = 0.2) -> LayoutFeasibility:
    """:class:`LayoutFeasibility` of ``vehicle`` (a shipped name, a vehicle file, ``VehicleParams``; None: the
    default car) on ``track`` (a ``Path``, a built-in name or a track file, e.g. a shipped cone file
    ``tracks.fs_layouts.fs_layout(name)``), its racing line ``margin_m`` [m] from the edges."""
    from vtrack_gym.tracks.gg_limits import gg_limits
    from vtrack_gym.tracks.lap_time import line_lap_time
    from vtrack_gym.tracks.raceline import RacingLineSpec, solve_racing_line
    from vtrack_gym.tracks.sources import load_track
    from vtrack_gym.tracks.table import COL_KAPPA
    from vtrack_gym.vehicle.catalog import resolve_vehicle
    from vtrack_gym.vehicle.turning import min_turning_radius_m

    params = resolve_vehicle(vehicle)
    path = load_track(track)
    width = float(np.min(path.half_widths_rows().sum(axis=1)))
    out = LayoutFeasibility(vehicle=params.name, track=path.name, min_turning_radius_m=min_turning_radius_m(params),
                            line_min_radius_m=math.nan, body_width_m=params.chassis.body_width_m,
                            min_track_width_m=width, margin_m=margin_m, lap_time_bound_s=math.nan)
    if not out.fits:
        return out
    line = solve_racing_line(path, params, RacingLineSpec(margin_m=margin_m)).path
    radius = 1.0 / float(np.max(np.abs(line.table[:, COL_KAPPA])))
    bound = line_lap_time(line, gg_limits(params), "raceline").lap_time_s
    return LayoutFeasibility(out.vehicle, out.track, out.min_turning_radius_m, radius, out.body_width_m, width,
                             margin_m, float(bound))


def feasibility_table(tracks: list[Any], vehicles: list[Any], margin_m: float = 0.2) -> list[LayoutFeasibility]:
    """:func:`layout_feasibility` of every car on every track (tracks outer, cars inner)."""
    return [layout_feasibility(t, v, margin_m) for t in tracks for v in vehicles]


__all__ = ["LayoutFeasibility", "feasibility_table", "layout_feasibility"]
