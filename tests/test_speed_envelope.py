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
