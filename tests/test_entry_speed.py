"""The per-policy entry-speed search on ISO 3888 (evaluation.rollouts.entry_speed): the bisection against judges with a
known threshold, real baselines against the car's physical bound, the CLI, the maneuvers suite's columns, bad input."""

from __future__ import annotations

import json
import math

import pytest

import vtrack_gym
from vtrack_gym.evaluation.rollouts import entry_speed as es
from vtrack_gym.evaluation.rollouts.entry_speed import bisect_entry_speed, planned_probes


def threshold_judge(threshold_kmh: float, calls: list[float] | None = None):
    """Passes every speed up to ``threshold_kmh`` (inclusive), fails above with reason ``cones_hit``."""
    def judge(speed: float) -> tuple[bool, str]:
        if calls is not None:
            calls.append(speed)
        return (speed <= threshold_kmh, "" if speed <= threshold_kmh else "cones_hit")
    return judge


# ----------------------------------------------------------------------------------------------- the bisection
def test_bisection_finds_the_grid_point_below_a_known_threshold_exactly() -> None:
    # lo 40, hi 72, tol 0.5: the probes lie on the grid 40 + 32 k / 64 = 40 + 0.5 k, so the answer is exact
    calls: list[float] = []
    found = bisect_entry_speed(threshold_judge(57.3, calls), 40.0, 72.0, tol_kmh=0.5, checks=0)
    assert found.max_pass_kmh == 57.0
    assert not found.capped and found.monotone
    assert calls[:3] == [40.0, 72.0, 56.0]            # lo, hi, then the midpoint
    assert len(calls) == planned_probes(40.0, 72.0, 0.5, 0) == 2 + 6
    assert all(p.passed == (p.speed_kmh <= 57.3) for p in found.probes)
    assert {p.reason for p in found.probes if not p.passed} == {"cones_hit"}


@pytest.mark.parametrize("threshold", [33.3, 41.0, 50.01, 66.6, 79.99])
def test_bisection_brackets_any_threshold_within_the_tolerance(threshold: float) -> None:
    found = bisect_entry_speed(threshold_judge(threshold), 30.0, 80.0, tol_kmh=0.25, checks=3)
    assert found.max_pass_kmh is not None
    assert found.max_pass_kmh <= threshold < found.max_pass_kmh + 0.25
    lowest_fail = min(p.speed_kmh for p in found.probes if not p.passed)
    assert lowest_fail - found.max_pass_kmh <= 0.25
    assert found.monotone
    checks = [p for p in found.probes if p.stage == "check"]
    assert len(checks) == 3 and all(30.0 < p.speed_kmh < found.max_pass_kmh for p in checks)


def test_bisection_edges_nothing_passes_and_everything_passes() -> None:
    none = bisect_entry_speed(threshold_judge(10.0), 30.0, 80.0, tol_kmh=0.5)
    # a fail at lo is looked into: four speeds evenly inside the range, then hi
    assert none.max_pass_kmh is None and [p.speed_kmh for p in none.probes] == [30.0, 40.0, 50.0, 60.0, 70.0, 80.0]
    capped = bisect_entry_speed(threshold_judge(150.0), 30.0, 80.0, tol_kmh=0.5, checks=2)
    assert capped.capped and capped.max_pass_kmh == 80.0
    assert [p.stage for p in capped.probes] == ["lo", "hi", "check", "check"]


def test_bisection_reports_a_non_monotone_verdict() -> None:
    def judge(speed: float) -> tuple[bool, str]:   # fails in a window well below its highest passing speed
        return (speed <= 60.0 and not 42.0 < speed < 48.0, "spin_out")

    found = bisect_entry_speed(judge, 30.0, 80.0, tol_kmh=0.5, checks=3)
    assert found.max_pass_kmh is not None and 59.5 < found.max_pass_kmh <= 60.0
    assert not found.monotone
    assert any(p.stage == "check" and not p.passed for p in found.probes)


