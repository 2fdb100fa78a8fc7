"""Small map files written from exact geometry, for the tests, the docs' example maps and the import benchmark.

    python benchmarks/map_files.py vtrack_gym/tracks/example_maps    # (re)writes the shipped example maps

The example "ring" is a stadium loop: two 100 m straights and two half turns of radius 40 m entered and left
through 20 m clothoids (curvature 0 -> 1/40 -> 0), two 3.5 m driving lanes and a 2 m sidewalk on the right. The
same loop is written as OpenDRIVE (four roads, the third stored backwards), GPX, Lanelet2 OSM and CommonRoad XML.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from vtrack_gym.tracks.opendrive_geometry import Geometry

RADIUS_M = 40.0
SPIRAL_M = 20.0
STRAIGHT_M = 100.0
LANE_M = 3.5
ORIGIN = (48.137, 11.575)   # lat, lon [deg] of the maps' origin (GPX, OSM)
A_WGS84, F_WGS84 = 6378137.0, 1.0 / 298.257223563


def turn_length_m() -> float:
    """Length [m] of one half turn: two clothoids and the arc between them (heading change pi)."""
    arc_turn = math.pi - SPIRAL_M / RADIUS_M     # each clothoid turns SPIRAL_M / (2 R)
    return 2.0 * SPIRAL_M + arc_turn * RADIUS_M


def ring_length_m() -> float:
    """Length [m] of the ring's reference line."""
    return 2.0 * STRAIGHT_M + 2.0 * turn_length_m()


def _chain(start: tuple[float, float, float], pieces: list[tuple[str, float, tuple]]) -> list[Geometry]:
    """Records ``(kind, length, params)`` chained from ``start`` (x, y, hdg), each from the previous one's end."""
    x, y, h = start
    out, s = [], 0.0
    for kind, length, params in pieces:
        g = Geometry(s, x, y, h, length, kind, params)
        ex, ey, eh, _ = g.evaluate(np.array([length]))
        x, y, h, s = float(ex[0]), float(ey[0]), float(eh[0]), s + length
        out.append(g)
    return out


def _turn() -> list[tuple[str, float, tuple]]:
    k = 1.0 / RADIUS_M
    return [("spiral", SPIRAL_M, (0.0, k)), ("arc", turn_length_m() - 2 * SPIRAL_M, (k,)),
            ("spiral", SPIRAL_M, (k, 0.0))]


def ring_roads() -> list[list[Geometry]]:
    """The ring's four roads in driving order (records chained; road 3 is later written backwards)."""
    roads, start = [], (0.0, 0.0, 0.0)
    for pieces in ([("line", STRAIGHT_M, ())], _turn(), [("line", STRAIGHT_M, ())], _turn()):
        recs = _chain(start, pieces)
        roads.append(recs)
        last = recs[-1]
        ex, ey, eh, _ = last.evaluate(np.array([last.length]))
        start = (float(ex[0]), float(ey[0]), float(eh[0]))
    return roads


def sample(records: list[Geometry], step_m: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, heading) every ~``step_m`` along chained records (end point included)."""
    xs, ys, hs = [], [], []
    for g in records:
        n = max(2, math.ceil(g.length / step_m) + 1)
        x, y, h, _ = g.evaluate(np.linspace(0.0, g.length, n))
        xs.append(x[:-1]), ys.append(y[:-1]), hs.append(h[:-1])
    x, y, h, _ = records[-1].evaluate(np.array([records[-1].length]))
    xs.append(x), ys.append(y), hs.append(h)
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(hs)


def _geometry_xml(g: Geometry) -> str:
    head = f'<geometry s="{g.s0!r}" x="{g.x0!r}" y="{g.y0!r}" hdg="{g.hdg!r}" length="{g.length!r}">'
    if g.kind == "line":
        body = "<line/>"
    elif g.kind == "arc":
        body = f'<arc curvature="{g.params[0]!r}"/>'
    elif g.kind == "spiral":
        body = f'<spiral curvStart="{g.params[0]!r}" curvEnd="{g.params[1]!r}"/>'
    elif g.kind == "poly3":
        body = '<poly3 a="{!r}" b="{!r}" c="{!r}" d="{!r}"/>'.format(*g.params)
    else:
        names = ("aU", "bU", "cU", "dU", "aV", "bV", "cV", "dV")
        attrs = " ".join(f'{n}="{v!r}"' for n, v in zip(names, g.params[:8], strict=True))
        p_range = "arcLength" if g.params[8] == g.length else "normalized"
        body = f'<paramPoly3 {attrs} pRange="{p_range}"/>'
    return f"      {head}{body}</geometry>"


def road_xml(rid: str, records: list[Geometry], lanes: str | None = None) -> str:
    """One ``<road>`` of chained records (their ``s0`` renumbered from 0) with the ring's lanes by default."""
    s, recs = 0.0, []
    for g in records:
        recs.append(Geometry(s, g.x0, g.y0, g.hdg, g.length, g.kind, g.params))
        s += g.length
    lanes = lanes or (f'<laneSection s="0"><left><lane id="1" type="driving"><width sOffset="0" a="{LANE_M}" b="0" '
                      'c="0" d="0"/></lane></left><center><lane id="0" type="none"/></center><right><lane id="-1" '
                      f'type="driving"><width sOffset="0" a="{LANE_M}" b="0" c="0" d="0"/></lane><lane id="-2" '
                      'type="sidewalk"><width sOffset="0" a="2" b="0" c="0" d="0"/></lane></right></laneSection>')
    geometry = "\n".join(_geometry_xml(g) for g in recs)
    return (f'  <road name="r{rid}" length="{s!r}" id="{rid}" junction="-1">\n    <planView>\n{geometry}\n'
            f'    </planView>\n    <lanes>{lanes}</lanes>\n  </road>')


