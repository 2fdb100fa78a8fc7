"""ASAM OpenDRIVE (``.xodr``) roads as a track: the reference lines of a route of roads, shifted by the lane offset
to the driven line, with the drivable carriageway's edges as per-station half widths.

Own parser (the standard library's expat, ``tracks.xml_reader``) and own geometry (``tracks.opendrive_geometry``):
the five reference-line records are closed-form or Fresnel integrals, and no PyPI library for them is both well
kept and light. Read: ``<road>`` (id, length), its ``<planView>`` geometry records, ``<lanes>`` with
``<laneOffset>`` and every ``<laneSection>``'s lanes and ``<width>`` polynomials. Lanes of a type in
``DRIVABLE_TYPES`` next to the reference line (and to each other) make the carriageway; the driven line is its
middle, or the middle of ``lane`` (an id in the direction of travel: -1 is the first lane right of the reference
line). The route is ``route`` (road ids in driving order; each next road must start or end where the previous one
ends, and is driven backwards in the second case); a map of one road needs none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks.fitting import MAX_LENGTH_M
from vtrack_gym.tracks.map_path import MapLine, map_path
from vtrack_gym.tracks.opendrive_geometry import GEOMETRY_KINDS, Geometry
from vtrack_gym.tracks.xml_reader import Element, number, read_xml

SAMPLE_M = 1.0
"""Spacing [m] of the centre points taken from the exact geometry."""
CONNECT_TOL_M = 0.1
"""Consecutive roads of a route must meet within this [m]."""
DRIVABLE_TYPES = frozenset({"driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp", "bidirectional",
                            "slipLane"})
"""Lane types that make the carriageway."""
MAX_ROADS = 100_000
"""Most roads one map may hold."""
GAP_TOL_M = 0.01
"""A road's geometry records must follow each other, and end at its length, within this [m]."""
_ROUTE_HINT = "give the roads to drive: route='1,2,3' (CLI --track-route 1,2,3)"


@dataclass(frozen=True)
class Poly:
    """A cubic a + b ds + c ds^2 + d ds^3 valid from ``s`` [m] on (``ds`` from there)."""

    s: float
    coef: tuple[float, float, float, float]


@dataclass(frozen=True)
class Road:
    """One parsed ``<road>``: id, length [m], geometry records, lane offsets and lane sections
    (``(s, {lane id: (type, [width polys])})``)."""

    id: str
    length: float
    geometry: tuple[Geometry, ...]
    offsets: tuple[Poly, ...]
    sections: tuple[tuple[float, dict[int, tuple[str, list[Poly]]]], ...]


def sniff(head: bytes) -> bool:
    """Whether a file's first bytes look like OpenDRIVE."""
    return b"<OpenDRIVE" in head


def _polys(file: FsPath, nodes: list[Element], key: str, road: str) -> tuple[Poly, ...]:
    """The cubics of ``nodes`` (``<laneOffset s=...>`` or ``<width sOffset=...>``), sorted by their start."""
    out = []
    for n in nodes:
        coef = tuple(number(n, c, file, 0.0) for c in "abcd")
        out.append(Poly(number(n, key, file), coef))  # type: ignore[arg-type]
    return tuple(sorted(out, key=lambda p: p.s))


def _geometry(file: FsPath, node: Element, road: str) -> Geometry:
    """One ``<geometry>`` record; ValueError naming the road, line and record for anything else."""
    kinds = [c for c in node.children if c.tag in GEOMETRY_KINDS]
    if len(kinds) != 1:
        got = ", ".join(f"<{c.tag}>" for c in node.children) or "nothing"
        raise ValueError(f"{file}, line {node.line}: road {road}: a <geometry> holds {got}; expected one of "
                         f"{', '.join(f'<{k}>' for k in GEOMETRY_KINDS)}")
    rec = kinds[0]
    s0, x0, y0, hdg, length = (number(node, a, file) for a in ("s", "x", "y", "hdg", "length"))
    if not length > 0.0:
        raise ValueError(f"{file}, line {node.line}: road {road}: a <geometry> of length {length:g} m; expected > 0")
    names = {"line": (), "arc": ("curvature",), "spiral": ("curvStart", "curvEnd"), "poly3": tuple("abcd"),
             "paramPoly3": ("aU", "bU", "cU", "dU", "aV", "bV", "cV", "dV")}[rec.tag]
    params = tuple(number(rec, a, file) for a in names)
    if rec.tag == "paramPoly3":
        p_range = rec.attrib.get("pRange", "arcLength")
        if p_range not in ("arcLength", "normalized"):
            raise ValueError(f"{file}, line {rec.line}: road {road}: pRange={p_range!r:.20}; expected arcLength or "
                             "normalized")
        params += (length if p_range == "arcLength" else 1.0,)
    return Geometry(s0, x0, y0, hdg, length, rec.tag, params)