def test_a_fail_at_the_lowest_speed_does_not_hide_a_pass_further_up() -> None:
    """Passing only in a window (35, 58.3] km/h, as a controller that clips a cone at low speed would."""
    def judge(speed: float) -> tuple[bool, str]:
        return (35.0 < speed <= 58.3, "cones_hit")

    found = bisect_entry_speed(judge, 30.0, 80.0, tol_kmh=0.5, checks=2)
    assert [p.stage for p in found.probes[:6]] == ["lo", "scan", "scan", "scan", "scan", "scan"]
    assert found.max_pass_kmh is not None and 57.8 < found.max_pass_kmh <= 58.3
    assert not found.monotone and not found.capped


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"lo_kmh": 80.0, "hi_kmh": 40.0}, "lo_kmh must be below hi_kmh"),
    ({"lo_kmh": 40.0, "hi_kmh": 250.0}, "hi_kmh must be a number in (0, 200]"),
    ({"lo_kmh": 0.0, "hi_kmh": 40.0}, "lo_kmh must be a number in (0, 200]"),
    ({"lo_kmh": 40.0, "hi_kmh": 80.0, "tol_kmh": 0.0}, "tol_kmh must be in [0.01, hi_kmh - lo_kmh"),
    ({"lo_kmh": 40.0, "hi_kmh": 80.0, "tol_kmh": 1e-300}, "tol_kmh must be in [0.01, hi_kmh - lo_kmh"),
    ({"lo_kmh": 40.0, "hi_kmh": 80.0, "checks": 11}, "checks must be an integer in [0, 10]"),
])
def test_bisection_refuses_bad_bounds(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        bisect_entry_speed(threshold_judge(50.0), **kwargs)


# ------------------------------------------------------------------------------------- the public entry point
def test_a_pass_above_the_physical_bound_is_flagged_not_clipped(monkeypatch: pytest.MonkeyPatch) -> None:
    """A judge that passes up to 1.1 x the bound (a policy cutting through the physics): reported as found."""
    bound = es.entry_speed_bound("vtrack/ISO3888-2-v1")
    monkeypatch.setattr(es, "judge_entry_speed",
                        lambda make, env_id, speed, *a: threshold_judge(1.1 * bound)(speed))
    found = vtrack_gym.max_entry_speed_kmh("stanley", "vtrack/ISO3888-2-v1", tol_kmh=0.5, checks=1)
    assert found.above_physical_bound
    assert 1.1 * bound - 0.5 < found.max_entry_speed_kmh <= 1.1 * bound
    assert found.entry_speed_fraction == pytest.approx(found.max_entry_speed_kmh / bound)
    assert found.metrics()["above_physical_bound"] == 1


def test_entry_speed_bounds_of_the_shipped_cars() -> None:
    """The bound is the feasibility module's on the least-curvature line (hatchback 67.4, SUV 66.6, sports 71.7
    km/h on ISO 3888-2, coasting); ISO 3888-1 holds the throttle, which keeps the speed up through the gates, so its
    bound is below the coasting one on the same line."""
    from vtrack_gym.tracks.feasibility import entry_speed_bound_kmh
    from vtrack_gym.vehicle.params import VehicleParams

    assert es.entry_speed_bound("vtrack/ISO3888-2-v1") == pytest.approx(67.42, abs=0.05)
    assert es.entry_speed_bound("ISO3888-2-v1", "suv") == pytest.approx(66.64, abs=0.05)
    assert es.entry_speed_bound("vtrack/ISO3888-2-v1", "sports") == pytest.approx(71.74, abs=0.05)
    held = es.entry_speed_bound("vtrack/ISO3888-1-v1")
    assert held < entry_speed_bound_kmh(VehicleParams(), "iso3888_1", "coast")


def test_a_real_baseline_stays_below_the_bound_and_passes_at_the_speed_it_reports() -> None:
    found = vtrack_gym.max_entry_speed_kmh("stanley", "vtrack/ISO3888-2-v1", tol_kmh=2.0, checks=1)
    assert found.env_id == "vtrack/ISO3888-2-v1" and found.policy_id == "stanley"
    assert found.max_entry_speed_kmh is not None, [(p.speed_kmh, p.reason) for p in found.probes]
    assert found.max_entry_speed_kmh <= found.entry_speed_bound_kmh + 2.0
    assert not found.above_physical_bound
    passed, reason = es.judge_entry_speed(es._factory("stanley")[0], "vtrack/ISO3888-2-v1",
                                          found.max_entry_speed_kmh)
    assert passed, reason
    fails = [p for p in found.probes if not p.passed]
    assert fails and all(p.reason in {"cones_hit", "spin_out", "off_track", "env_verdict", "time_limit"}
                         for p in fails)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"env_id": "vtrack/DLC120-v0"}, "env_id must be an ISO 3888 env taking entry_speed_kmh"),
    ({"env_id": "vtrack/ISO4138-Circle-v0"}, "env_id must be an ISO 3888 env"),
    ({"lo_kmh": 70.0, "hi_kmh": 50.0}, "lo_kmh must be below hi_kmh"),
    ({"hi_kmh": 201.0}, r"hi_kmh must be a number in \(0, 200\] km/h"),
    ({"lo_kmh": -5.0}, r"lo_kmh must be a number in \(0, 200\] km/h"),
    ({"seed": -1}, "seed must be an integer >= 0"),
])
def test_max_entry_speed_refuses_bad_input(kwargs: dict, message: str) -> None:
    env_id = kwargs.pop("env_id", "vtrack/ISO3888-2-v1")
    with pytest.raises(ValueError, match=message):
        vtrack_gym.max_entry_speed_kmh("stanley", env_id, **kwargs)


