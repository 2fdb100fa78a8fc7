"""CPU time of ``vtrack benchmark``'s job (the paper suite, every policy) split by policy, warm.

Each policy's episodes are scored in this process (``run_benchmark(policies=[name], workers=1)``, no store, no
figures) after one warm-up episode set (kernels compiled and cached, modules imported); the CPU time is
``time.process_time`` (all threads of this process), printed per policy with its share and the load average.
Run: ``python benchmarks/bench_benchmark_cpu.py [POLICY ...]`` (default: the policies ``vtrack benchmark`` scores without ``--policies``,
``default_policy_names()``).
"""

from __future__ import annotations

import logging
import os
import sys
import time

from vtrack_gym.baselines.resolve import default_policy_names
from vtrack_gym.evaluation.benchmark import run_benchmark

TARGET_CPU_S = 15.0


def policy_cpu_s(name: str) -> float:
    """CPU seconds of scoring ``name`` on the paper suite (this process, every thread)."""
    start = time.process_time()
    run_benchmark("paper", policies=[name], show_progress=False, workers=1)
    return time.process_time() - start


def main(names: list[str]) -> None:
    logging.disable(logging.WARNING)
    run_benchmark("paper", policies=["stanley"], show_progress=False, workers=1)   # warm-up: kernels, imports
    print(f"load average {os.getloadavg()[0]:.1f} at start; CPU time [s] of the paper suite per policy (warm)")
    spent = {}
    for name in names:
        spent[name] = policy_cpu_s(name)
        print(f"{name:<14} {spent[name]:7.2f} s   load {os.getloadavg()[0]:.1f}", flush=True)
    total = sum(spent.values())
    top = max(spent, key=spent.get)
    print(f"{'total':<14} {total:7.2f} s   (target {TARGET_CPU_S:g} s; {top} dominates: "
          f"{100 * spent[top] / total:.0f} %)")


if __name__ == "__main__":
    main(sys.argv[1:] or list(default_policy_names()))
