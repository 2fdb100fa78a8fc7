"""Shared timing helper for the benchmark scripts (best of several repeats, wall clock)."""

from __future__ import annotations

import time
from collections.abc import Callable


def rate(fn: Callable[[], object], work_per_call: float, min_seconds: float = 1.0, repeats: int = 3) -> float:
    """Best observed throughput of ``fn`` in work units per second (calls * work_per_call / seconds)."""
    fn()  # warm-up (JIT compilation, caches)
    best = 0.0
    for _ in range(repeats):
        calls = 0
        start = time.perf_counter()
        while True:
            fn()
            calls += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_seconds / repeats:
                break
        best = max(best, calls * work_per_call / elapsed)
    return best