# ------------------------------------------------------------------------------------------------------ the CLI
def test_cli_entry_speed_json(capsys: pytest.CaptureFixture[str]) -> None:
    from vtrack_gym.cli import main

    assert main(["entry-speed", "--policy", "stanley", "--tol-kmh", "2", "--checks", "0", "--format", "json"]) == 0
    captured = capsys.readouterr()
    (result,) = json.loads(captured.out)
    assert result["policy_id"] == "stanley" and result["env_id"] == "vtrack/ISO3888-2-v1"
    assert result["entry_speed_bound_kmh"] == pytest.approx(67.4, abs=0.05)
    assert result["max_entry_speed_kmh"] <= result["entry_speed_bound_kmh"] + 2.0
    assert result["entry_speed_fraction"] == pytest.approx(result["max_entry_speed_kmh"]
                                                           / result["entry_speed_bound_kmh"])
    assert result["above_physical_bound"] is False
    assert len(result["probes"]) <= planned_probes(result["lo_kmh"], result["hi_kmh"], 2.0, 0)
    assert "physical entry-speed bound 67.4 km/h" in captured.err


@pytest.mark.parametrize(("argv", "message"), [
    (["--hi-kmh", "250"], "argument --hi-kmh: must be a number in [0.01, 200]"),
    (["--lo-kmh", "80", "--hi-kmh", "60"], "lo_kmh must be below hi_kmh"),
    (["--env", "vtrack/DLC120-v0"], "argument --env: invalid choice"),
    (["--checks", "20"], "argument --checks: must be an integer in [0, 10]"),
])
def test_cli_entry_speed_refuses_bad_input(argv: list[str], message: str,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    from vtrack_gym.cli import main

    try:
        code = main(["entry-speed", "--policy", "stanley", *argv])
    except SystemExit as exc:   # argparse refuses the option itself
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err


# ----------------------------------------------------------------------------------------- the maneuvers suite
def test_maneuvers_suite_json_rows_carry_the_entry_speed_columns(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "board.sqlite"
    assert main(["benchmark", "--suite", "maneuvers", "--policies", "stanley", "--no-figures", "--workers", "1",
                 "--format", "json", "--store", str(store)]) == 0
    board = json.loads(capsys.readouterr().out)
    by_env = {e["env_id"]: e for e in board}
    searched = [env_id for env_id in by_env if env_id in es.ENTRY_SPEED_ENV_IDS]
    assert searched == ["vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2"]   # the suite runs the current versions
    for env_id in searched:
        entry = by_env[env_id]
        assert entry["entry_speed_bound_kmh"] == pytest.approx(es.entry_speed_bound(env_id), abs=1e-6)
        if entry["max_entry_speed_kmh"] is None:   # no probed speed passed (the -v2 lines keep 2 cm to the cones)
            assert entry["entry_speed_fraction"] is None
            continue
        assert entry["max_entry_speed_kmh"] <= entry["entry_speed_bound_kmh"] + es.DEFAULT_TOL_KMH
        assert entry["entry_speed_fraction"] == pytest.approx(entry["max_entry_speed_kmh"]
                                                              / entry["entry_speed_bound_kmh"])
        assert entry["above_physical_bound"] == 0
    others = [e for e in board if e["env_id"] not in es.ENTRY_SPEED_ENV_IDS]
    assert others and all(e["max_entry_speed_kmh"] is None for e in others)
    rows = {r["env_id"]: r for r in ResultStore(store, read_only=True).rows("maneuvers")}
    metrics = rows["vtrack/ISO3888-2-v2"]["metrics"]
    assert set(metrics) >= {"max_entry_speed_kmh", "entry_speed_probes", "entry_speed_monotone"}
    stored, shown = metrics["max_entry_speed_kmh"], by_env["vtrack/ISO3888-2-v2"]["max_entry_speed_kmh"]
    assert (stored is None or math.isnan(stored)) if shown is None else math.isclose(stored, shown)


# ------------------------------------------------------------------------------------------ rows and the board
def _row(success: bool, **metrics: float):
    from vtrack_gym.evaluation.storage.store import ResultRow

    return ResultRow(suite="maneuvers", env_id="vtrack/ISO3888-2-v1", policy_id="p", policy_hash="h", seed=0,
                     metrics={"max_e_y_m": 0.1, **metrics}, termination="completed", wall_time_per_step_s=1e-4,
                     success=success)


def test_the_store_refuses_entry_speed_metrics_outside_their_physical_range(tmp_path) -> None:
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = ResultStore(tmp_path / "s.sqlite")
    for bad, message in (({"max_entry_speed_kmh": 250.0}, r"max_entry_speed_kmh' must be in \[0, 200\]"),
                         ({"entry_speed_bound_kmh": -1.0}, r"entry_speed_bound_kmh' must be in \[0, 200\]"),
                         ({"entry_speed_fraction": -0.1}, "entry_speed_fraction' must be a number >= 0"),
                         ({"above_physical_bound": 2}, "above_physical_bound' must be 0 or 1")):
        with pytest.raises(ValueError, match=message):
            store.add([_row(True, **bad)])
    store.add([_row(True, max_entry_speed_kmh=61.0, entry_speed_bound_kmh=67.4, entry_speed_fraction=61.0 / 67.4,
                    above_physical_bound=0)])
    assert store.rows("maneuvers")[0]["metrics"]["max_entry_speed_kmh"] == 61.0


def test_the_board_aggregates_the_search_over_failed_episodes_too() -> None:
    """The row's verdict is at the default entry speed; the search's figures describe the policy at every speed."""
    from vtrack_gym.evaluation.benchmarking.benchmark import suite_columns, summarise

    failed = _row(False, max_entry_speed_kmh=58.0, entry_speed_bound_kmh=67.4, entry_speed_fraction=58.0 / 67.4,
                  above_physical_bound=0, cones_hit=1)
    (entry,) = summarise([failed], suite_columns("maneuvers"))
    assert entry["success_rate"] == 0.0
    assert entry["max_entry_speed_kmh"] == 58.0 and entry["entry_speed_fraction"] == pytest.approx(58.0 / 67.4)
    assert math.isnan(entry["max_e_y_m"])          # an episode metric: successful episodes only


def test_evaluate_on_the_maneuvers_suite_gives_the_benchmarks_entry_speed_metrics() -> None:
    """``vtrack_gym.evaluate(make, "maneuvers")`` scores like ``vtrack benchmark --suite maneuvers``: the search's
    metrics on the ISO 3888 rows, none on the others, the row's verdict at the id's default speed."""
    from vtrack_gym.baselines.resolve import policy_factory

    rows = {r.env_id: r for r in vtrack_gym.evaluate(policy_factory("lqr"), "maneuvers", policy_id="lqr")}
    searched = [env_id for env_id in rows if env_id in es.ENTRY_SPEED_ENV_IDS]
    assert searched == ["vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2"]
    for env_id in searched:
        m = rows[env_id].metrics
        assert m["entry_speed_bound_kmh"] == pytest.approx(es.entry_speed_bound(env_id), abs=1e-6)
        probes = dict(p.rsplit(":", 1) for p in m["entry_speed_probes"].split(","))
        if m.get("max_entry_speed_kmh") is None or math.isnan(m["max_entry_speed_kmh"]):
            assert "pass" not in probes.values()   # no probed speed passed (the -v2 lines keep 2 cm to the cones)
            continue
        assert m["max_entry_speed_kmh"] <= m["entry_speed_bound_kmh"] and m["above_physical_bound"] == 0
        assert probes[f"{m['max_entry_speed_kmh']:.2f}"] == "pass"
    assert all("max_entry_speed_kmh" not in r.metrics for e, r in rows.items() if e not in es.ENTRY_SPEED_ENV_IDS)


def test_two_entry_speeds_or_reference_lines_never_share_a_leaderboard_row(tmp_path) -> None:
    """An env made with another entry speed or reference line records it; the default records nothing extra."""
    import gymnasium as gym

    store = tmp_path / "board.sqlite"
    settings = ({}, {"entry_speed_kmh": 50.0}, {"entry_speed_kmh": 45.0}, {"reference": "lane_centres"})
    for kwargs in settings:
        rows = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("lqr", env),
                                   gym.make("vtrack/ISO3888-2-v1", **kwargs), store=store, policy_id="lqr")
        recorded = rows[0].options.get("protocol")
        assert recorded == ({k: v for k, v in kwargs.items() if v != 50.0} or None)
    board = vtrack_gym.leaderboard(store, suite="custom")
    assert len(board) == 3   # the default and an explicit 50 km/h are one setting; 45 km/h and lane centres apart
