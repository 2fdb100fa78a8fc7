"""One thread against two for the env step, on this (shared) machine: CPU time and wall time per car-step.

Each configuration runs in its own process (OpenMP reads its wait policy once): one thread; two threads with
OpenMP's default (active, spinning) waiting; two threads with passive waiting. The env step is ``BatchSim.step``
on the handling course; ``VTRACK_PARALLEL_MIN_N=1`` forces the multi-threaded kernel. CPU time is
``time.process_time`` (every thread), wall time ``time.perf_counter``; the ratios are against one thread measured in
the same run, with the load average. A two-thread set-up pays where its wall ratio is above 1 and its CPU ratio
stays near 1. Run: ``python benchmarks/bench_threads.py [N ...]`` (default N = 256 1024 4096 16384).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

CONFIGS = {"1 thread": {"NUMBA_NUM_THREADS": "1"},
           "2 active": {"NUMBA_NUM_THREADS": "2", "OMP_WAIT_POLICY": "ACTIVE"},
           "2 passive": {"NUMBA_NUM_THREADS": "2", "OMP_WAIT_POLICY": "PASSIVE"}}
MIN_WALL_S = 0.3


def measure(n: int) -> dict[str, float]:
    """CPU and wall ns per car-step of ``n`` cars in this process."""
    from bench_env_vs_plant import handling_course

    step = handling_course(n)
    step()   # compile / load and warm
    calls, c0, w0 = 0, time.process_time(), time.perf_counter()
    while time.perf_counter() - w0 < MIN_WALL_S:
        step()
        calls += 1
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    return {"cpu_ns": 1e9 * cpu / (calls * n), "wall_ns": 1e9 * wall / (calls * n)}


def run(config: dict[str, str], n: int) -> dict[str, float]:
    """``measure(n)`` in a fresh process with ``config``'s environment."""
    env = {**os.environ, **config, "VTRACK_PARALLEL_MIN_N": "1"}
    out = subprocess.run([sys.executable, __file__, "--child", str(n)], env=env, capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(sizes: list[int], rounds: int = 3) -> None:
    print(f"load average {os.getloadavg()[0]:.1f} at start; ns per car-step (CPU / wall), median of {rounds} rounds "
          "alternating the configurations; gains: one thread's over this one's (wall: > 1 is faster; CPU: < 1 "
          "costs more CPU)")
    print(f"{'N':>6} {'config':<10} {'CPU ns':>8} {'wall ns':>8} {'wall gain':>9} {'CPU ratio':>9} {'load':>5}")
    for n in sizes:
        found: dict[str, list[dict[str, float]]] = {name: [] for name in CONFIGS}
        for _ in range(rounds):
            for name, config in CONFIGS.items():
                found[name].append(run(config, n))
        one = found["1 thread"]
        for name, runs in found.items():
            wall = np.median([b["wall_ns"] / r["wall_ns"] for b, r in zip(one, runs, strict=True)])
            cpu = np.median([b["cpu_ns"] / r["cpu_ns"] for b, r in zip(one, runs, strict=True)])
            print(f"{n:>6} {name:<10} {np.median([r['cpu_ns'] for r in runs]):>8.0f} "
                  f"{np.median([r['wall_ns'] for r in runs]):>8.0f} {wall:>8.2f}x {cpu:>8.2f}x "
                  f"{os.getloadavg()[0]:>5.1f}", flush=True)


if __name__ == "__main__":
    if sys.argv[1:2] == ["--child"]:
        print(json.dumps(measure(int(sys.argv[2]))))
    else:
        main([int(a) for a in sys.argv[1:]] or [256, 1024, 4096, 16384])
