"""Small example maps shipped with the package: the same stadium loop ("ring": two 100 m straights, two half
turns of radius 40 m entered through 20 m clothoids, two 3.5 m lanes) as OpenDRIVE (``ring.xodr``, roads 1-4),
GPX (``ring.gpx``), Lanelet2 (``ring.osm``, the right lane as lanelets 1001-1004) and CommonRoad (``ring.xml``,
lanelets 1001-1003 and a planning problem from 1001 to 1003). Written by ``benchmarks/map_files.py``.
"""

from __future__ import annotations

from pathlib import Path

EXAMPLE_MAPS: tuple[str, ...] = ("ring.xodr", "ring.gpx", "ring.osm", "ring.xml")
"""The shipped example map files."""


def example_map(name: str) -> Path:
    """The path of the shipped example map ``name`` (one of ``EXAMPLE_MAPS``); ValueError naming them otherwise."""
    if name not in EXAMPLE_MAPS:
        raise ValueError(f"unknown example map {name!r}; shipped: {', '.join(EXAMPLE_MAPS)}")
    return Path(__file__).resolve().parent / name
