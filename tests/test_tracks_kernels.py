"""numba kernels: exact projection on arcs/straights and agreement with the numpy methods of Path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks import CurvatureProfile, Path, double_lane_change, handling_course, procedural_track

kernels = pytest.importorskip("vtrack_gym.tracks.kernels")


def project_all(p: Path, x: np.ndarray, y: np.ndarray, s_guess: np.ndarray,
                window_m: float = 10.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = np.empty_like(x)
    e = np.empty_like(x)
    psi = np.empty_like(x)
    kernels.project_batch(p.table, p.ds_m, p.length_m, p.closed, x, y, s_guess, window_m, s, e, psi)
    return s, e, psi


@pytest.mark.parametrize("radius", [20.0, 50.0, 200.0, 1000.0])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_kernel_projection_exact_on_arcs(radius: float, sign: float) -> None:
    length = min(100.0, 5.0 * radius)
    k = sign / radius
    p = Path.from_curvature(CurvatureProfile.from_segments(k, [(length, k)]))
    rng = np.random.default_rng(3)
    th = rng.uniform(0.02, length / radius - 0.02, 300)
    rho = radius + rng.uniform(-10.0, 10.0, 300)
    # centre at (0, sign R); heading sign * th
    x = rho * np.sin(th)
    y = sign * (radius - rho * np.cos(th))
    for guess in (-np.ones(300), radius * th + rng.uniform(-5.0, 5.0, 300)):
        s, e, psi = project_all(p, x, y, guess)
        assert np.max(np.abs(s - radius * th)) < 1e-6
        assert np.max(np.abs(e - sign * (radius - rho))) < 1e-6
        assert np.max(np.abs(psi - sign * th)) < 1e-9


def test_kernel_projection_exact_on_straight() -> None:
    psi0 = 2.5
    p = Path.from_curvature(CurvatureProfile.from_segments(0.0, [(150.0, 0.0)]), x0_m=-7.0, y0_m=1.0,
                            psi0_rad=psi0)
    rng = np.random.default_rng(4)
    s_true = rng.uniform(0.0, 150.0, 300)
    e_true = rng.uniform(-10.0, 10.0, 300)
    x = -7.0 + s_true * math.cos(psi0) - e_true * math.sin(psi0)
    y = 1.0 + s_true * math.sin(psi0) + e_true * math.cos(psi0)
    s, e, psi = project_all(p, x, y, -np.ones(300))
    assert np.max(np.abs(s - s_true)) < 1e-9 and np.max(np.abs(e - e_true)) < 1e-9
    assert np.allclose(psi, psi0, atol=1e-12)
    # beyond the ends: clamped
    s2, _, _ = project_all(p, np.array([-7.0 - 3.0 * math.cos(psi0)]), np.array([1.0 - 3.0 * math.sin(psi0)]),
                           np.array([-1.0]))
    assert s2[0] == 0.0


@pytest.mark.parametrize("which", ["handling", "dlc", "procedural"])
def test_kernels_agree_with_python(which: str) -> None:
    p = {"handling": handling_course, "dlc": double_lane_change, "procedural": lambda: procedural_track(7)}[which]()
    rng = np.random.default_rng(5)
    n = 2000
    s_true = rng.uniform(0.0, p.length_m, n)
    ref = p.sample(s_true)
    off = rng.uniform(-3.0, 3.0, n)
    x = ref.x - off * np.sin(ref.psi)
    y = ref.y + off * np.cos(ref.psi)
    guess = s_true + rng.uniform(-4.0, 4.0, n)
    if not p.closed:
        guess = np.clip(guess, 0.0, p.length_m)
    for g in (guess, -np.ones(n)):
        s_k, e_k, psi_k = project_all(p, x, y, g)
        py = p.project(x, y, s_guess=g)
        ds = np.abs(s_k - py.s)
        if p.closed:
            ds = np.minimum(ds, p.length_m - ds)
        assert np.max(ds) < 1e-9
        assert np.max(np.abs(e_k - py.e_y)) < 1e-9
        assert np.max(np.abs(psi_k - py.psi_ref)) < 1e-9
    # both find the true foot point (the offsets are well inside the radius of curvature)
    ds = np.abs(s_k - np.mod(s_true, p.length_m) if p.closed else s_k - s_true)
    if p.closed:
        ds = np.minimum(ds, p.length_m - ds)
    assert np.max(ds) < 1e-6
    assert np.max(np.abs(e_k - off)) < 1e-6


def test_projection_is_orthogonal_on_clothoids() -> None:
    p = handling_course()
    rng = np.random.default_rng(6)
    s0 = rng.uniform(0.0, p.length_m, 500)
    ref = p.sample(s0)
    x = ref.x + rng.uniform(-8.0, 8.0, 500)
    y = ref.y + rng.uniform(-8.0, 8.0, 500)
    s, e, _ = project_all(p, x, y, s0)
    foot = p.sample(s)
    along = (x - foot.x) * np.cos(foot.psi) + (y - foot.y) * np.sin(foot.psi)
    assert np.max(np.abs(along)) < 1e-8
    assert np.allclose(np.abs(e), np.hypot(x - foot.x, y - foot.y), atol=1e-8)


def test_interp_row_matches_sample() -> None:
    row = np.empty(8)
    for p in (handling_course(), double_lane_change()):
        s_all = np.concatenate((np.linspace(-20.0, p.length_m + 20.0, 997), [0.0, p.length_m, p.ds_m * 17]))
        ref = p.sample_array(s_all)
        for k, s in enumerate(s_all):
            kernels.interp_row(p.table, p.ds_m, p.length_m, p.closed, s, row)
            assert np.allclose(row, ref[k], rtol=0.0, atol=1e-11), (p.name, s)
    assert kernels.wrap_s(-1.0, 10.0, True) == 9.0 and kernels.wrap_s(-1.0, 10.0, False) == 0.0


def test_project_point_warm_start_window_and_wrap() -> None:
    p = handling_course()
    ref = p.sample(np.array([1.0]))
    x, y = float(ref.x[0]), float(ref.y[0])
    # warm start across the closure (guess just before the end of the lap)
    s = kernels.project_point(p.table, p.ds_m, p.length_m, p.closed, x, y, p.length_m - 2.0, 5.0)
    assert abs(s - 1.0) < 1e-9
    s_glob = kernels.project_point(p.table, p.ds_m, p.length_m, p.closed, x, y, -1.0, 5.0)
    assert abs(s_glob - 1.0) < 1e-9
