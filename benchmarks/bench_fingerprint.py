"""CPU time and peak memory of the policy fingerprint (``evaluation.identity.fingerprint.state_digest``) against the
depth of a state's nesting.

For each depth it builds a list nested that many levels deep (``[[[...]]]``, the shape of
``tests/test_fingerprint_complete.py``) and a chain of plain objects as deep, then reports the CPU time of one
digest (best of 3) and the peak memory the digest allocates (``tracemalloc``, a separate run: tracing slows the
walk). Linear work shows as a flat time and memory per level. The last lines show the documented bounds refusing
a deeper state with ``IncompleteFingerprint`` instead of reading it.
Run: ``python benchmarks/bench_fingerprint.py`` (``--depths 5000 10000`` for other depths).
"""

from __future__ import annotations

import argparse
import math
import os
import time
import tracemalloc
from typing import Any

from vtrack_gym.evaluation.identity import fingerprint
from vtrack_gym.evaluation.identity.fingerprint import IncompleteFingerprint, state_digest


class Node:
    """One level of a chain of plain objects."""

    def __init__(self, inner: object) -> None:
        self.inner = inner


def nested_list(depth: int) -> list[Any]:
    value: list[Any] = []
    for _ in range(depth):
        value = [value]
    return value


def object_chain(depth: int) -> Node:
    value: Any = 0.3
    for _ in range(depth):
        value = Node(value)
    return value


def cpu_seconds(value: object, repeats: int = 3) -> float:
    """Best CPU time of one ``state_digest(value)`` [s]."""
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        state_digest(value)
        best = min(best, time.process_time() - start)
    return best


def peak_mib(value: object) -> float:
    """Peak memory allocated while digesting ``value`` [MiB] (the state itself excluded)."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    state_digest(value)
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    return peak / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--depths", type=int, nargs="+", default=[5_000, 10_000, 20_000, 40_000, 100_000])
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}; bounds: depth {fingerprint.MAX_DEPTH}, objects "
          f"{fingerprint.MAX_OBJECTS}, bytes {fingerprint.MAX_STATE_BYTES}")
    print(f"{'shape':>8} {'depth':>8} {'CPU [s]':>9} {'us/level':>9} {'peak [MiB]':>11} {'B/level':>8}")
    for shape, build in (("lists", nested_list), ("objects", object_chain)):
        for depth in args.depths:
            value = build(depth)
            cpu, peak = cpu_seconds(value), peak_mib(value)
            print(f"{shape:>8} {depth:>8} {cpu:>9.3f} {1e6 * cpu / depth:>9.2f} {peak:>11.1f} "
                  f"{peak * 2**20 / depth:>8.0f}")
    too_deep = nested_list(fingerprint.MAX_DEPTH + 1)
    start = time.process_time()
    try:
        state_digest(too_deep)
        print("a state deeper than MAX_DEPTH was read: the bound does not hold")
    except IncompleteFingerprint as exc:
        print(f"depth {fingerprint.MAX_DEPTH + 1}: refused after {time.process_time() - start:.2f} s CPU: "
              f"{str(exc)[:100]}...")


if __name__ == "__main__":
    main()
