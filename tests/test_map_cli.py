"""Self-crossing roads from every entry (make kwarg, CLI flag, recorded in the identity) and a track set that
survives one bad file, the way a user types them."""

from __future__ import annotations

import sqlite3
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import map_files


def figure_eight_csv(file: Path) -> Path:
    """A closed figure eight (two 270 deg loops of radius 30 m whose straights cross): a road over a bridge."""
    first, second = map_files.figure_eight()
    x, y, _ = map_files.sample(first + second, 2.0)
    rows = "\n".join(f"{u:.6f},{v:.6f}" for u, v in zip(x[:-1], y[:-1], strict=True))
    file.write_text("x_m,y_m\n" + rows + "\n", encoding="utf-8")
    return file


def test_the_shipped_example_maps_are_the_writers_output(tmp_path: Path) -> None:
    from vtrack_gym.tracks.example_maps import EXAMPLE_MAPS, example_map

    written = {f.name: f.read_text(encoding="utf-8") for f in map_files.write_examples(tmp_path)}
    assert sorted(written) == sorted(EXAMPLE_MAPS)
    for name in EXAMPLE_MAPS:
        assert example_map(name).read_text(encoding="utf-8") == written[name], name


def test_allow_self_crossing_is_a_make_kwarg_recorded_in_the_identity(tmp_path: Path) -> None:
    from vtrack_gym.evaluation.api import env_identity

    eight = figure_eight_csv(tmp_path / "eight.csv")
    with pytest.raises(ValueError, match=r"crosses itself.*allow_self_crossing=True"):
        gym.make("vtrack/Track-v0", track=str(eight))
    env = gym.make("vtrack/Track-v0", track=str(eight), allow_self_crossing=True)
    path = env.unwrapped.paths[0]
    assert path.closed and path.self_intersects()
    _, options = env_identity(env)
    assert options["track_read"] == {"allow_self_crossing": True}
    vec = gym.make_vec("vtrack/Track-v0", num_envs=2, vectorization_mode="vector_entry_point", track=str(eight),
                       allow_self_crossing=True)
    np.testing.assert_array_equal(vec.unwrapped.sim.paths[0].table, path.table)
    vec.close()


def test_allow_self_crossing_on_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    eight = figure_eight_csv(tmp_path / "eight.csv")
    store = tmp_path / "runs.db"
    assert main(["eval", "--policy", "stanley", "--track", str(eight), "--store", str(store)]) == 2
    assert "pass allow_self_crossing=True" in capsys.readouterr().err
    assert main(["eval", "--policy", "stanley", "--track", str(eight), "--allow-self-crossing",
                 "--store", str(store)]) == 0
    with sqlite3.connect(store) as db:
        (options,), = db.execute("SELECT options_json FROM results").fetchall()
    assert '"allow_self_crossing": true' in options


def test_a_track_set_survives_one_bad_file(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from vtrack_gym.tracks.example_maps import example_map

    folder = tmp_path / "maps"
    folder.mkdir()
    figure_eight_csv(folder / "eight.csv")                               # refused: crosses itself
    (folder / "ring.gpx").write_bytes(example_map("ring.gpx").read_bytes())
    (folder / "broken.xodr").write_text("<OpenDRIVE><road id='1'", encoding="utf-8")
    store = tmp_path / "runs.db"
    code = main(["-v", "benchmark", "--tracks", str(folder), "--policies", "stanley", "--no-figures", "--workers", "1",
                 "--store", str(store)])
    err = capsys.readouterr().err
    assert code == 3
    assert f"refused: {folder / 'broken.xodr'}: line 1, column" in err and "malformed XML" in err
    assert f"refused: {folder / 'eight.csv'}: " in err and "crosses itself" in err
    assert f"track {folder / 'ring.gpx'}: gpx, closed, 491.3 m, min radius 38.7 m, half widths 3.50-3.50 m" in err
    assert "1 track files of --tracks" in err and "(2 refused)" in err
    assert err.index("refused:") < err.index("vtrack benchmark (tracks[")   # listed before any episode
    with sqlite3.connect(store) as db:
        rows = db.execute("SELECT env_id, options_json FROM results").fetchall()
    assert len(rows) == 1 and '"track_file": "ring.gpx"' in rows[0][1]


def test_every_command_taking_a_track_takes_the_read_options() -> None:
    from vtrack_gym.cli import build_parser

    parser = build_parser()
    commands = parser._subparsers._group_actions[0].choices    # argparse keeps the subparsers here
    taking = [name for name, sub in commands.items() if "--track" in sub._option_string_actions]
    assert {"benchmark", "eval", "plot", "video", "tune"} <= set(taking)
    for name in taking:
        options = commands[name]._option_string_actions
        for option in ("--allow-self-crossing", "--track-format", "--track-route", "--track-lane", "--road-width-m"):
            assert option in options, (name, option)


def test_a_track_set_with_allow_self_crossing_runs_the_bridge(tmp_path: Path) -> None:
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.evaluation.benchmarking.track_benchmark import benchmark_tracks

    folder = tmp_path / "set"
    folder.mkdir()
    figure_eight_csv(folder / "eight.csv")
    (folder / "broken.gpx").write_text("<gpx>", encoding="utf-8")
    result = benchmark_tracks(folder, {"stanley": lambda env: make_policy("stanley", env)},
                              allow_self_crossing=True)
    assert [f.name for f in result["tracks"]] == ["eight.csv"]
    assert [(f.name, why[:31]) for f, why in result["refused"]] == [("broken.gpx", "line 1, column 6: malformed XML")]
    row, = result["rows"]
    assert row.options["track_read"] == {"allow_self_crossing": True}


def test_a_track_set_of_bad_files_only_is_refused_before_any_episode(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture) -> None:
    folder = tmp_path / "bad"
    folder.mkdir()
    (folder / "a.xodr").write_text("<OpenDRIVE/>", encoding="utf-8")
    (folder / "b.gpx").write_text("<gpx></gpx>", encoding="utf-8")
    code = main(["benchmark", "--tracks", str(folder), "--policies", "stanley", "--no-figures",
                 "--store", str(tmp_path / "runs.db")])
    err = capsys.readouterr().err
    assert code == 2
    assert ("every track file was refused: a.xodr: line 1: no <road>; expected at least one; b.gpx: 0 track "
            "points") in err
    assert "episode" not in err
