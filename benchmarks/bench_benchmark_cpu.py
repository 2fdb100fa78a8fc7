"""CPU time of ``vtrack benchmark``'s job (the paper suite, every policy) split by policy, warm.

Each policy's episodes are scored in this process (``run_benchmark(policies=[name], workers=1)``, no store, no
figures) after one warm-up episode set of ``stanley`` (the env's kernels loaded, the scoring's modules imported);
each policy's own first use (its kernels loaded from the cache, as in a ``vtrack benchmark`` run whose kernels are
cached) is in its figure. The CPU time is ``time.process_time`` (all threads of this process), printed per policy
with its share and the load average. Run it once beforehand to fill the kernel cache.
Run: ``python benchmarks/bench_benchmark_cpu.py [POLICY ...]`` (default: the policies ``vtrack benchmark`` scores
without ``--policies``, ``default_policy_names()``).

``--against DIR`` compares with another checkout of the package (e.g. the main branch): each round runs this
script once for ``DIR`` and once for this checkout, alternating, each in a fresh process with its own kernel cache
(``$NUMBA_CACHE_DIR`` + ``-a`` / ``-b``, filled by one unmeasured run of each first), and prints both totals per
round and their ratio. ``--rounds N`` (default 2).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import subprocess
import sys
import time
from pathlib import Path

TARGET_CPU_S = 15.0
HERE = Path(__file__).resolve().parent


def policy_cpu_s(name: str) -> float:
    """CPU seconds of scoring ``name`` on the paper suite (this process, every thread)."""
    from vtrack_gym.evaluation.benchmarking.benchmark import run_benchmark

    start = time.process_time()
    run_benchmark("paper", policies=[name], show_progress=False, workers=1)
    return time.process_time() - start


def measure(names: list[str]) -> dict[str, float]:
    """CPU seconds per policy, after a warm-up run of ``stanley``."""
    from vtrack_gym.evaluation.benchmarking.benchmark import run_benchmark

    logging.disable(logging.WARNING)
    run_benchmark("paper", policies=["stanley"], show_progress=False, workers=1)   # warm-up: kernels, imports
    return {name: policy_cpu_s(name) for name in names}


def show(spent: dict[str, float]) -> None:
    total = sum(spent.values())
    top = max(spent, key=spent.get)
    for name, s in spent.items():
        print(f"{name:<14} {s:7.2f} s")
    print(f"{'total':<14} {total:7.2f} s   (target {TARGET_CPU_S:g} s; {top} dominates: "
          f"{100 * spent[top] / total:.0f} %)   load {os.getloadavg()[0]:.1f}", flush=True)


def child(checkout: Path, names: list[str], tag: str) -> dict[str, float]:
    """``measure(names)`` in a fresh process importing the package from ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout),
           "NUMBA_CACHE_DIR": os.environ.get("NUMBA_CACHE_DIR", "/tmp/numba_bench") + f"-{tag}"}
    out = subprocess.run([sys.executable, __file__, "--child", *names], env=env, capture_output=True, text=True,
                         check=True, cwd=checkout)
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(against: Path, names: list[str], rounds: int) -> None:
    here = HERE.parent
    print(f"load average {os.getloadavg()[0]:.1f} at start; CPU time [s] of the paper suite, all policies "
          f"(warm): {against} (A) against {here} (B), alternating")
    child(against, names, "a")   # unmeasured: fills each side's kernel cache (a first run compiles)
    child(here, names, "b")
    for r in range(rounds):
        a = child(against, names, "a")
        b = child(here, names, "b")
        print(f"round {r + 1}: A {sum(a.values()):6.2f} s   B {sum(b.values()):6.2f} s   B/A "
              f"{sum(b.values()) / sum(a.values()):.2f}   load {os.getloadavg()[0]:.1f}", flush=True)
        print("   per policy (A -> B): " + ", ".join(f"{n} {a[n]:.2f}->{b[n]:.2f}" for n in names), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("policies", nargs="*")
    ap.add_argument("--against", type=Path, help="another checkout to compare with (A/B, alternating)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    from vtrack_gym.baselines.resolve import default_policy_names

    names = args.policies or list(default_policy_names())
    if args.child:
        print(json.dumps(measure(names)))
    elif args.against is not None:
        compare(args.against.resolve(), names, args.rounds)
    else:
        print(f"load average {os.getloadavg()[0]:.1f} at start; CPU time [s] of the paper suite per policy (warm)")
        show(measure(names))


if __name__ == "__main__":
    main()
