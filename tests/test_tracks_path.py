"""Path (numpy side): exact integration of curvature, interpolation, exact projection on arcs and straights."""

from __future__ import annotations

import ast
import math
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from vtrack_gym.tracks import (
    COL_DKAPPA,
    COL_KAPPA,
    COL_PSI,
    COL_X,
    COL_Y,
    COL_Z,
    N_COLS,
    CurvatureProfile,
    Gate,
    Path,
    SineElevation,
    wrap_angle,
)
from vtrack_gym.tracks import path as path_module
from vtrack_gym.tracks import table as table_module

TRACKS_DIR = pathlib.Path(path_module.__file__).parent


def arc_path(radius: float, length: float, psi0: float = 0.0, closed: bool = False) -> Path:
    """Arc of constant left curvature 1/radius from the origin with heading psi0."""
    return Path.from_curvature(CurvatureProfile.from_segments(1.0 / radius, [(length, 1.0 / radius)]),
                               psi0_rad=psi0, closed=closed)


def test_column_order_is_fixed() -> None:
    assert (table_module.COL_X, table_module.COL_Y, table_module.COL_PSI, table_module.COL_KAPPA,
            table_module.COL_DKAPPA, table_module.COL_Z, table_module.COL_GRADE, table_module.COL_ZPP) \
        == tuple(range(8))
    assert N_COLS == 8


@pytest.mark.parametrize("radius", [20.0, 100.0, 1000.0])
def test_from_curvature_arc_is_an_exact_circle(radius: float) -> None:
    p = arc_path(radius, min(5.0 * radius, 400.0), psi0=0.3)
    s = p.s_m
    th = 0.3 + s / radius
    centre = np.array([-radius * math.sin(0.3), radius * math.cos(0.3)])
    assert np.max(np.abs(p.table[:, COL_X] - (centre[0] + radius * np.sin(th)))) < 1e-10
    assert np.max(np.abs(p.table[:, COL_Y] - (centre[1] - radius * np.cos(th)))) < 1e-10
    assert np.max(np.abs(p.table[:, COL_PSI] - th)) < 1e-13
    assert np.all(p.table[:, COL_KAPPA] == 1.0 / radius)
    assert np.all(p.table[:, COL_DKAPPA] == 0.0)
    # interpolation between samples stays on the circle
    q = p.sample(np.linspace(0.0, p.length_m, 3001))
    assert np.max(np.abs(np.hypot(q.x - centre[0], q.y - centre[1]) - radius)) < 1e-10
    assert np.max(np.abs(q.psi - (0.3 + np.linspace(0.0, p.length_m, 3001) / radius))) < 1e-12


def test_from_curvature_straight_and_clothoid_blend() -> None:
    prof = CurvatureProfile.from_segments(0.0, [(50.0, 0.0), (30.0, 0.02), (40.0, 0.02), (30.0, 0.0), (20.0, 0.0)])
    p = Path.from_curvature(prof, x0_m=5.0, y0_m=-2.0, psi0_rad=0.7, ds_m=0.2)
    assert p.ds_m <= 0.2 and abs(p.length_m - 170.0) < 1e-9
    on_straight = p.s_m <= 50.0
    s = p.s_m[on_straight]
    assert np.max(np.abs(p.table[on_straight, COL_X] - (5.0 + s * math.cos(0.7)))) < 1e-12
    assert np.max(np.abs(p.table[on_straight, COL_Y] - (-2.0 + s * math.sin(0.7)))) < 1e-12
    # heading = 0.7 + exact integral of kappa; kappa C^2 (smootherstep) with exact dkappa
    assert np.max(np.abs(p.table[:, COL_PSI] - (0.7 + prof.heading(p.s_m)))) < 1e-12
    assert abs(p.table[-1, COL_PSI] - (0.7 + 0.02 * (15.0 + 40.0 + 15.0))) < 1e-12
    fd = np.gradient(p.table[:, COL_KAPPA], p.ds_m)
    assert np.max(np.abs(fd - p.table[:, COL_DKAPPA])[2:-2]) < 1e-5
    assert abs(np.max(p.table[:, COL_DKAPPA]) - 1.875 * 0.02 / 30.0) < 1e-6
    # final straight is an exact line in the final direction
    tail = p.s_m >= 150.0
    psi_end = p.table[-1, COL_PSI]
    cross = (-(p.table[tail, COL_X] - p.table[-1, COL_X]) * math.sin(psi_end)
             + (p.table[tail, COL_Y] - p.table[-1, COL_Y]) * math.cos(psi_end))
    assert np.max(np.abs(cross)) < 1e-11


def test_from_curvature_callable_matches_profile() -> None:
    prof = CurvatureProfile.from_segments(0.0, [(20.0, 0.03), (30.0, -0.01), (25.0, 0.0)])
    exact = Path.from_curvature(prof)
    sampled = Path.from_curvature(prof.kappa, prof.length_m)
    assert np.max(np.abs(exact.table - sampled.table)) < 1e-6
    with pytest.raises(ValueError, match="length_m"):
        Path.from_curvature(prof.kappa)
    segments = Path.from_curvature([(20.0, 0.03), (30.0, -0.01), (25.0, 0.0)])
    assert np.array_equal(segments.table, exact.table)