def xodr_text(roads: list[str]) -> str:
    """An OpenDRIVE 1.6 document of ``<road>`` texts."""
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<OpenDRIVE>\n  <header revMajor="1" revMinor="6" name="test"/>\n'
            + "\n".join(roads) + "\n</OpenDRIVE>\n")


def reversed_records(records: list[Geometry]) -> list[Geometry]:
    """Lines and arcs of ``records`` stored from their end to their start (arcs with negated curvature;
    spirals reversed: curvature end -> start negated)."""
    out = []
    for g in reversed(records):
        ex, ey, eh, _ = g.evaluate(np.array([g.length]))
        params = {"line": (), "arc": (-g.params[0],) if g.params else (),
                  "spiral": (-g.params[1], -g.params[0]) if g.kind == "spiral" else ()}[g.kind]
        out.append(Geometry(0.0, float(ex[0]), float(ey[0]), float(eh[0]) + math.pi, g.length, g.kind, params))
    return out


def ring_xodr() -> str:
    """The ring as OpenDRIVE: roads 1-4 in driving order, road 3 stored backwards."""
    roads = ring_roads()
    return xodr_text([road_xml("1", roads[0]), road_xml("2", roads[1]), road_xml("3", reversed_records(roads[2])),
                      road_xml("4", roads[3])])


def geodetic(x: np.ndarray, y: np.ndarray, origin: tuple[float, float] = ORIGIN) -> tuple[np.ndarray, np.ndarray]:
    """Latitude, longitude [deg] of east, north points [m] in the tangent plane at ``origin`` (height 0): the
    inverse of ``vtrack_gym.tracks.gpx.local_xy``, by fixed-point iteration on the ellipsoid."""
    e2 = F_WGS84 * (2.0 - F_WGS84)
    lat0, lon0 = (math.radians(v) for v in origin)
    n0 = A_WGS84 / math.sqrt(1.0 - e2 * math.sin(lat0) ** 2)
    p0 = np.array([n0 * math.cos(lat0) * math.cos(lon0), n0 * math.cos(lat0) * math.sin(lon0),
                   n0 * (1.0 - e2) * math.sin(lat0)])
    east = np.array([-math.sin(lon0), math.cos(lon0), 0.0])
    north = np.array([-math.sin(lat0) * math.cos(lon0), -math.sin(lat0) * math.sin(lon0), math.cos(lat0)])
    up = np.cross(east, north)
    lat, lon = np.full_like(x, lat0), np.full_like(x, lon0)
    for _ in range(8):   # find the ellipsoid point whose tangent-plane east/north are x, y
        n = A_WGS84 / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
        p = np.stack([n * np.cos(lat) * np.cos(lon), n * np.cos(lat) * np.sin(lon), n * (1.0 - e2) * np.sin(lat)], -1)
        u = (p - p0) @ up
        q = p0 + x[:, None] * east + y[:, None] * north + u[:, None] * up
        lon = np.arctan2(q[:, 1], q[:, 0])
        lat = np.arctan2(q[:, 2], np.hypot(q[:, 0], q[:, 1]) * (1.0 - e2))
    return np.degrees(lat), np.degrees(lon)


