"""The ``trajectory`` suite (paper scenarios, three manoeuvres, three courses with a varying speed profile, every
episode with the agent on the pedals) and its ranking: success, then max |e_y|, then the RMS speed error."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.leaderboard.board import build_board, ranking_note
from vtrack_gym.evaluation.suite.suite_parts import Suite
from vtrack_gym.evaluation.suite.suites import extra_columns, get_suite, suite_names, then_metrics


def test_the_suite_drives_eight_courses_in_steer_accel() -> None:
    suite = get_suite("trajectory")
    episodes = suite.episodes_for()
    assert "trajectory" in suite_names() and len(episodes) == 8
    assert {ep.control for ep in episodes} == {"steer_accel"}
    assert [ep.env_id for ep in episodes][:2] == ["LateralTracking-v0", "DLC120-v0"]
    assert {"vtrack/HandlingCourseCircuit-v0", "vtrack/RingCircuit-v0", "vtrack/ProceduralRoad-v0",
            "vtrack/ISO3888-1-v1", "vtrack/ISO3888-2-v1", "vtrack/Slalom-v1"} <= {ep.env_id for ep in episodes}
    assert {"rms_e_v_mps", "time_lag_s"} <= set(extra_columns("trajectory"))
    assert then_metrics("trajectory") == ("rms_e_v_mps",) and then_metrics("paper") == ()
    assert "then mean max_e_y_m, then mean rms_e_v_mps" in ranking_note("max_e_y_m", then_metrics("trajectory"))


def test_a_then_metric_must_be_numeric() -> None:
    with pytest.raises(ValueError, match=r"Suite\.then_metrics must be numeric"):
        Suite(name="x", description="x", episodes=lambda seeds: [], then_metrics=("termination",))


def _record(policy: str, success: bool, max_e_y: float, rms_e_v: float) -> dict:
    return {"env_id": "DLC120-v0", "options": {"control": "steer_accel"}, "policy_id": policy, "policy_preset": "",
            "policy_hash": policy, "completed": 1, "success": int(success), "termination": "completed",
            "wall_time_per_step_s": 1e-5, "metrics": {"max_e_y_m": max_e_y, "rms_e_v_mps": rms_e_v}}


def test_equal_success_and_position_error_are_ordered_by_the_speed_error() -> None:
    records = [_record("a_slow_speed", True, 0.2, 0.9), _record("b_good_speed", True, 0.2, 0.3),
               _record("c_better_path", True, 0.1, 2.0), _record("d_failed", False, 0.05, 0.1)]
    board = build_board(records, ["rms_e_v_mps"], "max_e_y_m", then=("rms_e_v_mps",))
    assert [e["policy_id"] for e in board] == ["c_better_path", "b_good_speed", "a_slow_speed", "d_failed"]
    plain = build_board(records, ["rms_e_v_mps"], "max_e_y_m")     # without: the policy key decides the tie
    assert [e["policy_id"] for e in plain] == ["c_better_path", "a_slow_speed", "b_good_speed", "d_failed"]


def test_the_courses_are_registered_with_a_standing_start_profile() -> None:
    for env_id in ("vtrack/HandlingCourseCircuit-v0", "vtrack/RingCircuit-v0", "vtrack/ProceduralRoad-v0"):
        env = gym.make(env_id, control="steer_accel")
        obs, _ = env.reset(seed=0)
        layout = env.unwrapped.observation_layout
        assert obs[layout.index("v_x")] == 0.0                       # from standstill ...
        assert obs[layout.index("target_speed")] == pytest.approx(1.0, abs=0.2)   # ... and so is the reference
        assert env.action_space.shape == (2,)


@pytest.mark.slow
def test_vtrack_benchmark_trajectory_stores_speed_and_time_columns(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """``vtrack benchmark --suite trajectory`` drives all eight courses with the decoupled lqr; the board has the
    speed error and the time lag, and the rows record the mode."""
    store = tmp_path / "s.sqlite"
    assert main(["benchmark", "--suite", "trajectory", "--policies", "lqr", "--seeds", "0", "--no-figures",
                 "--store", str(store), "--format", "json"]) == 0
    captured = capsys.readouterr()
    assert "then mean rms_e_v_mps" in captured.err
    rows = vtrack_gym.evaluation.storage.store.ResultStore(store).rows()
    assert len(rows) == 8 and {r["suite"] for r in rows} == {"trajectory"}
    assert all(json.loads(r["options"])["control"] == "steer_accel" if isinstance(r["options"], str)
               else r["options"]["control"] == "steer_accel" for r in rows)
    board = vtrack_gym.evaluation.storage.store.ResultStore(store).leaderboard(
        "trajectory", ["rms_e_v_mps", "time_lag_s"])
    ring = next(e for e in board if "RingCircuit" in e["env_id"])
    assert np.isfinite(float(ring["rms_e_v_mps"])) and np.isfinite(float(ring["time_lag_s"]))
    assert float(ring["rms_e_v_mps"]) < 3.0    # the PD-FLC follows the standing-start profile within a few m/s