def _sections(file: FsPath, lanes: Element, road: str) -> tuple[tuple[float, dict[int, tuple[str, list[Poly]]]], ...]:
    """The lane sections of ``<lanes>``: (start s [m], {lane id: (type, width polys)})."""
    out = []
    for sec in lanes.find_all("laneSection"):
        table: dict[int, tuple[str, list[Poly]]] = {}
        for side in ("left", "right"):
            group = sec.find(side)
            for lane in [] if group is None else group.find_all("lane"):
                try:
                    lane_id = int(lane.attrib.get("id", ""))
                except ValueError:
                    raise ValueError(f"{file}, line {lane.line}: road {road}: a <lane> id "
                                     f"{lane.attrib.get('id', '(none)')!r:.20}; expected an integer") from None
                if lane.find_all("border") and not lane.find_all("width"):
                    raise ValueError(f"{file}, line {lane.line}: road {road}, lane {lane_id}: <border> records are "
                                     "not read; expected <width> records")
                table[lane_id] = (lane.attrib.get("type", "none"), list(_polys(file, lane.find_all("width"),
                                                                               "sOffset", road)))
        for sign, side in ((1, "left"), (-1, "right")):
            ids = sorted(abs(i) for i in table if i * sign > 0)
            if ids != list(range(1, len(ids) + 1)):
                raise ValueError(f"{file}, line {sec.line}: road {road}: the {side} lanes have ids "
                                 f"{[sign * i for i in ids]}; expected {sign}, {2 * sign}, ... from the centre")
        out.append((number(sec, "s", file), table))
    if not out:
        raise ValueError(f"{file}, line {lanes.line}: road {road}: <lanes> has no <laneSection>")
    return tuple(sorted(out, key=lambda t: t[0]))


def parse_roads(file: FsPath, root: Element) -> dict[str, Road]:
    """Every ``<road>`` of an OpenDRIVE document, by id; ValueError naming the line and road for bad records."""
    if root.tag != "OpenDRIVE":
        raise ValueError(f"{file}, line {root.line}: the root element is <{root.tag}>; expected <OpenDRIVE>")
    roads: dict[str, Road] = {}
    for node in root.find_all("road")[: MAX_ROADS + 1]:
        rid = node.attrib.get("id", "")
        if not rid or rid in roads:
            raise ValueError(f"{file}, line {node.line}: a <road> with {'a repeated' if rid else 'no'} id {rid!r:.20}")
        length = number(node, "length", file)
        if not length > 0.0:
            raise ValueError(f"{file}, line {node.line}: road {rid} has length {length:g} m; expected > 0")
        plan, lanes = node.find("planView"), node.find("lanes")
        if plan is None or not plan.find_all("geometry") or lanes is None:
            raise ValueError(f"{file}, line {node.line}: road {rid}: expected a <planView> with <geometry> records "
                             "and <lanes>")
        if length > MAX_LENGTH_M:
            raise ValueError(f"{file}, line {node.line}: road {rid} has length {length:g} m; at most "
                             f"{MAX_LENGTH_M:g} m")
        geometry = tuple(sorted((_geometry(file, g, rid) for g in plan.find_all("geometry")), key=lambda g: g.s0))
        _check_coverage(file, node, rid, length, geometry)
        roads[rid] = Road(rid, length, geometry, _polys(file, lanes.find_all("laneOffset"), "s", rid),
                          _sections(file, lanes, rid))
    if len(roads) > MAX_ROADS:
        raise ValueError(f"{file}: more than {MAX_ROADS} roads")
    if not roads:
        raise ValueError(f"{file}, line {root.line}: no <road>; expected at least one")
    return roads


