"""The ISO 3888 planned lines per shipped car: entry-speed bounds, peak curvatures and exact clearances, both versions.

    python benchmarks/maneuver_bounds.py            # every shipped car, both ISO 3888 tests (a few minutes)
    python benchmarks/maneuver_bounds.py --car suv  # one car

For each car and test it prints, as markdown tables:

- the physical entry-speed bound [km/h] (``tracks.feasibility.entry_speed_bound_kmh``): version 1, the 1 cm
  least-curvature line of ``tracks.planned_line`` with its curvature read through the path's interpolation;
  version 2, the least-curvature line of ``tracks.exact_line`` (0 cm, judged exactly) with the spline's exact
  curvature;
- each line's exact peak curvature over the version-2 least-curvature line's, and the body's least exact clearance
  to the cone lines (``tracks.gate_judge``, a perfect follower): the -v1 ids' 10 cm line, the 1 cm line, the -v2
  ids' 2 cm line and the 0 cm line.
"""

from __future__ import annotations

import argparse

import numpy as np

from vtrack_gym.tracks.feasibility import body_of, entry_speed_bound_kmh, planned_maneuver
from vtrack_gym.tracks.gate_judge import path_gate_clearance_m
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle

TESTS = (("iso3888_1", "hold_throttle", "ISO 3888-1"), ("iso3888_2", "coast", "ISO 3888-2"))
LINES = (("-v1 line (10 cm)", 0.1, 1), ("v1 bound line (1 cm)", 0.01, 1), ("-v2 line (2 cm)", 0.02, 2),
         ("v2 bound line (0 cm)", 0.0, 2))


def _peak(maneuver) -> float:
    """Exact peak curvature [1/m]: the spline's (version 2) or the table's rows (version 1: exact at its rows)."""
    if maneuver.line is not None:
        return maneuver.line.peak_curvature_per_m
    return float(np.max(np.abs(maneuver.path.table[:, 3])))


def _clearance(maneuver, vehicle) -> float:
    b = body_of(vehicle)
    row = np.array([b.cg_to_front_m, b.cg_to_front_m - b.length_m, 0.5 * b.width_m])
    return float(np.min(path_gate_clearance_m(maneuver.path, row, tol=1e-4, step_m=0.01)))


def main(argv: list[str] | None = None) -> None:
    """Print the bound table and the line table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--car", action="append", help="a shipped car (default: all)")
    cars = parser.parse_args(argv).car or list_vehicles()
    bounds = ["| car | test | bound -v1 [km/h] | bound -v2 [km/h] |", "|---|---|---|---|"]
    lines = ["| car | test | line | peak kappa [1/m] | / least (v2, 0 cm) | exact clearance [cm] |",
             "|---|---|---|---|---|---|"]
    for car in cars:
        vehicle = load_vehicle(car)
        for name, after, label in TESTS:
            old = entry_speed_bound_kmh(vehicle, name, after)
            new = entry_speed_bound_kmh(vehicle, name, after, planner_version=2)
            bounds.append(f"| {car} | {label} | {old:.1f} | {new:.1f} |")
            least = _peak(planned_maneuver(name, vehicle, 0.0, 2))
            for title, margin, version in LINES:
                m = planned_maneuver(name, vehicle, margin, version)
                lines.append(f"| {car} | {label} | {title} | {_peak(m):.5f} | {_peak(m) / least:.3f} | "
                             f"{100.0 * _clearance(m, vehicle):.2f} |")
            print(bounds[-1], flush=True)
    print("\n".join(bounds))
    print()
    print("\n".join(lines))


if __name__ == "__main__":
    main()
