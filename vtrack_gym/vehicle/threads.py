"""When a batch of cars is stepped on several threads, and how those threads wait.

Measured on a shared 2-core machine (``benchmarks/bench_threads.py``, CPU time and wall time per car-step, one
thread against two): two threads only pay from a few thousand cars on, and only when the idle thread sleeps
instead of spinning. So:

- below ``PARALLEL_MIN_N`` cars the single-threaded kernel runs (identical results either way);
- from there on the multi-threaded kernel runs, with OpenMP's passive waiting (``OMP_WAIT_POLICY=PASSIVE``) unless
  the environment already sets a wait policy; it takes effect when the threading layer starts, i.e. when no
  other library (torch, for one) started OpenMP in this process before the first parallel step;
- ``VTRACK_PARALLEL_MIN_N`` overrides the threshold (``1``: always parallel; a huge number: never), and numba's
  ``NUMBA_NUM_THREADS`` (or ``numba.set_num_threads``) the number of threads.
"""

from __future__ import annotations

import os

PARALLEL_MIN_N = 2048
"""Batches at least this large are stepped by the multi-threaded kernel (unless ``VTRACK_PARALLEL_MIN_N``)."""
MIN_N_VARIABLE = "VTRACK_PARALLEL_MIN_N"
"""The environment variable that overrides ``PARALLEL_MIN_N`` (a whole number >= 1)."""


def parallel_min_n() -> int:
    """The smallest batch stepped on several threads: ``$VTRACK_PARALLEL_MIN_N`` if set, else ``PARALLEL_MIN_N``;
    ``ValueError`` naming the variable for anything but a whole number >= 1."""
    text = os.environ.get(MIN_N_VARIABLE, "").strip()
    if not text:
        return PARALLEL_MIN_N
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise ValueError(f"{MIN_N_VARIABLE} must be a whole number >= 1 (got {text!r})")
    return value


def use_parallel(n: int) -> bool:
    """Whether a batch of ``n`` cars is stepped by the multi-threaded kernel; when it is, asks OpenMP for passive
    waiting first (``OMP_WAIT_POLICY``, unless already set)."""
    if n < parallel_min_n():
        return False
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    return True
