"""Load a user's centre-line from a CSV file; parse only, never evaluate.

Format: one point per line, fields separated by commas, semicolons or whitespace. Columns are found by name in a
header row, which is either the first non-blank line (``x,y,z``) or a comment line starting with ``#`` just before
the data (``# x_m, y_m, w_tr_right_m, w_tr_left_m``, the racetrack-database layout, loads as is). Accepted names
(case-insensitive; see ``COLUMN_NAMES``): x and y [m] (required), z [m], the half widths right and left of the
centre-line [m] (both or neither), and a reference speed [m/s]. Without a header, 2 columns are x, y and 3 are x,
y, z. Other comment lines and blank lines are ignored. A header naming an unknown column, one width without the
other, or rows whose column count differs from the header is an error naming the line and the fix; every problem
raises ``ValueError`` naming the file (and the line where there is one).

Closed loops are detected relative to the point spacing (a loop usually ends one sample short of its start),
``closed=True/False`` forces it. A centre-line that crosses itself (a figure-eight with a bridge) is refused unless
``allow_self_crossing=True``. Coordinates rounded to a decimal grid (mm, cm, ...) are smoothed by the rounding's RMS
error by default, so curvature stays accurate on dense inputs. File size, point count and the work of the
self-crossing check are bounded.
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import unicodedata
import warnings
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym._io import check_regular_input, read_regular_file
from vtrack_gym.tracks.closure import (  # noqa: F401  (re-exported: the loader's constants)
    CLOSED_GAP_M,
    CLOSED_GAP_SPACINGS,
    CLOSED_GAP_TURN_DEG,
    CLOSED_TURN_RATIO,
    detect_closed,
)
from vtrack_gym.tracks.fitting import MAX_COORDINATE_M, MAX_LENGTH_M, check_points
from vtrack_gym.tracks.geometry import first_crossing
from vtrack_gym.tracks.path import (
    DEFAULT_DS_M,
    MAX_CURVATURE_PER_M,
    MAX_CURVATURE_RATE_PER_M2,
    MAX_HALF_WIDTH_M,
    MAX_V_REF_MPS,
    Path,
)
from vtrack_gym.tracks.table import COL_DKAPPA, COL_KAPPA, COL_X, COL_Y
from vtrack_gym.tracks.track_noise import (  # noqa: F401  (re-exported: the loader's warnings)
    MAX_PLAUSIBLE_GRADE,
    NOISE_HINT_FACTOR,
    implausible_grade,
    noisy_curvature_hint,
    point_noise_m,
)

MIN_POINTS = 4
MIN_SPAN_M = 1.0            # points spanning less than this [m] in x and y are not a road in metres (degrees?)
MAX_POINTS = 200_000
MAX_FILE_BYTES = 64 * 2**20
MAX_LINE_CHARS = 4096       # longest line (characters), checked before the line is split
MAX_FIELD_CHARS = 64        # longest field (characters)
_SHOWN_CHARS = 40           # characters of a field quoted in an error message
DEFAULT_HALF_WIDTH_M = 3.5
NEAR_DUPLICATE_SHARE = 0.01    # consecutive points closer than this x the median spacing are refused (a kink)
DENSE_SPACING_M = 0.5       # points closer than this (median) [m] are averaged in blocks to about this spacing
_MAX_DECIMALS = 6

COLUMN_NAMES: dict[str, tuple[str, ...]] = {
    "x": ("x", "x_m"),
    "y": ("y", "y_m"),
    "z": ("z", "z_m"),
    "w_right": ("w_tr_right_m", "w_right_m", "w_right", "half_width_right_m"),
    "w_left": ("w_tr_left_m", "w_left_m", "w_left", "half_width_left_m"),
    "v": ("v_mps", "v_ref_mps", "vx_mps", "speed_mps"),
}
"""Column role -> accepted header names (lower case). Widths are half widths from the centre-line [m]."""

_ROLE = {name: role for role, names in COLUMN_NAMES.items() for name in names}
_HEADER_HELP = ("header must name the columns x, y and optionally z, the half widths w_tr_right_m and "
                "w_tr_left_m [m] (both or neither) and a speed v_mps [m/s] (accepted names: "
                + "; ".join(f"{role}: {', '.join(names)}" for role, names in COLUMN_NAMES.items()) + ")")


_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NON_FINITE = frozenset({"nan", "+nan", "-nan", "inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"})
_LINE_END = re.compile(r"\r\n|\r|\n")
_BLANK_RUN = re.compile(r"[ \t\r\n]+")   # blank lines and a line's leading blanks, skipped in one step
_ASCII_UNSAFE = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")  # the ASCII characters of _UNSAFE_CATEGORIES
_UNSAFE_CATEGORIES = frozenset({"Cc", "Cf", "Zl", "Zp", "Cs"})


def _shown(text: str) -> str:
    """``text`` quoted for a message, cut to ``_SHOWN_CHARS`` characters."""
    return repr(text[:_SHOWN_CHARS]) + ("..." if len(text) > _SHOWN_CHARS else "")


def _shown_list(texts: list[str]) -> str:
    """At most 8 of ``texts``, each cut, for a message."""
    return "[" + ", ".join(_shown(t) for t in texts[:8]) + (", ..." if len(texts) > 8 else "") + "]"


def _decimal_comma_hint(line: str) -> str:
    """A hint when the line looks like numbers written with decimal commas (``1,5;2,5`` or ``1,5 2,5``)."""
    tokens = re.split(r"[;\s]+", line.strip())
    decimal_commas = len(tokens) > 1 and any(re.fullmatch(r"[+-]?[0-9]+,[0-9]+", t) for t in tokens)
    return "; decimal commas? write 1.5, not 1,5" if decimal_commas else ""


def _line_breaks(text: str, start: int, end: int) -> int:
    """Number of line breaks (\\n, \\r\\n, lone \\r) in ``text[start:end]``, counted in C."""
    return text.count("\n", start, end) + text.count("\r", start, end) - text.count("\r\n", start, end)


def _line_spans(text: str) -> Iterator[tuple[int, int, int]]:
    """(line number, start, end) of every line that is not blank, from its first character that is not a space or
    tab; lines end at \\n, \\r\\n or \\r only (a U+2028 or \\v inside a line is no line break); nothing is copied.
    A run of blank lines (spaces and tabs only) is skipped in one regular-expression step, so the cost is linear
    in the file with a small constant."""
    pos, lineno = 0, 0
    while pos < len(text):
        blank = _BLANK_RUN.match(text, pos)
        if blank is not None:
            lineno += _line_breaks(text, pos, blank.end())
            pos = blank.end()
            if pos >= len(text):
                return
        m = _LINE_END.search(text, pos)
        end = m.start() if m else len(text)
        lineno += 1
        yield lineno, pos, end
        pos = m.end() if m else len(text)


def _checked_line(fs_path: FsPath, text: str, lineno: int, start: int, end: int) -> str:
    """The line, after its length and characters are checked (tabs allowed; no control, format or separator
    characters)."""
    if end - start > MAX_LINE_CHARS:
        raise ValueError(f"{fs_path}, line {lineno}: the line is {end - start} characters long (at most "
                         f"{MAX_LINE_CHARS}); is this a CSV of points, one per line?")
    line = text[start:end]
    if line.isascii():   # the common case, checked in C
        found = _ASCII_UNSAFE.search(line)
        bad = None if found is None else found.group()
    else:
        bad = next((c for c in line if c != "\t" and unicodedata.category(c) in _UNSAFE_CATEGORIES), None)
    if bad is not None:
        raise ValueError(f"{fs_path}, line {lineno}: the character U+{ord(bad):04X} "
                         f"({unicodedata.name(bad, 'a control character')}) is not allowed in a track file; "
                         "lines end with a line feed, fields are separated by commas, semicolons or spaces")
    return line


def _number(text: str) -> float | None:
    """``text`` as a number if it is one in plain ASCII notation (digits 0-9, '.', sign, exponent), else None
    (``3_0``, ``١``, ``1,5``, quoted numbers and ``nan`` are not)."""
    return float(text) if len(text) <= MAX_FIELD_CHARS and _NUMBER.fullmatch(text) else None


def _number_error(fs_path: FsPath, lineno: int, column: int, text: str, line: str) -> ValueError:
    """The error for a field that is not a number, with a hint for the usual causes."""
    where = f"{fs_path}, line {lineno}, column {column}"
    if len(text) > MAX_FIELD_CHARS:
        return ValueError(f"{where}: a field of {len(text)} characters (at most {MAX_FIELD_CHARS})")
    if text.lower() in _NON_FINITE or _NUMBER.fullmatch(text):   # nan, inf, or beyond the float range
        return ValueError(f"{where}: value must be finite (got {_shown(text)})")
    hint = ""
    if _decimal_comma_hint(line) or re.fullmatch(r"[+-]?[0-9]+,[0-9]+", text):
        hint = "; decimal commas? write 1.5, not 1,5"
    elif len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        hint = "; remove the quotes around numbers"
    elif "_" in text or any(c.isdigit() and not c.isascii() for c in text):
        hint = "; write numbers with the digits 0-9 only (no '_' or other scripts' digits)"
    return ValueError(f"{where}: not a number ({_shown(text)}){hint}")


def _split(line: str) -> list[str]:
    """Fields of a line: comma- or semicolon-separated if it has one, else whitespace-separated."""
    for sep in (",", ";"):
        if sep in line:
            return [f.strip() for f in line.split(sep)]
    return line.split()


def _is_number(text: str) -> bool:
    return _number(text) is not None or text.lower() in _NON_FINITE


def _comment_header(line: str) -> list[str] | None:
    """Fields of a ``#`` comment line that is a header, else None: it names both x and y, or any column by a
    name longer than one letter (``x_m``, ``w_tr_right_m``, ``v_mps``, ...)."""
    fields = _split(line.lstrip("#").strip())
    roles = {_ROLE.get(f.lower()) for f in fields}
    named = any(len(f) > 1 and f.lower() in _ROLE for f in fields)
    return fields if len(fields) >= 2 and ({"x", "y"} <= roles or named) else None


def _header_roles(fs_path: FsPath, lineno: int, fields: list[str]) -> list[str]:
    """Column roles of a header line; ValueError naming the line and the fix if it does not fit."""
    roles = [_ROLE.get(f.lower()) for f in fields]
    unknown = [f for f, r in zip(fields, roles, strict=True) if r is None]
    if unknown or len(set(roles)) != len(roles) or not {"x", "y"} <= set(roles):
        problem = (f"unknown column(s) {_shown_list(unknown)}" if unknown else
                   "a column is named twice" if len(set(roles)) != len(roles) else "x or y is missing")
        raise ValueError(f"{fs_path}, line {lineno}: {_HEADER_HELP} (got {_shown_list(fields)}: {problem}); fix: "
                         "rename the "
                         "columns in that line, or delete it if it is not a header")
    if ("w_right" in roles) != ("w_left" in roles):
        have = "w_tr_right_m" if "w_right" in roles else "w_tr_left_m"
        raise ValueError(f"{fs_path}, line {lineno}: the header names {have} without the other half width; fix: "
                         "name both w_tr_right_m and w_tr_left_m, or neither (then half_width_m applies)")
    return [str(r) for r in roles]


def read_track_bytes(fs_path: FsPath) -> bytes:
    """The bytes of a track file (a regular file of at most ``MAX_FILE_BYTES``), read once; ValueError naming the
    file when it is a folder, missing, not a regular file or too large."""
    if fs_path.is_dir():
        raise ValueError(f"{fs_path}: is a folder, not a track file (give a CSV file in it)")
    check_regular_input(fs_path, "track file")   # "not found", or "is a FIFO / character device ..."
    size = fs_path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ValueError(f"{fs_path}: the file is {size / 2**20:.1f} MiB; at most {MAX_FILE_BYTES // 2**20} MiB is "
                         "accepted (thin the points, e.g. keep every k-th line)")
    # regular files only, never more than MAX_FILE_BYTES even if the file grows meanwhile
    return read_regular_file(fs_path, MAX_FILE_BYTES, "track file")


def read_track_columns(fs_path: FsPath, data: bytes | None = None) -> tuple[dict[str, np.ndarray], list[int]]:
    """Parse a centre-line CSV -> ({role: values}, file line number of every point); roles as in COLUMN_NAMES.

    ``data``: the file's bytes when already read (``read_track_bytes``; parsed as given, the file is not read
    again). ValueError naming file, line and problem on any malformed content.
    """
    try:
        text = (read_track_bytes(fs_path) if data is None else data).decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{fs_path}: cannot read the track file ({exc})") from exc
    order: list[str] | None = None
    header_line = 0
    comment_header: tuple[int, list[str]] | None = None
    rows: list[list[float]] = []
    lines: list[int] = []
    n_cols: int | None = None
    for lineno, start, end in _line_spans(text):
        raw = _checked_line(fs_path, text, lineno, start, end)
        line = raw.strip(" \t")
        if not line:
            continue
        if line.startswith("#"):
            if not rows and order is None:
                found = _comment_header(line)
                comment_header = (lineno, found) if found is not None else comment_header
            continue
        fields = _split(line)
        if order is None and not rows and not all(_is_number(f) for f in fields):
            order = _header_roles(fs_path, lineno, fields)
            header_line, n_cols = lineno, len(order)
            continue
        if n_cols is None:
            if comment_header is not None:
                header_line, order = comment_header[0], _header_roles(fs_path, *comment_header)
                n_cols = len(order)
            else:
                n_cols = len(fields)
                if n_cols not in (2, 3):
                    raise ValueError(f"{fs_path}, line {lineno}: expected 2 (x, y) or 3 (x, y, z) columns "
                                     f"(got {n_cols}); fix: name the columns in a header line, e.g. "
                                     "'# x_m, y_m, w_tr_right_m, w_tr_left_m'")
        if len(fields) != n_cols:
            named = f" as named by the header on line {header_line}" if header_line else ""
            raise ValueError(f"{fs_path}, line {lineno}: expected {n_cols} columns{named} (got {len(fields)})"
                             + ("; fix: make the header name every column" if header_line else "")
                             + _decimal_comma_hint(line))
        values = []
        for k, f in enumerate(fields):
            v = _number(f)
            if v is None or not math.isfinite(v):
                raise _number_error(fs_path, lineno, k + 1, f, line)
            values.append(v)
        rows.append(values)
        lines.append(lineno)
        if len(rows) > MAX_POINTS:
            raise ValueError(f"{fs_path}, line {lineno}: more than {MAX_POINTS} points; fix: thin the points "
                             "(0.5-2 m spacing is plenty)")
    if len(rows) < MIN_POINTS:
        raise ValueError(f"{fs_path}: a track needs >= {MIN_POINTS} points (got {len(rows)})")
    data = np.asarray(rows, dtype=float)
    if order is None and data.shape[1] == 3:
        warnings.warn(f"{fs_path}: no header line: the third column is read as an elevation z [m]. If it is a "
                      "speed, name the columns in a first line 'x_m, y_m, v_mps'; a header 'x_m, y_m, z_m' "
                      "confirms the elevation", UserWarning, stacklevel=3)
    order = order or ["x", "y", "z"][: data.shape[1]]
    columns = {role: data[:, k] for k, role in enumerate(order)}
    _check_ranges(fs_path, columns, lines)
    x, y = columns["x"], columns["y"]
    step = np.hypot(np.diff(x), np.diff(y))
    dup = np.flatnonzero(step <= 1e-9 * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y)))))
    if dup.size:
        k = int(dup[0])
        raise ValueError(f"{fs_path}, lines {lines[k]} and {lines[k + 1]}: duplicate consecutive points "
                         f"({x[k]}, {y[k]})")
    return columns, lines


def _check_ranges(fs_path: FsPath, columns: dict[str, np.ndarray], lines: list[int]) -> None:
    """Coordinates within +-MAX_COORDINATE_M m, widths in (0, MAX_HALF_WIDTH_M] m and speeds in (0,
    MAX_V_REF_MPS] m/s, naming the first bad line (``FileSpeed`` refuses speeds under ``MIN_V_REF_MPS`` where a
    profile uses the column)."""
    for role in ("x", "y", "z"):
        if role in columns:
            bad = np.flatnonzero(np.abs(columns[role]) > MAX_COORDINATE_M)
            if bad.size:
                k = int(bad[0])
                raise ValueError(f"{fs_path}, line {lines[k]}: |{role}| = {abs(columns[role][k]):.4g} m exceeds "
                                 f"{MAX_COORDINATE_M:.0e} m (UTM eastings and northings stay below it); fix: subtract "
                                 "an offset (e.g. the first point's coordinates) from every point")
    limits = {"w_right": (0.0, MAX_HALF_WIDTH_M, "m", "half width"),
              "w_left": (0.0, MAX_HALF_WIDTH_M, "m", "half width"),
              "v": (0.0, MAX_V_REF_MPS, "m/s", "speed")}   # the 1 m/s floor: FileSpeed's, where the column is used
    for role, (low, high, unit, what) in limits.items():
        if role not in columns:
            continue
        ok = (columns[role] >= low) & (columns[role] > 0.0) & (columns[role] <= high)
        bad = np.flatnonzero(~ok)
        if bad.size:
            k = int(bad[0])
            span = f"(0, {high}]" if low == 0.0 else f"[{low}, {high}]"
            raise ValueError(f"{fs_path}, line {lines[k]}: {what} {COLUMN_NAMES[role][0]} = {columns[role][k]} "
                             f"{unit} is outside {span} {unit}")


def read_track_csv(fs_path: FsPath) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, list[int]]:
    """Parse a centre-line CSV -> (x [m], y [m], z [m] or None, file line number of every point)."""
    columns, lines = read_track_columns(fs_path)
    return columns["x"], columns["y"], columns.get("z"), lines


def rounding_quantum_m(x: np.ndarray, y: np.ndarray) -> float:
    """Decimal grid [m] all coordinates lie on (1, 0.1, ..., 1e-6), or 0.0 if they carry more digits."""
    v = np.concatenate((x, y))
    for decimals in range(_MAX_DECIMALS + 1):
        scaled = v * 10.0 ** decimals
        if np.all(np.abs(scaled - np.rint(scaled)) <= 1e-3 + 1e-15 * np.abs(scaled)):
            return 10.0 ** -decimals
    return 0.0


def auto_smoothing_m(x: np.ndarray, y: np.ndarray) -> float:
    """RMS 2-D deviation [m] the spline fit may make: the rounding error q / sqrt(6) of coordinates rounded to a
    decimal grid q (uniform error of variance q^2 / 12 in x and in y); 0 for full-precision coordinates."""
    return rounding_quantum_m(x, y) / math.sqrt(6.0)


def average_dense_points(columns: dict[str, np.ndarray], closed: bool) -> tuple[dict[str, np.ndarray], int]:
    """Average consecutive blocks of k points so that the median spacing becomes about DENSE_SPACING_M [m].

    Returns the averaged columns and k (1: unchanged). Averaging k points spread over an arc of length L moves
    the line inwards by about kappa L^2 / 24 (< 1 mm for L = 0.5 m and radii >= 6 m) and divides independent
    rounding errors by sqrt(k). A closed loop keeps its first point (the last block may be shorter).
    """
    x, y = columns["x"], columns["y"]
    h = float(np.median(np.hypot(np.diff(x), np.diff(y))))
    k = int(DENSE_SPACING_M // h) if h > 0.0 else 1
    m = x.size
    if k < 2 or m // k < 2 * MIN_POINTS:
        return columns, 1
    starts = np.arange(0, m, k)
    if not closed and m - starts[-1] < k:          # open line: keep both end points exactly
        starts = starts[:-1]
    out = {}
    for role, v in columns.items():
        sums = np.add.reduceat(v, starts)
        counts = np.diff(np.append(starts, m))
        out[role] = sums / counts
    if not closed:
        for role, v in columns.items():
            out[role] = np.concatenate(([v[0]], out[role][1:-1], [v[-1]])) if out[role].size > 2 else out[role]
    return out, k


def _check_near_duplicates(fs_path: FsPath, x: np.ndarray, y: np.ndarray, closed: bool, lines: list[int]) -> None:
    """ValueError naming both file lines if two consecutive points x, y [m] (the last and the first of a loop too)
    are closer than NEAR_DUPLICATE_SHARE x the median spacing: an interpolating spline turns sharply there (1 mm
    on a 1 m-spaced loop: a 7.7 cm radius)."""
    px, py = (np.append(x, x[0]), np.append(y, y[0])) if closed else (x, y)
    step = np.hypot(np.diff(px), np.diff(py))
    h = float(np.median(step))
    close = np.flatnonzero(step < NEAR_DUPLICATE_SHARE * h)
    if close.size:
        i = int(close[0])
        j = (i + 1) % len(lines)
        raise ValueError(f"{fs_path}, lines {lines[i]} and {lines[j]}: consecutive points only {step[i]:.3g} m apart, "
                         f"less than {NEAR_DUPLICATE_SHARE:.0%} of the median spacing {h:.3g} m (the fitted line would "
                         "kink there); fix: delete one of the two lines")


def _check_crossing(fs_path: FsPath, px: np.ndarray, py: np.ndarray, closed: bool, lines: list[int]) -> None:
    """ValueError naming the lines of the first pair of crossing segments (or of a cluster too dense to check)."""
    def line(k: int) -> int:
        return lines[k] if k < len(lines) else lines[0]

    found = first_crossing(px, py, closed)
    if found is None:
        return
    why, i, j = found
    if why is not None:
        raise ValueError(f"{fs_path}, lines {line(i)}-{line(j)}: {why}; fix: thin or remove those points")
    raise ValueError(f"{fs_path}: the centre-line crosses itself (segment lines {line(i)}-{line(i + 1)} meets "
                     f"segment lines {line(j)}-{line(j + 1)}); fix: if the road really crosses itself (a bridge), "
                     "pass allow_self_crossing=True (CLI: --allow-self-crossing), else correct those points")


def hermite_peaks(p0: np.ndarray, d0: np.ndarray, p1: np.ndarray, d1: np.ndarray, h: float) -> np.ndarray:
    """Largest |p(t)|, t in [0, 1], of each cubic Hermite interval with end values p0, p1 and end slopes d0, d1 (per
    metre) over length h [m]: the curvature the env interpolates between two table rows (``tracks.kernels._h3``)."""
    a = 2.0 * p0 + h * d0 - 2.0 * p1 + h * d1          # p(t) = a t^3 + b t^2 + c t + p0
    b = -3.0 * p0 - 2.0 * h * d0 + 3.0 * p1 - h * d1
    c = h * d0
    peaks = np.maximum(np.abs(p0), np.abs(p1))
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(b * b - 3.0 * a * c, 0.0))
        cubic = a != 0.0
        candidates = (np.where(cubic, (-b + root) / (3.0 * a), -c / (2.0 * b)),
                      np.where(cubic, (-b - root) / (3.0 * a), 0.0))
    for t in candidates:
        t = np.clip(np.nan_to_num(t, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)
        peaks = np.maximum(peaks, np.abs(((a * t + b) * t + c) * t + p0))
    return peaks


def _check_representable(fs_path: FsPath, path: Path, x: np.ndarray, y: np.ndarray, lines: list[int]) -> None:
    """ValueError naming the file line nearest the sharpest bend if the curvature the env can observe (the rows'
    Hermite interpolation) or its rate exceeds what an observation holds (``MAX_CURVATURE_PER_M``,
    ``MAX_CURVATURE_RATE_PER_M2``): a kink, not a road."""
    excess = unobservable(path)
    if excess is not None:
        what, value, limit, unit, peak = excess
        table = path.table
        k = int(np.argmin(np.hypot(x - table[peak, COL_X], y - table[peak, COL_Y])))
        raise ValueError(f"{fs_path}, line {lines[min(k, len(lines) - 1)]}: the fitted centre-line's {what} reaches "
                         f"{value:.3g} {unit} near this point, beyond the {limit:g} {unit} an observation "
                         "holds (a kink: a point off the line, a turn back on itself, an end point next to the start); "
                         "fix: correct the point, or pass smoothing_m (CLI: --track-smoothing-m) or closed")


def unobservable(path: Path) -> tuple[str, float, float, str, int] | None:
    """The first quantity of ``path`` an observation cannot hold, as (name, value, limit, unit, table row), or None:
    its curvature as the env interpolates it between rows (Hermite peaks) beyond ``MAX_CURVATURE_PER_M`` [1/m] or
    its curvature rate beyond ``MAX_CURVATURE_RATE_PER_M2`` [1/m^2]."""
    table = path.table
    kappa, rate = table[:, COL_KAPPA], table[:, COL_DKAPPA]
    kappa_peaks = hermite_peaks(kappa[:-1], rate[:-1], kappa[1:], rate[1:], path.ds_m)
    for values, limit, what, unit in ((kappa_peaks, MAX_CURVATURE_PER_M, "curvature", "1/m"),
                                      (np.abs(rate), MAX_CURVATURE_RATE_PER_M2, "curvature rate", "1/m^2")):
        peak = int(np.argmax(values))
        if not values[peak] <= limit:   # NaN counts as beyond
            return what, float(values[peak]), limit, unit, peak
    return None


def load_track_csv(path: str | os.PathLike[str], closed: bool | None = None, half_width_m: float | None = None, *,
                   smoothing_m: float | None = None, ds_m: float = DEFAULT_DS_M, name: str | None = None,
                   allow_self_crossing: bool = False) -> Path:
    """Centre-line Path from a CSV of points (see the module docstring for the format).

    ``closed`` None: detected from the end gap relative to the point spacing (:func:`detect_closed`).
    ``half_width_m`` [m]: drivable half width on both sides; None uses the file's per-point widths if it has them
    (then ``Path.half_width_m`` is their minimum) else 3.5 m; a number overrides the file's widths.
    ``smoothing_m`` [m]: RMS deviation the spline fit may make; None chooses it from the coordinates' rounding
    (:func:`auto_smoothing_m`; 0 for full-precision values, which the fit then interpolates) and first averages
    points denser than 0.5 m (:func:`average_dense_points`). A speed column is
    kept as ``Path.v_ref_mps``. ``allow_self_crossing`` accepts a centre-line that crosses itself (projection with
    a station guess keeps continuity across the crossing). Raises ValueError naming file, line and problem.
    """
    fs_path = FsPath(path)
    smoothing_given = smoothing_m is not None and smoothing_m > 0.0
    data = read_track_bytes(fs_path)   # read once: the digest names exactly the bytes parsed
    columns, lines = read_track_columns(fs_path, data)
    x, y, z = columns["x"], columns["y"], columns.get("z")
    try:
        check_points(x, y, z)  # counts, finiteness, duplicates, extent: before any geometry on the points
    except ValueError as exc:
        raise ValueError(f"{fs_path}: {exc}") from exc
    span = max(float(np.ptp(x)), float(np.ptp(y)))
    if span < MIN_SPAN_M:
        raise ValueError(f"{fs_path}: the points span only {span:.3g} m: coordinates must be metres (latitude and "
                         "longitude in degrees? project them to a metric grid such as UTM first)")
    if closed is None:
        closed = detect_closed(x, y)
    widths = np.column_stack((columns["w_left"], columns["w_right"])) if "w_left" in columns else None
    v_ref = columns.get("v")
    px, py = x, y
    if closed:  # a last point within NEAR_DUPLICATE_SHARE of a spacing of the first repeats the start: dropped
        repeat_m = max(1e-9 * max(1.0, float(np.max(np.abs(x))), float(np.max(np.abs(y)))),
                       NEAR_DUPLICATE_SHARE * float(np.median(np.hypot(np.diff(x), np.diff(y)))))
        if math.hypot(x[-1] - x[0], y[-1] - y[0]) > repeat_m:
            px, py = np.append(x, x[0]), np.append(y, y[0])
        else:
            x, y = x[:-1], y[:-1]
            z = None if z is None else z[:-1]
            widths = None if widths is None else widths[:-1]
            v_ref = None if v_ref is None else v_ref[:-1]
    loop_m = float(np.hypot(np.diff(px), np.diff(py)).sum())
    if loop_m > MAX_LENGTH_M:
        raise ValueError(f"{fs_path}: closing the loop makes the centre-line {loop_m / 1000:.0f} km long; at most "
                         f"{MAX_LENGTH_M / 1000:.0f} km is accepted (an open line: closed=False, --track-closed no)")
    if not allow_self_crossing:
        _check_crossing(fs_path, px, py, bool(closed), lines)
    raw_x, raw_y = x, y
    k = 1
    if smoothing_m is None:
        smoothing_m = auto_smoothing_m(x, y)
        cols = {"x": x, "y": y}
        for role, c in (("z", z), ("v", v_ref)):
            if c is not None:
                cols[role] = c
        if widths is not None:
            cols["wl"], cols["wr"] = widths[:, 0], widths[:, 1]
        cols, k = average_dense_points(cols, bool(closed))
        if k > 1:
            x, y, z, v_ref = cols["x"], cols["y"], cols.get("z"), cols.get("v")
            widths = None if widths is None else np.column_stack((cols["wl"], cols["wr"]))
            smoothing_m /= math.sqrt(k)
    if k == 1 and not smoothing_given:  # averaged blocks merge near-duplicates, a smoothing fit passes them
        _check_near_duplicates(fs_path, x, y, bool(closed), lines)  # by; a spline through raw points kinks there
    if half_width_m is None:
        half_width_m = DEFAULT_HALF_WIDTH_M if widths is None else float(widths.min())
    else:
        widths = None
    try:
        result = replace(Path.from_points(x, y, z, bool(closed), smoothing_m=smoothing_m, ds_m=ds_m,
                                          half_width_m=half_width_m, name=name or fs_path.stem, widths_m=widths,
                                          v_ref_mps=v_ref), source_sha256=hashlib.sha256(data).hexdigest())
    except ValueError as exc:
        raise ValueError(f"{fs_path}: {exc}") from exc
    if not allow_self_crossing and result.self_intersects():
        raise ValueError(f"{fs_path}: the fitted centre-line crosses itself (points too sparse or too noisy; "
                         "add points or raise smoothing_m)")
    _check_representable(fs_path, result, raw_x, raw_y, lines)
    noisy = noisy_curvature_hint(result, raw_x, raw_y)
    if noisy is not None:
        changes, n, hint = noisy
        warnings.warn(f"{fs_path}: the fitted curvature changes sign in {changes} of {n} point intervals (a road "
                      f"does only at its S-bends): the coordinates look noisy (smoothing_m = {smoothing_m:.3g} m). "
                      f"Pass smoothing_m={hint:g} (CLI: --track-smoothing-m {hint:g}), the RMS deviation [m] the fit "
                      f"may make, about {NOISE_HINT_FACTOR:g} x the points' estimated noise", UserWarning,
                      stacklevel=2)
    if z is not None:
        problem = implausible_grade(result, raw_x, raw_y)
        if problem is not None:
            warnings.warn(f"{fs_path}: {problem}: is the third column an elevation z [m]? A noisy elevation (GPS "
                          "altitude) makes false wheel lifts and speed losses; smooth it, or drop the column for a "
                          "flat road", UserWarning, stacklevel=2)
    return result


__all__ = [
    "COLUMN_NAMES",
    "auto_smoothing_m",
    "average_dense_points",
    "detect_closed",
    "implausible_grade",
    "load_track_csv",
    "noisy_curvature_hint",
    "point_noise_m",
    "read_track_bytes",
    "read_track_columns",
    "read_track_csv",
    "rounding_quantum_m",
    "unobservable",
]


def load(file: FsPath, read: Any) -> Path:
    """The track format registry's entry (``tracks.formats``): ``load_track_csv`` with a ``TrackRead``'s options
    (a route, lane or road width does not apply to a CSV file: ValueError naming them)."""
    extra = {k: v for k, v in read.identity().items() if k in ("route", "lane", "road_width_m")}
    if extra:
        raise ValueError(f"{file}: {', '.join(extra)} appl{'ies' if len(extra) == 1 else 'y'} to map files, not to "
                         "a CSV of points")
    return load_track_csv(file, closed=read.closed, smoothing_m=read.smoothing_m,
                          allow_self_crossing=read.allow_self_crossing)
