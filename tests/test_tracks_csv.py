"""CSV centre-line loader: happy paths (circle radius recovered) and every malformed case -> clear ValueError."""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

from vtrack_gym.tracks import COL_KAPPA, COL_PSI, COL_Z, Path, load_track_csv

RADIUS = 40.0


def write(tmp_path: pathlib.Path, text: str, name: str = "track.csv") -> pathlib.Path:
    f = tmp_path / name
    f.write_text(text)
    return f


def circle(n: int, repeat_first: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    th = np.linspace(0.0, 2.0 * math.pi, n + 1) if repeat_first else np.linspace(0.0, 2.0 * math.pi, n,
                                                                                   endpoint=False)
    return RADIUS * np.cos(th), RADIUS * np.sin(th), 1.5 * np.sin(th)


def test_circle_with_header_and_z_auto_closed(tmp_path: pathlib.Path) -> None:
    x, y, z = circle(60, repeat_first=True)
    lines = ["x,y,z"] + [f"{a:.9f},{b:.9f},{c:.9f}" for a, b, c in zip(x, y, z, strict=True)]
    p = load_track_csv(write(tmp_path, "\n".join(lines) + "\n"))
    assert p.closed and p.name == "track" and p.half_width_m == 3.5
    radius = 1.0 / p.table[:, COL_KAPPA]
    assert np.max(np.abs(radius / RADIUS - 1.0)) < 0.005
    assert abs(p.length_m / (2.0 * math.pi * RADIUS) - 1.0) < 0.005
    assert abs(p.table[-1, COL_PSI] - p.table[0, COL_PSI] - 2.0 * math.pi) < 1e-9
    assert p.table[:, COL_Z].max() == pytest.approx(1.5, abs=0.01)
    pr = p.project(np.array([0.0]), np.array([-RADIUS - 2.0]))
    assert pr.e_y[0] == pytest.approx(-2.0, abs=1e-3)                    # outside of a left (CCW) circle: right


def test_circle_whitespace_no_header_explicit_closed(tmp_path: pathlib.Path) -> None:
    x, y, _ = circle(24, repeat_first=False)                              # 10 m spacing: a sparse loop
    text = "# a comment\n\n" + "\n".join(f"{a} \t {b}" for a, b in zip(x, y, strict=True))
    f = write(tmp_path, text, "ring.txt")
    assert load_track_csv(f).closed                                       # end gap = one spacing, heading on
    assert not load_track_csv(f, closed=False).closed
    p = load_track_csv(f, closed=True, half_width_m=5.0)
    assert p.closed and p.half_width_m == 5.0
    assert np.max(np.abs(1.0 / p.table[:, COL_KAPPA] / RADIUS - 1.0)) < 0.005


def test_open_polyline_and_from_points(tmp_path: pathlib.Path) -> None:
    s = np.linspace(0.0, 200.0, 41)
    x, y = s, 10.0 * np.sin(s / 40.0)
    p = load_track_csv(write(tmp_path, "y,x\n" + "\n".join(f"{b},{a}" for a, b in zip(x, y, strict=True))))
    assert not p.closed
    q = p.sample(np.array([0.0, p.length_m]))
    assert np.allclose(q.x, [0.0, 200.0], atol=1e-9) and np.allclose(q.y, [0.0, 10.0 * math.sin(5.0)], atol=1e-9)
    direct = Path.from_points(x, y)
    assert np.allclose(direct.table, p.table)


@pytest.mark.parametrize(("text", "message"), [
    ("x,y\n0,0\n1,0\n2,1\n", r"track\.csv: a track needs >= 4 points \(got 3\)"),
    ("x,y\n0,0\n1,0\nabc,1\n3,1\n4,2\n", r"track\.csv, line 4, column 1: not a number \('abc'\)"),
    ("0 0\n1 0\n2 nan\n3 1\n4 2\n", r"track\.csv, line 3, column 2: value must be finite"),
    ("0 0\n1 0\n2 inf\n3 1\n4 2\n", r"line 3, column 2: value must be finite"),
    ("0,0\n1,0\n1,0\n3,1\n4,2\n", r"track\.csv, lines 2 and 3: duplicate consecutive points"),
    ("0,0\n10,10\n10,0\n0,10\n", r"track\.csv: the centre-line crosses itself \(segment lines 1-2 meets segment "
                                 r"lines 3-4\)"),
    ("0,0\n1,0,3\n2,0\n3,1\n", r"track\.csv, line 2: expected 2 columns \(got 3\)"),
    ("0,0,0,0\n1,1,1,1\n2,2,2,2\n3,3,3,3\n", r"line 1: expected 2 \(x, y\) or 3 \(x, y, z\) columns \(got 4\)"),
    ("5\n6\n7\n8\n", r"line 1: expected 2 \(x, y\) or 3 \(x, y, z\) columns \(got 1\)"),
    ("lat,lon\n0,0\n1,0\n2,0\n3,1\n", r"line 1: header must name the columns x, y"),
    ("x,y\n0,0\n1,0\n2,0\n3,1\nx,y\n", r"line 6, column 1: not a number \('x'\)"),
    ("", r"a track needs >= 4 points \(got 0\)"),
])
def test_malformed_files_raise(tmp_path: pathlib.Path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_track_csv(write(tmp_path, text))


def test_missing_file_and_closed_figure_eight(tmp_path: pathlib.Path) -> None:
    with pytest.raises(ValueError, match=r"nope\.csv: track file not found"):
        load_track_csv(tmp_path / "nope.csv")
    th = np.linspace(0.0, 2.0 * math.pi, 40, endpoint=False)
    x, y = 50.0 * np.sin(th), 25.0 * np.sin(2.0 * th)                    # lemniscate: crosses at the origin
    f = write(tmp_path, "\n".join(f"{a},{b}" for a, b in zip(x, y, strict=True)))
    with pytest.raises(ValueError, match="crosses itself"):
        load_track_csv(f, closed=True)
    with pytest.raises(ValueError, match="duplicates"):
        Path.from_points(np.array([0.0, 1.0, 1.0, 2.0]), np.array([0.0, 0.0, 0.0, 1.0]))
