"""Speed-up of ``vtrack benchmark --tracks DIR --workers 2`` over ``--workers 1`` on the same tracks, and whether the
rows are identical.

    PYTHONPATH=. python benchmarks/bench_workers.py [--rounds 3] [--circuits 8] [--policies smc,mpc,...]
                                                    [--workers 2]

The default workload is the use case of scoring the baselines on a folder of circuits: 8 circuits (the four of
``own_tracks.py`` and four seeded kart-like ones of ``random_circuits.py``) x the six default baselines of
``own_tracks.py`` = 48 episodes. ``--circuits 4 --policies lqr,stanley,pure_pursuit`` is the former, small
workload (12 episodes). The circuits are written to a temporary folder, then the two commands (each a fresh
``vtrack`` process, as a user runs it, numba cache warm) alternate for ``--rounds`` rounds, so that a change in the
machine's load hits both alike.

Prints per run: the wall time, the CPU time of the run (the process and its workers), the load average; for the
parallel runs also the parent's CPU time and each worker's episode CPU time (``vtrack -v``'s usage line), from which
an idle-machine estimate of the parallel run's wall time follows: the parent's CPU time (its imports, warm-up and
board, which run alone) plus the busiest worker's episode CPU time. Then the median ratios, the load average
before and after, and whether every run's JSON board equals the first one's apart from the clock-measured columns
(``evaluation.leaderboard.board.clock_measured_columns``).

To measure another checkout (e.g. before a change), run from a folder outside both checkouts with ``PYTHONPATH``
naming it: ``python -m vtrack_gym.cli`` puts the working directory first on the module path.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from random_circuits import random_circuit

from own_tracks import POLICIES, circuits, write_circuit_csv

CIRCUIT_SEED = 2024
"""Seed of the random circuits added to the four of ``own_tracks.py``."""
USAGE = re.compile(r"episodes in worker processes: \d+ on \d+; warm-up CPU ([\d.]+) s; episode CPU per worker "
                   r"\[([\d., ]*)\] s")
"""The usage line ``vtrack_gym.evaluation.rollouts.parallel`` logs at debug level (``vtrack -v``)."""


@dataclass(frozen=True)
class Run:
    """One ``vtrack benchmark`` process: wall and CPU time [s], the worker usage (parallel runs), the board."""

    workers: int
    wall_s: float
    cpu_s: float
    worker_cpu_s: tuple[float, ...]
    board: list[dict[str, object]]

    def idle_wall_s(self) -> float:
        """Wall time [s] on an idle machine with a core per worker: the CPU time outside the workers' episodes
        (the parent, alone) plus the busiest worker's; the CPU time itself for a run in one process."""
        if not self.worker_cpu_s:
            return self.cpu_s
        return self.cpu_s - sum(self.worker_cpu_s) + max(self.worker_cpu_s)


def clock_columns() -> frozenset[str]:
    """The board's clock-measured columns, as the package declares them (an older package, measured for a
    comparison, declares only ``metrics.CLOCK_MEASURED``: its board columns are derived the same way)."""
    try:
        from vtrack_gym.evaluation.leaderboard.board import clock_measured_columns
    except ImportError:
        from vtrack_gym.evaluation.scoring.metrics import CLOCK_MEASURED

        bounds = ("", "_lo", "_hi")
        return frozenset({"wall_time_per_step_us", *(f"{m}{b}" for m in CLOCK_MEASURED for b in bounds)})
    return clock_measured_columns()


def write_circuits(folder: Path, count: int) -> None:
    """The four circuits of ``own_tracks.py``, then ``count - 4`` seeded random ones, as CSV files."""
    own = list(circuits().items())
    for name, segments in own[:count]:
        write_circuit_csv(folder / f"{name}.csv", segments)
    rng = np.random.default_rng(CIRCUIT_SEED)
    for k in range(count - len(own)):
        write_circuit_csv(folder / f"random{k + 1}.csv", random_circuit(rng))


