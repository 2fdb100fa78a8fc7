"""Import time of an OpenDRIVE town map: a route of 100 m roads (lines, clothoids, arcs and a paramPoly3 every
fifth road; two lanes with width polynomials and a lane offset), read, routed and fitted into a checked Path.
It prints the process's CPU time (what the import costs) and the wall time (the same on an idle machine; more
where other work shares the cores).

    python benchmarks/bench_map_import.py            # a 10 km route, best of 3
    python benchmarks/bench_map_import.py 50000      # a 50 km route
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import map_files

from vtrack_gym.tracks.opendrive_geometry import Geometry

ROAD_M = 100.0
_LANES = ('<laneOffset s="0" a="0.1" b="0" c="0" d="0"/><laneSection s="0"><left><lane id="2" type="driving">'
          '<width sOffset="0" a="3.25" b="0.005" c="0" d="0"/></lane><lane id="1" type="driving"><width sOffset="0" '
          'a="3.5" b="0" c="0" d="0"/></lane></left><center><lane id="0" type="none"/></center><right><lane id="-1" '
          'type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane><lane id="-2" type="driving"><width '
          'sOffset="0" a="3.25" b="0.005" c="0" d="0"/></lane><lane id="-3" type="sidewalk"><width sOffset="0" '
          'a="2" b="0" c="0" d="0"/></lane></right></laneSection>')


def _pieces(k: int) -> list[tuple[str, float, tuple]]:
    """The records of road ``k`` (100 m): a snake of alternating bends, a gentle paramPoly3 every fifth road."""
    if k % 5 == 4:
        return [("paramPoly3", ROAD_M, (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1e-3, -6.6e-6, ROAD_M))]
    kappa = (1 / 50) * (1 if k % 2 else -1)
    return [("line", 40.0, ()), ("spiral", 15.0, (0.0, kappa)), ("arc", 15.0, (kappa,)),
            ("spiral", 15.0, (kappa, 0.0)), ("line", 15.0, ())]


def town_map(file: Path, length_m: float = 10_000.0) -> tuple[Path, str, float]:
    """Write a route of ``length_m`` / 100 roads to ``file``; returns it, the route (road ids in order) and its
    length [m] (the sum of the records' lengths)."""
    from vtrack_gym.tracks.opendrive_geometry import cubic_arc_length

    roads, start, total = [], (0.0, 0.0, 0.0), 0.0
    for k in range(round(length_m / ROAD_M)):
        pieces = _pieces(k)
        if pieces[0][0] == "paramPoly3":   # a record's length is its arc length
            g = Geometry(0.0, 0.0, 0.0, 0.0, ROAD_M, "paramPoly3", pieces[0][2])
            pieces = [("paramPoly3", cubic_arc_length(g), pieces[0][2])]
        records = map_files._chain(start, pieces)
        roads.append(map_files.road_xml(str(k + 1), records, _LANES))
        total += sum(r.length for r in records)
        last = records[-1]
        ex, ey, eh, _ = last.evaluate([last.length])
        start = (float(ex[0]), float(ey[0]), float(eh[0]))
    file.write_text(map_files.xodr_text(roads), encoding="utf-8")
    return file, ",".join(str(k + 1) for k in range(len(roads))), total


def main(length_m: float) -> None:
    from vtrack_gym.tracks import load_track

    with tempfile.TemporaryDirectory() as folder:
        file, route, _ = town_map(Path(folder) / "town.xodr", length_m)
        wall, cpu = [], []
        for _ in range(3):
            start, start_cpu = time.perf_counter(), time.process_time()
            path = load_track(file, route=route)
            wall.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
        import resource

        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024   # KiB on Linux
        print(f"{file.stat().st_size / 2**20:.1f} MiB, {len(route.split(','))} roads, route {path.length_m:.0f} m: "
              f"imported in {min(cpu):.2f} s of CPU time, {min(wall):.2f} s wall time (best of 3); peak RSS of "
              f"the process {peak:.0f} MiB")


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 10_000.0)