def gpx_text(x: np.ndarray, y: np.ndarray) -> str:
    """A GPX 1.1 track of points x, y [m] east and north of ``ORIGIN``."""
    lat, lon = geodetic(x, y)
    pts = "\n".join(f'      <trkpt lat="{a:.9f}" lon="{b:.9f}"><ele>520</ele></trkpt>' for a, b in zip(lat, lon,
                                                                                                      strict=True))
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<gpx version="1.1" creator="vtrack_gym tests" '
            'xmlns="http://www.topografix.com/GPX/1/1">\n  <trk><name>ring</name><trkseg>\n' + pts
            + "\n  </trkseg></trk>\n</gpx>\n")


def ring_centre(step_m: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, heading) of the whole ring's reference line (closed: the last point is the first)."""
    x, y, h = sample([g for road in ring_roads() for g in road], step_m)
    return x, y, h


def ring_lanelets(step_m: float = 2.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """The ring's right driving lane as lanelets, one per road: (left bound, right bound), each (n, 2) [m]."""
    out = []
    for road in ring_roads():
        x, y, h = sample(road, step_m)
        nx, ny = -np.sin(h), np.cos(h)
        out.append((np.column_stack((x, y)), np.column_stack((x - LANE_M * nx, y - LANE_M * ny))))
    return out


def osm_text(lanelets: list[tuple[np.ndarray, np.ndarray]], local_xy: bool = False) -> str:
    """A Lanelet2 OSM map: one lanelet (ids 1001, ...) per (left, right) bound pair; consecutive lanelets share
    the bounds' end nodes so the routing graph links them; a closed chain closes on the first lanelet's nodes.
    ``local_xy``: Autoware's layout, metric ``local_x`` / ``local_y`` tags and placeholder latitude/longitude 0."""
    nodes: list[str] = []
    ways: list[str] = []
    rels: list[str] = []
    ids = {"next": 1}
    joint: dict[tuple[int, int], int] = {}

    def node(p: np.ndarray) -> int:
        key = (round(p[0] * 1000), round(p[1] * 1000))
        if key in joint:
            return joint[key]
        nid = ids["next"]
        ids["next"] += 1
        nodes.append(_node_xml(nid, p, local_xy))
        joint[key] = nid
        return nid

    for k, (left, right) in enumerate(lanelets):
        bounds = []
        for side, pts in (("left", left), ("right", right)):
            refs = [node(pts[0])] + [_fresh(nodes, ids, p, local_xy) for p in pts[1:-1]] + [node(pts[-1])]
            wid = 100_000 + 2 * k + (side == "right")
            ways.append(f'  <way id="{wid}" version="1">' + "".join(f'<nd ref="{r}"/>' for r in refs)
                        + '<tag k="type" v="line_thin"/><tag k="subtype" v="solid"/></way>')
            bounds.append(wid)
        rels.append(f'  <relation id="{1001 + k}" version="1"><member type="way" ref="{bounds[0]}" role="left"/>'
                    f'<member type="way" ref="{bounds[1]}" role="right"/><tag k="type" v="lanelet"/>'
                    '<tag k="subtype" v="road"/><tag k="location" v="urban"/><tag k="one_way" v="yes"/>'
                    '<tag k="speed_limit" v="50"/></relation>')
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<osm version="0.6" generator="vtrack_gym tests">\n'
            + "\n".join(nodes + ways + rels) + "\n</osm>\n")


def _fresh(nodes: list[str], ids: dict[str, int], p: np.ndarray, local_xy: bool) -> int:
    nid = ids["next"]
    ids["next"] += 1
    nodes.append(_node_xml(nid, p, local_xy))
    return nid


def _node_xml(nid: int, p: np.ndarray, local_xy: bool) -> str:
    """One ``<node>``: at the latitude/longitude of x, y [m], or (Autoware) at 0, 0 with local_x / local_y tags."""
    if local_xy:
        return (f'  <node id="{nid}" version="1" lat="0" lon="0"><tag k="local_x" v="{float(p[0])!r}"/>'
                f'<tag k="local_y" v="{float(p[1])!r}"/></node>')
    lat, lon = geodetic(np.array([p[0]]), np.array([p[1]]))
    return f'  <node id="{nid}" version="1" lat="{lat[0]:.10f}" lon="{lon[0]:.10f}"/>'


