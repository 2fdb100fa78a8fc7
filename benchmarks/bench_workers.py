"""Speed-up of ``vtrack benchmark --tracks DIR --workers 2`` over ``--workers 1`` on the same tracks, and whether the
rows are identical.

    PYTHONPATH=. python benchmarks/bench_workers.py [--rounds 3] [--policies lqr,stanley,pure_pursuit] [--workers 2]

Writes the four circuits of ``own_tracks.py`` to a temporary folder, then alternates the two commands (each a fresh
``vtrack`` process, as a user runs it, numba cache warm) for ``--rounds`` rounds, so that a change in the machine's
load hits both alike. Prints each run's wall time, the median ratio, the load average before and after (the
machine may be shared), and whether every run's JSON board equals the first one's apart from the measured wall time
per step.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from own_tracks import circuits, write_circuit_csv

MEASURED_SUFFIXES = ("wall_time_per_step_us", "wall_time_per_step_us_lo", "wall_time_per_step_us_hi")


def board_without_clock(text: str) -> list[dict[str, object]]:
    """The JSON board of one run without the fields measured from the clock."""
    return [{k: v for k, v in entry.items() if k not in MEASURED_SUFFIXES} for entry in json.loads(text)]


def run_once(tracks: Path, policies: str, workers: int, store: Path) -> tuple[float, list[dict[str, object]]]:
    """Wall time [s] of one ``vtrack benchmark --tracks`` process and its board."""
    cmd = [sys.executable, "-m", "vtrack_gym.cli", "benchmark", "--tracks", str(tracks), "--policies", policies,
           "--workers", str(workers), "--no-figures", "--format", "json", "--store", str(store)]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return elapsed, board_without_clock(proc.stdout)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds (default: 3)")
    parser.add_argument("--policies", default="lqr,stanley,pure_pursuit", help="policies to score")
    parser.add_argument("--workers", type=int, default=2, help="the parallel run's --workers (default: 2)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="vtrack_bench_workers_") as tmp:
        tracks = Path(tmp) / "tracks"
        tracks.mkdir()
        for name, segments in circuits().items():
            write_circuit_csv(tracks / f"{name}.csv", segments)
        load_before = os.getloadavg()
        run_once(tracks, args.policies, 1, Path(tmp) / "warm.sqlite")  # compile/load the kernels once
        times: dict[int, list[float]] = {1: [], args.workers: []}
        boards = []
        for k in range(args.rounds):
            for workers in (1, args.workers) if k % 2 == 0 else (args.workers, 1):
                elapsed, board = run_once(tracks, args.policies, workers, Path(tmp) / f"r{k}w{workers}.sqlite")
                times[workers].append(elapsed)
                boards.append(board)
                print(f"round {k + 1}: --workers {workers}: {elapsed:.1f} s")
        load_after = os.getloadavg()
    ratio = statistics.median(times[1]) / statistics.median(times[args.workers])
    identical = all(b == boards[0] for b in boards[1:])
    print(f"{len(circuits())} tracks x {len(args.policies.split(','))} policies; cores: {os.cpu_count()}")
    print(f"median --workers 1: {statistics.median(times[1]):.1f} s, --workers {args.workers}: "
          f"{statistics.median(times[args.workers]):.1f} s, speed-up {ratio:.2f}x")
    print(f"rows identical across all runs: {identical}")
    print("load average (1, 5, 15 min) before: {:.2f} {:.2f} {:.2f}, after: {:.2f} {:.2f} {:.2f}"
          .format(*load_before, *load_after))
    return 0 if identical else 1


if __name__ == "__main__":
    raise SystemExit(main())
