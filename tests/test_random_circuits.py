"""benchmarks/random_circuits.py: its random circuits are closed, non-touching loops that load as tracks, and its
command line laps them and prints the summary table."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.tracks import load_track

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import random_circuits

import own_tracks


def test_random_circuits_are_closed_tracks_with_tight_corners_whose_roads_never_touch(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    radii = []
    for c in range(4):
        segments = random_circuits.random_circuit(rng)
        arcs = [s.radius_m for s in segments if math.isfinite(s.radius_m)]
        assert min(arcs) >= 6.0 - 1e-9 and max(arcs) <= 30.0 + 1e-9
        radii += arcs
        x, y, x_end, y_end, heading = own_tracks.trace_segments(segments, 2.0)
        assert math.hypot(x_end, y_end) < 1e-6 and math.isclose(heading, 2.0 * math.pi, abs_tol=1e-9)
        assert random_circuits.roads_apart(x, y, 2.0)
        path = load_track(own_tracks.write_circuit_csv(tmp_path / f"c{c}.csv", segments, 2.0))
        assert path.closed and not path.self_intersects(clearance_m=8.5)  # the road width
        assert math.isclose(path.length_m, sum(s.length_m for s in segments), rel_tol=0.01)
    assert min(radii) < 9.0  # hairpins and S-bends do reach the tight end


def test_roads_apart_refuses_a_loop_whose_legs_run_closer_than_the_road_width() -> None:
    t = np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False)
    narrow_x, narrow_y = 100.0 * np.cos(t), 4.0 * np.sin(t)     # an ellipse 8 m wide: its long legs 8 m apart
    step = float(np.mean(np.hypot(np.diff(narrow_x), np.diff(narrow_y))))
    assert not random_circuits.roads_apart(narrow_x, narrow_y, step)
    wide_x, wide_y = 100.0 * np.cos(t), 40.0 * np.sin(t)
    assert random_circuits.roads_apart(wide_x, wide_y, float(np.mean(np.hypot(np.diff(wide_x), np.diff(wide_y)))))


def test_the_command_laps_a_random_circuit_and_prints_the_table(tmp_path: Path, capsys) -> None:
    assert random_circuits.main(["--circuits", "1", "--spacing", "2", "--policies", "lqr",
                                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "| lqr | 1 of 1 |" in out
    assert (tmp_path / "circuit000_2m.csv").is_file()


@pytest.mark.parametrize("argv", [["--circuits", "0"], ["--spacing", "0"], ["--max-lateral-g", "0"],
                                  ["--max-speed-kmh", "-5"]])
def test_the_command_refuses_bad_arguments_naming_the_option(argv: list[str], capsys, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        random_circuits.main([*argv, "--out", str(tmp_path)])
    assert exc.value.code == 2 and argv[0] in capsys.readouterr().err
