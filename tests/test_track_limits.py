"""Track limits as a declared rule (``track_limits="wheels" | "body" | "centre"``), through the ways a user reaches
them: the make kwarg (``gym.make("vtrack/Track-v0", track=..., track_limits=...)``), ``info["cost"]`` and
``info["edge_margin_m"]``, the leaderboard row's metrics and identity, and ``vtrack eval --track FILE --track-limits
RULE``."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.cli import main
from vtrack_gym.tracks import Path as TrackPath
from vtrack_gym.vehicle import load_vehicle

HALF_WIDTH_M = 1.0
SPEED_MPS = 8.0


def _road() -> TrackPath:
    """A straight open road 2 m wide, 120 m long."""
    return TrackPath.from_points(np.linspace(0.0, 120.0, 61), np.zeros(61), half_width_m=HALF_WIDTH_M)


def _drive_straight(env_id: str, offset_m: float, **kwargs: object) -> tuple[dict, dict, list[dict]]:
    """Steer straight ahead from ``offset_m`` left of the centre line; (last info, success metrics, step infos)."""
    env = gym.make(env_id, track=_road(), speed_profile=SPEED_MPS, **kwargs)
    _, info = env.reset(seed=0, options={"initial_lateral_offset_m": offset_m})
    infos = []
    done = False
    while not done:
        _, _, term, trunc, info = env.step(np.zeros(1, dtype=np.float32))
        infos.append(info)
        done = term or trunc
    metrics = env.unwrapped.success_metrics()
    env.close()
    return info, metrics, infos


def test_rules_on_a_straight_road_driven_off_centre() -> None:
    """0.8 m left of centre on a 1 m half width: the CG and the right wheels are on the road, the body's left side
    is 0.758 m beyond the edge (hatchback: half body width 0.958 m, half track 0.8375 m)."""
    chassis = load_vehicle("hatchback").chassis
    body_out = 0.8 + chassis.body_width_m / 2 - HALF_WIDTH_M
    for rule, passes in (("wheels", True), ("centre", True), ("body", False)):
        info, metrics, infos = _drive_straight("vtrack/Track-v0", 0.8, track_limits=rule)
        assert info["termination"] == "completed", rule
        assert info["success"] is passes, rule
        assert metrics["track_limit_violations"] == (0.0 if passes else 1.0), rule
        assert metrics["min_edge_margin_m"] == pytest.approx(-body_out, abs=2e-3), rule
        costs = np.array([i["cost"] for i in infos])
        assert (costs == (0.0 if passes else 1.0)).all(), rule   # the body is out on every step
        margins = np.array([i["edge_margin_m"] for i in infos])
        assert margins.min() == pytest.approx(-body_out, abs=2e-3)


def test_all_four_wheels_off_is_an_excursion_and_the_episode_goes_on() -> None:
    """1.9 m left of centre: the right wheels (0.8375 m right of the CG) are 0.06 m beyond the edge too, so all
    four are off: one excursion; the whole car is not off, so the lap goes on to the end, where Track-v0's own
    rule (the centre) ends it off_road at the first step."""
    info, metrics, _ = _drive_straight("vtrack/Track-v0", 1.9, track_limits="wheels")
    assert info["termination"] == "completed" and info["success"] is False
    assert metrics["track_limit_violations"] == 1.0
    info_v0, _, infos_v0 = _drive_straight("vtrack/Track-v0", 1.9)
    assert info_v0["termination"] == "off_road" and len(infos_v0) == 1 and infos_v0[0]["cost"] == 1.0


def test_each_excursion_is_counted() -> None:
    """Weaving across the left edge line twice: two excursions of all four wheels."""
    env = gym.make("vtrack/Track-v0", track=_road(), speed_profile=SPEED_MPS, track_limits="wheels")
    env.reset(seed=0, options={"initial_lateral_offset_m": 0.0})
    layout = env.unwrapped.observation_layout
    targets = [0.0, 1.95, 0.0, 1.95, 0.0]        # e_y targets [m], 24 m of road each
    done, costs = False, []
    while not done:
        station = env.unwrapped._sim.station_m[0]
        target = targets[min(int(station // 24.0), len(targets) - 1)]
        obs = env.unwrapped._obs_row
        action = np.clip(-0.4 * (obs[layout.index("e_y")] - target) - 1.2 * obs[layout.index("e_phi")], -1, 1)
        _, _, term, trunc, info = env.step(np.array([action], dtype=np.float32))
        costs.append(info["cost"])
        done = term or trunc
    metrics = env.unwrapped.success_metrics()
    assert info["termination"] == "completed" and info["success"] is False
    rises = int(np.count_nonzero(np.diff(np.concatenate(([0.0], costs))) > 0))
    assert metrics["track_limit_violations"] == 2.0 == rises


def test_track_limits_is_refused_where_the_rule_is_not_the_road() -> None:
    with pytest.raises(ValueError, match="track_limits must be one of wheels, body, centre"):
        gym.make("vtrack/Track-v0", track=_road(), track_limits="kerbs")
    with pytest.raises(ValueError, match="track_limits applies to the ids that drive a road"):
        gym.make("vtrack/ISO4138-Circle-v0", track_limits="body")
    with pytest.raises(ValueError, match="cone gates"):
        gym.make("vtrack/DLC120-v0", track_limits="body")


def test_pinned_id_with_centre_keeps_its_verdict_and_reports_the_margin() -> None:
    """Track-v0's own rule made explicit: the same episode, now with the two metrics."""
    plain, plain_metrics, _ = _drive_straight("vtrack/Track-v0", 0.5)
    ruled, metrics, _ = _drive_straight("vtrack/Track-v0", 0.5, track_limits="centre")
    assert plain["success"] is ruled["success"] is True and plain_metrics == {}
    assert plain["progress_m"] == ruled["progress_m"]
    assert metrics["track_limit_violations"] == 0.0 and metrics["min_edge_margin_m"] < 0.0


