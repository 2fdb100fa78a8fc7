"""The fast test tier's cost with an empty and with a warm kernel cache: wall and CPU time, load average.

    python benchmarks/bench_fast_tier.py            # cold (an empty NUMBA_CACHE_DIR), then warm (the same one)
    python benchmarks/bench_fast_tier.py --warm-only --cache-dir ~/.cache/numba

Runs ``python -m pytest -m "not slow" -n 2 -p no:randomly`` from the repository root, each time in a fresh process
tree, and prints per run: wall time [s], CPU time [s] (user + system of pytest and every process it waited for:
the xdist workers and the interpreters the tests start), the 1-minute load average before and after, and the
pytest summary line. The cold run compiles every kernel the tests reach (twice: each xdist worker compiles its
own until the other has written the cache); the warm run loads them. CPU time is the figure to compare on a
shared machine: wall time grows with the load, CPU time hardly at all.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIER = [sys.executable, "-m", "pytest", "-q", "-m", "not slow", "-n", "2", "-p", "no:randomly"]


@dataclass(frozen=True)
class TierRun:
    """One run of the fast tier: ``wall_s`` and ``cpu_s`` [s], the 1-minute load before and after, its summary."""

    label: str
    wall_s: float
    cpu_s: float
    load_before: float
    load_after: float
    summary: str


def _children_cpu_s() -> float:
    """User + system CPU time of every waited-for descendant so far [s]."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_tier(label: str, cache_dir: Path, timeout_s: float) -> TierRun:
    """The fast tier once with ``NUMBA_CACHE_DIR=cache_dir``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache_dir), "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    load_before, cpu_before, start = os.getloadavg()[0], _children_cpu_s(), time.monotonic()
    done = subprocess.run(TIER, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout_s)
    wall, cpu = time.monotonic() - start, _children_cpu_s() - cpu_before
    lines = done.stdout.strip().splitlines()
    return TierRun(label, wall, cpu, load_before, os.getloadavg()[0], lines[-1] if lines else done.stderr[-300:])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache-dir", type=Path, default=None,
                        help="the kernel cache to use (default: a new empty directory, so the first run is cold)")
    parser.add_argument("--warm-only", action="store_true", help="one run, on the cache as it is")
    parser.add_argument("--timeout", type=float, default=3600.0, help="per run [s]")
    args = parser.parse_args(argv)
    cache = args.cache_dir or Path(tempfile.mkdtemp(prefix="vtrack_fast_tier_cache_"))
    labels = ["warm"] if args.warm_only else ["cold", "warm"]
    print(f"fast tier: {' '.join(TIER[1:])}  (NUMBA_CACHE_DIR={cache}, {os.cpu_count()} cores)")
    for label in labels:
        r = run_tier(label, cache, args.timeout)
        print(f"{r.label:5s} wall {r.wall_s:7.1f} s  CPU {r.cpu_s:7.1f} s  load {r.load_before:.2f} -> "
              f"{r.load_after:.2f}  | {r.summary}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
