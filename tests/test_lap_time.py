"""The quasi-steady-state lap-time bound: the analytic circle (2 pi R / sqrt(a R)) with constant and with the car's own
speed-dependent lateral limit, the profile inside the car's friction ellipse at every interval and on it at every
row, the powertrain's own forward limit, and ``vtrack lap-bound``."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import vtrack_gym.tracks as vt
from vtrack_gym.cli import main
from vtrack_gym.tracks import COL_KAPPA, GGLimits, Path
from vtrack_gym.vehicle.catalog import load_vehicle
from vtrack_gym.vehicle.longitudinal import (
    brake_decel_limit_mps2,
    forward_accel_limit_mps2,
    resistance_n,
    top_speed_mps,
)
from vtrack_gym.vehicle.steady_state import lateral_limit_mps2


def circle(radius_m: float, ds_m: float) -> Path:
    """A closed circle of radius ``radius_m`` [m] (exact curvature), rows every ``ds_m`` [m] or a little less."""
    return Path.from_curvature(lambda s: np.full_like(s, 1.0 / radius_m), 2.0 * math.pi * radius_m,
                               dkappa=np.zeros_like, closed=True, ds_m=ds_m, half_width_m=5.0)


@pytest.mark.parametrize("radius_m", [15.0, 50.0, 400.0])
def test_a_circle_at_a_constant_lateral_limit_takes_2_pi_r_over_sqrt_a_r(radius_m: float) -> None:
    """Grid: rows every 0.05 m (at most); a = 8 m/s^2, below the top speed on every radius."""
    a = 8.0
    bound = vt.lap_time_bound(circle(radius_m, 0.05), line="centreline", limits=GGLimits.constant(a, 3.0, 9.0, 70.0))
    expected = 2.0 * math.pi * radius_m / math.sqrt(a * radius_m)
    assert abs(bound.lap_time_s / expected - 1.0) < 1e-6
    assert abs(bound.ellipse_usage - 1.0) < 1e-9


@pytest.mark.parametrize("vehicle", ["hatchback", "sports"])
def test_a_circle_at_the_cars_own_speed_dependent_limit(vehicle: str) -> None:
    """The car's lateral limit falls with speed: the speed v* on radius R solves v^2 / R = A_y(v) (found here with
    brentq on ``vehicle.steady_state``), and the lap takes 2 pi R / sqrt(a R) with a = A_y(v*). Grid 0.05 m."""
    car = load_vehicle(vehicle)
    radius = 80.0
    v_star = brentq(lambda v: v * v / radius - lateral_limit_mps2(car, v), 1.0, 60.0, xtol=1e-14, rtol=1e-15)
    a = lateral_limit_mps2(car, v_star)
    bound = vt.lap_time_bound(circle(radius, 0.05), car, line="centreline")
    assert abs(bound.lap_time_s / (2.0 * math.pi * radius / math.sqrt(a * radius)) - 1.0) < 1e-6


@pytest.fixture(scope="module")
def course_bound() -> vt.LapTimeBound:
    return vt.lap_time_bound("handling_course", "hatchback", line="raceline")


def test_the_profile_is_inside_the_cars_ellipse_everywhere_and_on_it_at_every_row(course_bound) -> None:
    """Measured here against the car's own figures (``vehicle.steady_state`` and ``vehicle.longitudinal``, not the
    package's tables): each interval's constant a_x with the largest a_y of its ends inside the ellipse at the
    faster end's speed; at every row either the lateral limit or an adjacent interval's ellipse is reached."""
    car = load_vehicle("hatchback")
    path, table = course_bound.path, course_bound.speed_table
    v = table.v_mps
    u = v * v
    a_x = np.diff(u) / (2.0 * table.ds_m)
    fast = np.maximum(v[:-1], v[1:])
    s_fine = np.linspace(0.0, path.length_m, 16 * (v.size - 1) + 1)   # the documented curvature of an interval:
    k_fine = np.abs(path.sample(s_fine).kappa)                           # its largest of 17 samples, ends included
    kappa = np.max(np.lib.stride_tricks.sliding_window_view(k_fine, 17)[::16], axis=1)
    a_y_lim = lateral_limit_mps2(car, fast)
    grip_n = car.tyres.friction_mu * car.chassis.mass_kg * 9.81      # braking: the tyres' grip caps the brakes
    brakes_n = (brake_decel_limit_mps2(car, fast) * car.chassis.mass_kg - resistance_n(car, fast))
    brake = (np.minimum(brakes_n, grip_n) + resistance_n(car, fast)) / car.chassis.mass_kg
    along = np.where(a_x >= 0.0, forward_accel_limit_mps2(car, fast), brake)
    usage = (a_x / along) ** 2 + (fast ** 2 * kappa / a_y_lim) ** 2
    assert usage.max() < 1.0 + 2e-3    # the package's speed table interpolates the powertrain every 0.25 m/s
    assert v.max() <= top_speed_mps(car)
    row_tight = np.maximum(np.append(usage, usage[0]), np.insert(usage, 0, usage[-1])) > 1.0 - 2e-3
    k_row = np.maximum(np.append(kappa, kappa[0]), np.insert(kappa, 0, kappa[-1]))
    lateral_tight = u * k_row > lateral_limit_mps2(car, v) * (1.0 - 2e-3)
    assert np.all(row_tight | lateral_tight)


def test_on_straights_the_car_accelerates_at_its_powertrains_limit(course_bound) -> None:
    car = load_vehicle("hatchback")
    path, table = course_bound.path, course_bound.speed_table
    u = table.v_mps ** 2
    a_x = np.diff(u) / (2.0 * table.ds_m)
    straight = (np.abs(path.table[:-1, COL_KAPPA]) < 1e-5) & (np.abs(path.table[1:, COL_KAPPA]) < 1e-5)
    driving = straight & (a_x > 0.0)
    assert driving.sum() > 100
    expected = forward_accel_limit_mps2(car, table.v_mps[1:][driving])
    assert np.max(np.abs(a_x[driving] - expected)) < 2e-3


def test_the_bound_refuses_an_unknown_line() -> None:
    with pytest.raises(ValueError, match="line must be one of raceline, centreline"):
        vt.lap_time_bound("handling_course", line="fastest")


def test_cli_lap_bound_prints_both_lines_and_writes_the_figure(tmp_path, capsys) -> None:
    figure = tmp_path / "lap.png"
    assert main(["lap-bound", "--track", "handling_course", "--format", "json", "--plot", str(figure)]) == 0
    rows = json.loads(capsys.readouterr().out)
    by_line = {r["line"]: r for r in rows}
    assert set(by_line) == {"raceline", "centreline"}
    assert by_line["raceline"]["lap_time_s"] < by_line["centreline"]["lap_time_s"]
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["lap-bound", "--track", "handling_course", "--line", "centreline", "--vehicle", "sports"]) == 0
    table = capsys.readouterr().out
    assert "| handling_course |" in table and "raceline" not in table


def test_cli_lap_bound_refuses_bad_input(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["lap-bound", "--track", "handling_course", "--margin-m", "-1"])
    assert exc.value.code == 2 and "argument --margin-m: must be a number in [0, 5]" in capsys.readouterr().err
    assert main(["lap-bound", "--track", "no_such_track.csv"]) == 2
    assert "track file not found" in capsys.readouterr().err