def run_once(tracks: Path, policies: str, workers: int, store: Path) -> Run:
    """One ``vtrack -v benchmark --tracks`` process, timed."""
    cmd = [sys.executable, "-m", "vtrack_gym.cli", "-v", "benchmark", "--tracks", str(tracks), "--policies",
           policies, "--workers", str(workers), "--no-figures", "--format", "json", "--store", str(store)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    usage = USAGE.search(proc.stderr)
    worker_cpu = tuple(float(c) for c in usage.group(2).split(",")) if usage and workers > 1 else ()
    clock = clock_columns()
    board = [{k: v for k, v in entry.items() if k not in clock} for entry in json.loads(proc.stdout)]
    return Run(workers, elapsed, cpu, worker_cpu, board)


def describe(run: Run) -> str:
    text = f"--workers {run.workers}: wall {run.wall_s:5.1f} s, CPU {run.cpu_s:5.1f} s"
    if run.worker_cpu_s:
        parent = run.cpu_s - sum(run.worker_cpu_s)
        text += (f" (parent {parent:.1f} s, workers' episodes {', '.join(f'{c:.1f}' for c in run.worker_cpu_s)} "
                 f"s; idle estimate {run.idle_wall_s():.1f} s)")
    return text + " | load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def summarise(runs: list[Run], workers: int, n_tracks: int, n_policies: int) -> bool:
    """Print the medians and ratios; whether every board equals the first."""
    one = [r for r in runs if r.workers == 1]
    many = [r for r in runs if r.workers == workers]
    med = {k: statistics.median(v) for k, v in (("w1", [r.wall_s for r in one]), ("wn", [r.wall_s for r in many]),
                                                  ("i1", [r.idle_wall_s() for r in one]),
                                                  ("in", [r.idle_wall_s() for r in many]))}
    print(f"{n_tracks} tracks x {n_policies} policies = {n_tracks * n_policies} episodes; cores: {os.cpu_count()}")
    print(f"median wall --workers 1: {med['w1']:.1f} s, --workers {workers}: {med['wn']:.1f} s, "
          f"speed-up {med['w1'] / med['wn']:.2f}x")
    if all(r.worker_cpu_s for r in many):
        print(f"idle-machine estimate from CPU times: --workers 1 {med['i1']:.1f} s, --workers {workers} "
              f"{med['in']:.1f} s, speed-up {med['i1'] / med['in']:.2f}x")
    identical = all(r.board == runs[0].board for r in runs[1:])
    print(f"rows identical across all runs (apart from the clock-measured columns): {identical}")
    return identical


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds (default: 3)")
    parser.add_argument("--circuits", type=int, default=8, help="circuits: the 4 of own_tracks.py, then seeded "
                        "random ones (default: 8)")
    parser.add_argument("--policies", default=",".join(POLICIES), help="policies to score (default: %(default)s)")
    parser.add_argument("--workers", type=int, default=2, help="the parallel run's --workers (default: 2)")
    args = parser.parse_args(argv)
    if args.circuits < 1 or args.rounds < 1 or args.workers < 2:
        parser.error("--circuits and --rounds must be >= 1, --workers >= 2")
    runs: list[Run] = []
    with tempfile.TemporaryDirectory(prefix="vtrack_bench_workers_") as tmp:
        tracks = Path(tmp) / "tracks"
        tracks.mkdir()
        write_circuits(tracks, args.circuits)
        load_before = os.getloadavg()
        run_once(tracks, args.policies, 1, Path(tmp) / "warm.sqlite")  # compile/load the kernels once
        for k in range(args.rounds):
            for workers in (1, args.workers) if k % 2 == 0 else (args.workers, 1):
                runs.append(run_once(tracks, args.policies, workers, Path(tmp) / f"r{k}w{workers}.sqlite"))
                print(f"round {k + 1}: {describe(runs[-1])}", flush=True)
        load_after = os.getloadavg()
    identical = summarise(runs, args.workers, args.circuits, len(args.policies.split(",")))
    print("load average (1, 5, 15 min) before: {:.2f} {:.2f} {:.2f}, after: {:.2f} {:.2f} {:.2f}"
          .format(*load_before, *load_after))
    return 0 if identical else 1


if __name__ == "__main__":
    raise SystemExit(main())
