"""Tracking in time: the speed error, the time lag behind the timed reference, the longitudinal ISO 2631-1 comfort
value and lap times, checked against analytic cases and independent computations from recorded episodes, through
the public entry points (``vtrack_gym.evaluate``, ``rollout``, ``vtrack eval`` / ``vtrack benchmark``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.benchmarking.benchmark import LEADERBOARD_COLUMNS, TIMING_COLUMNS
from vtrack_gym.evaluation.rollouts.rollout import rollout, rollout_batch
from vtrack_gym.evaluation.scoring import iso2631
from vtrack_gym.evaluation.scoring.laps import lap_crossing_times, lap_metrics, lap_times
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace, timing_metrics
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore
from vtrack_gym.tracks import CurvatureLimited, speed_table

ROOT = Path(__file__).resolve().parents[1]
CLUB = ROOT / "own_tracks" / "club.csv"
PROFILE = CurvatureLimited(max_speed_mps=12.0, max_lateral_accel_mps2=5.0)


# ----------------------------------------------------------------------------------------------- laps, analytic
def test_lap_time_at_constant_speed_on_a_circle_is_two_pi_r_over_v() -> None:
    radius, v, dt = 37.0, 13.7, 0.04   # the lap time 16.969... s is no multiple of the control period
    period = 2.0 * math.pi * radius / v
    t = dt * np.arange(1, int(3.4 * period / dt))
    laps = lap_times(t, v * t, 2.0 * math.pi * radius)
    assert laps.size == 3
    np.testing.assert_allclose(laps, period, rtol=1e-6)
    crossings = lap_crossing_times(t, v * t, 2.0 * math.pi * radius)
    np.testing.assert_allclose(crossings, period * np.arange(1, 4), rtol=1e-6)


def test_lap_crossing_counts_the_first_crossing_and_refuses_bad_input() -> None:
    # forward to 12 m (past the 10 m line between t = 1 and 2 s), back to 8 m, forward again: one lap, crossed at 1.5 s
    t = np.array([1.0, 2.0, 3.0, 4.0])
    p = np.array([8.0, 12.0, 8.0, 13.0])
    np.testing.assert_allclose(lap_crossing_times(t, p, 10.0), [1.5])
    figures = lap_metrics(t, p, 10.0)
    assert figures["lap_times_s"] == [1.5] and figures["best_lap_s"] == figures["mean_lap_s"] == 1.5
    none = lap_metrics(t, p, 20.0)
    assert none["lap_times_s"] == [] and math.isnan(none["best_lap_s"]) and math.isnan(none["mean_lap_s"])
    with pytest.raises(ValueError, match="lap_length_m"):
        lap_times(t, p, 0.0)
    with pytest.raises(ValueError, match="same length"):
        lap_times(t, p[:2], 10.0)
    with pytest.raises(ValueError, match="time_s must increase"):
        lap_times(np.array([1.0, 1.0, 2.0, 3.0]), p, 10.0)


# ----------------------------------------------------------------------------------------------- a real circuit
def _independent_reference_time_s(path: object, s0: float, s1: float) -> float:
    """int_{s0}^{s1} ds / v_ref(s) by a fine trapezoid rule on the speed table's rows (v^2 linear between rows, as
    the env interpolates it; the profile evaluated again here), laps unrolled: not the time law's closed form."""
    table = speed_table(path, PROFILE)
    rows_s = np.arange(table.v_mps.size) * table.ds_m
    s = np.linspace(s0, s1, 400_001)
    inside = np.mod(s, table.length_m) if table.closed else s
    v = np.sqrt(np.interp(inside, rows_s, table.v_mps ** 2))
    return float(np.trapezoid(1.0 / v, s))


@pytest.fixture(scope="module")
def club_episode() -> tuple:
    """One lap of the club circuit with the PD-FLC following a curvature-limited profile, the mpc steering."""
    env = gym.make("vtrack/Track-v0", track=str(CLUB), speed_profile=PROFILE)
    trace = rollout(vtrack_gym.make_policy("mpc", env), env, seed=0)
    path = env.unwrapped.current_path
    env.close()
    return trace, evaluate_trace(trace), path


