"""``TrackBank``: the paths of a batch and their packed tables for the compiled step (the owner of their columns).

All paths in use are concatenated into ``tables`` (M, ``N_ENV_COLS``): the path's own columns
(``tracks.table``), then the squared reference speed and the half widths left / right (``kernels.C_V2``,
``C_WL``, ``C_WR``) and the reference's time law at each row (``C_T``, ``tracks.time_law``); ``meta`` (K,
``N_TM``) holds per path its first row, row count, spacing, length, closed flag, half width, whether the speed
protocol follows a profile, the station and mode of an ``EntryThenRelease`` protocol's release, and the table's
lap time (``kernels.TM_*``). Code outside this class reads the
bank through its named accessors, never by column number.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vtrack_gym.envs.scenarios import MAX_EPISODE_S
from vtrack_gym.envs.speed import is_profile, release_columns, speed_tables
from vtrack_gym.tracks.table import COL_KAPPA, COL_PSI, COL_X, COL_Y
from vtrack_gym.tracks.time_law import time_law

TIME_LIMIT_FACTOR = 1.5
TIME_LIMIT_MARGIN_S = 30.0


class TrackBank:
    """The paths a scenario's cars drive on, their speed tables and the packed arrays the kernel reads."""

    def __init__(self, paths: tuple, speed: Any, vehicle: Any = None) -> None:
        from vtrack_gym.envs import kernels as k
        from vtrack_gym.tracks.sources import check_observable

        self.paths = check_observable(paths)   # every route (file, Path, built-in): observations stay in the box
        self.speed_tables = speed_tables(paths, speed, vehicle)
        self.time_laws = tuple(time_law(t) for t in self.speed_tables)
        """The reference's time law t_ref(s) of each speed table (``tracks.time_law``)."""
        self.tables = np.ascontiguousarray(np.concatenate([
            np.column_stack([p.table, t.v_mps ** 2, p.half_widths_rows(), law.row_times_s]) for p, t, law in zip(
                paths, self.speed_tables, self.time_laws, strict=True)]))
        counts = np.array([p.table.shape[0] for p in paths], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        meta = np.zeros((len(paths), k.N_TM))
        meta[:, k.TM_START] = starts
        meta[:, k.TM_N] = counts
        meta[:, k.TM_DS] = [p.ds_m for p in paths]
        meta[:, k.TM_LEN] = [p.length_m for p in paths]
        meta[:, k.TM_CLOSED] = [1.0 if p.closed else 0.0 for p in paths]
        meta[:, k.TM_HALF_WIDTH] = [p.half_width_m for p in paths]
        meta[:, k.TM_PROFILE] = 1.0 if is_profile(speed) else 0.0
        meta[:, [k.TM_RELEASE_S, k.TM_RELEASE_HOLD]] = release_columns(paths, speed)
        meta[:, k.TM_LAP_T] = [law.total_time_s for law in self.time_laws]
        self.meta = meta
        self.length_m = meta[:, k.TM_LEN].copy()
        """Length of each path [m] (K,)."""
        self.closed = meta[:, k.TM_CLOSED] != 0.0
        """Whether each path is a closed loop (K,)."""
        self._peak_kappa = np.array([float(np.max(np.abs(p.table[:, COL_KAPPA]))) for p in paths])

    def __len__(self) -> int:
        return len(self.paths)

    def finish_speeds(self) -> np.ndarray:
        """Per path (K,): the reference speed at the finish line [m/s] of a closed path whose profile starts
        slower than it finishes (a standing start: rows 0 and n - 1 are the same point, and a car that has
        completed its lap reads the next lap's start there); NaN for every other path."""
        out = np.full(len(self.paths), np.nan)
        for j, (path, table) in enumerate(zip(self.paths, self.speed_tables, strict=True)):
            if path.closed and abs(float(table.v_mps[-1]) - float(table.v_mps[0])) > 1e-9:
                out[j] = float(table.v_mps[-1])
        return out

    def start_pose(self, track: int) -> tuple[float, float, float]:
        """The first row's x, y [m] and heading [rad] of path ``track``."""
        row = self.paths[track].table[0]
        return float(row[COL_X]), float(row[COL_Y]), float(row[COL_PSI])

    def peak_curvature(self, track: int) -> float:
        """The largest |curvature| of path ``track`` [1/m]."""
        return float(self._peak_kappa[track])

    def time_limit_s(self) -> float:
        """The derived time limit [s]: ``TIME_LIMIT_FACTOR`` x the longest profile lap time (v linear between rows)
        + ``TIME_LIMIT_MARGIN_S`` (the standstill start and the PD-FLC lag). ValueError naming the lap time and
        the fix if it exceeds ``MAX_EPISODE_S``."""
        laps = [float(np.sum(2.0 * t.ds_m / (t.v_mps[1:] + t.v_mps[:-1]))) for t in self.speed_tables]
        worst = int(np.argmax(laps))
        limit = TIME_LIMIT_FACTOR * laps[worst] + TIME_LIMIT_MARGIN_S
        if limit > MAX_EPISODE_S:
            length = float(self.speed_tables[worst].length_m)
            raise ValueError(f"track {self.paths[worst].name!r}: the speed profile takes {laps[worst]:.4g} s for its "
                             f"{length:.4g} m (mean {length / laps[worst]:.3g} m/s), so the derived time limit "
                             f"{TIME_LIMIT_FACTOR} x lap + {TIME_LIMIT_MARGIN_S:.0f} s = {limit:.4g} s exceeds the "
                             f"maximum {MAX_EPISODE_S:.0f} s of simulated time; fix: raise the profile's speeds "
                             "(--max-speed-kmh, the file's speed column) or drive a shorter track")
        return limit
