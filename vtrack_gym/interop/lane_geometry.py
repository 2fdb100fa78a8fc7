"""Centre-line geometry of a highway-env lane (``StraightLane`` / ``SineLane``): exact projection, arc length.

Used by the highway-env adapter (``vtrack_gym.interop.highway``). highway-env's lanes are analytic curves in a
chord frame, so the projection is exact (Newton on the closest-point condition) instead of going through a
tabulated ``vtrack_gym.tracks.Path``: the stations are true arc lengths and e_y is the perpendicular distance.
highway-env is imported only when a geometry is built.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


class LaneGeometry:
    """Centre line of a highway-env ``StraightLane`` or ``SineLane`` with exact projection and arc length.

    In the lane's chord frame (origin ``lane.start``, unit x along ``lane.direction``, y along
    ``lane.direction_lateral``) the centre line is ``y = A sin(w x + phase)`` (A = 0 for a straight lane), so
    heading ``atan(y')``, curvature ``y'' / (1 + y'^2)^1.5`` and its arc-length derivative are analytic. Arc
    length s(x) is tabulated once (trapezoid, ``step_m``) over the lane plus margins so the preview can map
    stations back to chord abscissae.
    """

    def __init__(self, lane: Any, step_m: float = 0.25, margin_before_m: float = 100.0,
                 margin_after_m: float = 200.0) -> None:
        from highway_env.road.lane import SineLane, StraightLane

        if not isinstance(lane, StraightLane):
            raise NotImplementedError(f"only StraightLane/SineLane centre lines are supported (got "
                                      f"{type(lane).__name__})")
        self.lane = lane
        is_sine = isinstance(lane, SineLane)
        self.amp = float(lane.amplitude) if is_sine else 0.0
        self.w = float(lane.pulsation) if is_sine else 0.0
        self.phase = float(lane.phase) if is_sine else 0.0
        self.x0, self.y0 = (float(c) for c in lane.start)
        self.ux, self.uy = (float(c) for c in lane.direction)
        self.chord_heading = math.atan2(self.uy, self.ux)
        self.length = float(lane.length)  # chord length [m]
        self.half_width = 0.5 * float(lane.width_at(0.0))
        x = np.arange(-margin_before_m, self.length + margin_after_m + step_m, step_m)
        slope = self.amp * self.w * np.cos(self.w * x + self.phase)
        ds = np.sqrt(1.0 + slope * slope)
        s = np.concatenate(([0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * step_m)))
        self._x_tab = x
        self._s_tab = s - np.interp(0.0, x, s)  # s = 0 at the lane start (x = 0)
        curv = -self.amp * self.w * self.w * np.sin(self.w * x + self.phase)
        self._k_tab = curv / (ds * ds * ds)  # y'' / (1 + y'^2)^1.5 on the grid (preview: linear in s, < 1e-6 1/m)
        self._x_first, self._inv_step = float(x[0]), 1.0 / step_m
        self._s_list = self._s_tab.tolist()
        self.arc_length = self.station_at(self.length)

    # ----------------------------------------------------------------------------------------- chord frame
    def to_chord(self, px: float, py: float) -> tuple[float, float]:
        """World point -> chord-frame (x, y)."""
        dx, dy = px - self.x0, py - self.y0
        return dx * self.ux + dy * self.uy, -dx * self.uy + dy * self.ux

    def centre(self, x: float) -> tuple[float, float]:
        """World position of the centre line at chord abscissa ``x``."""
        yc = self.amp * math.sin(self.w * x + self.phase)
        return self.x0 + x * self.ux - yc * self.uy, self.y0 + x * self.uy + yc * self.ux

    def _derivatives(self, x: float) -> tuple[float, float, float, float]:
        """(y, y', y'', y''') of the centre line at chord abscissa ``x``."""
        th = self.w * x + self.phase
        sn, cs = math.sin(th), math.cos(th)
        a, w = self.amp, self.w
        return a * sn, a * w * cs, -a * w * w * sn, -a * w * w * w * cs

    def project(self, px: float, py: float) -> tuple[float, float, float, float, float]:
        """Closest centre-line point of world point (px, py).

        Returns ``(x*, e_y, psi_ref, kappa, dkappa_ds)``: chord abscissa [m], signed perpendicular offset
        (left-positive) [m], world heading of the centre line [rad], curvature [1/m], d kappa / d s [1/m^2].
        """
        qx, qy = self.to_chord(px, py)
        x = qx
        if self.amp != 0.0:
            for _ in range(12):  # Newton on g(x) = (x - qx) + (y(x) - qy) y'(x) = 0
                y, y1, y2, _ = self._derivatives(x)
                g = (x - qx) + (y - qy) * y1
                dg = 1.0 + y1 * y1 + (y - qy) * y2
                step = g / dg if dg > 0.1 else g
                x -= step
                if abs(step) < 1e-10:
                    break
        y, y1, y2, y3 = self._derivatives(x)
        q = 1.0 + y1 * y1
        root = math.sqrt(q)
        e_y = (-(qx - x) * y1 + (qy - y)) / root  # (q - c) . n with n = (-y', 1)/sqrt(1 + y'^2)
        kappa = y2 / (q * root)
        dkappa_ds = (y3 / (q * root) - 3.0 * y1 * y2 * y2 / (q * q * root)) / root
        return x, e_y, self.chord_heading + math.atan(y1), kappa, dkappa_ds

    # ------------------------------------------------------------------------------------------ arc length
    def station_at(self, x: float) -> float:
        """Arc length [m] from the lane start to chord abscissa ``x`` (clamped to the tabulated range)."""
        u = (x - self._x_first) * self._inv_step
        last = len(self._s_list) - 1
        if u <= 0.0:
            return self._s_list[0]
        if u >= last:
            return self._s_list[last]
        i = int(u)
        s0 = self._s_list[i]
        return s0 + (u - i) * (self._s_list[i + 1] - s0)

    def abscissa_at(self, s: float) -> float:
        """Chord abscissa [m] of arc-length station ``s``."""
        return float(np.interp(s, self._s_tab, self._x_tab))

    def curvature_at_stations(self, s: np.ndarray) -> np.ndarray:
        """Curvature [1/m] at arc-length stations ``s`` (beyond the tabulated margin: clamped)."""
        return np.interp(s, self._s_tab, self._k_tab)

    def polyline(self, step_m: float = 1.0) -> np.ndarray:
        """(N, 2) world points of the centre line over the lane's chord."""
        x = np.arange(0.0, self.length + step_m, step_m)
        yc = self.amp * np.sin(self.w * x + self.phase)
        return np.column_stack((self.x0 + x * self.ux - yc * self.uy, self.y0 + x * self.uy + yc * self.ux))
