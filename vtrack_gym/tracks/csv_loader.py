"""Load a user's centre-line from a CSV file (columns x, y and optional z [m]); parse only, never evaluate.

Format: one point per line, 2 (x, y) or 3 (x, y, z) numeric columns separated by commas or whitespace. An
optional header row names the columns (``x``, ``y``, ``z`` in any order, case-insensitive; also ``x_m`` etc.).
Blank lines and lines starting with ``#`` are ignored. Every problem raises ``ValueError`` naming the file, the
line and the problem.
"""

from __future__ import annotations

import math
import os
from pathlib import Path as FsPath

import numpy as np

from vtrack_gym.tracks.fitting import check_points
from vtrack_gym.tracks.geometry import self_intersection_pairs
from vtrack_gym.tracks.path import DEFAULT_DS_M, Path

CLOSED_GAP_M = 1.0       # first and last points closer than this [m]: closed path (auto-detection)
MIN_POINTS = 4
_HEADER_NAMES = {"x": "x", "x_m": "x", "y": "y", "y_m": "y", "z": "z", "z_m": "z"}


def _split(line: str) -> list[str]:
    """Fields of a line: comma-separated if it has a comma, else whitespace-separated."""
    if "," in line:
        return [f.strip() for f in line.split(",")]
    return line.split()


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_track_csv(fs_path: FsPath) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, list[int]]:
    """Parse a centre-line CSV -> (x [m], y [m], z [m] or None, file line number of every point).

    ValueError naming file, line and problem on any malformed content.
    """
    if not fs_path.is_file():
        raise ValueError(f"{fs_path}: track file not found")
    try:
        text = fs_path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{fs_path}: cannot read the track file ({exc})") from exc
    order: list[str] | None = None
    rows: list[list[float]] = []
    lines: list[int] = []
    n_cols: int | None = None
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = _split(line)
        if order is None and not rows and not all(_is_number(f) for f in fields):
            names = [_HEADER_NAMES.get(f.lower()) for f in fields]
            if None in names or len(set(names)) != len(names) or not {"x", "y"} <= set(names) or len(names) > 3:
                raise ValueError(f"{fs_path}, line {lineno}: header must name the columns x, y and optionally z "
                                 f"(got {fields})")
            order = [str(n) for n in names]
            n_cols = len(order)
            continue
        if n_cols is None:
            n_cols = len(fields)
            if n_cols not in (2, 3):
                raise ValueError(f"{fs_path}, line {lineno}: expected 2 (x, y) or 3 (x, y, z) columns "
                                 f"(got {n_cols})")
        if len(fields) != n_cols:
            raise ValueError(f"{fs_path}, line {lineno}: expected {n_cols} columns (got {len(fields)})")
        values = []
        for k, f in enumerate(fields):
            try:
                v = float(f)
            except ValueError:
                raise ValueError(f"{fs_path}, line {lineno}, column {k + 1}: not a number ({f!r})") from None
            if not math.isfinite(v):
                raise ValueError(f"{fs_path}, line {lineno}, column {k + 1}: value must be finite (got {f!r})")
            values.append(v)
        rows.append(values)
        lines.append(lineno)
    if len(rows) < MIN_POINTS:
        raise ValueError(f"{fs_path}: a track needs >= {MIN_POINTS} points (got {len(rows)})")
    data = np.asarray(rows, dtype=float)
    order = order or ["x", "y", "z"][: data.shape[1]]
    col = {name: data[:, k] for k, name in enumerate(order)}
    x, y, z = col["x"], col["y"], col.get("z")
    step = np.hypot(np.diff(x), np.diff(y))
    dup = np.flatnonzero(step <= 1e-9 * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y)))))
    if dup.size:
        k = int(dup[0])
        raise ValueError(f"{fs_path}, lines {lines[k]} and {lines[k + 1]}: duplicate consecutive points "
                         f"({x[k]}, {y[k]})")
    return x, y, z, lines


def load_track_csv(path: str | os.PathLike[str], closed: bool | None = None, half_width_m: float = 3.5, *,
                   smoothing_m: float = 0.0, ds_m: float = DEFAULT_DS_M, name: str | None = None) -> Path:
    """Centre-line Path from a CSV of x, y [, z] points [m] (see the module docstring).

    ``closed`` None: closed when the first and last points are within 1 m. ``half_width_m`` [m] is the drivable
    half width; ``smoothing_m`` [m] the RMS deviation the spline fit may make (0 interpolates). Raises ValueError
    (naming file, line and problem) for a missing file, fewer than 4 points, non-numeric or non-finite values, a
    wrong column count, duplicate consecutive points or a self-intersecting centre-line.
    """
    fs_path = FsPath(path)
    x, y, z, lines = read_track_csv(fs_path)
    try:
        check_points(x, y, z)  # counts, finiteness, duplicates, extent: before any geometry on the points
    except ValueError as exc:
        raise ValueError(f"{fs_path}: {exc}") from exc
    gap = math.hypot(x[-1] - x[0], y[-1] - y[0])
    if closed is None:
        closed = gap <= CLOSED_GAP_M
    px, py = x, y
    if closed:
        if gap > 1e-9 * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y)))):
            px, py = np.append(x, x[0]), np.append(y, y[0])
        else:
            x, y = x[:-1], y[:-1]
            z = None if z is None else z[:-1]
    hits = self_intersection_pairs(np.column_stack((px, py)), bool(closed))
    if hits.shape[0]:
        i, j = (int(v) for v in hits[0])
        line_j = lines[j] if j < len(lines) else lines[0]
        line_j1 = lines[j + 1] if j + 1 < len(lines) else lines[0]
        raise ValueError(f"{fs_path}: the centre-line crosses itself (segment lines {lines[i]}-{lines[i + 1]} "
                         f"meets segment lines {line_j}-{line_j1})")
    try:
        result = Path.from_points(x, y, z, bool(closed), smoothing_m=smoothing_m, ds_m=ds_m,
                                  half_width_m=half_width_m, name=name or fs_path.stem)
    except ValueError as exc:
        raise ValueError(f"{fs_path}: {exc}") from exc
    if result.self_intersects():
        raise ValueError(f"{fs_path}: the fitted centre-line crosses itself (points too sparse or too noisy; "
                         "add points or raise smoothing_m)")
    return result
