"""OpenDRIVE reference-line geometry and lane widths against analytic geometry: spirals (curvature and length to
1e-6), arcs, poly3 and paramPoly3 records, lane offsets and width polynomials, and the ring map's length."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.tracks import load_track
from vtrack_gym.tracks.opendrive import lateral, parse_roads
from vtrack_gym.tracks.opendrive_geometry import Geometry
from vtrack_gym.tracks.table import COL_KAPPA
from vtrack_gym.tracks.xml_reader import read_xml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import map_files


def circle_curvature(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Curvature [1/m] of the circle through each three consecutive points (signed, left positive)."""
    ax, ay, bx, by, cx, cy = x[:-2], y[:-2], x[1:-1], y[1:-1], x[2:], y[2:]
    cross = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return 2.0 * cross / (np.hypot(bx - ax, by - ay) * np.hypot(cx - bx, cy - by) * np.hypot(cx - ax, cy - ay))


@pytest.mark.parametrize(("k0", "k1", "length"), [(0.0, 1 / 40, 20.0), (0.02, -0.03, 50.0), (-0.05, -0.01, 35.0),
                                                  (0.01, 0.01 + 1e-13, 30.0)])
def test_a_spiral_has_its_linear_curvature_and_its_length(k0: float, k1: float, length: float) -> None:
    g = Geometry(0.0, 12.0, -3.0, 0.7, length, "spiral", (k0, k1))
    s = np.linspace(0.0, length, int(length / 0.01) + 1)
    x, y, hdg, kappa = g.evaluate(s)
    chords = np.hypot(np.diff(x), np.diff(y))
    assert abs(chords.sum() - length) < 1e-6
    expected = k0 + (k1 - k0) * s / length
    np.testing.assert_allclose(kappa, expected, atol=1e-15)
    np.testing.assert_allclose(circle_curvature(x, y), expected[1:-1], atol=1e-6)   # from the positions alone
    np.testing.assert_allclose(np.arctan2(np.diff(y), np.diff(x)), (hdg[:-1] + hdg[1:]) / 2, atol=1e-8)
    assert (x[0], y[0]) == (12.0, -3.0)


def test_an_arc_lies_on_its_circle() -> None:
    k = -1 / 25
    g = Geometry(0.0, 0.0, 0.0, 0.3, 60.0, "arc", (k,))
    x, y, hdg, _ = g.evaluate(np.linspace(0.0, 60.0, 601))
    cx, cy = -math.sin(0.3) / k, math.cos(0.3) / k       # centre of the circle left (k > 0) or right of the start
    np.testing.assert_allclose(np.hypot(x - cx, y - cy), 25.0, atol=1e-9)
    np.testing.assert_allclose(hdg[-1], 0.3 + k * 60.0, atol=1e-15)


@pytest.mark.parametrize("kind", ["poly3", "paramPoly3-arcLength", "paramPoly3-normalized"])
def test_cubic_records_follow_their_polynomials_at_arc_length(kind: str) -> None:
    if kind == "poly3":
        g = Geometry(0.0, 5.0, 1.0, 0.4, 40.0, "poly3", (0.5, 0.05, 0.002, -3e-5))
    else:
        p_end = 40.0 if kind.endswith("arcLength") else 1.0
        scale = 1.0 / p_end
        params = (0.0, 40.0 * scale, 0.0, 0.0, 0.0, 0.0, 30.0 * scale ** 2 * 0.1, 0.0, p_end)
        g = Geometry(0.0, 5.0, 1.0, 0.4, 40.0, "paramPoly3", params)
    from vtrack_gym.tracks.opendrive_geometry import cubic_arc_length

    length = cubic_arc_length(g) if kind != "poly3" else 40.0
    g = Geometry(g.s0, g.x0, g.y0, g.hdg, min(length, 40.0), g.kind, g.params)
    s = np.linspace(0.0, g.length, 4001)
    x, y, _, kappa = g.evaluate(s)
    chords = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    np.testing.assert_allclose(chords, s, atol=1e-6)          # sampled at arc length
    u = math.cos(g.hdg) * (x - g.x0) + math.sin(g.hdg) * (y - g.y0)
    v = -math.sin(g.hdg) * (x - g.x0) + math.cos(g.hdg) * (y - g.y0)
    if kind == "poly3":
        np.testing.assert_allclose(v, np.polynomial.polynomial.polyval(u, g.params), atol=1e-9)
    else:
        p = u / g.params[1]
        np.testing.assert_allclose(v, g.params[6] * p ** 2, atol=1e-9)
    np.testing.assert_allclose(circle_curvature(x, y), kappa[1:-1], atol=1e-6)


