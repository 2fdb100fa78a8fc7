"""The reference's time law: the time t_ref(s) [s] at which a car driving a speed table exactly reaches station s.

A trajectory is a path and its timing. A ``tracks.SpeedTable`` holds v_ref at the path's rows with v^2 linear in s
between rows (how the env interpolates it), so the speed is that of a constant acceleration on each interval and
the time across an interval of length ds between speeds v0 and v1 is exactly ``2 ds / (v0 + v1)``; inside an
interval, ``t(s) = t_i + 2 (s - s_i) / (v_i + v(s))`` with ``v(s)`` the interpolated speed. No quadrature error.

On a closed path t_ref counts laps: ``t_ref(s + L) = t_ref(s) + T_lap`` with T_lap = ``lap_time_s``. On an open path
s is clamped to [0, L] like the path.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vtrack_gym.tracks.speed_profiles import SpeedTable


@dataclass(frozen=True, eq=False)
class TimeLaw:
    """Cumulative reference times of a ``SpeedTable`` (``row_times_s`` (n,) [s] at s = i ds_m, starting at 0)."""

    table: SpeedTable
    row_times_s: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        v = self.table.v_mps
        t = np.concatenate(([0.0], np.cumsum(2.0 * self.table.ds_m / (v[:-1] + v[1:]))))
        t.flags.writeable = False
        object.__setattr__(self, "row_times_s", t)

    @property
    def total_time_s(self) -> float:
        """Time to drive the whole table from s = 0 to its end (one lap on a closed path) [s]."""
        return float(self.row_times_s[-1])

    def time_at(self, s_m: np.ndarray | float) -> np.ndarray:
        """t_ref(s) [s] at arc length(s) s [m]: laps counted on a closed path, clamped to [0, L] on an open one."""
        s = np.asarray(s_m, dtype=np.float64)
        length = self.table.length_m
        if self.table.closed:
            laps = np.floor(s / length)
            s_in = s - laps * length
        else:
            laps = np.zeros_like(s)
            s_in = np.clip(s, 0.0, length)
        ds = self.table.ds_m
        i = np.clip(np.floor(s_in / ds).astype(np.int64), 0, self.table.v_mps.size - 2)
        v = self.table.v_mps
        frac = (s_in - i * ds) / ds
        v_s = np.sqrt(v[i] ** 2 + frac * (v[i + 1] ** 2 - v[i] ** 2))
        t = self.row_times_s[i] + 2.0 * (s_in - i * ds) / (v[i] + v_s)
        return t + laps * self.total_time_s


def time_law(table: SpeedTable) -> TimeLaw:
    """The time law t_ref(s) of ``table`` (see the module docstring)."""
    return TimeLaw(table)


__all__ = ["TimeLaw", "time_law"]
