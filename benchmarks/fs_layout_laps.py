"""Every shipped car on every shipped Formula Student layout: is it drivable (full-lock radius against the racing
line's tightest bend, body against the narrowest width), its lap-time bound, and what a race baseline drives in
``vtrack/Race-v0`` (standing start, the wheels track-limit rule, the cones judged).

    python benchmarks/fs_layout_laps.py [--laps 2] [--policies raceline,centreline]

Prints two Markdown tables (feasibility, closed-loop laps). Takes a few minutes (one episode per car, layout and
policy).
"""

from __future__ import annotations

import argparse
import math


def feasibility_rows() -> list[str]:
    from vtrack_gym.tracks.fs_layouts import FS_LAYOUTS, fs_layout
    from vtrack_gym.tracks.layout_feasibility import feasibility_table
    from vtrack_gym.vehicle.catalog import list_vehicles

    rows = ["| layout | car | full-lock radius [m] | line's tightest radius [m] | body / track width [m] | drivable "
            "| lap-time bound [s] |", "|---|---|---|---|---|---|---|"]
    cars = list(list_vehicles())
    for layout, f in zip([n for n in FS_LAYOUTS for _ in cars],
                         feasibility_table([fs_layout(n) for n in FS_LAYOUTS], cars), strict=True):
        rows.append(f"| {layout} | {f.vehicle} | {f.min_turning_radius_m:.2f} | {f.line_min_radius_m:.2f} | "
                    f"{f.body_width_m:.2f} / {f.min_track_width_m:.2f} | {'yes' if f.drivable else 'no'} | "
                    f"{f.lap_time_bound_s:.2f} |")
    return rows


def lap_rows(laps: int, policies: list[str]) -> list[str]:
    import gymnasium as gym

    import vtrack_gym
    from vtrack_gym.tracks.fs_layouts import FS_LAYOUTS
    from vtrack_gym.vehicle.catalog import list_vehicles

    rows = ["| layout | car | policy | end | laps | best lap [s] | bound [s] | track-limit breaches | cones hit |",
            "|---|---|---|---|---|---|---|---|---|"]
    for layout in FS_LAYOUTS:
        for car in list_vehicles():
            for policy in policies:
                env = gym.make("vtrack/Race-v0", track=layout, vehicle=car, laps=laps)
                try:
                    row = vtrack_gym.evaluate(lambda e, p=policy: vtrack_gym.make_policy(p, e), env)[0]
                finally:
                    env.close()
                m = row.metrics
                best = m.get("best_lap_s", math.nan)
                rows.append(f"| {layout} | {car} | {policy} | {row.termination} | {int(m['laps_completed'])} | "
                            f"{best:.2f} | {m['lap_time_bound_s']:.2f} | {int(m['track_limit_violations'])} | "
                            f"{int(m['cones_hit'])} |")
                print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--policies", default="raceline,centreline")
    parser.add_argument("--skip-feasibility", action="store_true")
    args = parser.parse_args()
    if not args.skip_feasibility:
        print("\n".join(feasibility_rows()), flush=True)
        print()
    print("\n".join(lap_rows(args.laps, args.policies.split(","))))


if __name__ == "__main__":
    main()
