"""Forked workers of ``run_tasks``: they start warm (the parent loaded the kernels, each policy and the scoring
before the fork), run their native libraries single-threaded, and report where the CPU time went."""

from __future__ import annotations

import ctypes
import json
import logging
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from vtrack_gym.evaluation.benchmarking.benchmark import policy_factories, score_episode
from vtrack_gym.evaluation.rollouts.parallel import USAGE_PREFIX, EpisodeTask, run_tasks, usage_line
from vtrack_gym.evaluation.rollouts.worker_threads import limit_native_threads, loaded_openblas
from vtrack_gym.evaluation.suite.suites import Episode

OPENBLAS_GETTERS = ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                    "openblas_get_num_threads64_", "openblas_get_num_threads")


def openblas_threads() -> list[int]:
    """The thread count of every loaded OpenBLAS that exports a getter."""
    counts = []
    for path in loaded_openblas():
        lib = ctypes.CDLL(path)
        getter = next((getattr(lib, n) for n in OPENBLAS_GETTERS if hasattr(lib, n)), None)
        if getter is not None:
            counts.append(int(getter()))
    return counts


@dataclass(frozen=True)
class Probe:
    """What a worker saw while scoring one task (a stand-in for a row: ``run_task`` logs its termination)."""

    termination: str
    new_modules: tuple[str, ...]
    blas_threads: tuple[int, ...]
    max_e_y_m: float


def probing_score(name: str, policy: Any, env: Any, ep: Episode, suite: str) -> tuple[Probe, None]:
    """``score_episode``, recording the modules it imported and the OpenBLAS thread counts of its process."""
    before = set(sys.modules)
    row, _ = score_episode(name, policy, env, ep, suite)
    new = tuple(sorted(m for m in set(sys.modules) - before if not m.startswith("vtrack_gym.")))
    return Probe(row.termination, new, tuple(openblas_threads()), row.metrics["max_e_y_m"]), None


def test_workers_start_warm_single_threaded_and_score_like_one_process(caplog: pytest.LogCaptureFixture) -> None:
    factories = policy_factories(["lqr", "stanley"])
    tasks = [EpisodeTask(n, m, Episode("DLC120-v0", s), "custom", probing_score)
             for n, m in factories.items() for s in (0, 1)]
    with caplog.at_level(logging.DEBUG, logger="vtrack_gym.evaluation.rollouts.parallel"):
        forked = [probe for probe, _ in run_tasks(tasks, workers=2)]
    serial = [probe for probe, _ in run_tasks(tasks, workers=1)]
    assert [p.max_e_y_m for p in forked] == [p.max_e_y_m for p in serial]
    assert all(p.new_modules == () for p in forked), [p.new_modules for p in forked]
    if openblas_threads():  # an OpenBLAS build of numpy/scipy: each worker runs it with one thread
        assert all(p.blas_threads and set(p.blas_threads) == {1} for p in forked)
    (line,) = [r.getMessage() for r in caplog.records if r.getMessage().startswith(USAGE_PREFIX)]
    assert line.startswith(f"{USAGE_PREFIX} 4 on ") and "episode CPU per worker" in line


def test_a_factory_failing_in_the_warm_up_fails_in_its_task() -> None:
    calls: list[str] = []

    def broken(env: Any) -> Any:
        calls.append("parent")  # only the parent's calls are seen here (a worker appends to its own copy)
        raise RuntimeError("no weights file")

    good = policy_factories(["stanley"])["stanley"]
    tasks = [EpisodeTask("stanley", good, Episode("DLC120-v0", 0), "custom", score_episode),
             EpisodeTask("mine", broken, Episode("DLC120-v0", 0), "custom", score_episode)]
    with pytest.raises(RuntimeError, match="no weights file"):
        run_tasks(tasks, workers=2)
    assert calls == ["parent"]  # built once by the warm-up, for all workers


def test_limit_native_threads_sets_every_loaded_openblas() -> None:
    code = ("import json, numpy, scipy.linalg, sys; sys.path.insert(0, {tests!r}); from test_parallel_workers "
            "import openblas_threads; from vtrack_gym.evaluation.rollouts.worker_threads import limit_native_threads; "
            "before = openblas_threads(); done = limit_native_threads(1); print(json.dumps([before, done, "
            "openblas_threads()]))")
    out = subprocess.run([sys.executable, "-c", code.format(tests=str(Path(__file__).parent))], capture_output=True,
                         text=True, check=True).stdout
    before, done, after = json.loads(out)
    if not before:
        pytest.skip("numpy and scipy are not built on OpenBLAS here")
    assert len(done) == len(before) and set(after) == {1}
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        limit_native_threads(0)


def test_loaded_openblas_reads_the_process_maps(tmp_path: Path) -> None:
    maps = tmp_path / "maps"
    maps.write_text("7f00-7f01 r-xp 00000000 08:01 123 /venv/numpy.libs/libscipy_openblas64_-abc.so\n"
                    "7f01-7f02 r-xp 00000000 08:01 124 /usr/lib/libm.so.6\n"
                    "7f02-7f03 rw-p 00000000 00:00 0 \n")
    assert loaded_openblas(maps) == ["/venv/numpy.libs/libscipy_openblas64_-abc.so"]
    assert loaded_openblas(tmp_path / "absent") == []


def test_usage_line_names_the_busiest_worker_first() -> None:
    line = usage_line(12, 2.5, [3.0, 4.25], 5.0)
    assert line == (f"{USAGE_PREFIX} 12 on 2; warm-up CPU 2.50 s; episode CPU per worker [4.25, 3.00] s "
                    "(sum 7.25 s); pool wall 5.00 s")


class Straight:
    """A policy that counts its decisions and steers straight (one object shared by every episode)."""

    def __init__(self) -> None:
        self.decisions = 0

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[Any, Any]:
        self.decisions += 1
        return np.zeros(1, dtype=np.float32), state


def test_the_warm_up_never_drives_a_policy_object_shared_by_the_tasks() -> None:
    shared = Straight()
    tasks = [EpisodeTask("straight", lambda env: shared, Episode("DLC120-v0", s), "custom", score_episode)
             for s in (0, 1)]
    forked = run_tasks(tasks, workers=2)
    assert shared.decisions == 0  # the parent built it for the warm-up, only the workers (their copies) drove it
    serial = run_tasks(tasks, workers=1)
    assert shared.decisions > 0
    assert [r.metrics["max_e_y_m"] for r, _ in forked] == [r.metrics["max_e_y_m"] for r, _ in serial]
