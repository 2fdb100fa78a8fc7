"""Issue 19 items 2 and 3: success verdicts, validity-first ranking (failed episodes apart), multi-seed
evaluation with bootstrap confidence intervals in every format, and "tied with" notes."""

from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.cli._options import parse_seeds as _parse_seeds
from vtrack_gym.evaluation.leaderboard.board import Estimate, build_board, estimate, failure_reason
from vtrack_gym.evaluation.leaderboard.report_formats import to_csv, to_json, to_latex, to_markdown
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore, StoreError
from vtrack_gym.evaluation.suite.suites import primary_metric

COLUMNS = ["max_e_y_m", "itae", "cones_hit"]


class ConstantSteering:
    """A policy that always commands the same normalised steering action."""

    def __init__(self, action: float, name: str) -> None:
        self.action = action
        self.policy_id = name

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.array([self.action], dtype=np.float32), state


def record(policy: str, seed: int, e_y: float, *, termination: str = "completed", cones: float | None = None,
           itae: float = 1.0, progress: float = 100.0, success: int | None = None) -> dict:
    metrics = {"max_e_y_m": e_y, "itae": itae, "progress_m": progress}
    if cones is not None:
        metrics["cones_hit"] = cones
    out = {"env_id": "DLC120-v0", "policy_id": policy, "policy_preset": "", "policy_hash": "h" + policy,
           "completed": int(termination == "completed"), "termination": termination, "wall_time_per_step_s": 1e-5,
           "metrics": metrics}
    if success is not None:
        out["success"] = success
    return out


# ------------------------------------------------------------------------------------------ success verdict
def test_failure_reasons_and_rows_without_a_verdict() -> None:
    # a row without a verdict is judged by completion alone (the criterion's verdict travels with the row)
    assert ResultRow("paper", "DLC120-v0", "p", "h", 0, {"cones_hit": 3.0}, "completed", 1e-5).verdict()
    assert not ResultRow("paper", "DLC120-v0", "p", "h", 0, {}, "spin_out", 1e-5).verdict()
    assert failure_reason("spin_out", {"cones_hit": 0.0}) == "spin_out"
    assert failure_reason("completed", {"cones_hit": 2.0}) == "cones_hit"
    assert failure_reason("completed", {}) == "env_verdict"


def test_env_verdict_is_the_row_verdict() -> None:
    from vtrack_gym.evaluation.scoring.trace import STEP_SIGNALS, Trace

    info = {name: 0.0 for name in STEP_SIGNALS} | {"fz_n": np.ones(4), "acc_substeps_mps2": np.zeros((2, 3))}
    kw = {"env_id": "DLC120-v0", "policy_id": "p", "seed": 0, "physics_rate_hz": 1000.0, "control_period_s": 0.01,
          "termination": "completed", "wall_time_s": 0.1}
    assert Trace.from_infos([info], **kw).success is None
    assert Trace.from_infos([info, info | {"success": False}], **kw).success is False
    row = ResultRow("paper", "DLC120-v0", "p", "h", 0, {"cones_hit": 0.0}, "completed", 1e-5)
    assert row.verdict() and not ResultRow("paper", "DLC120-v0", "p", "h", 0, {"cones_hit": 0.0}, "completed",
                                           1e-5, success=False).verdict()


