"""A Lanelet2 map (``.osm``) as a track, through the ``lanelet2`` package (the ``lanelet2`` extra): a lanelet
sequence's centre lines, with the distances to its left and right bounds as half widths.

The route is ``route``: lanelet ids in driving order; two consecutive ids that do not follow each other are joined
by the shortest route of Lanelet2's routing graph (German traffic rules for a vehicle), so ``route='1001,1004'``
drives from lanelet 1001 to lanelet 1004. A map of one lanelet needs none. Latitude and longitude are projected by
Lanelet2's ``LocalCartesianProjector`` at the file's first node (a local east-north tangent plane), unless every
node carries Autoware's metric ``local_x`` / ``local_y`` tags, which are then its coordinates.
"""

from __future__ import annotations

import math
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks.map_path import centre_of_bounds, expand_route, lanelet_line, map_path, no_route_error
from vtrack_gym.tracks.xml_reader import Element, number, read_xml


def _origin(file: FsPath, root: Element) -> tuple[float, float]:
    """Latitude, longitude [deg] of the first ``<node>``, after ``check_osm``."""
    if root.tag != "osm":
        raise ValueError(f"{file}, line {root.line}: the root element is <{root.tag}>; expected <osm>")
    node = root.find("node")
    if node is None:
        raise ValueError(f"{file}, line {root.line}: no <node>; expected a Lanelet2 map")
    check_osm(file, root)
    return number(node, "lat", file), number(node, "lon", file)


def _ids(file: FsPath, nodes: list[Element], what: str) -> set[int]:
    """The integer ids of ``nodes``; ValueError naming the line of one that is not an integer or repeats."""
    ids: set[int] = set()
    for n in nodes:
        text = n.attrib.get("id", "")
        if not text.lstrip("-").isdigit() or len(text) > 19 or int(text) in ids:
            raise ValueError(f"{file}, line {n.line}: a <{what}> id {text[:20]!r}; expected a unique integer")
        ids.add(int(text))
    return ids


def check_osm(file: FsPath, root: Element) -> None:
    """What lanelet2's C++ reader assumes, checked first (it may crash on less): integer unique ids, latitudes in
    [-90, 90] and longitudes in [-180, 180], and every reference naming an element of the file. ValueError naming
    the line otherwise."""
    nodes = root.find_all("node")
    layers = {"node": _ids(file, nodes, "node"), "way": _ids(file, root.find_all("way"), "way"),
              "relation": _ids(file, root.find_all("relation"), "relation")}
    for n in nodes:
        lat, lon = number(n, "lat", file), number(n, "lon", file)
        if abs(lat) > 90.0 or abs(lon) > 180.0:
            raise ValueError(f"{file}, line {n.line}: node lat={lat:g}, lon={lon:g}; expected latitude in [-90, 90] "
                             "and longitude in [-180, 180] degrees")
    refs = [("node", r) for w in root.find_all("way") for r in w.find_all("nd")]
    refs += [(m.attrib.get("type", ""), m) for rel in root.find_all("relation") for m in rel.find_all("member")]
    for kind, ref in refs:
        text = ref.attrib.get("ref", "")
        if kind not in layers or not text.lstrip("-").isdigit() or len(text) > 19 or int(text) not in layers[kind]:
            raise ValueError(f"{file}, line {ref.line}: a reference to {kind or 'an element'} {text[:20]!r}; "
                             f"expected the id of a {kind or 'node, way or relation'} of the file")


def _lanelet2() -> Any:
    try:
        import lanelet2
        import lanelet2.core
        import lanelet2.io
        import lanelet2.projection
        import lanelet2.routing
        import lanelet2.traffic_rules
    except ImportError as exc:
        raise ImportError("reading a Lanelet2 map (.osm) needs the lanelet2 package: pip install "
                          f"'vtrack_gym[lanelet2]' ({exc})") from exc
    return lanelet2


def _tags(node: Element) -> dict[str, str]:
    return {t.attrib.get("k", ""): t.attrib.get("v", "") for t in node.find_all("tag")}


def _xml(node: Element) -> str:
    """``node`` and its children as XML text (attributes quoted)."""
    from xml.sax.saxutils import quoteattr

    attrs = "".join(f" {k}={quoteattr(v)}" for k, v in node.attrib.items())
    inner = "".join(_xml(c) for c in node.children)
    return f"<{node.tag}{attrs}>{inner}</{node.tag}>"


