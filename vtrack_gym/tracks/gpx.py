"""A GPX recording (``.gpx``: the ``<trkpt>`` points of every track segment in order, else a route's ``<rtept>``)
as a track of a given road width.

Latitude and longitude are projected onto the local tangent plane at the first point (east x, north y [m]; WGS84
ellipsoid, heights ignored): exact at the first point, within about 1 cm of the ellipsoid's distances 10 km away.
A recording is noisy: unless ``smoothing_m`` is given, the fit may deviate from the points by
``NOISE_HINT_FACTOR`` x their noise estimated from third differences (``tracks.track_noise.point_noise_m``). The
drivable half width is ``road_width_m`` / 2 on both sides (default ``DEFAULT_ROAD_WIDTH_M``).
"""

from __future__ import annotations

import math
from pathlib import Path as FsPath
from typing import Any

import numpy as np

from vtrack_gym.tracks.map_path import MapLine, map_path
from vtrack_gym.tracks.xml_reader import Element, number, read_xml

DEFAULT_ROAD_WIDTH_M = 7.0
"""Road width [m] of a GPX track when none is given (two 3.5 m lanes)."""
A_WGS84 = 6378137.0
F_WGS84 = 1.0 / 298.257223563


def sniff(head: bytes) -> bool:
    """Whether a file's first bytes look like GPX."""
    return b"<gpx" in head


def local_xy(lat_deg: np.ndarray, lon_deg: np.ndarray, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """East, north [m] of points (latitude, longitude [deg]) in the tangent plane of the WGS84 ellipsoid at
    (``lat0``, ``lon0``) [deg]."""
    e2 = F_WGS84 * (2.0 - F_WGS84)

    def ecef(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
        n = A_WGS84 / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
        return np.stack([n * np.cos(lat) * np.cos(lon), n * np.cos(lat) * np.sin(lon),
                         n * (1.0 - e2) * np.sin(lat)], -1)

    la0, lo0 = math.radians(lat0), math.radians(lon0)
    d = ecef(np.radians(lat_deg), np.radians(lon_deg)) - ecef(np.array(la0), np.array(lo0))
    east = np.array([-math.sin(lo0), math.cos(lo0), 0.0])
    north = np.array([-math.sin(la0) * math.cos(lo0), -math.sin(la0) * math.sin(lo0), math.cos(la0)])
    return d @ east, d @ north


def _points(file: FsPath, root: Element) -> list[Element]:
    """The track points (``trkpt``) in document order, else the route points (``rtept``)."""
    if root.tag != "gpx":
        raise ValueError(f"{file}, line {root.line}: the root element is <{root.tag}>; expected <gpx>")
    points = list(root.iter("trkpt")) or list(root.iter("rtept"))
    if len(points) < 4:
        raise ValueError(f"{file}: {len(points)} track points (<trkpt>, or <rtept> of a route); a track needs >= 4")
    return points


def gpx_line(file: FsPath, root: Element, road_width_m: float) -> MapLine:
    """The projected points of a GPX document with half widths ``road_width_m`` / 2."""
    points = _points(file, root)
    lat = np.array([number(p, "lat", file) for p in points])
    lon = np.array([number(p, "lon", file) for p in points])
    bad = np.flatnonzero((np.abs(lat) > 90.0) | (np.abs(lon) > 180.0))
    if bad.size:
        p = points[int(bad[0])]
        raise ValueError(f"{file}, line {p.line}: lat={lat[bad[0]]:g}, lon={lon[bad[0]]:g}; expected latitude in "
                         "[-90, 90] and longitude in [-180, 180] degrees")
    x, y = local_xy(lat, lon, float(lat[0]), float(lon[0]))
    step = np.hypot(np.diff(x), np.diff(y))
    keep = np.concatenate(([True], step > 0.01))   # a logger standing still repeats its position
    lines = [p.line for p, k in zip(points, keep, strict=True) if k]
    x, y = x[keep], y[keep]

    def where(k: int) -> str:
        return f"line {lines[min(k, len(lines) - 1)]}"

    widths = np.full((x.size, 2), 0.5 * road_width_m)
    return MapLine(x, y, widths, where)


def load(file: FsPath, read: Any) -> Any:
    """The track format registry's entry: a GPX file as a ``tracks.Path`` (``read``: a ``tracks.formats.TrackRead``;
    route and lane do not apply)."""
    from vtrack_gym.tracks.csv_loader import read_track_bytes
    if read.route or read.lane is not None:
        raise ValueError(f"{file}: route and lane apply to road maps; a GPX track is one recorded line")
    data = read_track_bytes(file)
    width = DEFAULT_ROAD_WIDTH_M if read.road_width_m is None else read.road_width_m
    line = gpx_line(file, read_xml(file, data, "GPX"), width)
    return map_path(file, data, line, closed=read.closed, smoothing_m=read.smoothing_m,
                    allow_self_crossing=read.allow_self_crossing)