def commonroad_text(lanelets: list[tuple[np.ndarray, np.ndarray]], start_xy: tuple[float, float] | None = None,
                    goal_lanelet: int | None = None) -> str:
    """A CommonRoad 2020a scenario: lanelets 1001, ... each the successor of the one before (a closed chain links
    the last to the first), and a planning problem from ``start_xy`` to ``goal_lanelet`` when given."""
    def bound(tag: str, pts: np.ndarray) -> str:
        return (f"<{tag}>" + "".join(f"<point><x>{float(p[0])!r}</x><y>{float(p[1])!r}</y></point>" for p in pts)
                + f"<lineMarking>solid</lineMarking></{tag}>")

    n = len(lanelets)
    closed = np.allclose(lanelets[0][0][0], lanelets[-1][0][-1])
    items = []
    for k, (left, right) in enumerate(lanelets):
        succ = 1001 + (k + 1) % n if (k + 1 < n or closed) else None
        pred = 1001 + (k - 1) % n if (k > 0 or closed) else None
        links = (f'<predecessor ref="{pred}"/>' if pred else "") + (f'<successor ref="{succ}"/>' if succ else "")
        items.append(f'  <lanelet id="{1001 + k}">{bound("leftBound", left)}{bound("rightBound", right)}{links}'
                     "<laneletType>urban</laneletType></lanelet>")
    if start_xy is not None and goal_lanelet is not None:
        items.append(
            f'  <planningProblem id="1"><initialState><position><point><x>{start_xy[0]!r}</x><y>{start_xy[1]!r}</y>'
            "</point></position><orientation><exact>0.0</exact></orientation><time><exact>0</exact></time>"
            "<velocity><exact>10.0</exact></velocity><yawRate><exact>0.0</exact></yawRate><slipAngle><exact>0.0"
            "</exact></slipAngle></initialState><goalState><time><intervalStart>0</intervalStart><intervalEnd>1000"
            f'</intervalEnd></time><position><lanelet ref="{goal_lanelet}"/></position></goalState>'
            "</planningProblem>")
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<commonRoad timeStepSize="0.1" commonRoadVersion="2020a" '
            'author="vtrack_gym tests" affiliation="" source="generated" benchmarkID="DEU_Ring-1_1_T-1" '
            'date="2026-12-04">\n  <location><geoNameId>-999</geoNameId><gpsLatitude>999</gpsLatitude>'
            "<gpsLongitude>999</gpsLongitude></location>\n  <scenarioTags><Urban/></scenarioTags>\n"
            + "\n".join(items) + "\n</commonRoad>\n")


def figure_eight(radius_m: float = 30.0) -> tuple[list[Geometry], list[Geometry]]:
    """A closed figure eight as two roads: two 270 deg loops of radius ``radius_m`` whose straights cross near
    (not at) the origin, as a road over a bridge does."""
    r, a, b = radius_m, -15.5 / math.sqrt(2.0), -15.0 / math.sqrt(2.0)
    first = _chain((a, a, math.pi / 4), [("line", r + 15.5, ()), ("arc", 1.5 * math.pi * r, (1 / r,)),
                                         ("line", r - 15.0, ())])
    second = _chain((b, -b, -math.pi / 4), [("line", r + 15.0, ()), ("arc", 1.5 * math.pi * r, (-1 / r,)),
                                            ("line", r - 15.5, ())])
    return first, second


def write_examples(folder: Path) -> list[Path]:
    """Write the ring in every format into ``folder``; returns the files."""
    folder.mkdir(parents=True, exist_ok=True)
    x, y, _ = ring_centre(5.0)
    lanes = ring_lanelets()
    right_lane = ring_lanelets()
    start = (float(right_lane[0][0][3, 0] + right_lane[0][1][3, 0]) / 2, float(right_lane[0][0][3, 1]
                                                                            + right_lane[0][1][3, 1]) / 2)
    texts = {"ring.xodr": ring_xodr(), "ring.gpx": gpx_text(x[:-1], y[:-1]), "ring.osm": osm_text(lanes),
             "ring.xml": commonroad_text(lanes[:3], start, 1003)}
    out = []
    for name, text in texts.items():
        (folder / name).write_text(text, encoding="utf-8")
        out.append(folder / name)
    return out


if __name__ == "__main__":
    for f in write_examples(Path(sys.argv[1] if len(sys.argv) > 1 else "example_maps")):
        print(f)
