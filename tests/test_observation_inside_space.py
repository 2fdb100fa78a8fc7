"""Accepted settings keep every observation inside ``observation_space``; what it cannot hold is refused by name."""

from __future__ import annotations

import math
import pathlib
import warnings

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.envs.observation import SCALAR_BOUNDS, SPEED_PREVIEW_BOUND
from vtrack_gym.tracks.csv_loader import hermite_peaks, load_track_csv
from vtrack_gym.tracks.kernels import _h3
from vtrack_gym.tracks.path import MAX_CURVATURE_PER_M, MAX_CURVATURE_RATE_PER_M2, MAX_V_REF_MPS
from vtrack_gym.tracks.speed_profiles import ConstantSpeed, CurvatureLimited


def _write(tmp_path: pathlib.Path, name: str, x: np.ndarray, y: np.ndarray) -> pathlib.Path:
    path = tmp_path / name
    path.write_text("x,y\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(x.tolist(), y.tolist(), strict=True)))
    return path


def test_the_bounds_are_the_settings_limits() -> None:
    assert SCALAR_BOUNDS["target_speed"] == SCALAR_BOUNDS["v_x"] == SPEED_PREVIEW_BOUND == MAX_V_REF_MPS
    assert SCALAR_BOUNDS["curvature"] == MAX_CURVATURE_PER_M
    assert SCALAR_BOUNDS["curvature_rate"] == MAX_CURVATURE_RATE_PER_M2


def test_hermite_peaks_is_the_interpolated_maximum() -> None:
    rng = np.random.default_rng(3)
    n, h = 400, 0.25
    p0, p1 = rng.normal(0.0, 1.0, n), rng.normal(0.0, 1.0, n)
    d0, d1 = rng.normal(0.0, 20.0, n), rng.normal(0.0, 20.0, n)
    t = np.linspace(0.0, 1.0, 20001)
    dense = np.array([np.max(np.abs([_h3.py_func(a, b, c, d, tt, h) for tt in t[::50]])) for a, b, c, d in
                      zip(p0, d0, p1, d1, strict=True)])
    exact = hermite_peaks(p0, d0, p1, d1, h)
    assert np.all(exact >= dense - 1e-12)
    for i in range(0, n, 40):  # a fine grid comes within its own resolution of the peak
        fine = np.max(np.abs(_h3.py_func(p0[i], d0[i], p1[i], d1[i], t, h)))
        assert exact[i] == pytest.approx(fine, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("speed", [MAX_V_REF_MPS * (1 + 1e-9), 150.0, 1e9])
def test_reference_speeds_beyond_the_bound_are_refused(speed: float) -> None:
    with pytest.raises(ValueError, match=r"ConstantSpeed\.v_mps must be in \[1\.0, 100\.0\] m/s"):
        ConstantSpeed(speed)
    with pytest.raises(ValueError, match=r"CurvatureLimited\.max_speed_mps must be in \[1\.0, 100\.0\] m/s"):
        CurvatureLimited(speed, 5.0)


def test_out_and_back_line_is_refused_naming_its_line(tmp_path: pathlib.Path) -> None:
    x = np.concatenate([np.arange(0.0, 100.0, 5.0), np.arange(100.0, -1.0, -5.0)])
    y = np.concatenate([np.zeros(20), np.ones(21)])
    with pytest.raises(ValueError, match=r"out_back\.csv, line \d+: the fitted centre-line's curvature reaches "
                                         r"[\d.]+ 1/m .* beyond the 2 1/m an observation holds"):
        load_track_csv(_write(tmp_path, "out_back.csv", x, y))


def _kinked_files(tmp_path: pathlib.Path) -> list[pathlib.Path]:
    """Circles and lines with one point displaced by 1-10 % of the spacing, and a lap whose end point lies 2 cm
    from its start (full-precision coordinates: the spline interpolates them)."""
    files = []
    for spacing in (0.5, 2.0, 5.0):
        for share in (0.01, 0.05, 0.1):
            n = round(2 * math.pi * 30.0 / spacing)
            t = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
            x, y = 30.0 * np.cos(t), 30.0 * np.sin(t)
            x[n // 3] += share * spacing
            files.append(_write(tmp_path, f"circle_{spacing}_{share}.csv", x, y))
            xs = np.arange(0.0, 120.0, spacing)
            ys = np.zeros_like(xs)
            ys[xs.size // 2] = share * spacing
            files.append(_write(tmp_path, f"line_{spacing}_{share}.csv", xs, ys))
    t = np.linspace(0.0, 2 * math.pi, 90)
    x, y = 30.0 * np.cos(t), 30.0 * np.sin(t)
    y[-1] = y[0] + 0.02
    files.append(_write(tmp_path, "end_2cm.csv", x, y))
    return files


def test_kinks_are_refused_or_observed_inside_the_space(tmp_path: pathlib.Path) -> None:
    refused = 0
    files = _kinked_files(tmp_path)
    for file in files:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                path = load_track_csv(file)
        except ValueError as exc:
            assert re_line(str(exc)), str(exc)
            refused += 1
            continue
        kappa, rate = path.table[:, 3], path.table[:, 4]
        assert np.max(hermite_peaks(kappa[:-1], rate[:-1], kappa[1:], rate[1:], path.ds_m)) <= MAX_CURVATURE_PER_M
        assert np.max(np.abs(rate)) <= MAX_CURVATURE_RATE_PER_M2
        _drive_inside_space(path)
    assert refused < len(files)  # ordinary kinks are smoothed by the loader and driven


def re_line(message: str) -> bool:
    return ", line " in message and "an observation holds" in message


def _drive_inside_space(path: object, steps: int = 300) -> None:
    env = gym.make("vtrack/Track-v0", track=path, speed_profile=CurvatureLimited(25.0, 6.0))
    try:
        obs, _ = env.reset(seed=0)
        space = env.observation_space
        for _ in range(steps):
            assert space.contains(obs)
            obs, _, terminated, truncated, _ = env.step(np.zeros(1, dtype=np.float32))
            if terminated or truncated:
                break
        assert space.contains(obs)
    finally:
        env.close()


def test_fastest_reference_speed_is_inside_the_space(tmp_path: pathlib.Path) -> None:
    x = np.arange(0.0, 3000.0, 5.0)
    env = gym.make("vtrack/Track-v0", track=load_track_csv(_write(tmp_path, "straight.csv", x, np.zeros_like(x))),
                   speed_profile=ConstantSpeed(MAX_V_REF_MPS))
    try:
        obs, _ = env.reset(seed=0)
        assert env.observation_space.contains(obs)
        layout = env.unwrapped.observation_layout
        assert obs[layout.index("target_speed")] == MAX_V_REF_MPS
    finally:
        env.close()

