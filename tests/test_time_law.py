"""The reference time law against closed forms: constant speed, constant acceleration, laps on a closed path."""

import numpy as np
import pytest

from vtrack_gym.tracks.speed_profiles import ConstantSpeed, SpeedTable
from vtrack_gym.tracks.time_law import time_law


def test_constant_speed_time_is_distance_over_speed():
    table = SpeedTable(np.full(101, 20.0), 1.0, False, ConstantSpeed(20.0))
    law = time_law(table)
    assert law.total_time_s == pytest.approx(5.0, rel=1e-14)
    assert law.time_at(np.array([0.0, 37.3, 100.0, 150.0])) == pytest.approx([0.0, 1.865, 5.0, 5.0], rel=1e-13)


def test_constant_acceleration_is_exact_between_and_at_rows():
    a, v0, ds = 2.0, 5.0, 0.7
    s = np.arange(50) * ds
    v = np.sqrt(v0 ** 2 + 2 * a * s)
    law = time_law(SpeedTable(v, ds, False, ConstantSpeed(1.0)))
    probe = np.array([0.0, 0.35, 3.1, 20.0, s[-1]])
    exact = (np.sqrt(v0 ** 2 + 2 * a * probe) - v0) / a
    assert law.time_at(probe) == pytest.approx(exact, rel=1e-12, abs=1e-12)


def test_closed_path_counts_laps():
    v = 10.0 + np.sin(np.linspace(0, 2 * np.pi, 201))
    v[-1] = v[0]
    law = time_law(SpeedTable(v, 0.5, True, ConstantSpeed(1.0)))
    lap = law.total_time_s
    assert law.time_at(100.0 + 12.25) == pytest.approx(lap + law.time_at(12.25), rel=1e-13)
    assert law.time_at(2 * 100.0) == pytest.approx(2 * lap, rel=1e-13)
