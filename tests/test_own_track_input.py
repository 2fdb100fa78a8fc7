"""Driving a user's track: speed floors and the time-limit cap, loop detection on sparse points, UTM coordinates,
noisy coordinates, near-duplicate points and the CLI's speed options, each through a public entry point
(``load_track``, ``gym.make("vtrack/Track-v0", ...)``, ``vtrack_gym.cli.main``)."""

from __future__ import annotations

import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.tracks import COL_KAPPA, ConstantSpeed, load_track
from vtrack_gym.tracks.table import COL_GRADE


def write_xy(file: Path, x: np.ndarray, y: np.ndarray, fmt: str = "%.6f", extra: str = "",
             extra_values: list[str] | None = None) -> Path:
    """A CSV with header x_m, y_m (and one more column named ``extra`` with ``extra_values``)."""
    header = "x_m,y_m" + (f",{extra}" if extra else "")
    rows = [f"{fmt % a},{fmt % b}" + (f",{extra_values[k]}" if extra else "")
            for k, (a, b) in enumerate(zip(x, y, strict=True))]
    file.write_text(header + "\n" + "\n".join(rows) + "\n")
    return file


def circle_xy(radius_m: float, n: int, cx: float = 0.0, cy: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    return cx + radius_m * np.cos(t), cy + radius_m * np.sin(t)


# ------------------------------------------------------------------------------------ 1: speed floor, time cap
def test_tiny_speeds_are_refused_and_the_derived_time_limit_is_capped(tmp_path: Path) -> None:
    x, y = circle_xy(100.0, 300)
    loop = write_xy(tmp_path / "loop.csv", x, y)
    with pytest.raises(ValueError, match=r"ConstantSpeed\.v_mps must be in \[1\.0, 100\.0\] m/s"):
        gym.make("vtrack/Track-v0", track=str(loop), speed_profile=1e-6)
    # a long straight at the 1 m/s floor: 1.5 x 20 km / 1 m/s + 30 s > 2 h -> refused, naming the lap time
    s = np.arange(0.0, 20_000.0, 20.0)
    long_road = write_xy(tmp_path / "long.csv", s, np.zeros_like(s), "%.1f")
    with pytest.raises(ValueError, match=r"the speed profile takes 1\.998e\+04 s for its 1\.998e\+04 m .* exceeds "
                                         r"the maximum 7200 s of simulated time; fix: raise the profile's speeds"):
        gym.make("vtrack/Track-v0", track=str(long_road), speed_profile=ConstantSpeed(1.0))
    env = gym.make("vtrack/Track-v0", track=str(loop), speed_profile=ConstantSpeed(1.0))  # 628 m at 1 m/s: fine
    assert env.unwrapped.scenario.time_limit_s == pytest.approx(1.5 * 2.0 * math.pi * 100.0 + 30.0, rel=2e-3)


def test_a_speed_column_below_one_mps_is_refused_where_it_sets_the_speed(tmp_path: Path) -> None:
    x, y = circle_xy(100.0, 300)
    v = ["10.0"] * x.size
    v[7] = "0.001"
    f = write_xy(tmp_path / "v.csv", x, y, extra="v_mps", extra_values=v)
    with pytest.raises(ValueError, match=r"gives 0\.\d+ m/s at s = \d+\.\d m; FileSpeed needs speeds in "
                                         r"\[1\.0, 100\.0\] m/s"):
        gym.make("vtrack/Track-v0", track=str(f), speed_profile="file")
    gym.make("vtrack/Track-v0", track=str(f), speed_profile=ConstantSpeed(10.0))   # the column unused: fine
    v[7] = "0"
    with pytest.raises(ValueError, match=r"v\.csv, line 9: speed v_mps = 0\.0 m/s is outside \(0, 100\.0\] m/s"):
        load_track(write_xy(tmp_path / "v.csv", x, y, extra="v_mps", extra_values=v))
    v[7] = "10.0"
    f = write_xy(tmp_path / "v.csv", x, y, extra="v_mps", extra_values=v)
    with pytest.raises(ValueError, match=r"gives 0\.5 m/s .* FileSpeed needs speeds in \[1\.0, 100\.0\] m/s"):
        from vtrack_gym.tracks import FileSpeed

        gym.make("vtrack/Track-v0", track=str(f), speed_profile=FileSpeed(scale=0.05))


@pytest.mark.parametrize(("argv", "message"), [
    (["--speed-profile", "constant", "--max-speed-kmh", "0.01"], r"--max-speed-kmh: must be a number in \[3\.6, 360\]"),
    (["--max-speed-kmh", "1000"], r"--max-speed-kmh: must be a number in \[3\.6, 360\] \(got '1000'\)"),
    (["--max-lateral-g", "5"], r"--max-lateral-g: must be a number in \[0\.01, 3\.058\d*\] \(got '5'\)"),
    (["--max-lateral-g", "0"], r"--max-lateral-g: must be a number in \[0\.01, 3\.058\d*\]"),
    (["--speed-profile", "file", "--max-speed-kmh", "10"],
     r"--max-speed-kmh does not apply to --speed-profile file .* fix: drop --max-speed-kmh"),
    (["--speed-profile", "constant", "--max-lateral-g", "0.5"], r"--max-lateral-g does not apply to --speed-profile "
                                                                 r"constant"),
    (["--track-smoothing-m", "-1"], r"--track-smoothing-m: must be a number in \[0, 50\]"),
])
def test_cli_speed_options_name_the_option_and_its_range(argv: list[str], message: str, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    x, y = circle_xy(100.0, 300)
    loop = write_xy(tmp_path / "loop.csv", x, y)
    try:   # a number out of its range is refused while parsing (SystemExit 2), a misplaced option by the command
        code = main(["eval", "--policy", "stanley", "--track", str(loop), "--store", str(tmp_path / "s.db"), *argv])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    assert __import__("re").search(message, capsys.readouterr().err)


# ----------------------------------------------------------------------------------- 2: sparse loops, forcing
def test_sparse_loops_close_and_open_u_roads_stay_open(tmp_path: Path) -> None:
    t = np.linspace(0.0, 2.0 * math.pi, 20, endpoint=False)             # 424 m ellipse, end gap 13 m, 20 points
    ellipse = load_track(write_xy(tmp_path / "ellipse.csv", 90.0 * np.cos(t), 40.0 * np.sin(t), "%.1f"))
    assert ellipse.closed and ellipse.length_m == pytest.approx(423.7, abs=1.0)
    square = load_track(write_xy(tmp_path / "square.csv", np.array([0.0, 100.0, 100.0, 0.0]),
                                 np.array([0.0, 0.0, 100.0, 100.0]), "%.0f"))
    assert square.closed
    # an open U: two straight legs joined by a semicircle of radius 10 m, points every 10 m; the ends are 20 m
    # (2 spacings) apart but the road ends straight: the closing chord would turn 90 deg at both ends
    legs = np.arange(100.0, -1.0, -10.0)
    a = np.linspace(-math.pi / 2, math.pi / 2, 5)[1:-1]
    ux = np.concatenate((legs[::-1], 100.0 + 10.0 * np.cos(a), legs))
    uy = np.concatenate((np.full(legs.size, -10.0), 10.0 * np.sin(a), np.full(legs.size, 10.0)))
    u_file = write_xy(tmp_path / "u.csv", ux, uy)
    assert not load_track(u_file).closed
    assert load_track(u_file, closed=True).closed
    env = gym.make("vtrack/Track-v0", track=str(tmp_path / "ellipse.csv"), closed=False)
    assert not env.unwrapped.current_path.closed
    with pytest.raises(ValueError, match="closed= and smoothing_m= apply to a CSV track file only"):
        gym.make("vtrack/Track-v0", track="handling_course", closed=True)


def test_cli_track_closed_option_and_the_printed_decision(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    t = np.linspace(0.0, 2.0 * math.pi, 20, endpoint=False)
    f = write_xy(tmp_path / "ellipse.csv", 90.0 * np.cos(t), 40.0 * np.sin(t), "%.1f")
    store = tmp_path / "s.db"
    assert main(["eval", "--policy", "stanley", "--track", str(f), "--store", str(store)]) == 0
    err = capsys.readouterr().err
    assert f"--track {f}: read as a closed loop (detected; --track-closed yes/no forces it), 423.7 m, 20 points" in err
    assert main(["eval", "--policy", "stanley", "--track", str(f), "--track-closed", "no", "--store",
                 str(store)]) == 0
    assert "read as an open road (forced by --track-closed), 410.3 m, 20 points" in capsys.readouterr().err
    from vtrack_gym.evaluation.storage.store import ResultStore

    auto, forced = ResultStore(store, read_only=True).rows()
    assert auto["env_id"] != forced["env_id"] and forced["options"]["track_read"] == {"closed": False}
    assert "track_read" not in auto["options"]
    assert auto["termination"] == "completed" and auto["metrics"]["progress_m"] > 420.0   # the whole loop


# ------------------------------------------------------------------------------------------- 3: UTM coordinates
UTM_OFFSET_M = (650_000.0, 5_300_000.0)   # a northern-hemisphere UTM position (northing 5300 km)


@pytest.mark.parametrize("policy", ["stanley", "mpc"])
def test_utm_coordinates_drive_like_the_same_track_at_the_origin(policy: str, tmp_path: Path) -> None:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import own_tracks

    origin = own_tracks.write_circuit_csv(tmp_path / "hairpins.csv", own_tracks.circuits()["hairpins"])
    lines = origin.read_text().splitlines()
    shifted = [lines[0]]
    for line in lines[1:]:
        f = line.split(",")
        f[0], f[1] = f"{float(f[0]) + UTM_OFFSET_M[0]:.3f}", f"{float(f[1]) + UTM_OFFSET_M[1]:.3f}"
        shifted.append(",".join(f))
    utm = tmp_path / "hairpins_utm.csv"
    utm.write_text("\n".join(shifted) + "\n")
    p0, p1 = load_track(origin), load_track(utm)
    assert p1.closed and p1.length_m == pytest.approx(p0.length_m, abs=1e-6)
    np.testing.assert_allclose(p1.table[:, COL_KAPPA], p0.table[:, COL_KAPPA], rtol=0.0, atol=1e-6)
    rows = []
    for f in (origin, utm):
        env = gym.make("vtrack/Track-v0", track=str(f))
        row, = vtrack_gym.evaluate(vtrack_gym.make_policy(policy, env), env)
        rows.append(row)
    assert rows[0].termination == rows[1].termination == "completed"
    for key in ("max_e_y_m", "rms_e_y_m", "duration_s", "progress_m"):
        assert rows[1].metrics[key] == pytest.approx(rows[0].metrics[key], rel=1e-5, abs=1e-5), key


def test_coordinates_beyond_1e7_m_name_the_line_and_the_fix(tmp_path: Path) -> None:
    x, y = circle_xy(50.0, 64, cx=6.5e5, cy=2.0e7)
    with pytest.raises(ValueError, match=r"big\.csv, line 2: \|y\| = 2e\+07 m exceeds 1e\+07 m .* fix: subtract an "
                                         r"offset"):
        load_track(write_xy(tmp_path / "big.csv", x, y, "%.3f"))


# ------------------------------------------------------------------------------------------ 4: noisy coordinates
def noisy_circle(file: Path, noise_m: float) -> Path:
    """R = 100 m circle, points every 1 m, ``noise_m`` of Gaussian noise on x and y, full precision."""
    x, y = circle_xy(100.0, 628)
    rng = np.random.default_rng(0)
    return write_xy(file, x + rng.normal(0.0, noise_m, x.size), y + rng.normal(0.0, noise_m, x.size))


def test_noisy_coordinates_warn_with_a_smoothing_that_recovers_the_curvature(tmp_path: Path) -> None:
    import re
    import warnings

    f = noisy_circle(tmp_path / "gps.csv", 0.02)
    with pytest.warns(UserWarning, match=r"gps\.csv: the fitted curvature changes sign in \d+ of \d+ point intervals"
                                         r".* Pass smoothing_m=[0-9.]+ \(CLI: --track-smoothing-m [0-9.]+\)") as rec:
        raw = load_track(f)
    assert np.ptp(raw.table[:, COL_KAPPA]) > 0.2                                  # the symptom: +-0.25 1/m
    hint = float(re.search(r"--track-smoothing-m ([0-9.]+)", str(rec[0].message)).group(1))
    assert 0.03 <= hint <= 0.1                                                    # ~2 x the 2-D noise (0.028 m)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                                            # no warning once smoothed
        env = gym.make("vtrack/Track-v0", track=str(f), smoothing_m=hint)
        clean = load_track(write_xy(tmp_path / "clean.csv", *circle_xy(100.0, 628)))
    kappa = env.unwrapped.current_path.table[:, COL_KAPPA]
    np.testing.assert_allclose(kappa, 0.01, rtol=0.02)                            # the README: within 2 %
    np.testing.assert_allclose(clean.table[:, COL_KAPPA], 0.01, rtol=1e-3)


def test_cli_track_smoothing_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = noisy_circle(tmp_path / "gps.csv", 0.02)
    store = tmp_path / "s.db"
    assert main(["eval", "--policy", "stanley", "--track", str(f), "--track-smoothing-m", "0.057", "--store",
                 str(store)]) == 0
    from vtrack_gym.evaluation.storage.store import ResultStore

    row, = ResultStore(store, read_only=True).rows()
    assert row["options"]["track_read"] == {"smoothing_m": 0.057}
    assert row["termination"] == "completed" and row["metrics"]["max_e_y_m"] < 0.2


# ------------------------------------------------------------------------------------------- 5: near-duplicates
def test_a_near_duplicate_point_is_refused_naming_both_lines(tmp_path: Path) -> None:
    x, y = circle_xy(100.0, 628)                                                  # 1 m spacing
    t = 2.0 * math.pi * 40 / 628 + 0.001 / 100.0                                  # 1 mm after point 40
    xd, yd = np.insert(x, 41, 100.0 * math.cos(t)), np.insert(y, 41, 100.0 * math.sin(t))
    f = write_xy(tmp_path / "neardup.csv", xd, yd)
    with pytest.raises(ValueError, match=r"neardup\.csv, lines 42 and 43: consecutive points only 0\.001 m apart, "
                                         r"less than 1% of the median spacing 1 m .* fix: delete one of the two lines"):
        gym.make("vtrack/Track-v0", track=str(f))
    fixed = load_track(write_xy(tmp_path / "fixed.csv", np.delete(xd, 41), np.delete(yd, 41)))
    np.testing.assert_allclose(fixed.table[:, COL_KAPPA], 0.01, rtol=1e-3)
    smoothed = load_track(f, smoothing_m=0.02)      # a smoothing fit passes the near-duplicate by: no kink
    np.testing.assert_allclose(smoothed.table[:, COL_KAPPA], 0.01, rtol=0.05)


def test_dense_cm_rounded_points_still_load_accurately(tmp_path: Path) -> None:
    x, y = circle_xy(50.0, 3142)                                                  # 0.1 m spacing, cm-rounded
    p = load_track(write_xy(tmp_path / "dense.csv", x, y, "%.2f"))
    assert p.closed
    np.testing.assert_allclose(p.table[:, COL_KAPPA], 0.02, rtol=0.03)


def test_a_loop_ending_within_a_hair_of_its_start_repeats_the_start_and_is_not_refused(tmp_path: Path) -> None:
    """A loop file whose last point lands 8 mm from the first (its length not a multiple of the spacing, or the
    start repeated with rounding): the last point is the start again, dropped, not a near-duplicate kink."""
    x, y = circle_xy(100.0, 629)                                  # ~1 m spacing
    x, y = np.append(x, x[0] + 0.008), np.append(y, y[0])         # the start again, 8 mm off
    with_repeat = load_track(write_xy(tmp_path / "repeat.csv", x, y))
    without = load_track(write_xy(tmp_path / "plain.csv", x[:-1], y[:-1]))
    assert with_repeat.closed and without.closed
    assert with_repeat.length_m == pytest.approx(without.length_m, abs=1e-9)
    kappa = with_repeat.table[:, COL_KAPPA]
    assert np.max(np.abs(kappa - 0.01)) < 1e-3                   # no kink: the radius stays 100 m


def test_a_track_shorter_than_20_m_is_refused_not_completed_at_once(tmp_path: Path) -> None:
    """A 3 m road counted as completed (and a success) after one step: an open road is completed 5 m before its
    end, so a track must be at least 4 x that long."""
    s = np.linspace(0.0, 3.0, 7)
    tiny = write_xy(tmp_path / "tiny.csv", s, np.zeros_like(s))
    with pytest.raises(ValueError, match=r"track 'tiny' is 3 m long: a track needs at least 20 m"):
        gym.make("vtrack/Track-v0", track=str(tiny), speed_profile=ConstantSpeed(5.0))
    s = np.linspace(0.0, 30.0, 31)
    env = gym.make("vtrack/Track-v0", track=str(write_xy(tmp_path / "short.csv", s, np.zeros_like(s))),
                   speed_profile=ConstantSpeed(5.0))
    row, = vtrack_gym.evaluate(vtrack_gym.make_policy("lqr", env), env)
    assert row.termination == "completed" and row.metrics["duration_s"] > 3.0   # it drove the 25 m


def test_a_noisy_elevation_column_warns_and_a_real_one_does_not(tmp_path: Path) -> None:
    """GPS altitude (0.3 m of noise every 5 m) fitted exactly gives grades of tens of % and false wheel lifts: the
    loader warns naming the grade; a smooth 3 m hill does not warn."""
    import warnings

    x, y = circle_xy(200.0, 251)                                   # 5 m spacing
    hill = 3.0 * np.sin(np.arctan2(y, x))
    noisy = hill + np.random.default_rng(0).normal(0.0, 0.3, hill.size)
    with pytest.warns(UserWarning, match=r"the fitted road grade changes sign in \d+ of 251 point intervals"):
        load_track(write_xy(tmp_path / "gps.csv", x, y, extra="z_m", extra_values=[f"{v:.3f}" for v in noisy]))
    cliff = hill.copy()
    cliff[100:] += 4.0                                               # a 4 m step between two points 5 m apart
    cliff[-1] -= 2.0
    with pytest.warns(UserWarning, match=r"the fitted road grade reaches [+-]\d+ % at s = \d+ m, steeper than "
                                         r"public roads \(35 %\): is the third column an elevation z"):
        load_track(write_xy(tmp_path / "cliff.csv", x, y, extra="z_m", extra_values=[f"{v:.3f}" for v in cliff]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        path = load_track(write_xy(tmp_path / "hill.csv", x, y, extra="z_m", extra_values=[f"{v:.3f}" for v in hill]))
    assert np.max(np.abs(path.table[:, COL_GRADE])) < 0.05          # a 1.5 % hill


def test_degrees_and_folders_get_messages_that_name_the_mistake(tmp_path: Path) -> None:
    lat = np.array([48.1371, 48.1372, 48.1375, 48.1379, 48.1380])
    lon = np.array([11.5754, 11.5760, 11.5765, 11.5762, 11.5755])
    with pytest.raises(ValueError, match=r"the points span only 0\.00\d+ m: coordinates must be metres \(latitude"):
        load_track(write_xy(tmp_path / "latlon.csv", lat, lon))
    with pytest.raises(ValueError, match=r"is a folder, not a track file"):
        load_track(str(tmp_path))
    with pytest.raises(ValueError, match=r"is a folder, not a track file"):
        gym.make("vtrack/Track-v0", track=str(tmp_path))