def autoware_osm(file: FsPath, root: Element, ll2: Any) -> str | None:
    """Autoware's layout, where every node carries metric ``local_x`` / ``local_y`` tags [m] (its latitude and
    longitude may be placeholders): the document with each node's latitude, longitude and ``ele`` set to the
    point that lanelet2's ``LocalCartesianProjector`` at (0, 0) maps back to exactly those x, y; None for any
    other map. ValueError naming the line of a tag that is not a finite number."""
    nodes = root.find_all("node")
    tags = [_tags(n) for n in nodes]
    if not nodes or not all("local_x" in t and "local_y" in t for t in tags):
        return None
    projector = ll2.projection.LocalCartesianProjector(ll2.io.Origin(0.0, 0.0))
    parts = []
    for node, t in zip(nodes, tags, strict=True):
        try:
            x, y = float(t["local_x"]), float(t["local_y"])
        except ValueError:
            x = math.nan
        if not (math.isfinite(x) and math.isfinite(y) and max(abs(x), abs(y)) <= 1e6):
            raise ValueError(f"{file}, line {node.line}: node {node.attrib.get('id')}: local_x / local_y must be "
                             "finite numbers within 1000 km [m]")
        gps = projector.reverse(ll2.core.BasicPoint3d(x, y, 0.0))
        kept = "".join(_xml(c) for c in node.children if c.attrib.get("k") != "ele")
        parts.append(f'<node id="{node.attrib["id"]}" lat="{gps.lat!r}" lon="{gps.lon!r}"><tag k="ele" '
                     f'v="{gps.alt!r}"/>{kept}</node>')
    parts += [_xml(c) for c in root.children if c.tag != "node"]
    return '<?xml version="1.0" encoding="UTF-8"?><osm version="0.6">' + "".join(parts) + "</osm>"


def _load_map(file: FsPath, root: Element, ll2: Any) -> Any:
    """The lanelet2 map of ``file`` (projected at its first node, or Autoware's local coordinates)."""
    import tempfile

    local = autoware_osm(file, root, ll2)
    with tempfile.TemporaryDirectory() as folder:
        if local is not None:
            source = FsPath(folder) / "local.osm"
            source.write_text(local, encoding="utf-8")
            origin = (0.0, 0.0)
        else:
            source, origin = file, _origin(file, root)
        projector = ll2.projection.LocalCartesianProjector(ll2.io.Origin(*origin))
        try:
            lmap, errors = ll2.io.loadRobust(str(source), projector)
        except Exception as exc:  # lanelet2's C++ layer raises its own kinds on bad content
            raise ValueError(f"{file}: lanelet2 cannot read the map ({type(exc).__name__}: {exc})") from None
    return lmap, errors


def _xy(line: Any) -> np.ndarray:
    return np.array([[p.x, p.y] for p in line], dtype=float)


def load(file: FsPath, read: Any) -> Any:
    """The track format registry's entry: a Lanelet2 map as a ``tracks.Path`` (``read``: a
    ``tracks.formats.TrackRead``; lane and road width do not apply)."""
    from vtrack_gym.tracks.csv_loader import read_track_bytes

    if read.lane is not None or read.road_width_m is not None:
        raise ValueError(f"{file}: lane and road_width_m do not apply to a Lanelet2 map (its lanelets have bounds)")
    data = read_track_bytes(file)
    root = read_xml(file, data, "Lanelet2 OSM")
    _origin(file, root)   # checks the document before lanelet2's reader sees it
    ll2 = _lanelet2()
    lmap, errors = _load_map(file, root, ll2)
    layer = lmap.laneletLayer
    ids = sorted(str(ll.id) for ll in layer)
    if not ids:
        raise ValueError(f"{file}: no lanelet in the map" + (f" ({'; '.join(errors[:3])})" if errors else ""))
    if not read.route and len(ids) > 1:
        raise no_route_error(file, ids, "by the shortest route of the routing graph")
    route = read.route or (ids[0],)
    for rid in route:
        if not rid.lstrip("-").isdigit() or int(rid) not in layer:
            raise ValueError(f"{file}: route: no lanelet with id {rid!r:.30} in the map (lanelets: "
                             f"{', '.join(ids[:12])}{', ...' if len(ids) > 12 else ''})")
    rules = ll2.traffic_rules.create(ll2.traffic_rules.Locations.Germany, ll2.traffic_rules.Participants.Vehicle)
    graph = ll2.routing.RoutingGraph(lmap, rules)

    def between(a: str, b: str) -> list[str] | None:
        first, last = layer[int(a)], layer[int(b)]
        if any(f.id == last.id for f in graph.following(first)):
            return [a, b]
        found = graph.getRoute(first, last)
        return None if found is None else [str(ll.id) for ll in found.shortestPath()]

    parts = []
    for rid in expand_route(file, route, between):
        left, right = _xy(layer[int(rid)].leftBound), _xy(layer[int(rid)].rightBound)
        parts.append((rid, centre_of_bounds(left, right), left, right))
    return map_path(file, data, lanelet_line(parts), closed=read.closed, smoothing_m=read.smoothing_m,
                    allow_self_crossing=read.allow_self_crossing)