def _check_coverage(file: FsPath, node: Element, rid: str, length: float, geometry: tuple[Geometry, ...]) -> None:
    """ValueError naming the road when its geometry records leave a gap or end before its length."""
    end = 0.0
    for g in geometry:
        if abs(g.s0 - end) > GAP_TOL_M:
            raise ValueError(f"{file}, line {node.line}: road {rid}: a <geometry> starts at s = {g.s0:g} m where the "
                             f"records before end at s = {end:g} m; expected contiguous records from s = 0")
        end = g.s0 + g.length
    if abs(end - length) > GAP_TOL_M:
        raise ValueError(f"{file}, line {node.line}: road {rid}: its <geometry> records end at s = {end:g} m; expected "
                         f"its length {length:g} m")


def _poly_at(polys: tuple[Poly, ...] | list[Poly], s: np.ndarray) -> np.ndarray:
    """The piecewise cubic ``polys`` at ``s`` [m] (0 before the first piece)."""
    if not polys:
        return np.zeros_like(s)
    starts = np.array([p.s for p in polys])
    idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(polys) - 1)
    coef = np.array([p.coef for p in polys])[idx]
    ds = s - starts[idx]
    return np.where(s >= starts[0], coef[:, 0] + ds * (coef[:, 1] + ds * (coef[:, 2] + ds * coef[:, 3])), 0.0)


def reference_line(road: Road, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, heading) of the road's reference line at ``s`` [m]."""
    starts = np.array([g.s0 for g in road.geometry])
    idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(road.geometry) - 1)
    x, y, hdg = np.empty_like(s), np.empty_like(s), np.empty_like(s)
    for k, g in enumerate(road.geometry):
        mask = idx == k
        if mask.any():
            gx, gy, gh, _ = g.evaluate(np.minimum(s[mask] - g.s0, g.length))
            x[mask], y[mask], hdg[mask] = gx, gy, gh
    return x, y, hdg


def lateral(road: Road, s: np.ndarray, lane: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t of the driven line, t of the left edge, t of the right edge) [m] at ``s``: lateral offsets from the
    reference line (left positive) of the carriageway's drivable lanes and of ``lane``'s middle (None: the
    carriageway's)."""
    offset = _poly_at(road.offsets, s)
    starts = np.array([sec[0] for sec in road.sections])
    which = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(starts) - 1)
    t = np.empty_like(s)
    left, right = np.empty_like(s), np.empty_like(s)
    for k, (s_sec, table) in enumerate(road.sections):
        mask = which == k
        if not mask.any():
            continue
        ds = s[mask] - s_sec
        edges: dict[int, np.ndarray] = {0: np.zeros_like(ds)}   # outer edge of every lane, from the reference line
        drivable = {1: True, -1: True}
        edge_of = {1: np.zeros_like(ds), -1: np.zeros_like(ds)}
        for sign in (1, -1):
            for lane_id in sorted((i for i in table if i * sign > 0), key=abs):
                kind, widths = table[lane_id]
                edges[lane_id] = edges[lane_id - sign] + sign * _poly_at(widths, ds)
                if drivable[sign] and kind in DRIVABLE_TYPES:
                    edge_of[sign] = edges[lane_id]
                else:
                    drivable[sign] = False
        left[mask], right[mask] = offset[mask] + edge_of[1], offset[mask] + edge_of[-1]
        if lane is None:
            t[mask] = 0.5 * (left[mask] + right[mask])
        elif lane in edges and lane in table:
            t[mask] = offset[mask] + 0.5 * (edges[lane] + edges[lane - (1 if lane > 0 else -1)])
        else:
            raise ValueError(f"road {road.id}, lane section at s = {s_sec:g} m: no lane {lane} (lanes "
                             f"{sorted(table)})")
    return t, left, right


def road_line(road: Road, lane: int | None, reverse: bool) -> tuple[np.ndarray, ...]:
    """(x, y, left width, right width, s) of a road's driven line, sampled every ``SAMPLE_M`` [m] or finer, in
    the direction of travel (``reverse``: from the road's end to its start, lanes mirrored)."""
    n = max(2, math.ceil(road.length / SAMPLE_M) + 1)
    s = np.linspace(0.0, road.length, n)
    x, y, hdg = reference_line(road, s)
    t, left, right = lateral(road, s, None if lane is None else (-lane if reverse else lane))
    cx, cy = x - t * np.sin(hdg), y + t * np.cos(hdg)
    wl, wr = left - t, t - right
    if reverse:
        return cx[::-1], cy[::-1], wr[::-1], wl[::-1], s[::-1]
    return cx, cy, wl, wr, s


