"""The evaluation workflow of a user with their own agent and tracks, through the CLI and the Python API:
figures belong to their run, ``vtrack_gym.leaderboard`` ranks what ``vtrack leaderboard`` ranks, a folder of tracks
is one suite, and episodes run in several local processes or on Ray with the rows of one process."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.benchmarking.benchmark import policy_factories, score_episode
from vtrack_gym.evaluation.benchmarking.track_benchmark import benchmark_tracks, track_files
from vtrack_gym.evaluation.figures.figure_runs import figure_runs, run_folder, safe_folder
from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask, run_tasks
from vtrack_gym.evaluation.scoring.metrics import CLOCK_MEASURED
from vtrack_gym.evaluation.storage.store import ResultStore
from vtrack_gym.evaluation.suite.suites import Episode

MEASURED = ("wall_time_s", "created_utc", "wall_time_per_step_us", "wall_time_per_step_us_lo",
            "wall_time_per_step_us_hi",
            *(f"{m}{suffix}" for m in CLOCK_MEASURED for suffix in ("", "_lo", "_hi")))
"""Fields measured from the clock: the only ones allowed to differ between two runs of the same episodes."""


def write_road(file: Path, radius_m: float, angle_deg: float, spacing_m: float = 2.0) -> Path:
    """An open road: 30 m straight, an arc of ``radius_m`` turning ``angle_deg`` (left positive), 30 m straight."""
    s = np.arange(0.0, 60.0 + radius_m * math.radians(abs(angle_deg)), spacing_m)
    arc_len = radius_m * math.radians(abs(angle_deg))
    kappa = np.where((s > 30.0) & (s <= 30.0 + arc_len), math.copysign(1.0 / radius_m, angle_deg), 0.0)
    psi = np.concatenate([[0.0], np.cumsum(kappa[1:] * np.diff(s))])
    x = np.concatenate([[0.0], np.cumsum(np.cos(psi[:-1]) * np.diff(s))])
    y = np.concatenate([[0.0], np.cumsum(np.sin(psi[:-1]) * np.diff(s))])
    file.write_text("x_m,y_m\n" + "\n".join(f"{a:.4f},{b:.4f}" for a, b in zip(x, y, strict=True)) + "\n")
    return file


@pytest.fixture(scope="module")
def tracks(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("my_tracks")
    for name, radius, angle in (("left", 40.0, 60.0), ("right", 30.0, -45.0), ("wide", 80.0, 30.0)):
        write_road(folder / f"{name}.csv", radius, angle)
    (folder / "notes.txt").write_text("not a track")
    return folder


def comparable(rows: list[Any]) -> list[dict[str, Any]]:
    """Rows (ResultRow or board dicts) without the clock-measured fields, NaN made comparable."""
    out = []
    for r in rows:
        d = dataclasses.asdict(r) if dataclasses.is_dataclass(r) else dict(r)
        if isinstance(d.get("metrics"), dict):
            d["metrics"] = {k: v for k, v in d["metrics"].items() if k not in MEASURED}
        out.append(json.loads(json.dumps({k: v for k, v in d.items() if k not in MEASURED}, default=str)
                              .replace("NaN", "null")))
    return out


# ------------------------------------------------------------------------------------ many tracks, many processes
def test_track_folder_and_glob_select_the_csv_files(tracks: Path) -> None:
    assert [f.name for f in track_files(tracks)] == ["left.csv", "right.csv", "wide.csv"]
    assert [f.name for f in track_files(str(tracks / "w*.csv"))] == ["wide.csv"]
    with pytest.raises(ValueError, match="no track file found"):
        track_files(str(tracks / "*.gpx"))


def test_tracks_in_two_processes_give_the_rows_of_one(tracks: Path) -> None:
    factories = policy_factories(["lqr", "stanley"])
    serial = benchmark_tracks(tracks, factories, workers=1)
    forked = benchmark_tracks(tracks, factories, workers=2)
    assert len(serial["rows"]) == 6 and serial["suite"].startswith("tracks[my_tracks")
    assert comparable(forked["rows"]) == comparable(serial["rows"])
    assert {r.options["track_file"] for r in serial["rows"]} == {"left.csv", "right.csv", "wide.csv"}
    board = vtrack_gym.leaderboard(serial["rows"])
    pooled = [e for e in board if e["env_id"] == "all 3 tracks"]
    assert len(pooled) == 2 and len(board) == 2 + 6  # across tracks, then per track
    for entry in pooled:
        per_track = [e for e in board if e["policy_id"] == entry["policy_id"] and e is not entry]
        assert entry["episodes"] == 3
        assert entry["success_rate"] == pytest.approx(np.mean([e["success_rate"] for e in per_track]))
        assert entry["success_rate_lo"] <= entry["success_rate"] <= entry["success_rate_hi"]


def test_progress_counts_every_episode_across_workers() -> None:
    class Counter:
        n = 0

        def update(self, k: int) -> None:
            self.n += k

    make = policy_factories(["lqr"])["lqr"]
    tasks = [EpisodeTask("lqr", make, Episode("DLC120-v0", s), "custom", score_episode) for s in (0, 1, 2)]
    bar = Counter()
    results = run_tasks(tasks, workers=2, progress=bar)
    assert bar.n == 3 and [row.seed for row, _ in results] == [0, 1, 2]
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        run_tasks(tasks, workers=0)


def test_evaluate_with_workers_gives_the_rows_of_one_process() -> None:
    make = lambda env: vtrack_gym.make_policy("stanley", env)  # noqa: E731  (a closure: fine for local processes)
    one = vtrack_gym.evaluate(make, "DLC120-v0", seeds=[0, 1])
    two = vtrack_gym.evaluate(make, "DLC120-v0", seeds=[0, 1], workers=2)
    assert comparable(two) == comparable(one) and len({r.policy_hash for r in two}) == 1


def test_cli_tracks_workers_and_store(tracks: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    outputs = []
    for workers in ("1", "2"):
        store = tmp_path / f"w{workers}.sqlite"
        assert main(["benchmark", "--tracks", str(tracks), "--policies", "lqr", "--workers", workers,
                     "--no-figures", "--format", "json", "--store", str(store)]) == 0
        captured = capsys.readouterr()
        assert "3 track files of --tracks" in captured.err
        outputs.append(json.loads(captured.out))
    assert comparable(outputs[1]) == comparable(outputs[0])
    assert outputs[0][0]["env_id"] == "all 3 tracks" and len(outputs[0]) == 4
    (suite,) = ResultStore(tmp_path / "w1.sqlite", read_only=True).suites()
    assert main(["leaderboard", "--store", str(tmp_path / "w1.sqlite"), "--suite", suite, "--format", "json"]) == 0
    stored = json.loads(capsys.readouterr().out)
    assert comparable(stored) == comparable(outputs[0])
    assert comparable(vtrack_gym.leaderboard(tmp_path / "w1.sqlite", suite=suite)) == comparable(stored)
    assert main(["benchmark", "--tracks", str(tracks), "--suite", "paper"]) == 2
    assert "cannot be combined with --suite" in capsys.readouterr().err


def test_ray_backend_gives_the_rows_of_one_process(tracks: Path) -> None:
    os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        pytest.skip("Ray is already initialised in this process")
    factories = policy_factories(["lqr"])
    local = benchmark_tracks(str(tracks / "[lr]*.csv"), factories, workers=1)
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        remote = benchmark_tracks(str(tracks / "[lr]*.csv"), factories, backend="ray")
    finally:
        ray.shutdown()
    assert len(local["rows"]) == 2 and comparable(remote["rows"]) == comparable(local["rows"])


# ------------------------------------------------------------------------------------ the leaderboard API
def test_leaderboard_api_equals_the_cli_and_composes_with_evaluate(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "b.sqlite"
    mine = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("lqr", env), "DLC120-v0", seeds=[0, 1],
                               store=store, policy_id="my_agent")
    theirs = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("stanley", env), "DLC120-v0", seeds=[0, 1],
                                 store=store)
    from_rows = vtrack_gym.leaderboard(mine + theirs)
    from_store = vtrack_gym.leaderboard(store, suite="custom")
    assert [e["policy_id"] for e in from_rows] == [e["policy_id"] for e in from_store] and len(from_rows) == 2
    assert comparable(from_rows) == comparable(from_store)
    assert main(["leaderboard", "--store", str(store), "--suite", "custom", "--format", "json"]) == 0
    assert comparable(json.loads(capsys.readouterr().out)) == comparable(from_store)
    scored = [e for e in from_store if e["success_rate"] > 0]
    assert scored and all(e["max_e_y_m_lo"] <= e["max_e_y_m"] <= e["max_e_y_m_hi"] for e in scored)
    pd = pytest.importorskip("pandas")
    frame = vtrack_gym.leaderboard(store, suite="custom", as_frame=True)
    assert isinstance(frame, pd.DataFrame) and list(frame["policy_id"]) == [e["policy_id"] for e in from_store]
    with pytest.raises(ValueError, match="no suite 'paper'"):
        vtrack_gym.leaderboard(store)


# ------------------------------------------------------------------------------------ figures belong to their run
def test_run_folders_are_named_by_suite_policies_car_and_envs() -> None:
    a = run_folder("paper", ["smc", "lqr"])
    assert a.startswith("paper/lqr+smc-") and a == run_folder("paper", ["lqr", "smc", "smc"])
    assert len({a, run_folder("paper", ["lqr"]), run_folder("robust", ["smc", "lqr"]),
                run_folder("paper", ["smc", "lqr"], "sedan")}) == 4
    assert run_folder("paper", [f"p{i}" for i in range(9)]).startswith("paper/9-policies-")
    assert safe_folder(Path("root"), "../etc") is None and safe_folder(Path("root"), "/abs") is None
    shown = [{"id": 1, "options": {"figures": "x"}}, {"id": 3, "options": {"figures": "y"}}]
    stored = [*shown, {"id": 2, "options": {"figures": "x"}}]
    assert figure_runs(shown, stored) == ["y"]  # row 2 of run x is not on the board


def _captions(html: str) -> list[str]:
    return [part.split("</figcaption>")[0] for part in html.split("<figcaption>")[1:]]


def test_figures_of_two_runs_never_mix(tracks: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store, figures = tmp_path / "s.sqlite", tmp_path / "figs"
    common = ["benchmark", "--tracks", str(tracks / "left.csv"), "--store", str(store), "--figures", str(figures),
              "--workers", "1"]
    assert main([*common, "--policies", "lqr,stanley"]) == 0
    assert main([*common, "--policies", "lqr"]) == 0
    capsys.readouterr()
    runs = sorted(str(p.relative_to(figures)) for p in figures.glob("*/*") if p.is_dir())
    assert len(runs) == 2 and all(any((figures / r).glob("*.png")) for r in runs)  # the first was not replaced
    rows = ResultStore(store, read_only=True).rows()
    first = {r["options"]["figures"] for r in rows[:2]}
    second = {r["options"]["figures"] for r in rows[2:]}
    assert len(first) == len(second) == 1 and first != second and first | second == set(runs)
    suite = rows[0]["suite"]
    board = tmp_path / "board.html"
    lb = ["leaderboard", "--store", str(store), "--suite", suite, "--figures", str(figures), "--format", "html",
          "--out", str(board)]
    assert main(lb) == 0
    captions = _captions(board.read_text())
    # run 1's lqr rows were replaced by run 2's: only run 2's figures are on the board
    (run_2,) = second
    assert captions and all(c.startswith(run_2 + "/") for c in captions)
    assert main([*common, "--policies", "lqr", "--no-figures"]) == 0
    assert main(lb) == 0
    assert "No figures" in board.read_text() and not _captions(board.read_text())
