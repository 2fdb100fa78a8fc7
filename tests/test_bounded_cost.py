"""Cost bounded by the input: the smoothing fit of a 200k-point GPS-like CSV within 60 s of CPU (measured by
``benchmarks/bench_csv_fit.py``), blank lines read in linear time with a small constant, ``--tracks`` globs that
walk a symlink loop once, every numeric CLI option ranged at parse time, the entry-speed tolerance floored."""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.cli import build_parser, main
from vtrack_gym.evaluation.storage.store import ResultStore

ROOT = Path(__file__).resolve().parents[1]


def _bench_csv_fit():
    spec = importlib.util.spec_from_file_location("bench_csv_fit", ROOT / "benchmarks" / "bench_csv_fit.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("smoothing", ["auto", "0.05"])
def test_200k_point_gps_csv_fit_within_60_s_of_cpu(tmp_path: Path, smoothing: str) -> None:
    bench = _bench_csv_fit()
    file = bench.write_gps_road(tmp_path / "gps.csv", 200_000)
    seconds, outcome = bench.cpu_seconds(file, smoothing)
    assert seconds < 60.0, (seconds, outcome)
    if smoothing != "auto":
        assert outcome == "100.0 km"   # smoothed enough to be a road


def test_fit_cost_grows_about_linearly() -> None:
    """20x the points costs far less than the 400x of a quadratic fit (5k -> 100k points, same road)."""
    import warnings

    from vtrack_gym.tracks import Path as TrackPath

    rng = np.random.default_rng(1)
    times = []
    for n in (5_000, 100_000):
        s = np.arange(n) * 0.5
        x = s + rng.normal(0.0, 0.03, n)
        y = 30.0 * np.sin(s / 300.0) + rng.normal(0.0, 0.03, n)
        start = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            TrackPath.from_points(x, y, smoothing_m=0.05)
        times.append(time.process_time() - start)
    assert times[1] < 60.0 * max(times[0], 0.05), times


def test_64_mib_of_blank_lines_is_read_in_seconds(tmp_path: Path) -> None:
    from vtrack_gym.tracks.csv_loader import MAX_FILE_BYTES, load_track_csv

    file = tmp_path / "blank.csv"
    body = "0,0\n10,0\n20,1\n30,3\n"
    file.write_text("x,y\n" + " \t\r\n" * ((MAX_FILE_BYTES - 100) // 4) + body)
    start = time.process_time()
    path = load_track_csv(file)
    assert time.process_time() - start < 10.0
    assert path.length_m > 29.0


def test_blank_lines_keep_the_line_numbers_of_errors(tmp_path: Path) -> None:
    from vtrack_gym.tracks.csv_loader import load_track_csv

    file = tmp_path / "t.csv"
    file.write_text("x,y\n\n  \r\n\r\t\n0,0\n1,zero\n")
    with pytest.raises(ValueError, match=r"line 7"):
        load_track_csv(file)


def _road(file: Path) -> Path:
    s = np.arange(0.0, 80.0, 2.0)
    file.write_text("x_m,y_m\n" + "\n".join(f"{v:.3f},{0.002 * v * v:.4f}" for v in s) + "\n")
    return file


def test_tracks_glob_walks_a_symlink_loop_once(tmp_path: Path) -> None:
    from vtrack_gym.evaluation.benchmarking.track_benchmark import track_files

    root = tmp_path / "tracks"
    (root / "a" / "b").mkdir(parents=True)
    _road(root / "one.csv")
    _road(root / "a" / "b" / "two.csv")
    (root / "a" / "b" / "up").symlink_to(root)            # a loop back to the top
    (root / "a" / "self").symlink_to(root / "a")          # and one onto itself
    (root / ".hidden").mkdir()
    _road(root / ".hidden" / "skip.csv")
    found = track_files(str(root / "**" / "*.csv"))
    assert [p.relative_to(root).as_posix() for p in found] == ["a/b/two.csv", "one.csv"]
    store = tmp_path / "s.sqlite"
    assert main(["benchmark", "--tracks", str(root / "**" / "*.csv"), "--policies", "stanley", "--no-figures",
                 "--workers", "1", "--store", str(store)]) == 0
    assert len(ResultStore(store, read_only=True).rows()) == 2


def _numeric_actions() -> list[tuple[str, argparse.Action]]:
    parser = build_parser()
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += [(name, a) for a in sub._actions if a.type is not None]
    return found


def test_every_numeric_option_is_ranged_at_parse_time() -> None:
    unranged = [f"{name} {'/'.join(a.option_strings)}" for name, a in _numeric_actions() if a.type in (int, float)]
    assert unranged == []
    ranged = [a.type.__name__ for _, a in _numeric_actions() if a.type not in (int, float)]
    assert "integer" in ranged and "number" in ranged


@pytest.mark.parametrize("argv", [["benchmark", "--workers", "0"], ["benchmark", "--workers", "100000"],
                                  ["video", "--env", "DLC120-v0", "--policies", "mpc", "--out", "v.mp4", "--fps",
                                   "0"],
                                  ["entry-speed", "--policy", "lqr", "--tol-kmh", "1e-300"],
                                  ["lap-bound", "--track", "handling_course", "--step-m", "0"]])
def test_out_of_range_numbers_are_refused_before_any_work(argv: list[str],
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {argv[-2]}" in err and "must be" in err


def test_entry_speed_tolerance_is_floored_and_the_bisection_ends() -> None:
    from vtrack_gym.evaluation.rollouts.entry_speed import MIN_TOL_KMH, bisect_entry_speed, check_search

    with pytest.raises(ValueError, match=r"tol_kmh must be in \[0.01, "):
        check_search(10.0, 100.0, 1e-300, 0)
    assert MIN_TOL_KMH == 0.01
    found = bisect_entry_speed(lambda v: (v <= 55.55, "cones_hit"), 10.0, 100.0, MIN_TOL_KMH, 0)
    assert 55.54 <= found.max_pass_kmh <= 55.55 and len(found.probes) < 20
