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


def _closed_circuit_arcs(segments: list, max_radius_m: float) -> list[float]:
    """The arc radii [m] of a random circuit, checked within [6 m, ``max_radius_m``], its trace closed in position
    and heading, and its roads apart."""
    arcs = [s.radius_m for s in segments if math.isfinite(s.radius_m)]
    assert min(arcs) >= 6.0 - 1e-9 and max(arcs) <= max_radius_m + 1e-9
    x, y, x_end, y_end, heading = own_tracks.trace_segments(segments, 2.0)
    assert math.hypot(x_end, y_end) < 1e-6 and math.isclose(heading, 2.0 * math.pi, abs_tol=1e-9)
    assert random_circuits.roads_apart(x, y, 2.0)
    return arcs


def test_random_circuits_are_closed_tracks_with_tight_corners_whose_roads_never_touch(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    radii = []
    for c in range(4):
        segments = random_circuits.random_circuit(rng)
        radii += _closed_circuit_arcs(segments, max_radius_m=30.0)
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


def test_fast_circuits_carry_tight_hairpins_and_fast_sweepers(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    radii = []
    for _ in range(4):
        segments = random_circuits.random_circuit(rng, layout="fast")
        radii += _closed_circuit_arcs(segments, max_radius_m=250.0)
        straights = [s.length_m for s in segments if not math.isfinite(s.radius_m)]
        assert max(straights) >= 112.0   # 6 m hairpin (0.75 g) to 80 km/h at 2 m/s^2 takes 112 m
    assert min(radii) < 15.0 and max(radii) > 60.0
    with pytest.raises(ValueError, match="layout must be one of kart, fast"):
        random_circuits.random_circuit(rng, layout="oval")


def test_the_lateral_share_is_a_share_of_the_driven_cars_own_limit(tmp_path: Path, capsys) -> None:
    from vtrack_gym.vehicle.catalog import load_vehicle
    from vtrack_gym.vehicle.steady_state import lowest_lateral_limit_mps2

    args = random_circuits.parse(["--lateral-share", "0.93", "--max-speed-kmh", "80", "--vehicle", "suv"])
    expected = 0.93 * lowest_lateral_limit_mps2(load_vehicle("suv"), 80.0 / 3.6) / 9.81
    assert random_circuits.lateral_limit_g(args) == pytest.approx(expected, rel=1e-12)
    assert 0.68 < expected < 0.71
    with pytest.raises(SystemExit):
        random_circuits.parse(["--lateral-share", "0.9", "--max-lateral-g", "0.7"])
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["--circuits", "0"], ["--spacing", "0"], ["--max-lateral-g", "0"],
                                  ["--max-speed-kmh", "-5"], ["--lateral-share", "1.2"]])
def test_the_command_refuses_bad_arguments_naming_the_option(argv: list[str], capsys, tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        random_circuits.main([*argv, "--out", str(tmp_path)])
    assert exc.value.code == 2 and argv[0] in capsys.readouterr().err


@pytest.mark.slow
def test_lqr_and_mpc_lap_a_fast_circuit_at_93_percent_of_the_cars_limit(tmp_path: Path) -> None:
    """Seed 1's 11th fast circuit (a 90 deg R 67.5 m corner taken at 80 km/h, 6-15 m hairpins and S-bends after
    180 m straights), at 80 km/h and 93 % of the car's own limit on the envelope profile: the MPC spun out here on
    the per-axis profile."""
    from vtrack_gym.vehicle.params import VehicleParams
    from vtrack_gym.vehicle.steady_state import lowest_lateral_limit_mps2

    rng = np.random.default_rng(1)
    for _ in range(11):
        segments = random_circuits.random_circuit(rng, layout="fast")
    file = own_tracks.write_circuit_csv(tmp_path / "circuit010.csv", segments, 2.0)
    lateral_g = 0.93 * lowest_lateral_limit_mps2(VehicleParams(), 80.0 / 3.6) / 9.81
    for policy in ("lqr", "mpc"):
        with pytest.warns(UserWarning, match=r"\(93% of it\)"):
            r = own_tracks.drive(file, policy, None, 80.0, lateral_g, "envelope")
        assert r["success"] and r["termination"] == "completed", (policy, r)
        assert r["max_e_y_m"] < 0.6, (policy, r)