def test_speed_error_and_time_lag_on_a_circuit_with_a_profile(club_episode: tuple) -> None:
    trace, m, path = club_episode
    assert trace.completed and path.closed
    err = trace["v_mps"] - trace["target_speed_mps"]
    # Track-v0 starts from standstill under a profile that starts at speed: the peak error is the start's v_ref
    assert 0.0 < m["rms_e_v_mps"] < m["max_e_v_mps"] == pytest.approx(abs(err[0]), rel=1e-12)
    assert m["max_e_v_mps"] <= float(np.max(trace["target_speed_mps"]))
    assert float(np.median(np.abs(err))) < 0.5   # once up to speed the PD-FLC follows the profile closely
    # e_t = t_end - (T(s0 + progress) - T(s0)), T by an independent quadrature of 1 / v_ref
    s0 = trace.reference.start_station_m
    expected = trace["time_s"][-1] - _independent_reference_time_s(path, s0, s0 + trace["progress_m"][-1])
    assert m["time_lag_s"] == pytest.approx(expected, abs=1e-4)
    assert m["time_lag_s"] > 0.0   # the car starts below the profile's speed and lags it through the corners


def test_one_lap_is_timed_within_the_last_control_step(club_episode: tuple) -> None:
    trace, m, path = club_episode
    t, p = trace["time_s"], trace["progress_m"]
    assert p[-2] < path.length_m <= p[-1]   # one lap ends the episode
    lap = t[-2] + (path.length_m - p[-2]) / (p[-1] - p[-2]) * (t[-1] - t[-2])
    assert m["lap_times_s"] == [pytest.approx(lap, rel=1e-12)]
    assert t[-2] < m["best_lap_s"] == m["mean_lap_s"] <= t[-1]


def test_longitudinal_comfort_is_the_x_term_of_the_total_value(club_episode: tuple) -> None:
    trace, m, _ = club_episode
    acc, fs = trace.acc_physics_mps2, trace.physics_rate_hz
    assert m["comfort_a_wx_mps2"] == pytest.approx(iso2631.weighted_rms(acc[:, 0], fs, "Wd"), rel=1e-12)
    a_wy, a_wz = iso2631.weighted_rms(acc[:, 1], fs, "Wd"), iso2631.weighted_rms(acc[:, 2], fs, "Wk")
    assert m["comfort_a_v_mps2"] ** 2 == pytest.approx(m["comfort_a_wx_mps2"] ** 2 + a_wy ** 2 + a_wz ** 2, rel=1e-9)
    assert 0.0 < m["comfort_a_wx_mps2"] < m["comfort_a_v_mps2"]


# ----------------------------------------------------------------------------------------------- other envs
def test_rows_of_the_paper_lane_change_carry_the_timing_columns() -> None:
    row, = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("mpc", env), "DLC120-v0", seeds=[0])
    m = row.metrics
    assert row.verdict()
    for name in ("rms_e_v_mps", "max_e_v_mps", "time_lag_s", "comfort_a_wx_mps2"):
        assert math.isfinite(m[name]), name
    assert 0.0 < m["rms_e_v_mps"] <= m["max_e_v_mps"]
    assert "lap_times_s" not in m and "best_lap_s" not in m   # an open path: no laps


def test_the_vector_env_times_its_cars_as_the_single_env() -> None:
    env = gym.make("vtrack/LateralTracking-v0")   # a closed path at a held speed
    single = timing_metrics(rollout(vtrack_gym.make_policy("lqr", env), env, seed=0, max_steps=1500))
    batch, = rollout_batch(vtrack_gym.make_policy("lqr", env), "vtrack/LateralTracking-v0", [0], max_steps=1500)
    env.close()
    assert batch.reference is not None and batch.reference.closed
    assert batch.n_steps == 1500 and math.isfinite(single["time_lag_s"])
    assert timing_metrics(batch)["time_lag_s"] == pytest.approx(single["time_lag_s"], abs=1e-9)


