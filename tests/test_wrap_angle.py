"""The one angle wrap (``tracks.kernels.wrap_angle``), against the exact IEEE remainder modulo the double 2 pi."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks import wrap_angle
from vtrack_gym.tracks.kernels import wrap_angle as wrap_one

PI = math.pi


def _exact(a: float) -> float:
    """``a`` reduced exactly modulo the double 2 pi into (-pi, pi] (``math.remainder`` is exact)."""
    r = math.remainder(a, 2.0 * PI)
    return PI if r <= -PI else r


def test_inside_angles_come_back_bit_for_bit() -> None:
    a = np.random.default_rng(0).uniform(-PI, PI, 20000)
    a = np.concatenate([a, [0.0, -0.0, 1e-300, -1e-300, PI, math.nextafter(PI, 0.0), math.nextafter(-PI, 0.0)]])
    np.testing.assert_array_equal(wrap_angle(a), a)
    assert all(wrap_one(float(x)) == x for x in a)


@pytest.mark.parametrize("a", [-PI, math.nextafter(PI, 4.0), 3.0 * PI, -3.0 * PI, math.nextafter(3.0 * PI, 0.0),
                               2.0 * PI, -2.0 * PI, 7.0, -7.0, 1e3, -1e3])
def test_edges_are_inside_and_within_an_ulp_of_exact(a: float) -> None:
    w = wrap_one(a)
    assert -PI < w <= PI
    exact = _exact(a)
    assert abs(w - exact) <= 4.0 * math.ulp(max(abs(a), PI)) or abs(abs(w - exact) - 2.0 * PI) < 1e-12


def test_many_turns_stay_inside_and_close() -> None:
    a = np.random.default_rng(1).uniform(-50.0 * PI, 50.0 * PI, 20000)
    w = wrap_angle(a)
    assert np.all((w > -PI) & (w <= PI))
    exact = np.array([_exact(x) for x in a])
    diff = np.abs(w - exact)
    diff = np.minimum(diff, np.abs(diff - 2.0 * PI))  # -pi + eps and pi are the same angle
    assert diff.max() <= 64 * math.ulp(50.0 * PI)


def test_numpy_entry_keeps_shape_and_equals_the_compiled_one() -> None:
    a = np.linspace(-20.0, 20.0, 12).reshape(3, 4)
    w = wrap_angle(a)
    assert w.shape == (3, 4) and w.dtype == np.float64
    assert [wrap_one(float(x)) for x in a.ravel()] == list(w.ravel())
    assert wrap_angle(3.0 * PI).shape == () and float(wrap_angle(-PI)) == PI
