"""The lap figure of a lap-time bound (matplotlib, imported lazily; PNG): the racing line over the track coloured by
speed, the speed along each line, and the g-g usage against the car's friction ellipse."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.lap_time import LapTimeBound
from vtrack_gym.tracks.path import Path

ELLIPSE_SPEEDS_KMH: tuple[float, ...] = (60.0, 120.0, 180.0)
"""Speeds at which the car's friction ellipse is drawn on the g-g panel [km/h] (those below its top speed)."""
LINE_COLOURS = {"raceline": "tab:red", "centreline": "tab:blue"}
ZOOM_HALF_SPAN_M = 40.0
"""Half span [m] of the inset on the line's slowest corner."""


def accelerations(bound: LapTimeBound) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(speed [m/s], a_x [m/s^2], a_y [m/s^2]) at every row interval's faster end: a_x the interval's constant
    acceleration, a_y = v^2 kappa (signed: left turns positive)."""
    v = bound.speed_table.v_mps
    u = v ** 2
    a_x = np.diff(u) / (2.0 * bound.speed_table.ds_m)
    fast = np.where(u[1:] >= u[:-1], np.arange(1, v.size), np.arange(v.size - 1))
    return v[fast], a_x, u[fast] * bound.path.table[fast, tb.COL_KAPPA]


def _draw_track(ax: Any, track: Path, bound: LapTimeBound, edges: tuple[np.ndarray, np.ndarray]) -> Any:
    """Edges, centre line and ``bound``'s line coloured by speed on ``ax``; returns the coloured collection."""
    from matplotlib.collections import LineCollection

    for edge in edges:
        ax.plot(edge[:, 0], edge[:, 1], color="0.35", lw=0.8)
    ax.plot(track.table[:, tb.COL_X], track.table[:, tb.COL_Y], color="0.6", lw=0.6, ls="--")
    line = bound.path.table[:, [tb.COL_X, tb.COL_Y]]
    segments = np.stack((line[:-1], line[1:]), axis=1)
    kmh = 3.6 * bound.speed_table.v_mps
    coloured = LineCollection(segments, cmap="viridis", linewidths=1.8)
    coloured.set_array(0.5 * (kmh[:-1] + kmh[1:]))
    ax.add_collection(coloured)
    ax.set_aspect("equal")
    return coloured


def _track_panel(ax: Any, track: Path, bounds: Sequence[LapTimeBound]) -> Any:
    """The track with the first bound's line coloured by speed, and an inset on its slowest corner
    (``ZOOM_HALF_SPAN_M`` either side, outlined on the track); returns the coloured collection."""
    from matplotlib.patches import Rectangle

    from vtrack_gym.tracks.track_edges import edge_polylines

    edges = edge_polylines(track)
    coloured = _draw_track(ax, track, bounds[0], edges)
    ax.autoscale()
    slowest = int(np.argmin(bounds[0].speed_table.v_mps))
    x0, y0 = bounds[0].path.table[slowest, [tb.COL_X, tb.COL_Y]]
    inset = ax.inset_axes((0.62, 0.02, 0.36, 0.36))
    _draw_track(inset, track, bounds[0], edges)
    inset.set_xlim(x0 - ZOOM_HALF_SPAN_M, x0 + ZOOM_HALF_SPAN_M)
    inset.set_ylim(y0 - ZOOM_HALF_SPAN_M, y0 + ZOOM_HALF_SPAN_M)
    inset.set_xticks([])
    inset.set_yticks([])
    ax.add_patch(Rectangle((x0 - ZOOM_HALF_SPAN_M, y0 - ZOOM_HALF_SPAN_M), 2.0 * ZOOM_HALF_SPAN_M,
                           2.0 * ZOOM_HALF_SPAN_M, fill=False, edgecolor="0.3", lw=0.8))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{bounds[0].line} over the track (grey: edges, dashed: centre line; inset: slowest corner)",
                 fontsize=9)
    return coloured


def _gg_panel(ax: Any, bounds: Sequence[LapTimeBound]) -> None:
    """a_x against a_y of each line, with the car's ellipse at ``ELLIPSE_SPEEDS_KMH``."""
    limits = bounds[0].limits
    theta = np.linspace(0.0, 2.0 * np.pi, 241)
    for kmh in ELLIPSE_SPEEDS_KMH:
        v = kmh / 3.6
        if v >= limits.top_speed_mps:
            continue
        a_y, a_fwd, a_brk = (float(a) for a in limits.at(v))
        ax.plot(a_y * np.sin(theta) / 9.81, np.where(np.cos(theta) >= 0, a_fwd, a_brk) * np.cos(theta) / 9.81,
                color="0.5", lw=0.7, ls=":")
        ax.annotate(f"{kmh:g} km/h", (0.0, a_fwd / 9.81), fontsize=6, color="0.4", ha="center", va="bottom")
    for b in bounds:
        _, a_x, a_y = accelerations(b)
        ax.plot(a_y / 9.81, a_x / 9.81, ".", ms=1.0, color=LINE_COLOURS.get(b.line, "k"), label=b.line)
    ax.set_xlabel("lateral acceleration [g]")
    ax.set_ylabel("longitudinal acceleration [g]")
    ax.set_title("g-g usage (dotted: the car's limit at a speed)", fontsize=9)
    ax.legend(fontsize=7, markerscale=8)


def write_lap_figure(track: Path, bounds: Sequence[LapTimeBound], file: str | FsPath, title: str = "") -> FsPath:
    """Write the lap figure of ``bounds`` (one per line; the first is drawn over the track) on ``track`` to
    ``file`` (PNG); returns the path written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not bounds:
        raise ValueError("write_lap_figure needs at least one lap-time bound")
    fig = plt.figure(figsize=(12.0, 7.5))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.3, 1.0))
    ax_track = fig.add_subplot(grid[:, 0])
    ax_speed = fig.add_subplot(grid[0, 1])
    ax_gg = fig.add_subplot(grid[1, 1])
    coloured = _track_panel(ax_track, track, bounds)
    fig.colorbar(coloured, ax=ax_track, shrink=0.6, label=f"{bounds[0].line} speed [km/h]")
    for b in bounds:
        s = np.arange(b.speed_table.v_mps.size) * b.speed_table.ds_m
        ax_speed.plot(s, 3.6 * b.speed_table.v_mps, lw=0.9, color=LINE_COLOURS.get(b.line, "k"),
                      label=f"{b.line}: {b.lap_time_s:.2f} s")
    ax_speed.set_xlabel("distance along the line [m]")
    ax_speed.set_ylabel("speed [km/h]")
    ax_speed.legend(fontsize=7)
    ax_speed.set_title("speed along each line at the car's limit", fontsize=9)
    _gg_panel(ax_gg, bounds)
    fig.suptitle(title or f"{track.name}: lap-time bound of {bounds[0].limits.name}", fontsize=10)
    fig.tight_layout()
    out = FsPath(file)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


__all__ = ["accelerations", "write_lap_figure"]