def _straight_with_lanes(tmp_path: Path) -> Path:
    """A 100 m straight road: lane offset 0.2 + 0.01 s, lane -1 width 3 + 0.01 ds + 1e-4 ds^2 - 1e-6 ds^3 in a
    first section, 3.5 m from s = 60 m on (a second section), lane 1 3.2 m, lane -2 a 2 m sidewalk."""
    lanes = ('<laneOffset s="0" a="0.2" b="0.01" c="0" d="0"/>'
             '<laneSection s="0"><left><lane id="1" type="driving"><width sOffset="0" a="3.2" b="0" c="0" d="0"/>'
             '</lane></left><center><lane id="0" type="none"/></center><right><lane id="-1" type="driving">'
             '<width sOffset="0" a="3" b="0.01" c="1e-4" d="-1e-6"/></lane><lane id="-2" type="sidewalk">'
             '<width sOffset="0" a="2" b="0" c="0" d="0"/></lane></right></laneSection>'
             '<laneSection s="60"><left><lane id="1" type="driving"><width sOffset="0" a="3.2" b="0" c="0" d="0"/>'
             '</lane></left><center><lane id="0" type="none"/></center><right><lane id="-1" type="driving">'
             '<width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></right></laneSection>')
    records = [Geometry(0.0, 0.0, 0.0, 0.0, 100.0, "line", ())]
    file = tmp_path / "straight.xodr"
    file.write_text(map_files.xodr_text([map_files.road_xml("7", records, lanes)]), encoding="utf-8")
    return file


def test_lane_offsets_and_width_polynomials_give_the_widths(tmp_path: Path) -> None:
    file = _straight_with_lanes(tmp_path)
    road = parse_roads(file, read_xml(file, file.read_bytes(), "OpenDRIVE"))["7"]
    s = np.linspace(0.0, 100.0, 1001)
    w1 = np.where(s < 60.0, 3.0 + 0.01 * s + 1e-4 * s ** 2 - 1e-6 * s ** 3, 3.5)
    offset = 0.2 + 0.01 * s
    t, left, right = lateral(road, s, None)
    np.testing.assert_allclose(left, offset + 3.2, atol=1e-12)
    np.testing.assert_allclose(right, offset - w1, atol=1e-12)       # the sidewalk is not drivable
    np.testing.assert_allclose(t, offset + (3.2 - w1) / 2, atol=1e-12)
    t_lane, _, _ = lateral(road, s, -1)
    np.testing.assert_allclose(t_lane, offset - w1 / 2, atol=1e-12)
    path = load_track(file, lane=-1)
    rows = path.s_m
    w_rows = np.where(rows < 60.0, 3.0 + 0.01 * rows + 1e-4 * rows ** 2 - 1e-6 * rows ** 3, 3.5)
    inside = np.abs(rows - 60.0) > 1.0      # the step at the section start is interpolated over one sample
    np.testing.assert_allclose(path.widths_m[inside, 1], w_rows[inside] / 2, atol=1e-3)
    np.testing.assert_allclose(path.widths_m[inside, 0], 3.2 + w_rows[inside] / 2, atol=1e-3)


def test_the_ring_has_its_analytic_length_and_curvature(tmp_path: Path) -> None:
    file = tmp_path / "ring.xodr"
    file.write_text(map_files.ring_xodr(), encoding="utf-8")
    path = load_track(file, route="1,2,3,4")
    assert path.closed
    assert abs(path.length_m - map_files.ring_length_m()) < 1e-6
    assert abs(np.abs(path.table[:, COL_KAPPA]).max() - 1 / map_files.RADIUS_M) < 1e-3
    np.testing.assert_allclose(path.widths_m, map_files.LANE_M, atol=1e-9)
    lane = load_track(file, route="1,2,3,4", lane=-1)      # the outer lane: radius 40 + 1.75 m in the turns
    extra = 2 * math.pi * map_files.LANE_M / 2
    assert abs(lane.length_m - (map_files.ring_length_m() + extra)) < 1e-4
    np.testing.assert_allclose(lane.widths_m[:, 1], 1.75, atol=1e-9)
    np.testing.assert_allclose(lane.widths_m[:, 0], 5.25, atol=1e-9)
    backwards = load_track(file, route="4,3,2,1")           # every road driven against its direction
    assert abs(backwards.length_m - map_files.ring_length_m()) < 1e-6
    assert np.abs(backwards.table[:, COL_KAPPA]).max() == pytest.approx(1 / map_files.RADIUS_M, abs=1e-3)
    assert backwards.table[:, COL_KAPPA].min() < 0.0 < path.table[:, COL_KAPPA].max()
