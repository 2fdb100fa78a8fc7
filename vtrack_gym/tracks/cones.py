"""Cone-lined tracks: a CSV of cones (``tag,x,y``) in the Formula Student convention -> a ``Path`` between them.

Tags: ``blue`` cones line the LEFT edge, ``yellow`` the RIGHT edge, ``orange`` / ``big_orange`` mark the start
(FS Driverless Handbook, as FSSIM, FSDS and the teams' track files write it). Each side's cones are listed in driving
order (files listing the cones in any order, as FSDS's do, are chained by nearest neighbour from the orange
cones, and driven the way that puts blue on the left; a file without a header is read as ``tag,x,y,...``). The
centre line is the midline of the two cone lines (each resampled by its own arc length, then paired),
fitted by a smoothing spline; each station's half widths are its distances to the two cone lines (the lines through
the cone centres: the track limits); the cones themselves go with the path (``Path.cones_m``, discs of
``CONE_RADIUS_M``) for ``track_limits=`` to judge. A loop (both lines end within ``MAX_CONE_GAP_M`` of their
start) starts at the centre point nearest the orange cones.

Errors name the file and the cone rows (the file's line numbers, header = line 1): an unknown tag, a side with
too few cones, two neighbouring cones of a side more than ``MAX_CONE_GAP_M`` apart (sparse), a cone with no cone
of the other colour within ``MAX_TRACK_WIDTH_M`` (unpaired), and the two cone lines crossing.

One public function, ``load_cone_track``, so that the reader can be registered as a track format.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks.path import Path

LEFT_TAGS = ("blue",)
RIGHT_TAGS = ("yellow",)
START_TAGS = ("orange", "big_orange")
MAX_CONE_GAP_M = 6.0
"""CHOICE: neighbouring cones of one side further apart than this are a gap in the track's edge (FS layouts place
them at most 5 m apart on straights, closer in corners)."""
MAX_TRACK_WIDTH_M = 10.0
"""CHOICE: a cone with no cone of the other colour within this is unpaired (FS tracks are 3 m wide at least)."""
MIN_CONES_PER_SIDE = 3
CENTRE_SMOOTHING_M = 0.05
"""RMS deviation [m] the centre line's spline may make from the cone midline (the midline kinks at every cone)."""
MAX_FILE_BYTES = 10_000_000
CONE_RADIUS_M = {"blue": 0.114, "yellow": 0.114, "orange": 0.114, "big_orange": 0.1425}
"""Base radius of each cone [m]: FS small cones 228 mm across the base, big orange cones 285 mm (FS Driverless
Handbook, from memory, unverified); the judge measures the body against these discs."""


