"""The lap-time bound of a car on many circuits, centre line against racing line (the table of docs/racing-line.md).

    python benchmarks/lap_bounds.py                          # the package's circuits
    python benchmarks/lap_bounds.py 'racetrack-database/tracks/*.csv' --vehicle hatchback

Per circuit: its length, the quasi-steady-state lap-time bound along the centre line and along the minimum-curvature
racing line (``vtrack_gym.tracks.lap_time_bound``), the racing line's gain, the time to solve the racing line, its
linearisations and its least clearance between body side and edge. A Markdown table on stdout.
"""

from __future__ import annotations

import argparse
import glob
import sys
import time
from pathlib import Path

import vtrack_gym.tracks as vt

PACKAGE_CIRCUITS = ("handling_course", str(Path(vt.__file__).parent / "example_maps" / "ring.gpx"))


def bound_row(track: str, vehicle: str | None, limits: vt.GGLimits) -> dict[str, str]:
    """One table row: the circuit's centre-line and racing-line bounds and the racing line's solve figures."""
    path = vt.load_track(track, allow_self_crossing=True) if track.endswith(".csv") else vt.load_track(track)
    centre = vt.lap_time_bound(path, vehicle, "centreline", limits=limits)
    start = time.perf_counter()
    line = vt.solve_racing_line(path, vehicle)
    solve_s = time.perf_counter() - start
    race = vt.lap_time_bound(line.path, vehicle, "centreline", limits=limits)
    gain = 100.0 * (1.0 - race.lap_time_s / centre.lap_time_s)
    return {"circuit": Path(track).stem if track.endswith((".csv", ".gpx")) else track,
            "length_m": f"{path.length_m:.0f}", "centreline_s": f"{centre.lap_time_s:.2f}",
            "raceline_s": f"{race.lap_time_s:.2f}", "gain_%": f"{gain:.2f}", "solve_s": f"{solve_s:.1f}",
            "linearisations": str(line.iterations), "min_edge_margin_m": f"{line.min_edge_margin_m:.3f}"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tracks", nargs="?", default=None, help="a glob of track files (default: the package's)")
    parser.add_argument("--vehicle", default=None, help="a shipped car or a vehicle file (default: hatchback)")
    args = parser.parse_args(argv)
    tracks = sorted(glob.glob(args.tracks)) if args.tracks else list(PACKAGE_CIRCUITS)
    limits = vt.gg_limits(args.vehicle)
    rows = []
    for track in tracks:
        rows.append(bound_row(track, args.vehicle, limits))
        print(" | ".join(rows[-1].values()), file=sys.stderr)
    print("| " + " | ".join(rows[0]) + " |")
    print("|" + "---|" * len(rows[0]))
    for row in rows:
        print("| " + " | ".join(row.values()) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