def test_hermite_interpolation_consistent_with_table() -> None:
    prof = CurvatureProfile.from_segments(0.01, [(40.0, -0.04), (40.0, 0.05), (30.0, 0.0)])
    elev = SineElevation((1.0, 0.3), (80.0, 31.0), (0.2, 1.0), 0.0)
    p = Path.from_curvature(prof, elevation=elev)
    fine = Path.from_curvature(prof, elevation=elev, ds_m=0.01)
    s = np.linspace(0.0, p.length_m, 777)
    a = p.sample_array(s)
    b = fine.sample_array(s)
    assert np.max(np.abs(a[:, :3] - b[:, :3])) < 1e-9      # X, Y, psi
    assert np.max(np.abs(a[:, COL_KAPPA] - prof.kappa(s))) < 1e-7
    assert np.max(np.abs(a[:, COL_Z] - elev.z(s))) < 1e-9
    # sample at the grid points returns the table rows
    rows = p.sample_array(p.s_m[:-1])
    assert np.max(np.abs(rows - p.table[:-1])) < 1e-12


@pytest.mark.parametrize("radius", [20.0, 50.0, 200.0, 1000.0])
def test_project_exact_on_arcs(radius: float) -> None:
    length = min(100.0, 5.0 * radius)
    p = arc_path(radius, length)
    rng = np.random.default_rng(1)
    th = rng.uniform(0.02, length / radius - 0.02, 400)
    rho = radius + rng.uniform(-10.0, 10.0, 400)
    x, y = rho * np.sin(th), radius - rho * np.cos(th)
    for guess in (None, radius * th + rng.uniform(-5.0, 5.0, 400)):
        pr = p.project(x, y, s_guess=guess)
        assert np.max(np.abs(pr.s - radius * th)) < 1e-6
        assert np.max(np.abs(pr.e_y - (radius - rho))) < 1e-6     # left of a left turn = towards the centre
        assert np.max(np.abs(pr.psi_ref - th)) < 1e-9
        assert np.max(np.abs(pr.kappa - 1.0 / radius)) < 1e-12


def test_project_exact_on_straight_and_sign_convention() -> None:
    psi0 = -2.0
    p = Path.from_curvature(CurvatureProfile.from_segments(0.0, [(200.0, 0.0)]), x0_m=3.0, y0_m=4.0, psi0_rad=psi0)
    rng = np.random.default_rng(2)
    s_true = rng.uniform(0.0, 200.0, 500)
    e_true = rng.uniform(-10.0, 10.0, 500)
    x = 3.0 + s_true * math.cos(psi0) - e_true * math.sin(psi0)
    y = 4.0 + s_true * math.sin(psi0) + e_true * math.cos(psi0)
    pr = p.project(x, y)
    assert np.max(np.abs(pr.s - s_true)) < 1e-9
    assert np.max(np.abs(pr.e_y - e_true)) < 1e-9
    _, e_y, e_phi = p.frenet_errors(x, y, np.full(500, psi0 + 0.1))
    assert np.allclose(e_phi, 0.1) and np.allclose(e_y, e_true, atol=1e-9)


def test_open_path_clamps_and_closed_path_wraps() -> None:
    p = Path.from_curvature(CurvatureProfile.from_segments(0.0, [(100.0, 0.0)]))
    pr = p.project(np.array([-5.0, 105.0]), np.array([1.0, -2.0]))
    assert np.allclose(pr.s, [0.0, 100.0])
    assert np.allclose(p.sample(np.array([-3.0, 130.0])).x, [0.0, 100.0])
    radius = 50.0
    circle = arc_path(radius, 2.0 * math.pi * radius, closed=True)
    assert circle.closed and abs(circle.table[-1, COL_PSI] - 2.0 * math.pi) < 1e-12
    assert circle.table[-1, COL_X] == circle.table[0, COL_X] and circle.table[-1, COL_Y] == circle.table[0, COL_Y]
    th = np.array([-0.01, 0.01, math.pi, 2.0 * math.pi - 1e-4])
    x, y = (radius + 2.0) * np.sin(th), radius - (radius + 2.0) * np.cos(th)
    pr = circle.project(x, y)
    assert np.allclose(pr.s, np.mod(radius * th, circle.length_m), atol=1e-9)
    assert np.allclose(pr.e_y, -2.0, atol=1e-9)
    warm = circle.project(x, y, s_guess=np.array([circle.length_m - 1.0, 1.0, 157.0, 0.5]))
    assert np.allclose(warm.s, pr.s, atol=1e-9)
    a = circle.sample(np.array([10.0, 10.0 + circle.length_m, 10.0 - 3.0 * circle.length_m]))
    assert np.allclose(a.x, a.x[0], atol=1e-9) and np.allclose(a.kappa, 1.0 / radius)