def test_after_the_iso3888_entry_gate_the_speed_error_is_zero() -> None:
    env = gym.make("vtrack/ISO3888-2-v1")
    trace = rollout(vtrack_gym.make_policy("mpc", env), env, seed=0)
    gate = env.unwrapped.current_path.gates[0].s_start_m
    env.close()
    err = trace["v_mps"] - trace["target_speed_mps"]
    after = trace["station_m"] > gate + 1.0   # a step after the one that crossed the gate
    assert after.sum() > 10 and np.all(err[after] == 0.0)
    m = evaluate_trace(trace)
    assert m["max_e_v_mps"] == pytest.approx(float(np.max(np.abs(err[~after]))), rel=1e-12)
    assert math.isfinite(m["time_lag_s"]) and math.isfinite(m["comfort_a_wx_mps2"])


# ----------------------------------------------------------------------------------------------- store and CLI
def _row(metrics: dict, policy: str) -> ResultRow:
    return ResultRow("custom", "Track-v0", policy, f"h{policy}", 0, metrics, "completed", 1e-5, success=True)


def test_old_rows_without_the_new_columns_still_read(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.sqlite")
    old = {"max_e_y_m": 0.2, "rms_e_y_m": 0.05, "rms_speed_error_mps": 0.3}   # a row written before these columns
    new = {"max_e_y_m": 0.1, "rms_e_y_m": 0.04, "rms_e_v_mps": 0.25, "max_e_v_mps": 0.9, "time_lag_s": -0.4,
           "comfort_a_wx_mps2": 0.2, "lap_times_s": [61.5, 60.25], "best_lap_s": 60.25, "mean_lap_s": 60.875}
    store.add([_row(old, "old"), _row(new, "new")])
    stored = {r["policy_id"]: r["metrics"] for r in ResultStore(store.path, read_only=True).rows()}
    assert stored["new"]["lap_times_s"] == [61.5, 60.25] and stored["new"]["time_lag_s"] == -0.4
    board = {e["policy_id"]: e for e in store.leaderboard("custom", LEADERBOARD_COLUMNS)}
    assert board["new"]["best_lap_s"] == 60.25 and board["new"]["time_lag_s"] == -0.4
    assert all(math.isnan(board["old"][c]) for c in TIMING_COLUMNS)
    assert main(["leaderboard", "--store", str(store.path), "--suite", "custom", "--columns", "all"]) == 0


@pytest.mark.parametrize("bad", [[-1.0], ["61"], 61.5, [math.inf]])
def test_a_bad_lap_list_is_refused_naming_the_metric(tmp_path: Path, bad: object) -> None:
    with pytest.raises(ValueError, match="lap_times_s"):
        ResultStore(tmp_path / "s.sqlite").add([_row({"lap_times_s": bad}, "x")])
    with pytest.raises(ValueError, match="comfort_a_wx_mps2"):
        ResultStore(tmp_path / "s.sqlite").add([_row({"comfort_a_wx_mps2": -0.1}, "x")])


def test_cli_eval_and_benchmark_print_the_timing_columns(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = str(tmp_path / "s.sqlite")
    track = ["--track", str(CLUB), "--speed-profile", "curvature", "--max-speed-kmh", "43.2", "--max-lateral-g", "0.5"]
    assert main(["eval", "--policy", "lqr", *track, "--store", store]) == 0
    out = capsys.readouterr().out
    header = [c.strip() for c in next(x for x in out.splitlines() if x.startswith("| seed")).strip("|").split("|")]
    assert {"rms_e_v_mps", "max_e_v_mps", "time_lag_s", "comfort_a_wx_mps2", "best_lap_s", "mean_lap_s",
            "lap_times_s"} <= set(header)
    cells = dict(zip(header, (c.strip() for c in out.splitlines()[-1].strip("|").split("|")), strict=True))
    assert float(cells["lap_times_s"]) == pytest.approx(float(cells["best_lap_s"]), rel=1e-3)   # one lap, 3 digits
    assert main(["benchmark", *track, "--policies", "lqr", "--no-figures", "--store", store, "--columns", "all",
                 "--format", "json"]) == 0
    entry, = json.loads(capsys.readouterr().out)
    assert set(TIMING_COLUMNS) <= set(entry)
    assert entry["best_lap_s"] > 0.0 and entry["rms_e_v_mps"] > 0.0 and math.isfinite(entry["time_lag_s"])
    assert main(["leaderboard", "--store", store, "--suite", "custom", "--columns", "all"]) == 0
    md = capsys.readouterr().out
    assert all(f" {c} " in md for c in TIMING_COLUMNS)
