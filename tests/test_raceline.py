"""The minimum-curvature racing line: the analytic ring, inside the track at every row (distances to the edges
measured here, independently of the package), never slower than the centre line on the shipped circuits, clear
errors for tracks too narrow for the car."""

from __future__ import annotations

import math
import sys
from pathlib import Path as FsPath

import numpy as np
import pytest

import vtrack_gym.tracks as vt
from vtrack_gym.tracks import COL_KAPPA, COL_PSI, COL_X, COL_Y, GGLimits, Path
from vtrack_gym.vehicle.catalog import load_vehicle

sys.path.insert(0, str(FsPath(__file__).resolve().parents[1] / "benchmarks"))
import own_tracks

HATCHBACK_HALF_WIDTH_M = 0.5 * load_vehicle("hatchback").chassis.body_width_m
RING_MAP = FsPath(vt.__file__).parent / "example_maps" / "ring.gpx"


def ring(radius_m: float, half_width_m: float) -> Path:
    """A constant-width ring: a closed circle of radius ``radius_m`` (left turn), half width either side."""
    return Path.from_curvature(lambda s: np.full_like(s, 1.0 / radius_m), 2.0 * math.pi * radius_m,
                               dkappa=np.zeros_like, closed=True, ds_m=0.25, half_width_m=half_width_m, name="ring")