def test_cli_track_limits_is_recorded_with_the_row(tmp_path: Path) -> None:
    x = np.linspace(0.0, 150.0, 76)
    file = tmp_path / "road.csv"
    file.write_text("x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "".join(f"{a:.1f},0.0,2.0,2.0\n" for a in x))
    store = tmp_path / "s.db"
    for rule in ("body", "wheels", None):
        argv = ["eval", "--policy", "stanley", "--track", str(file), "--store", str(store)]
        assert main(argv + (["--track-limits", rule] if rule else [])) == 0
    from vtrack_gym.evaluation.storage.store import ResultStore

    body, wheels, default = ResultStore(store, read_only=True).rows()
    assert body["options"]["protocol"] == {"track_limits": "body"}
    assert wheels["options"]["protocol"] == {"track_limits": "wheels"}
    assert "protocol" not in default["options"] and "track_limit_violations" not in default["metrics"]
    assert len({body["env_id"], wheels["env_id"], default["env_id"]}) == 3
    for row in (body, wheels):
        assert row["metrics"]["track_limit_violations"] == 0.0 and row["success"]
        assert row["metrics"]["min_edge_margin_m"] == pytest.approx(2.0 - 0.958, abs=0.02)   # on the centre line
    with pytest.raises(SystemExit):
        main(["eval", "--policy", "stanley", "--track", str(file), "--track-limits", "kerbs"])


def test_cli_benchmark_tracks_takes_the_rule(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "tracks"
    folder.mkdir()
    x = np.linspace(0.0, 150.0, 76)
    rows = "".join(f"{a:.1f},0.0,2.0,2.0\n" for a in x)
    (folder / "road.csv").write_text("x_m,y_m,w_tr_right_m,w_tr_left_m\n" + rows)
    store = tmp_path / "s.db"
    assert main(["benchmark", "--tracks", str(folder), "--policies", "stanley", "--track-limits", "body",
                 "--no-figures", "--workers", "1", "--store", str(store)]) == 0
    from vtrack_gym.evaluation.storage.store import ResultStore

    (row,) = ResultStore(store, read_only=True).rows()
    assert row["options"]["protocol"] == {"track_limits": "body"} and row["metrics"]["track_limit_violations"] == 0.0
    # the rule without a track: refused before any episode, as a user typing it sees it
    assert main(["benchmark", "--policies", "stanley", "--track-limits", "body", "--no-figures",
                 "--store", str(tmp_path / "other.db")]) == 2
    assert "--track-limits applies to --track FILE or --tracks" in capsys.readouterr().err
    assert not (tmp_path / "other.db").exists()