def test_preview_bounds_and_wrap_angle() -> None:
    prof = CurvatureProfile.from_segments(0.0, [(30.0, 0.0), (20.0, 0.05), (40.0, 0.05)])
    p = Path.from_curvature(prof)
    s = np.array([0.0, 10.0, 60.0])
    d = np.array([0.0, 5.0, 25.0, 100.0])
    pv = p.preview(s, d)
    assert pv.shape == (3, 4)
    assert np.allclose(pv, prof.kappa(np.clip(s[:, None] + d[None, :], 0.0, p.length_m)), atol=1e-9)
    xmin, xmax, ymin, ymax = p.bounds()
    assert xmin == 0.0 and ymin == 0.0 and xmax > 30.0 and ymax > 10.0
    assert np.allclose(wrap_angle(np.array([math.pi, -math.pi, 3.0 * math.pi, 0.5])), [math.pi, math.pi, math.pi, 0.5])


def test_self_intersects() -> None:
    loop = CurvatureProfile.from_segments(0.0, [(20.0, 0.0), (10.0, 0.1), (60.0, 0.1), (10.0, 0.0), (30.0, 0.0)])
    assert Path.from_curvature(loop).self_intersects()                    # a 6.3 rad loop crosses its lead-in
    u_turn = CurvatureProfile.from_segments(0.0, [(50.0, 0.0), (10.0, 0.1), (21.4, 0.1), (10.0, 0.0), (50.0, 0.0)])
    hairpin = Path.from_curvature(u_turn)
    assert not hairpin.self_intersects()
    assert not hairpin.self_intersects(clearance_m=15.0)                   # legs ~ 20 m apart
    assert hairpin.self_intersects(clearance_m=30.0)


def test_path_is_immutable_and_validated() -> None:
    p = arc_path(30.0, 50.0)
    assert not p.table.flags.writeable and p.table.flags.c_contiguous and p.table.dtype == np.float64
    with pytest.raises(ValueError):
        p.table[0, 0] = 1.0
    good = np.zeros((10, 8))
    good[:, 0] = np.arange(10.0)
    with pytest.raises(ValueError, match=r"Path\.table"):
        Path(np.zeros((10, 7)), 1.0)
    with pytest.raises(ValueError, match=r"Path\.ds_m"):
        Path(good, -1.0)
    with pytest.raises(ValueError, match=r"Path\.half_width_m"):
        Path(good, 1.0, half_width_m=0.0)
    bad = good.copy()
    bad[3, 2] = np.nan
    with pytest.raises(ValueError, match="finite"):
        Path(bad, 1.0)
    with pytest.raises(ValueError, match="closed path"):
        Path(good, 1.0, closed=True)
    with pytest.raises(ValueError, match="gates"):
        Path(good, 1.0, gates=(Gate(5.0, 20.0, 1.0, -1.0),))
    with pytest.raises(ValueError, match=r"Gate\.s_end_m"):
        Gate(5.0, 5.0, 1.0, -1.0)
    with pytest.raises(ValueError, match=r"Gate\.y_left_m"):
        Gate(5.0, 6.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="does not close"):
        Path.from_curvature(CurvatureProfile.from_segments(0.02, [(100.0, 0.02)]), closed=True)


def test_profile_validation() -> None:
    with pytest.raises(ValueError, match=r"CurvatureProfile\.knots_m"):
        CurvatureProfile((0.0, 2.0, 1.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="kappa_per_m"):
        CurvatureProfile((0.0, 1.0), (0.0,))
    with pytest.raises(ValueError, match="segment 1"):
        CurvatureProfile.from_segments(0.0, [(1.0, 0.0), (-1.0, 0.0)])
    with pytest.raises(ValueError, match=r"SineElevation\.wavelengths_m"):
        SineElevation((1.0,), (0.0,), (0.0,))
    prof = CurvatureProfile.from_segments(0.0, [(10.0, 0.1), (5.0, 0.1)])
    assert abs(prof.total_turn_rad - (0.5 + 0.5)) < 1e-15
    assert abs(float(prof.heading(np.array([20.0]))[0]) - (1.0 + 0.5)) < 1e-15   # held beyond the end


def test_no_numba_outside_kernels() -> None:
    for f in TRACKS_DIR.glob("*.py"):
        if f.name == "kernels.py":
            continue
        tree = ast.parse(f.read_text())
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            assert not any(n.split(".")[0] == "numba" or n.endswith("tracks.kernels") for n in names), f.name
    code = ("import sys, vtrack_gym.tracks; "
            "assert 'numba' not in sys.modules and 'vtrack_gym.tracks.kernels' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_pickle_round_trip_keeps_path_read_only() -> None:
    import pickle

    p = Path.from_curvature(CurvatureProfile.from_segments(0.0, [(30.0, 0.02), (30.0, 0.0)]), closed=False,
                            gates=(Gate(1.0, 5.0, 1.0, -1.0, "g"),), name="x", version="7")
    p.project(np.array([1.0]), np.array([1.0]))            # fills the KD-tree cache
    q = pickle.loads(pickle.dumps(p))
    assert np.array_equal(q.table, p.table) and not q.table.flags.writeable
    assert (q.name, q.version, q.gates, q.ds_m, q.length_m) == (p.name, p.version, p.gates, p.ds_m, p.length_m)
