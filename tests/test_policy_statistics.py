"""Solver statistics on every leaderboard row: the policy's own compute per decision and its failed solves."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.benchmarking.benchmark import LEADERBOARD_COLUMNS, suite_columns
from vtrack_gym.evaluation.scoring.metrics import compute_metrics
from vtrack_gym.evaluation.scoring.trace import Trace
from vtrack_gym.evaluation.suite.suites import suite_names

STATISTICS = ("policy_time_p50_us", "policy_time_p95_us", "policy_time_max_us", "policy_real_time_factor",
              "solver_failures")


def _trace(times_s: np.ndarray, failures: int | None) -> Trace:
    signals = {"time_s": np.arange(times_s.size) * 0.01}
    return Trace("t", "p", 0, signals, np.zeros((times_s.size, 4)), np.zeros((times_s.size, 3)), 100.0, 0.01,
                 "completed", 1e-4, policy_time_s=times_s, solver_failures=failures)


def test_compute_metrics_are_the_percentiles_of_the_decision_times() -> None:
    times = np.arange(1, 101) * 1e-5          # 10 us .. 1000 us
    m = compute_metrics(_trace(times, 2))
    assert m["policy_time_p50_us"] == pytest.approx(505.0)
    assert m["policy_time_p95_us"] == pytest.approx(950.5)
    assert m["policy_time_max_us"] == pytest.approx(1000.0)
    assert m["policy_real_time_factor"] == pytest.approx(0.01 / 950.5e-6)
    assert m["solver_failures"] == 2.0


def test_a_trace_without_timings_or_a_count_has_missing_statistics() -> None:
    m = compute_metrics(_trace(np.zeros(0), None))
    assert all(math.isnan(m[k]) for k in STATISTICS)


@pytest.mark.parametrize("suite", suite_names())
def test_every_suite_has_the_statistics_columns(suite: str) -> None:
    assert set(STATISTICS) <= set(suite_columns(suite)) and set(STATISTICS) <= set(LEADERBOARD_COLUMNS)


def _track(path: Path) -> Path:
    path.write_text("x_m,y_m\n0,0\n40,0\n80,3\n120,3\n")
    return path


def test_benchmark_json_rows_carry_the_statistics(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    track = _track(tmp_path / "bend.csv")
    store = tmp_path / "s.sqlite"
    assert main(["benchmark", "--policies", "stanley,mpc_osqp", "--track", str(track), "--no-figures", "--store",
                 str(store), "--format", "json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert {entry["policy_id"] for entry in board} == {"stanley", "mpc_osqp"}
    for entry in board:
        assert 0.0 < entry["policy_time_p50_us"] <= entry["policy_time_p95_us"] <= entry["policy_time_max_us"]
        assert entry["policy_real_time_factor"] == pytest.approx(1e4 / entry["policy_time_p95_us"], rel=1e-9)
        assert entry["solver_failures"] == 0