def dense_edges(track: Path, spacing_m: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """The left and right edge points every ``spacing_m`` of centre line (interpolated rows and widths)."""
    s = np.linspace(0.0, track.length_m, int(track.length_m / spacing_m) + 1)
    row = track.sample(s)
    w_left, w_right = track.half_widths(s)
    normal = np.column_stack((-np.sin(row.psi), np.cos(row.psi)))
    centre = np.column_stack((row.x, row.y))
    return centre + w_left[:, None] * normal, centre - w_right[:, None] * normal


def edge_distances(track: Path, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's distance to the nearest dense left / right edge point (a KD-tree; 2 cm spacing)."""
    from scipy.spatial import cKDTree

    left, right = dense_edges(track)
    return cKDTree(left).query(points)[0], cKDTree(right).query(points)[0]


def test_on_a_ring_the_minimum_curvature_line_is_the_outer_edge_and_its_bound_is_analytic() -> None:
    """Among closed lines in an annulus the circle of largest radius has the least integral of kappa^2 (2 pi / R):
    the outer bound, R + w - (body half width + margin). Its lap at a constant lateral limit a takes
    2 pi R_line / sqrt(a R_line): longer than the centre line's, since lap time grows as sqrt(R)."""
    radius, half_width, margin = 100.0, 6.0, 0.2
    solved = vt.solve_racing_line(ring(radius, half_width), "hatchback", vt.RacingLineSpec(margin_m=margin))
    r_line = radius + half_width - HATCHBACK_HALF_WIDTH_M - margin
    xy = solved.path.table[:, [COL_X, COL_Y]]
    centre = np.array([0.0, radius])             # a left turn from the origin heading +x
    assert np.max(np.abs(np.hypot(*(xy - centre).T) - r_line)) < 1e-5
    assert np.max(np.abs(1.0 / solved.path.table[:, COL_KAPPA] - r_line)) < 1e-4
    limits = GGLimits.constant(8.0, 3.0, 9.0, 60.0)
    bound = vt.lap_time_bound(solved.path, line="centreline", limits=limits)
    expected = 2.0 * math.pi * r_line / math.sqrt(8.0 * r_line)
    assert abs(bound.lap_time_s / expected - 1.0) < 1e-6
    centre_line = vt.lap_time_bound(ring(radius, half_width), line="centreline", limits=limits)
    assert centre_line.lap_time_s < bound.lap_time_s   # minimum curvature is not minimum time on a ring


def shipped_circuits(tmp: FsPath) -> dict[str, Path]:
    """The package's closed circuits (the handling course, the example ring map) and the benchmark's four
    circuits of own_tracks.py (6-7 m hairpins, widths 4 and 4.5 m)."""
    paths = {"handling_course": vt.load_track("handling_course"), "ring.gpx": vt.load_track(RING_MAP)}
    for name, segments in own_tracks.circuits().items():
        paths[name] = vt.load_track(own_tracks.write_circuit_csv(tmp / f"{name}.csv", segments))
    return paths


@pytest.fixture(scope="module")
def circuits(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return shipped_circuits(tmp_path_factory.mktemp("circuits"))


@pytest.fixture(scope="module")
def lines(circuits: dict[str, Path]) -> dict[str, vt.RacingLine]:
    return {name: vt.solve_racing_line(track) for name, track in circuits.items()}


def test_the_line_keeps_the_body_and_margin_inside_the_edges_at_every_row(circuits, lines) -> None:
    """Measured here: each row's distance to densely sampled edge points, and its offset inside the widths."""
    for name, track in circuits.items():
        line = lines[name].path
        xy = line.table[:, [COL_X, COL_Y]]
        d_left, d_right = edge_distances(track, xy)
        clearance = HATCHBACK_HALF_WIDTH_M + 0.2
        assert min(d_left.min(), d_right.min()) >= clearance - 1.5e-3, name
        proj = track.project(xy[:, 0], xy[:, 1])
        w_left, w_right = track.half_widths(proj.s)
        assert np.all((proj.e_y < w_left) & (-proj.e_y < w_right)), name
        widths = line.half_widths_rows()                 # the line's own half widths: distances to the edges
        assert np.max(np.abs(widths[:, 0] - d_left)) < 2e-3 and np.max(np.abs(widths[:, 1] - d_right)) < 2e-3


def test_the_racing_line_is_never_slower_than_the_centre_line_on_the_shipped_circuits(circuits, lines) -> None:
    limits = vt.gg_limits("hatchback")
    for name, track in circuits.items():
        centre = vt.lap_time_bound(track, line="centreline", limits=limits).lap_time_s
        race = vt.lap_time_bound(lines[name].path, line="centreline", limits=limits).lap_time_s
        assert race < centre, (name, race, centre)


def test_the_racing_line_is_smoother_than_the_centre_line(circuits, lines) -> None:
    """The objective itself: the integral of kappa^2 along the line falls."""
    for name, track in circuits.items():
        line = lines[name].path
        energy = [float(np.sum(p.table[:-1, COL_KAPPA] ** 2) * p.ds_m) for p in (track, line)]
        assert energy[1] < energy[0], name


def test_a_track_too_narrow_for_the_car_is_refused_naming_the_station_and_widths() -> None:
    with pytest.raises(ValueError, match=r"too narrow for .*drivable width 2\.000 m < 2 x 1\.158 m"):
        vt.racing_line(ring(100.0, 1.0), "hatchback")
    path = vt.racing_line(ring(100.0, 1.0), "hatchback", margin_m=0.0)   # 2.0 m > 1.916 m: fits without margin
    assert abs(1.0 / path.table[0, COL_KAPPA] - (101.0 - HATCHBACK_HALF_WIDTH_M)) < 1e-3
    with pytest.raises(ValueError, match=r"RacingLineSpec.margin_m must be in \[0.0, 5.0\] m"):
        vt.racing_line(ring(100.0, 6.0), margin_m=-1.0)


def test_an_open_road_gets_a_line_inside_its_widths() -> None:
    track = vt.load_track("step_curvature")
    solved = vt.solve_racing_line(track)
    d_left, d_right = edge_distances(track, solved.path.table[:, [COL_X, COL_Y]])
    assert min(d_left.min(), d_right.min()) >= HATCHBACK_HALF_WIDTH_M + 0.2 - 1.5e-3
    assert not solved.path.closed and abs(solved.path.table[0, COL_PSI]) < 0.2


def test_the_qp_solver_meets_its_optimality_conditions() -> None:
    """A random banded box QP: at the solution, free variables have zero gradient and those at a bound a gradient
    pushing outwards (KKT): the projected gradient step x - clip(x - g) vanishes."""
    from scipy.sparse import diags

    from vtrack_gym.tracks.box_qp import solve_box_qp

    rng = np.random.default_rng(3)
    n = 400
    main, off = 2.0 + rng.random(n), -0.9 * rng.random(n - 1)
    h = diags([off, main, off], [-1, 0, 1]).tocsr()
    f = rng.normal(size=n)
    lo, hi = -np.full(n, 0.3), np.full(n, 0.4)
    x = solve_box_qp(h, f, lo, hi).x
    g = h @ x + f
    assert np.all((x >= lo) & (x <= hi))
    assert np.max(np.abs(x - np.clip(x - g, lo, hi))) < 1e-6
    assert (x < lo + 1e-6).any() and (x > hi - 1e-6).any() and (np.abs(g) < 1e-6).any()


def test_the_racing_line_is_a_track_the_env_drives_and_judges_by_its_own_widths() -> None:
    """Its half widths are distances to the real edges: the env's track-limit rule reads them as it reads a
    track's (stanley at 60 km/h and 0.5 g for 60 s of the handling course)."""
    import gymnasium as gym

    import vtrack_gym

    line = vt.racing_line("handling_course")
    env = gym.make("vtrack/Track-v0", track=line, speed_profile=vt.EnvelopeLimited(60.0 / 3.6, 0.5 * 9.81),
                   track_limits="body")
    policy = vtrack_gym.make_policy("stanley", env)
    obs, _ = env.reset(seed=0)
    for _ in range(1200):
        action, _ = policy.predict(obs)
        obs, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
    metrics = env.unwrapped.success_metrics()
    assert metrics["track_limit_violations"] == 0.0 and 0.1 < metrics["min_edge_margin_m"] < 1.0
    env.close()
