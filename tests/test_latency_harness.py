"""Compute charged in the harness: ``evaluate(..., latency=)``, ``vtrack eval/benchmark --latency``; rows record the
mode and the share of late decisions; the board ranks charged rows apart, beside the ideal ones."""

from __future__ import annotations

import json
import time

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.rollouts.rollout import rollout


class SleepyPolicy:
    """Steers straight after sleeping ``seconds`` a decision."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        time.sleep(self.seconds)
        return np.zeros((1,), dtype=np.float32), state


def test_rollout_charges_the_policy_call() -> None:
    env = gym.make("DLC120-v0", latency="measured")
    trace = rollout(SleepyPolicy(0.025), env, seed=0, max_steps=6)
    stats = env.unwrapped.latency_stats()
    assert stats["decisions"] == 6 and stats["late_share"] == 1.0
    assert stats["max_latency_s"] >= 0.025
    assert float(np.min(trace.policy_time_s)) >= 0.025


def test_evaluate_records_latency_and_the_board_shows_both() -> None:
    def stanley(env):
        return vtrack_gym.make_policy("stanley", env)

    ideal = vtrack_gym.evaluate(stanley, "DLC120-v0", [0])
    charged = vtrack_gym.evaluate(stanley, "DLC120-v0", [0], latency=0.02)
    assert charged[0].options["latency_s"] == 0.02 and "latency_s" not in ideal[0].options
    assert charged[0].metrics["late_decision_share"] == 1.0   # 20 ms > the 10 ms control period, every decision
    assert "late_decision_share" not in ideal[0].metrics
    assert charged[0].metrics["max_e_y_m"] > ideal[0].metrics["max_e_y_m"]   # two periods of delay cost tracking
    board = vtrack_gym.leaderboard(ideal + charged)
    assert sorted(e["env_id"] for e in board) == ["DLC120-v0", "DLC120-v0 [latency_s=0.02]"]


def test_cli_eval_and_benchmark_take_latency(tmp_path, capsys) -> None:
    store = tmp_path / "board.db"
    assert main(["eval", "--policy", "stanley", "--env", "DLC120-v0", "--latency", "measured",
                 "--store", str(store)]) == 0
    assert "late_decision_share" in capsys.readouterr().out
    assert main(["leaderboard", "--store", str(store), "--suite", "custom", "--format", "json"]) == 0
    entries = json.loads(capsys.readouterr().out)
    assert [e["env_id"] for e in entries] == ['DLC120-v0 [latency="measured"]']
    assert 0.0 <= entries[0]["late_decision_share"] <= 1.0
    with pytest.raises(SystemExit):
        main(["benchmark", "--latency", "sometimes", "--store", str(store)])
    assert "--latency must be" in capsys.readouterr().err


def test_cli_benchmark_charges_a_fixed_budget(tmp_path, capsys) -> None:
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "board.db"
    assert main(["benchmark", "--policies", "stanley", "--latency", "0.004", "--no-figures", "--workers", "1",
                 "--store", str(store)]) == 0
    rows = ResultStore(store).rows(suite="paper")
    assert rows and all(r["options"]["latency_s"] == 0.004 for r in rows)
    assert all(r["metrics"]["late_decision_share"] == 0.0 for r in rows)   # 4 ms < 10 ms: never late
    assert 'latency_s=0.004' in capsys.readouterr().out
