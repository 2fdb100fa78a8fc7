"""Speed profiles inside the friction ellipse (tracks.speed_profiles.EnvelopeLimited) and the car's own limit."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from vtrack_gym.tracks import CurvatureLimited, CurvatureProfile, Path, speed_table
from vtrack_gym.tracks.feasibility import envelope_profile
from vtrack_gym.tracks.speed_profiles import EnvelopeLimited, check_lateral_limit, envelope_usage
from vtrack_gym.vehicle.catalog import load_vehicle
from vtrack_gym.vehicle.steady_state import grip_limit, lateral_limit_curve, lowest_lateral_limit_mps2

A_LAT, A_ACC, A_DEC = 7.0, 2.0, 3.0


def _paths() -> dict[str, Path]:
    return {
        "circle": Path.from_curvature(CurvatureProfile.from_segments(1 / 30, [(2 * math.pi * 30, 1 / 30)]),
                                      closed=True),
        "straight-circle-straight": Path.from_curvature(CurvatureProfile.from_segments(
            0.0, [(100.0, 0.0), (5.0, 1 / 25), (60.0, 1 / 25), (5.0, 0.0), (100.0, 0.0)])),
        "chicane": Path.from_curvature(CurvatureProfile.from_segments(
            0.0, [(80.0, 0.0), (8.0, 1 / 20), (10.0, 1 / 20), (16.0, -1 / 15), (10.0, -1 / 15), (8.0, 0.0),
                  (80.0, 0.0)])),
    }


@pytest.mark.parametrize("name", list(_paths()))
def test_combined_acceleration_never_leaves_the_ellipse(name: str) -> None:
    path = _paths()[name]
    table = speed_table(path, EnvelopeLimited(30.0, A_LAT, A_ACC, A_DEC))
    usage = envelope_usage(table, path, A_LAT, A_ACC, A_DEC)
    assert np.max(usage) <= 1.0 + 1e-9
    s = np.linspace(0.0, path.length_m, 20001)
    assert np.max(table.v_ref(s) ** 2 * np.abs(path.sample(s).kappa)) <= A_LAT * (1.0 + 1e-9)
    assert np.max(table.v_mps) <= 30.0
    if name == "circle":                          # nothing to brake for: the lateral limit itself, sqrt(A_y R)
        assert table.v_mps == pytest.approx(math.sqrt(A_LAT * 30.0), rel=1e-6)
    else:                                         # the per-axis profile asks for more than the ellipse allows
        per_axis = speed_table(path, CurvatureLimited(30.0, A_LAT, A_ACC, A_DEC))
        assert np.max(envelope_usage(per_axis, path, A_LAT, A_ACC, A_DEC)) > 1.9
        assert np.all(table.v_mps <= per_axis.v_mps + 1e-12)


def test_braking_is_done_before_the_corner() -> None:
    path = _paths()["straight-circle-straight"]
    table = speed_table(path, EnvelopeLimited(30.0, A_LAT, A_ACC, A_DEC))
    s_corner = 105.0                              # the arc (full curvature) starts here
    v_corner = math.sqrt(A_LAT * 25.0)
    assert float(table.v_ref(s_corner)) == pytest.approx(v_corner, rel=1e-3)
    # on a straight the full deceleration is allowed: v^2 falls by 2 A_dec per metre before the entry blend
    s = np.array([60.0, 70.0])
    v2 = table.v_ref(s) ** 2
    assert (v2[0] - v2[1]) / 10.0 == pytest.approx(2.0 * A_DEC, rel=1e-6)


def test_lateral_limit_above_the_cars_is_refused_and_near_it_warned() -> None:
    with pytest.raises(ValueError, match=r"max_lateral_accel_mps2 = 8.000 m/s\^2.*limit 7.800 m/s\^2.*'my car'"):
        EnvelopeLimited(30.0, 8.0, vehicle_limit_mps2=7.8, vehicle_name="my car")
    with pytest.warns(UserWarning, match="above 90% of the limit"):
        EnvelopeLimited(30.0, 7.5, vehicle_limit_mps2=7.8, vehicle_name="my car")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        EnvelopeLimited(30.0, 6.8, vehicle_limit_mps2=7.8, vehicle_name="my car")
        check_lateral_limit(100.0, None, "no car")


def test_envelope_profile_uses_the_cars_own_limit_not_mu_g() -> None:
    car = load_vehicle("hatchback")
    limit = lowest_lateral_limit_mps2(car, 80.0 / 3.6)
    assert limit < 0.95 * car.tyres.friction_mu * 9.81                       # well below mu g = 8.83 m/s^2
    assert 0.78 * 9.81 < limit < 0.83 * 9.81
    profile = envelope_profile(car, 80.0 / 3.6, 0.7 * 9.81)
    assert profile.vehicle_limit_mps2 == limit and profile.vehicle_name == car.name
    with pytest.raises(ValueError, match=r"0.850 g.*0.80\d g\) of 'C-Class Hatchback \(paper\)'"):
        envelope_profile(car, 80.0 / 3.6, 0.85 * 9.81)     # below mu g, above the car's limit


def test_lateral_limit_curve_is_the_grip_limit() -> None:
    car = load_vehicle("suv")
    speeds, accels = lateral_limit_curve(car)
    assert list(speeds) == sorted(speeds) and len(speeds) >= 8
    eq = grip_limit(car, 50.0)
    assert float(np.interp(eq.speed_mps, speeds, accels)) == pytest.approx(eq.path_lateral_accel_mps2, rel=2e-3)
    assert max(accels) < car.tyres.friction_mu * 9.81
    low = lowest_lateral_limit_mps2(car, 30.0)
    assert low <= min(np.interp(np.linspace(speeds[0], 30.0, 50), speeds, accels)) + 1e-12


def _independent_usage(table, path: Path, a_lat: float, a_acc: float, a_dec: float, n: int = 200001) -> np.ndarray:
    """(a_x / A_x)^2 + (a_y / A_y)^2 on a fine grid from the speed table's own queries: a_x = d(v^2)/ds / 2 by
    central differences of v_ref(s)^2, a_y = v_ref(s)^2 |kappa(s)| (not the profile's row arithmetic)."""
    s = np.linspace(0.0, path.length_m, n)
    v2 = table.v_ref(s) ** 2
    a_x = np.gradient(v2, s) / 2.0
    a_y = v2 * np.abs(path.sample(s).kappa)
    return (a_x / np.where(a_x >= 0.0, a_acc, a_dec)) ** 2 + (a_y / a_lat) ** 2


@pytest.mark.parametrize("name", list(_paths()))
def test_combined_acceleration_inside_the_ellipse_between_rows_too(name: str) -> None:
    path = _paths()[name]
    table = speed_table(path, EnvelopeLimited(30.0, A_LAT, A_ACC, A_DEC))
    usage = _independent_usage(table, path, A_LAT, A_ACC, A_DEC)
    # the central difference straddles a row (where a_x jumps) at two of the fine samples per row: allow the
    # first-order error of that straddle, nothing else
    assert np.quantile(usage, 0.99) <= 1.0 + 1e-6
    assert np.max(usage) <= 1.0 + 0.05
    assert np.median(usage) > 0.2                           # the profile does use the envelope


def test_braking_distance_and_exit_acceleration_are_the_analytic_ones() -> None:
    """A 350 m straight, a step into a 25 m circle for 80 m, a step out onto a 150 m straight: the speed on the
    arc is sqrt(A_y R) with a_x = 0 (the ellipse leaves no braking at full lateral); on the straight before it
    v^2 = v_c^2 + 2 A_dec (s_c - s) back to the top speed, after it v^2 = v_c^2 + 2 A_acc (s - s_exit)."""
    path = Path.from_curvature(CurvatureProfile.from_segments(
        0.0, [(350.0, 0.0), (0.01, 1 / 25), (80.0, 1 / 25), (0.01, 0.0), (150.0, 0.0)]))
    v_top = 30.0
    table = speed_table(path, EnvelopeLimited(v_top, A_LAT, A_ACC, A_DEC))
    v_c2, s_c, s_exit, ds = A_LAT * 25.0, 350.0, 430.02, path.ds_m
    s_brake = s_c - (v_top ** 2 - v_c2) / (2.0 * A_DEC)
    s = np.linspace(0.0, s_brake - 1.0, 200)
    assert table.v_ref(s) == pytest.approx(v_top, rel=1e-12)
    s = np.linspace(s_brake + 1.0, s_c - 1.0, 400)
    assert table.v_ref(s) ** 2 == pytest.approx(v_c2 + 2.0 * A_DEC * (s_c - s), abs=2.0 * A_DEC * ds)
    s = np.linspace(s_c + 1.0, s_exit - 1.0, 200)
    assert table.v_ref(s) == pytest.approx(math.sqrt(v_c2), rel=1e-9)
    s = np.linspace(s_exit + 1.0, path.length_m - 1.0, 200)
    expected = np.minimum(v_c2 + 2.0 * A_ACC * (s - s_exit), v_top ** 2)
    assert table.v_ref(s) ** 2 == pytest.approx(expected, abs=2.0 * A_ACC * ds)


def test_profile_of_limits_defaults_to_the_envelope_and_checks_the_car() -> None:
    from vtrack_gym.tracks.speed_limits import PROFILE_KINDS, speed_profile_from_limits

    assert PROFILE_KINDS[0] == "envelope"
    # speeding up as the driven car's powertrain allows at the throttle its speed loop holds (bound by the env)
    assert speed_profile_from_limits() == EnvelopeLimited(40.0 / 3.6, 0.7 * 9.81, None,
                                                          throttle_authority="speed_loop")
    assert speed_profile_from_limits(throttle_authority=None) == EnvelopeLimited(40.0 / 3.6, 0.7 * 9.81)
    assert isinstance(speed_profile_from_limits("curvature", 80.0, 0.7), CurvatureLimited)
    car = load_vehicle("hatchback")
    with pytest.raises(ValueError, match=r"max_lateral_g = 8\.33\d m/s\^2 \(0\.850 g\) against the steady-state "
                                         r"lateral limit 7\.8\d\d m/s\^2 \(0\.80\d g\) of "
                                         r"'C-Class Hatchback \(paper\)' at speeds up to 80 km/h"):
        speed_profile_from_limits("envelope", 80.0, 0.85, vehicle=car)
    with pytest.warns(UserWarning, match=r"\(93%.*above 90% of the limit"):
        speed_profile_from_limits("curvature", 80.0, 0.75, vehicle=car)


def test_gym_make_checks_the_profile_against_the_driven_car() -> None:
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)

    with pytest.raises(ValueError, match=r"EnvelopeLimited\.max_lateral_accel_mps2 = 7\.848 m/s\^2 \(0\.800 g\) "
                                         r"against the steady-state lateral limit 7\.3\d\d m/s\^2 \(0\.74\d g\) of "
                                         r"'Compact SUV \(RAV4-class, FWD\)'"):
        gym.make("vtrack/Track-v0", speed_profile=EnvelopeLimited(80.0 / 3.6, 0.8 * 9.81), vehicle="suv")
    with pytest.raises(ValueError, match=r"CurvatureLimited\.max_lateral_accel_mps2 .* 'C-Class Hatchback"):
        gym.make_vec("vtrack/Track-v0", num_envs=2, speed_profile=CurvatureLimited(80.0 / 3.6, 0.85 * 9.81))
    with pytest.warns(UserWarning, match=r"\(93% of it\): above 90% of the limit"):
        gym.make("vtrack/Track-v0", speed_profile=EnvelopeLimited(80.0 / 3.6, 0.93 * 0.8049 * 9.81)).close()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        gym.make("vtrack/Track-v0").close()           # the default profile (0.7 g) is well inside the car's limit


def test_cli_refuses_a_lateral_limit_above_the_cars_naming_option_limit_and_car(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    x = 100.0 * np.cos(np.linspace(0.0, 2.0 * math.pi, 300, endpoint=False))
    y = 100.0 * np.sin(np.linspace(0.0, 2.0 * math.pi, 300, endpoint=False))
    loop = tmp_path / "loop.csv"
    np.savetxt(loop, np.column_stack([x, y]), fmt="%.4f", delimiter=",", header="x_m, y_m")
    common = ["eval", "--policy", "lqr", "--track", str(loop), "--store", str(tmp_path / "s.db")]
    assert main([*common, "--max-speed-kmh", "80", "--max-lateral-g", "0.85"]) == 2
    err = capsys.readouterr().err
    assert "--max-lateral-g = 8.33" in err and "m/s^2 (0.850 g)" in err
    assert "(0.805 g) of 'C-Class Hatchback (paper)'" in err
    assert main([*common, "--max-speed-kmh", "80", "--max-lateral-g", "0.76", "--vehicle", "suv",
                 "--speed-profile", "curvature"]) == 2
    assert "of 'Compact SUV (RAV4-class, FWD)' at speeds up to 80 km/h" in capsys.readouterr().err
