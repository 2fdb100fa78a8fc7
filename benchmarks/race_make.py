"""``gym.make`` of the race ids with the racing line and its lap-time bound solved (cache cleared before each make)
and found in the process's cache (``tracks.race_bound_cache``), wall and CPU time, the machine's load average.

    python benchmarks/race_make.py [--repeats 3]

The first make of the process is left out of both columns (imports, compiled kernels). Ratio: solved / cached.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import gymnasium as gym

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.tracks.race_bound_cache import bound_cache

IDS = ("vtrack/Race-v0", "vtrack/RaceRing-v0")


def timed_make(env_id: str) -> tuple[float, float]:
    """(wall, CPU) seconds of one ``gym.make(env_id)``."""
    wall, cpu = time.perf_counter(), time.process_time()
    gym.make(env_id).close()
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    print("| id | solved wall [s] | solved CPU [s] | cached wall [s] | cached CPU [s] | ratio (wall) |")
    print("|---|---|---|---|---|---|")
    for env_id in IDS:
        timed_make(env_id)   # warm-up: imports and compiled kernels
        solved, cached = [], []
        for _ in range(args.repeats):
            bound_cache().clear()
            solved.append(timed_make(env_id))
            cached.append(timed_make(env_id))
        s_wall, s_cpu = (statistics.median(x) for x in zip(*solved, strict=True))
        c_wall, c_cpu = (statistics.median(x) for x in zip(*cached, strict=True))
        print(f"| {env_id} | {s_wall:.3f} | {s_cpu:.3f} | {c_wall:.3f} | {c_cpu:.3f} | {s_wall / c_wall:.1f} |",
              flush=True)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