def _ends(road: Road) -> tuple[np.ndarray, np.ndarray]:
    """The reference line's start and end points."""
    x, y, _ = reference_line(road, np.array([0.0, road.length]))
    return np.array([x[0], y[0]]), np.array([x[1], y[1]])


def _directions(file: FsPath, roads: dict[str, Road], route: tuple[str, ...]) -> list[bool]:
    """Whether each road of ``route`` is driven backwards; ValueError naming two roads that do not meet."""
    ends = [_ends(roads[r]) for r in route]
    reverse: list[bool] = []
    for k in range(len(route)):
        if k == 0:
            if len(route) == 1:
                reverse.append(False)
                continue
            start, end = ends[0]
            nxt = ends[1]
            reverse.append(min(_gap(start, p) for p in nxt) < min(_gap(end, p) for p in nxt))
            continue
        prev_end = ends[k - 1][0 if reverse[-1] else 1]
        start, end = ends[k]
        if _gap(prev_end, start) <= CONNECT_TOL_M:
            reverse.append(False)
        elif _gap(prev_end, end) <= CONNECT_TOL_M:
            reverse.append(True)
        else:
            raise ValueError(f"{file}: route: road {route[k]} does not connect to road {route[k - 1]} (road "
                             f"{route[k - 1]} ends at ({prev_end[0]:.2f}, {prev_end[1]:.2f}); road {route[k]} runs "
                             f"from ({start[0]:.2f}, {start[1]:.2f}) to ({end[0]:.2f}, {end[1]:.2f})); expected "
                             f"consecutive roads to meet within {CONNECT_TOL_M:g} m (a junction's connecting road "
                             "between them?)")
    return reverse


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.hypot(*(a - b)))


def route_line(file: FsPath, roads: dict[str, Road], route: tuple[str, ...], lane: int | None) -> MapLine:
    """The centre line of ``route`` through ``roads`` (a one-road map: that road)."""
    if not route:
        if len(roads) > 1:
            shown = ", ".join(list(roads)[:12]) + (", ..." if len(roads) > 12 else "")
            raise ValueError(f"{file}: the map has {len(roads)} roads ({shown}); {_ROUTE_HINT}")
        route = tuple(roads)
    missing = [r for r in route if r not in roads]
    if missing:
        shown = ", ".join(list(roads)[:12]) + (", ..." if len(roads) > 12 else "")
        raise ValueError(f"{file}: route: no road with id {missing[0]!r:.30} in the map (roads: {shown})")
    total = sum(roads[r].length for r in route)
    if total > MAX_LENGTH_M:   # checked before any road is sampled: bounded memory
        raise ValueError(f"{file}: the route is {total / 1000:.0f} km long; at most {MAX_LENGTH_M / 1000:.0f} km")
    parts = []
    for k, (rid, rev) in enumerate(zip(route, _directions(file, roads, route), strict=True)):
        try:
            cx, cy, wl, wr, s = road_line(roads[rid], lane, rev)
        except ValueError as exc:
            raise ValueError(f"{file}: {exc}") from None
        cut = 0 if k == 0 else 1   # the joint is the previous road's last point
        parts.append((cx[cut:], cy[cut:], wl[cut:], wr[cut:], s[cut:], np.full(cx.size - cut, k)))
    x, y, wl, wr, s, which = (np.concatenate(c) for c in zip(*parts, strict=True))

    def where(k: int) -> str:
        return f"road {route[int(which[k])]} at s = {s[k]:.1f} m"

    return MapLine(x, y, np.column_stack((wl, wr)), where)


def load(file: FsPath, read: Any) -> Any:
    """The track format registry's entry: an OpenDRIVE file as a ``tracks.Path`` (route, lane, closed,
    smoothing_m, allow_self_crossing from ``read``, a ``tracks.formats.TrackRead``)."""
    from vtrack_gym.tracks.csv_loader import read_track_bytes

    if read.road_width_m is not None:
        raise ValueError(f"{file}: road_width_m applies to a GPX track; an OpenDRIVE road has its lane widths")
    data = read_track_bytes(file)
    roads = parse_roads(file, read_xml(file, data, "OpenDRIVE"))
    line = route_line(file, roads, read.route, read.lane)
    smoothing = 0.0 if read.smoothing_m is None else read.smoothing_m   # exact geometry: interpolated
    return map_path(file, data, line, closed=read.closed, smoothing_m=smoothing,
                    allow_self_crossing=read.allow_self_crossing)