def test_store_keeps_the_success_column(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.sqlite")
    store.add([ResultRow("paper", "DLC120-v0", "p", "h", s, {"max_e_y_m": 0.1, "cones_hit": float(s)}, "completed",
                         1e-5, success=s == 0) for s in range(2)])
    assert [r["success"] for r in store.rows()] == [1, 0]
    board = store.leaderboard("paper", COLUMNS)
    assert board[0]["success_rate"] == 0.5 and board[0]["failed"] == 1
    assert board[0]["failure_reasons"] == "cones_hit x1" and board[0]["cones_hit"] == 0.0


def test_older_schema_is_refused_untouched(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    ResultStore(path)
    with sqlite3.connect(path) as con:
        con.execute("UPDATE vtrack_meta SET value = '2' WHERE key = 'schema_version'")
    con.close()
    before = path.read_bytes()
    with pytest.raises(StoreError, match="older than this vtrack_gym's"):
        ResultStore(path)
    assert path.read_bytes() == before


# ------------------------------------------------------------------------------------------ validity first
def test_failed_episodes_never_improve_a_policy() -> None:
    """An early crash (small ITAE, no cone passed) and a one-step episode (ITAE 0) rank below a completed run."""
    records = [record("good", 0, 0.3, cones=0.0, itae=1.65, progress=345.0),
               record("crash", 0, 1.9, termination="spin_out", cones=0.0, itae=0.30, progress=26.0),
               record("onestep", 0, 0.0, termination="off_road", cones=0.0, itae=0.0, progress=0.1),
               record("cones", 0, 3.5, cones=1.0, itae=76.0, progress=345.0),
               record("cones2", 0, 0.7, cones=2.0, itae=15.7, progress=345.0)]
    board = build_board(records, COLUMNS)
    assert [e["policy_id"] for e in board] == ["good", "cones2", "cones", "crash", "onestep"]
    assert [e["rank"] for e in board] == [1, 2, 3, 4, 5]
    crash = board[3]
    assert math.isnan(crash["itae"]) and math.isnan(crash["cones_hit"])  # failed metrics are not aggregated
    assert crash["failed"] == 1 and crash["failure_reasons"] == "spin_out x1"
    assert crash["failed_progress_m"] == 26.0 and crash["failed_max_e_y_m"] == 1.9
    assert board[0]["itae"] == 1.65 and board[0]["failed"] == 0 and board[0]["failure_reasons"] == ""


def test_success_rate_outranks_the_primary_metric() -> None:
    records = [record("steady", s, 0.5) for s in range(4)]
    records += [record("lucky", s, 0.1) for s in range(3)] + [record("lucky", 3, 9.0, termination="off_road")]
    board = build_board(records, COLUMNS)
    assert [(e["policy_id"], float(e["success_rate"])) for e in board] == [("steady", 1.0), ("lucky", 0.75)]
    assert board[1]["max_e_y_m"] == pytest.approx(0.1)  # over its successful episodes only


def test_env_success_verdict_is_used_when_given() -> None:
    board = build_board([record("a", 0, 0.1, success=0), record("b", 0, 0.2, success=1)], COLUMNS)
    assert [e["policy_id"] for e in board] == ["b", "a"] and board[1]["failure_reasons"] == "env_verdict x1"


@pytest.mark.slow
def test_zero_steering_and_full_lock_rank_below_every_default_baseline() -> None:
    from vtrack_gym.baselines.resolve import policy_names
    from vtrack_gym.evaluation.benchmarking.benchmark import LEADERBOARD_COLUMNS, summarise

    baselines = [n for n in policy_names() if n in ("smc", "mpc", "lqr", "stanley", "pure_pursuit", "mpc_osqp")]
    assert {"smc", "mpc", "lqr", "stanley", "pure_pursuit"} <= set(baselines)
    rows = []
    for name in baselines:
        rows += vtrack_gym.evaluate(lambda env, name=name: vtrack_gym.make_policy(name, env), "paper", policy_id=name)
    zero = vtrack_gym.evaluate(ConstantSteering(0.0, "zero_steering"), "paper")
    lock = vtrack_gym.evaluate(ConstantSteering(1.0, "full_lock"), "paper")
    by = {(r.policy_id, r.env_id): r for r in rows + zero + lock}
    # the pathology: on the lane change full lock spins out at once, so its raw ITAE and cone count look best
    assert by[("full_lock", "DLC120-v0")].termination == "spin_out"
    assert by[("full_lock", "DLC120-v0")].metrics["itae"] < min(by[(n, "DLC120-v0")].metrics["itae"]
                                                                 for n in baselines)
    board = summarise(rows + zero + lock, LEADERBOARD_COLUMNS)
    for env_id in ("LateralTracking-v0", "DLC120-v0"):
        ranks = {e["policy_id"]: e["rank"] for e in board if e["env_id"] == env_id}
        worst_baseline = max(ranks[n] for n in baselines)
        assert ranks["zero_steering"] > worst_baseline and ranks["full_lock"] > worst_baseline, (env_id, ranks)


# ------------------------------------------------------------------------------------------ uncertainty
def test_bootstrap_interval_rules() -> None:
    values = [float(v) for v in range(10)]
    e = estimate(values)
    assert isinstance(e, Estimate) and e == 4.5
    half = 1.96 * np.std(values) / math.sqrt(len(values))  # the normal approximation of the same interval
    assert e.lo == pytest.approx(4.5 - half, abs=0.3) and e.hi == pytest.approx(4.5 + half, abs=0.3)
    from vtrack_gym.evaluation.leaderboard import board

    board._bootstrap_ci.cache_clear()
    again = estimate(values)
    assert (again.lo, again.hi) == (e.lo, e.hi)  # fixed generator seed: reproducible
    one = estimate([0.3])
    assert one == 0.3 and math.isnan(one.lo) and math.isnan(one.hi)  # one episode: no interval
    flat = estimate([0.2, 0.2, 0.2])
    assert (flat.lo, flat.hi) == (0.2, 0.2)  # zero variance: the point value
    assert math.isnan(estimate([])) and math.isnan(estimate([1.0, None]))


def test_ties_are_reported() -> None:
    records = [record("a", s, 0.10 + 0.02 * s) for s in range(5)] + [record("b", s, 0.11 + 0.02 * s)
                                                                      for s in range(5)]
    records += [record("c", s, 0.9 + 0.01 * s) for s in range(5)]
    board = build_board(records, COLUMNS)
    notes = {e["policy_id"]: e["tied_with"] for e in board}
    assert notes == {"a": "b", "b": "a", "c": ""}
    twins = build_board([record("a", 0, 0.1), {**record("a", 0, 0.1), "policy_hash": "other"}], COLUMNS)
    assert sorted(e["tied_with"] for e in twins) == ["a@ha", "a@other"]
    presets = build_board([{**record("s", 0, 0.1), "policy_preset": p, "policy_hash": p} for p in ("default", "paper")],
                          COLUMNS)
    assert sorted(e["tied_with"] for e in presets) == ["s", "s:paper"]


def test_every_format_shows_the_intervals(tmp_path: Path) -> None:
    from vtrack_gym.evaluation.leaderboard.html_report import to_html

    board = build_board([record("a", s, 0.1 * (s + 1)) for s in range(3)], COLUMNS)
    e = board[0]["max_e_y_m"]
    cell = f"0.2 [{e.lo:.3g}, {e.hi:.3g}]"
    assert e.lo < 0.2 < e.hi
    assert cell in to_markdown(board) and cell in to_latex(board) and cell in to_html(board)
    parsed = next(csv.DictReader(io.StringIO(to_csv(board))))
    assert float(parsed["max_e_y_m_lo"]) == e.lo and float(parsed["max_e_y_m_hi"]) == e.hi
    data = json.loads(to_json(board))[0]
    assert (data["max_e_y_m"], data["max_e_y_m_lo"], data["max_e_y_m_hi"]) == (pytest.approx(0.2), e.lo, e.hi)
    assert data["success_rate"] == 1.0 and data["success_rate_lo"] == 1.0


def test_primary_metric_per_suite() -> None:
    assert [primary_metric(s) for s in ("paper", "robust", "highway", "custom")] == [
        "max_e_y_m", "max_e_y_m", "itae", "max_e_y_m"]


def test_seed_syntax() -> None:
    assert _parse_seeds("0-9") == list(range(10)) and _parse_seeds("0,3,5") == [0, 3, 5]
    assert _parse_seeds("0-2, 2, 7") == [0, 1, 2, 7]
    for bad in ("a", "3-1", "-1", "1-", "0-99999", ","):
        with pytest.raises(ValueError, match="--seeds"):
            _parse_seeds(bad)


def test_eval_over_seeds_prints_intervals(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = str(tmp_path / "s.sqlite")
    assert main(["eval", "--policy", "lqr", "--env", "LateralTracking-v0", "--seeds", "0-2", "--store", store]) == 0
    out = capsys.readouterr().out
    assert "| 0 | completed | 1 |" in out and "| 2 | completed | 1 |" in out
    summary = out.split("\n\n")[-1]
    assert "| LateralTracking-v0 | lqr |" in summary and "| 1 | 3 | 1 [1, 1] |" in summary  # rank, episodes, success
    assert main(["leaderboard", "--suite", "custom", "--store", store, "--format", "csv"]) == 0
    parsed = list(csv.DictReader(io.StringIO(capsys.readouterr().out)))
    assert len(parsed) == 1 and parsed[0]["episodes"] == "3" and parsed[0]["max_e_y_m_lo"] != ""


def test_benchmark_seeds_paper_suite_is_deterministic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two seeds of the paper suite give identical episodes (no noise), so every interval is the point value."""
    assert main(["benchmark", "--policies", "stanley", "--seeds", "0-1", "--no-figures", "--format", "json",
                 "--store", str(tmp_path / "s.sqlite")]) == 0
    board = json.loads(capsys.readouterr().out)
    assert [(e["env_id"], e["episodes"]) for e in board] == [("DLC120-v0", 2), ("LateralTracking-v0", 2)]
    lateral = board[1]
    assert lateral["success_rate"] == 1.0
    assert lateral["max_e_y_m_lo"] == lateral["max_e_y_m"] == lateral["max_e_y_m_hi"]
