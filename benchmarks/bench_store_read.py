"""CPU and wall time of reading a large leaderboard store: ``ResultStore.rows()`` and ``vtrack leaderboard``.

Writes a store of N rows shaped like a benchmark's (about 30 metrics, a track's provenance in the options) in one
``add`` in a temporary folder, then times, each in a fresh process (imports excluded), the first ``rows()`` of a
read-only ``ResultStore`` (every row checked against its SHA-256 and the row rule, all against the row count and
digest) and ``vtrack leaderboard --suite bulk`` (the store read once, then the board aggregated: bootstrap
intervals per policy and env, not a store cost). ``--compare DIR`` times another checkout of the package
(e.g. a ``git worktree`` of an older commit) on the same store in the same run, the two alternating, so both
figures share the machine's load. Run: ``python benchmarks/bench_store_read.py [N] [--compare DIR]
[--repeats K]`` (default 100000 rows, 3 repeats; the best of the repeats is printed, and the load average).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
METRICS = {**{f"max_{k}": 0.25 for k in ("e_y_m", "e_phi_deg", "a_y_mps2", "hand_wheel_deg", "roll_deg",
                                         "yaw_rate_degps", "beta_deg", "jerk_mps3")},
           **{f"rms_{k}": 0.1 for k in ("e_y_m", "e_phi_deg", "a_y_mps2", "hand_wheel_deg", "roll_deg",
                                        "yaw_rate_degps", "beta_deg", "jerk_mps3")},
           "itae": 1.5, "duration_s": 12.0, "progress_m": 120.0, "remaining_m": 0.0, "cones_hit": 0,
           "steering_reversals_per_s": 0.4, "comfort_a_v_mps2": 0.3, "comfort_band": "not uncomfortable",
           "wall_time_per_step_s": 1e-4, "wall_time_s": 0.1, "termination": "completed"}
OPTIONS = {"vehicle": "paper", "track_file": "road.csv", "track_sha256": "ab" * 32, "speed_profile": "constant"}


def rows(n: int) -> list:
    """``n`` rows of 10 policies on 10 envs."""
    from vtrack_gym.evaluation.storage.store import ResultRow

    return [ResultRow("bulk", f"DLC{100 + i % 10}-v0", f"policy{i // 10 % 10}", f"{i // 10 % 10:012x}", i // 100,
                      {**METRICS, "max_e_y_m": 0.2 + 1e-6 * i}, "completed", 1e-4, options=dict(OPTIONS))
            for i in range(n)]


READ = textwrap.dedent("""
    import sys, time
    from vtrack_gym.evaluation.storage.store import ResultStore
    cpu, wall = time.process_time(), time.perf_counter()
    got = ResultStore(sys.argv[1], read_only=True).rows()
    print(time.process_time() - cpu, time.perf_counter() - wall, len(got))
""")
LEADERBOARD = textwrap.dedent("""
    import contextlib, io, sys, time
    from vtrack_gym.cli import main
    cpu, wall = time.process_time(), time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(["leaderboard", "--store", sys.argv[1], "--suite", "bulk", "--format", "csv"])
    assert code == 0, code
    print(time.process_time() - cpu, time.perf_counter() - wall, 0)
""")


def timed(code: str, store: Path, checkout: Path) -> tuple[float, float]:
    """(CPU [s], wall [s]) of ``code`` on ``store`` in a fresh process importing the package from ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    done = subprocess.run([sys.executable, "-c", code, str(store)], capture_output=True, text=True, env=env,
                          check=True, cwd=checkout)
    cpu, wall, _ = done.stdout.split()
    return float(cpu), float(wall)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", nargs="?", type=int, default=100_000, help="rows in the store (default 100000)")
    parser.add_argument("--compare", type=Path, default=None, help="another checkout of the package to time")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each measure (best shown; default 3)")
    args = parser.parse_args()
    from vtrack_gym.evaluation.storage.store import ResultStore

    checkouts = {"this checkout": ROOT, **({f"{args.compare}": args.compare.resolve()} if args.compare else {})}
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.sqlite"
        start = time.process_time()
        ResultStore(path).add(rows(args.n))
        print(f"add {args.n} rows (one batch): {time.process_time() - start:.2f} s CPU")
        best: dict[tuple[str, str], tuple[float, float]] = {}
        for _ in range(args.repeats):
            for measure, code in (("rows() first read", READ), ("vtrack leaderboard", LEADERBOARD)):
                for name, checkout in checkouts.items():
                    cpu, wall = timed(code, path, checkout)
                    old = best.get((measure, name), (float("inf"), float("inf")))
                    best[(measure, name)] = (min(old[0], cpu), min(old[1], wall))
        print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (2-core machine)")
        for (measure, name), (cpu, wall) in best.items():
            print(f"{measure:<20} {name:<40} {cpu:7.2f} s CPU {wall:7.2f} s wall")
        if args.compare:
            for measure in ("rows() first read", "vtrack leaderboard"):
                mine, other = best[(measure, "this checkout")], best[(measure, str(args.compare))]
                print(f"{measure:<20} this checkout / other: {mine[0] / other[0]:.2f} x CPU, "
                      f"{mine[1] / other[1]:.2f} x wall")


if __name__ == "__main__":
    main()