def _read(file: FsPath) -> list[tuple[int, str, float, float]]:
    """(line, tag, x, y) of every cone row; ValueError naming the line for a malformed one."""
    from vtrack_gym._io import read_regular_file

    text = read_regular_file(file, MAX_FILE_BYTES, "cones file").decode("utf-8-sig")
    lines = text.splitlines()
    header = [h.strip().lower() for h in (lines[0].lstrip("#").split(",") if lines else [])]
    first = 1
    if header and header[0] in LEFT_TAGS + RIGHT_TAGS + START_TAGS:   # no header: tag, x, y, ... (FSDS's files)
        header, first = ["tag", "x", "y"], 0
    if not {"tag", "x", "y"} <= set(header):
        raise ValueError(f"{file}: a cones file needs the header columns tag, x, y (got {lines[0]!r:.80})")
    col = {name: header.index(name) for name in ("tag", "x", "y")}
    rows = []
    for k, line in enumerate(lines[first:], start=first + 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        parts = [p.strip() for p in line.split(",")]
        try:
            tag, x, y = parts[col["tag"]].lower(), float(parts[col["x"]]), float(parts[col["y"]])
        except (IndexError, ValueError):
            raise ValueError(f"{file}: line {k}: expected tag,x,y with numbers (got {line!r:.80})") from None
        if not (np.isfinite(x) and np.isfinite(y)):
            raise ValueError(f"{file}: line {k}: cone coordinates must be finite (got {x}, {y})")
        if tag not in LEFT_TAGS + RIGHT_TAGS + START_TAGS:
            raise ValueError(f"{file}: line {k}: unknown cone tag {tag!r} (blue: left, yellow: right, orange or "
                             "big_orange: start)")
        rows.append((k, tag, x, y))
    return rows


def _chain(xy: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Indices of the cones ``xy`` in a nearest-neighbour chain from the cone nearest ``start`` (x, y) [m]."""
    todo = list(range(len(xy)))
    order = [todo.pop(int(np.argmin(np.hypot(*(xy - start).T))))]
    while todo:
        last = xy[order[-1]]
        order.append(todo.pop(int(np.argmin([np.hypot(*(xy[j] - last)) for j in todo]))))
    return np.array(order)


def _side(file: FsPath, rows: list, tags: tuple[str, ...], name: str,
          start: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(xy (m, 2) [m], line numbers (m,)) of one side's cones, in file order when its neighbours are all within
    ``MAX_CONE_GAP_M``, else chained by nearest neighbour from the cone nearest ``start`` (the orange cones; None:
    the side's first cone); ValueError for too few or a gap."""
    own = [(k, x, y) for k, tag, x, y in rows if tag in tags]
    if len(own) < MIN_CONES_PER_SIDE:
        raise ValueError(f"{file}: {len(own)} {'/'.join(tags)} cones on the {name} side (at least "
                         f"{MIN_CONES_PER_SIDE} needed)")
    xy = np.array([(x, y) for _, x, y in own])
    lines = np.array([k for k, _, _ in own])
    if np.any(np.hypot(*np.diff(xy, axis=0).T) > MAX_CONE_GAP_M):    # not in driving order: chain them
        order = _chain(xy, xy[0] if start is None else start)
        xy, lines = xy[order], lines[order]
    gaps = np.hypot(*np.diff(xy, axis=0).T)
    if np.any(gaps > MAX_CONE_GAP_M):
        j = int(np.argmax(gaps > MAX_CONE_GAP_M))
        raise ValueError(f"{file}: lines {lines[j]} and {lines[j + 1]}: {name} cones {gaps[j]:.2f} m apart (sparse: "
                         f"at most {MAX_CONE_GAP_M:g} m between neighbouring cones of a side)")
    return xy, lines


def _polyline_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance [m] of each point (p, 2) to the polyline ``line`` (m, 2)."""
    a, b = line[:-1], line[1:]
    u = b - a
    uu = np.maximum(np.einsum("ij,ij->i", u, u), 1e-300)
    v = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("pij,ij->pi", v, u) / uu, 0.0, 1.0)
    d = v - t[..., None] * u[None, :, :]
    return np.sqrt(np.min(np.einsum("pij,pij->pi", d, d), axis=1))


def _check_paired(file: FsPath, xy: np.ndarray, lines: np.ndarray, other: np.ndarray, name: str,
                  other_name: str) -> None:
    """ValueError naming the first cone of ``xy`` with no cone of ``other`` within ``MAX_TRACK_WIDTH_M``."""
    dist = np.min(np.hypot(xy[:, None, 0] - other[None, :, 0], xy[:, None, 1] - other[None, :, 1]), axis=1)
    if np.any(dist > MAX_TRACK_WIDTH_M):
        j = int(np.argmax(dist > MAX_TRACK_WIDTH_M))
        raise ValueError(f"{file}: line {lines[j]}: {name} cone at ({xy[j, 0]:g}, {xy[j, 1]:g}) has no {other_name} "
                         f"cone within {MAX_TRACK_WIDTH_M:g} m (unpaired; nearest {dist[j]:.2f} m)")


def _check_not_crossing(file: FsPath, left: np.ndarray, ll: np.ndarray, right: np.ndarray, rl: np.ndarray) -> None:
    """ValueError naming the four cone lines where a left segment crosses a right one."""
    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        return np.sign((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
                       - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))

    a, b = left[:-1, None, :], left[1:, None, :]
    c, d = right[None, :-1, :], right[None, 1:, :]
    cross = (orient(a, b, c) * orient(a, b, d) < 0) & (orient(c, d, a) * orient(c, d, b) < 0)
    if cross.any():
        i, j = np.argwhere(cross)[0]
        raise ValueError(f"{file}: the cone lines cross: left cones of lines {ll[i]}-{ll[i + 1]} and right cones "
                         f"of lines {rl[j]}-{rl[j + 1]}")


def _blue_on_the_left(left: np.ndarray, ll: np.ndarray, right: np.ndarray,
                     rl: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Both sides reversed when, driven in their order, the blue cones would lie on the right: the direction of
    travel follows from the colours (a loop keeps its first cones, an open road starts at its other end)."""
    heading = (left[1] + right[1]) - (left[0] + right[0])
    across = left[0] - right[0]
    if heading[0] * across[1] - heading[1] * across[0] >= 0.0:
        return left, ll, right, rl
    loop = np.hypot(*(left[-1] - left[0])) <= MAX_CONE_GAP_M

    def flip(a: np.ndarray) -> np.ndarray:
        return np.concatenate((a[:1], a[:0:-1])) if loop else a[::-1]

    return flip(left), flip(ll), flip(right), flip(rl)


def _resample(line: np.ndarray, n: int, closed: bool) -> np.ndarray:
    """``n`` points along a polyline (closed: back to its start) at equal arc-length fractions."""
    pts = np.vstack((line, line[:1])) if closed else line
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
    u = np.linspace(0.0, s[-1], n, endpoint=not closed)
    return np.column_stack((np.interp(u, s, pts[:, 0]), np.interp(u, s, pts[:, 1])))


def load_cone_track(file: str | os.PathLike[str], *, closed: bool | None = None, ds_m: float = 0.25) -> Path:
    """The ``Path`` between the cones of ``file`` (``tag,x,y`` CSV, module docstring): its centre line, per-station
    half widths to the blue (left) and yellow (right) cone lines, ``closed`` (None: a loop when both cone lines end
    within ``MAX_CONE_GAP_M`` of their start), sampled every ``ds_m`` [m]. ValueError naming the cone lines for
    an unknown tag, a sparse side, an unpaired cone or crossing cone lines."""
    file = FsPath(file)
    rows = _read(file)
    start = np.array([(x, y) for _, tag, x, y in rows if tag in START_TAGS])
    anchor = start.mean(axis=0) if start.size else None
    left, ll = _side(file, rows, LEFT_TAGS, "left (blue)", anchor)
    right, rl = _side(file, rows, RIGHT_TAGS, "right (yellow)", anchor)
    left, ll, right, rl = _blue_on_the_left(left, ll, right, rl)
    _check_paired(file, left, ll, right, "blue", "yellow")
    _check_paired(file, right, rl, left, "yellow", "blue")
    if closed is None:
        closed = bool(np.hypot(*(left[-1] - left[0])) <= MAX_CONE_GAP_M
                      and np.hypot(*(right[-1] - right[0])) <= MAX_CONE_GAP_M)
    loop_l = np.vstack((left, left[:1])) if closed else left
    loop_r = np.vstack((right, right[:1])) if closed else right
    _check_not_crossing(file, loop_l, np.append(ll, ll[0]) if closed else ll,
                        loop_r, np.append(rl, rl[0]) if closed else rl)
    n = 8 * max(len(left), len(right))
    centre = 0.5 * (_resample(left, n, closed) + _resample(right, n, closed))
    if closed and start.size:
        centre = np.roll(centre, -int(np.argmin(np.hypot(*(centre - start.mean(axis=0)).T))), axis=0)
    widths = np.column_stack((_polyline_distance(centre, loop_l), _polyline_distance(centre, loop_r)))
    path = Path.from_points(centre[:, 0], centre[:, 1], closed=closed, smoothing_m=CENTRE_SMOOTHING_M, ds_m=ds_m,
                            half_width_m=float(np.median(widths)), name=file.name.split(".")[0], widths_m=widths)
    cones = np.array([(x, y, CONE_RADIUS_M[tag]) for _, tag, x, y in rows])
    return dataclasses.replace(path, cones_m=cones)


def sniff(head: bytes) -> bool:
    """True when a CSV's first line (``head``: the file's first bytes) is a cone map's: a ``tag`` column in its
    header, or no header and a cone tag first (``tracks.formats`` asks it for ``.csv`` files)."""
    first = head.decode("utf-8-sig", errors="replace").splitlines()[0] if head else ""
    fields = [h.strip().lower() for h in first.lstrip("#").split(",")]
    return "tag" in fields or fields[0] in LEFT_TAGS + RIGHT_TAGS + START_TAGS


def load(file: FsPath, read: Any) -> Path:
    """The track-format entry (``tracks.formats``): ``load_cone_track`` with ``read.closed``."""
    return load_cone_track(file, closed=read.closed)
