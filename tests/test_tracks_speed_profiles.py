"""Speed profiles: analytic checks (circle: v = sqrt(a_lat / kappa); straight-circle-straight: v^2 linear in s with
slope 2a on the ramps), limits respected everywhere (rows and between rows), closed loops consistent across the
wrap, parameter validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks import (
    ConstantSpeed,
    CurvatureLimited,
    FileSpeed,
    Path,
    SpeedTable,
    as_speed_profile,
    speed_table,
)
from vtrack_gym.tracks.speed_profiles import lateral_accel_mps2

PROFILE = CurvatureLimited(max_speed_mps=20.0, max_lateral_accel_mps2=3.0, max_accel_mps2=1.5, max_decel_mps2=2.5)
RADIUS_M = 30.0
STRAIGHT_M = 200.0
ARC_M = 100.0
STEP_M = 0.01     # curvature step from 0 to 1/R over 1 cm: practically a circle joined to straights


def straight_circle_straight() -> Path:
    k = 1.0 / RADIUS_M
    return Path.from_curvature([(STRAIGHT_M, 0.0), (STEP_M, k), (ARC_M, k), (STEP_M, 0.0), (STRAIGHT_M, 0.0)],
                               ds_m=0.25)


def check_limits(path: Path, table: SpeedTable, profile: CurvatureLimited) -> None:
    """Lateral acceleration, speed and longitudinal acceleration within the profile's limits, at rows and on a
    grid 40 x finer than the rows."""
    s = np.linspace(0.0, path.length_m, 40 * path.n_samples)
    assert np.all(lateral_accel_mps2(table, path, s) <= profile.max_lateral_accel_mps2 * (1.0 + 1e-9))
    assert np.all(table.v_ref(s) <= profile.max_speed_mps * (1.0 + 1e-12))
    slope = np.diff(table.v_ref(s) ** 2) / np.diff(s) / 2.0          # dv/dt = v dv/ds = d(v^2)/ds / 2
    assert np.all(slope <= profile.max_accel_mps2 * (1.0 + 1e-6))
    assert np.all(slope >= -profile.max_decel_mps2 * (1.0 + 1e-6))


@pytest.mark.parametrize("radius_m", [6.0, 25.0, 120.0])
def test_circle_speed_is_sqrt_of_lateral_accel_over_curvature(radius_m: float) -> None:
    circle = Path.from_curvature(CurvatureProfileFactory.circle(radius_m), closed=True, ds_m=0.25)
    table = speed_table(circle, PROFILE)
    expected = min(PROFILE.max_speed_mps, math.sqrt(PROFILE.max_lateral_accel_mps2 * radius_m))
    assert np.allclose(table.v_mps, expected, rtol=1e-9, atol=0.0)
    check_limits(circle, table, PROFILE)


class CurvatureProfileFactory:
    @staticmethod
    def circle(radius_m: float) -> list[tuple[float, float]]:
        return [(1e-9, 1.0 / radius_m), (2.0 * math.pi * radius_m - 1e-9, 1.0 / radius_m)]


def test_straight_circle_straight_ramps_are_v_squared_linear_with_slope_2a() -> None:
    path = straight_circle_straight()
    table = speed_table(path, PROFILE)
    check_limits(path, table, PROFILE)
    v_c = math.sqrt(PROFILE.max_lateral_accel_mps2 * RADIUS_M)
    s = path.s_m
    v2 = table.v_mps ** 2
    entry, exit_ = STRAIGHT_M, STRAIGHT_M + 2 * STEP_M + ARC_M
    in_arc = (s > entry + 1.0) & (s < exit_ - 1.0)
    assert np.allclose(table.v_mps[in_arc], v_c, rtol=1e-9)
    brake_len = (PROFILE.max_speed_mps ** 2 - v_c ** 2) / (2.0 * PROFILE.max_decel_mps2)
    accel_len = (PROFILE.max_speed_mps ** 2 - v_c ** 2) / (2.0 * PROFILE.max_accel_mps2)
    braking = (s > entry - brake_len + 1.0) & (s < entry - 1.0)
    accelerating = (s > exit_ + 1.0) & (s < exit_ + accel_len - 1.0)
    assert np.polyfit(s[braking], v2[braking], 1)[0] == pytest.approx(-2.0 * PROFILE.max_decel_mps2, rel=1e-9)
    assert np.polyfit(s[accelerating], v2[accelerating], 1)[0] == pytest.approx(2.0 * PROFILE.max_accel_mps2,
                                                                                rel=1e-9)
    assert np.max(np.abs(np.diff(v2[braking], 2))) < 1e-9                       # straight lines in (s, v^2)
    # the ramps end where the curve starts/ends (within the one-row look-ahead of the lateral limit)
    assert np.all(table.v_mps[s < entry - brake_len - 1.0] == PROFILE.max_speed_mps)
    assert np.all(table.v_mps[s > exit_ + accel_len + 1.0] == PROFILE.max_speed_mps)
    # between rows the speed follows the same v^2 line
    mid = s[braking][:-1] + 0.125
    assert np.allclose(table.v_ref(mid) ** 2, np.interp(mid, s, v2), rtol=1e-12)


def test_closed_loop_profile_is_consistent_across_the_wrap() -> None:
    k = 1.0 / 7.0
    arc = 7.0 * (math.pi - 8.0 * k)
    hairpin = [(8.0, k), (arc, k), (8.0, 0.0)]
    loop = Path.from_curvature([*hairpin, (150.0, 0.0), *hairpin, (150.0, 0.0)], closed=True, ds_m=0.25)
    table = speed_table(loop, PROFILE)
    check_limits(loop, table, PROFILE)
    assert table.v_mps[0] == table.v_mps[-1]
    # s = 0 is the entry of a hairpin: its braking ramp starts at the end of the table and runs on across the wrap
    assert table.v_mps[0] < 0.5 * PROFILE.max_speed_mps
    v2 = table.v_mps ** 2
    ramp = np.concatenate((v2[-40:-1], v2[:4]))                                 # rows n-41 .. n-2, then 0 .. 3
    slope = np.diff(ramp) / loop.ds_m
    assert np.allclose(slope, -2.0 * PROFILE.max_decel_mps2, rtol=1e-9)
    assert table.v_ref(np.array([loop.length_m + 3.0]))[0] == pytest.approx(table.v_ref(np.array([3.0]))[0])


def test_constant_and_file_profiles_and_preview() -> None:
    path = straight_circle_straight()
    table = speed_table(path, ConstantSpeed(11.0))
    assert np.all(table.v_mps == 11.0) and table.preview(np.array([0.0, 5.0]), np.array([0.0, 10.0])).shape == (2, 2)
    v = np.linspace(5.0, 15.0, path.n_samples)
    with_speed = Path(path.table, path.ds_m, v_ref_mps=v)
    ft = speed_table(with_speed, FileSpeed())
    assert np.array_equal(ft.v_mps, v)
    s = np.array([0.0, 100.0, 300.0])
    d = np.array([0.0, 2.5, 50.0])
    assert np.allclose(ft.preview(s, d), ft.v_ref(s[:, None] + d[None, :]))
    assert np.allclose(ft.v_ref(np.array([100.0])), np.sqrt(np.interp(100.0, with_speed.s_m, v ** 2)))
    assert np.allclose(speed_table(with_speed, FileSpeed(scale=0.5)).v_mps, 0.5 * v)
    with pytest.raises(ValueError, match="has no speed column: add a 'v_mps' column"):
        speed_table(path, FileSpeed())
    assert as_speed_profile(12.0) == ConstantSpeed(12.0) and as_speed_profile("file") == FileSpeed()
    assert as_speed_profile(PROFILE) is PROFILE
    with pytest.raises(ValueError, match="speed_profile must be"):
        as_speed_profile("fast")


@pytest.mark.parametrize(("build", "message"), [
    (lambda: ConstantSpeed(0.0), r"ConstantSpeed\.v_mps must be in \[1\.0, 100\.0\] m/s \(got 0\.0\)"),
    (lambda: ConstantSpeed(1e-6), r"ConstantSpeed\.v_mps must be in \[1\.0, 100\.0\] m/s \(got 1e-06\)"),
    (lambda: ConstantSpeed(float("nan")), r"ConstantSpeed\.v_mps must be a finite number in"),
    (lambda: CurvatureLimited(-1.0, 3.0), r"CurvatureLimited\.max_speed_mps must be in \[1\.0, 100\.0\]"),
    (lambda: CurvatureLimited(0.01 / 3.6, 3.0), r"CurvatureLimited\.max_speed_mps must be in \[1\.0, 100\.0\]"),
    (lambda: CurvatureLimited(10.0, 0.0), r"CurvatureLimited\.max_lateral_accel_mps2 must be in \(0\.0, 30\.0\]"),
    (lambda: CurvatureLimited(10.0, 3.0, max_accel_mps2=31.0), r"CurvatureLimited\.max_accel_mps2 must be in"),
    (lambda: CurvatureLimited(10.0, 3.0, max_decel_mps2=True),
     r"CurvatureLimited\.max_decel_mps2 must be a finite number in"),
    (lambda: FileSpeed(scale=-1.0), r"FileSpeed\.scale must be in"),
])
def test_parameters_are_validated(build, message) -> None:
    with pytest.raises(ValueError, match=message):
        build()
