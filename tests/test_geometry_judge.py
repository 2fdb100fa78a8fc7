"""The exact geometry judge (``tracks.judge``) against closed-form cases: body rectangle, cones as discs, edges as
polylines, and the least clearance between two control steps found to within 1 mm."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks import judge
from vtrack_gym.vehicle import load_vehicle

FRONT, REAR, HALF = 1.915, 1.915 - 4.75, 0.958      # the hatchback's body [m]
CONE_R = 0.15
NO_CONES = np.zeros((0, 3))


def _body() -> np.ndarray:
    return judge.body_row(load_vehicle("hatchback").chassis)


def _straight_edges(y_left: float, y_right: float, x0: float = -50.0, x1: float = 50.0, n: int = 201) -> np.ndarray:
    x = np.linspace(x0, x1, n)
    return np.column_stack((x, np.full(n, y_left), x, np.full(n, y_right), np.zeros(n), np.ones(n)))


def test_body_row_is_the_cars_data() -> None:
    c = load_vehicle("hatchback").chassis
    row = _body()
    assert row[0] == pytest.approx(c.cg_to_front_end_m) and row[1] == pytest.approx(c.cg_to_front_end_m
                                                                                     - c.body_length_m)
    assert row[2] == pytest.approx(c.body_width_m / 2)
    assert row[3:5].tolist() == pytest.approx([c.cg_to_front_axle_m, c.track_width_m / 2])


def test_point_to_rectangle_outside_inside_and_at_a_corner() -> None:
    psi = 0.4
    c, s = math.cos(psi), math.sin(psi)
    # 0.3 m ahead of the front face, on the centre line of the body
    px, py = (FRONT + 0.3) * c, (FRONT + 0.3) * s
    assert judge.point_rect(px, py, 0.0, 0.0, psi, FRONT, REAR, HALF) == pytest.approx(0.3, abs=1e-12)
    # 0.2 m inside the left side, mid-body
    lon, lat = 0.0, HALF - 0.2
    assert judge.point_rect(c * lon - s * lat, s * lon + c * lat, 0.0, 0.0, psi, FRONT, REAR, HALF) == \
        pytest.approx(-0.2, abs=1e-12)
    # diagonally off the front-left corner by (0.03, 0.04): 5 cm
    lon, lat = FRONT + 0.03, HALF + 0.04
    assert judge.point_rect(c * lon - s * lat, s * lon + c * lat, 0.0, 0.0, psi, FRONT, REAR, HALF) == \
        pytest.approx(0.05, abs=1e-12)


def test_a_body_side_one_millimetre_into_a_cone_line() -> None:
    """Cones every 3 m along y = 2; the car drives along x with its left side 1 mm into the cones' discs."""
    cones = np.array([[x, 2.0, CONE_R] for x in np.arange(-30.0, 31.0, 3.0)])
    for into, expected in ((0.001, -0.001), (-0.001, 0.001)):
        y = 2.0 - CONE_R - HALF + into
        worst = min(judge.rect_disc(x, y, 0.0, FRONT, REAR, HALF, cx, cy, r)
                    for x in np.linspace(-3.0, 3.0, 13) for cx, cy, r in cones)
        assert worst == pytest.approx(expected, abs=1e-12)
    # the swept judge sees it too, from one step to the next (33 cm at 120 km/h)
    pose0, pose1 = np.array([0.0, 2.0 - CONE_R - HALF + 0.001, 0.0]), np.array([0.333, 2.0 - CONE_R - HALF + 0.001,
                                                                                0.0])
    least, _ = judge.sweep_min(judge.MEASURE_CONES, pose0, pose1, _body(), np.zeros((2, 4)), 0, 0, False, cones,
                               judge.SWEEP_TOL_M)
    assert least == pytest.approx(-0.001, abs=1e-3) and least < 0.0


def test_a_yawed_rectangle_passes_a_cone_at_a_lane_end_between_two_steps() -> None:
    """Yawed 0.1 rad and translating along x, the front-left corner (the body's highest point) passes 5 mm under a
    cone's edge half-way through the step; at both sampled poses the body is clear."""
    body = _body()
    front, half = body[0], body[2]
    psi = 0.1
    corner_x, corner_y = front * math.cos(psi) - half * math.sin(psi), front * math.sin(psi) + half * math.cos(psi)
    cone = np.array([[10.0, corner_y + CONE_R - 0.005, CONE_R]])
    step = 0.333
    x_mid = cone[0, 0] - corner_x
    pose0, pose1 = np.array([x_mid - step / 2, 0.0, psi]), np.array([x_mid + step / 2, 0.0, psi])
    ends = [judge.rect_disc(p[0], p[1], p[2], body[0], body[1], body[2], *cone[0]) for p in (pose0, pose1)]
    assert min(ends) > 0.0      # a judge at the control steps sees nothing
    least, last = judge.sweep_min(judge.MEASURE_CONES, pose0, pose1, body, np.zeros((2, 4)), 0, 0, False, cone,
                                  judge.SWEEP_TOL_M)
    assert last == pytest.approx(ends[1], abs=1e-12)
    assert -0.005 - 1e-9 <= least <= -0.005 + judge.SWEEP_TOL_M


def test_a_corner_cuts_an_edge_between_two_steps() -> None:
    """A car turning on the spot: its front-left corner (radius R from the CG) peaks at y = R half-way through the
    step; the left edge lies at y = R - 4 mm, so the body crosses it by 4 mm and is back inside at both ends."""
    body = _body()
    front, half = body[0], body[2]
    radius, alpha = math.hypot(front, half), math.atan2(half, front)
    delta = 0.1
    pose0, pose1 = np.array([0.0, 0.0, math.pi / 2 - alpha - delta]), np.array([0.0, 0.0, math.pi / 2 - alpha + delta])
    edges = _straight_edges(radius - 0.004, -10.0)
    n = edges.shape[0]
    at_ends = [judge.pose_measure(judge.MEASURE_BODY, *p, body, edges, 0, n - 1, False) for p in (pose0, pose1)]
    assert min(at_ends) == pytest.approx(radius * (1.0 - math.cos(delta)) - 0.004, abs=1e-9)
    assert min(at_ends) > 0.0
    least, _ = judge.sweep_min(judge.MEASURE_BODY, pose0, pose1, body, edges, 0, n - 1, False, NO_CONES,
                               judge.SWEEP_TOL_M)
    assert -0.004 - 1e-9 <= least <= -0.004 + judge.SWEEP_TOL_M


def test_an_edge_vertex_poking_into_the_side_is_seen() -> None:
    """A right edge with a spike whose tip lies 2 cm inside the body's right side; every corner stays clear."""
    body = _body()
    half = body[2]
    x = np.array([-20.0, -1.0, 0.0, 1.0, 20.0])
    y = np.array([-1.5, -1.5, -half + 0.02, -1.5, -1.5])
    edges = np.column_stack((x, np.full(5, 10.0), x, y, np.zeros(5), np.ones(5)))
    value = judge.pose_measure(judge.MEASURE_BODY, 0.0, 0.0, 0.0, body, edges, 0, 4, False)
    assert value == pytest.approx(-0.02, abs=1e-12)
    corners = min(judge.point_polyline(cx, cy, edges[:, 2], edges[:, 3], edges[:, 4], edges[:, 5], 0, 4, False, 1.0)
                  for cx in (body[0], body[1]) for cy in (half, -half))
    assert corners > 0.0


def test_wheels_measure_is_negative_only_with_all_four_wheels_beyond_the_edge() -> None:
    body = _body()
    t = body[4]
    edges = _straight_edges(5.0, -5.0)
    n = edges.shape[0]
    # CG 1 m beyond the left edge: the left wheels are t + 1 m out, the right wheels 1 - t m out
    assert judge.pose_measure(judge.MEASURE_WHEELS, 0.0, 6.0, 0.0, body, edges, 0, n - 1, False) == \
        pytest.approx(-(1.0 - t), abs=1e-12)
    # CG just beyond the edge: the right wheels are still on the track
    assert judge.pose_measure(judge.MEASURE_WHEELS, 0.0, 5.5, 0.0, body, edges, 0, n - 1, False) == \
        pytest.approx(t - 0.5, abs=1e-12)
    assert judge.pose_measure(judge.MEASURE_CENTRE, 0.0, 5.5, 0.0, body, edges, 0, n - 1, False) == \
        pytest.approx(-0.5, abs=1e-12)


def test_signed_distance_reads_the_side_along_the_centre_lines_normal() -> None:
    """An L-shaped right edge (track on its left; normals (0, 1), the corner's bisector, (-1, 0)): points in the
    outer and inner corner regions get the right sign; so does a point near an inner edge folded back on itself."""
    ex, ey = np.array([-10.0, 0.0, 0.0]), np.array([0.0, 0.0, 10.0])
    nx, ny = np.array([0.0, -math.sqrt(0.5), -1.0]), np.array([1.0, math.sqrt(0.5), 0.0])
    assert judge.point_polyline(1.0, -1.0, ex, ey, nx, ny, 0, 2, False, 1.0) == pytest.approx(-math.sqrt(2.0))
    assert judge.point_polyline(-1.0, 1.0, ex, ey, nx, ny, 0, 2, False, 1.0) == pytest.approx(1.0)
    assert judge.point_polyline(-0.5, -0.5, ex, ey, nx, ny, 0, 2, False, 1.0) == pytest.approx(-0.5)
    # an inner edge that folds back (its rows run against the centre line between x = 1 and x = 0.5): a point on
    # the track side, above the fold, is inside although it lies to the right of the folded segment's direction
    fx, fy = np.array([-2.0, 0.0, 1.0, 0.5, 2.0]), np.zeros(5)
    up_x, up_y = np.zeros(5), np.ones(5)
    assert judge.point_polyline(0.75, 0.3, fx, fy, up_x, up_y, 0, 4, False, 1.0) == pytest.approx(0.3)


def test_closed_edges_wrap_and_edge_polylines_follow_the_widths() -> None:
    from vtrack_gym.tracks import Path

    a = np.linspace(0.0, 2.0 * math.pi, 400)
    ring = Path.from_points(20.0 * np.sin(a), 20.0 - 20.0 * np.cos(a), closed=True, half_width_m=3.0)
    edges = judge.edge_polylines(ring)
    r_left = np.hypot(edges[:, 0], edges[:, 1] - 20.0)
    r_right = np.hypot(edges[:, 2], edges[:, 3] - 20.0)
    assert np.allclose(r_left, 17.0, atol=1e-6) and np.allclose(r_right, 23.0, atol=1e-6)
    n = edges.shape[0]
    # a point at the start, 1 m inside the outer edge, searched over a window that wraps past the last row
    value = judge.pose_measure(judge.MEASURE_CENTRE, 0.0, -2.0, 0.0, _body(), edges, n - 10, n + 10, True)
    assert value == pytest.approx(1.0, abs=1e-4)


def test_one_judge_for_track_edges_cones_and_cone_gates() -> None:
    """The ISO 3888 gate criterion sweeps the same judge: its clearance, reach and sweep are ``tracks.judge``'s."""
    from vtrack_gym.tracks import gate_judge

    assert gate_judge.rect_gate is judge.rect_gate and gate_judge.rect_reach_m is judge.reach_m
    body3 = np.array([FRONT, REAR, HALF])
    assert judge.reach_m(body3) == math.hypot(max(FRONT, -REAR), HALF)
    assert judge.reach_m(_body()) >= judge.reach_m(body3)       # the full row: its wheel points too
    gate = np.array([10.0, 0.2, 0.05, 12.0, 1.2, -1.2])
    for y in (0.0, 0.3, 0.6):
        pose0, pose1 = np.array([5.0, y, 0.0]), np.array([5.4, y + 0.02, 0.03])
        swept = judge.sweep_min(judge.MEASURE_GATES, pose0, pose1, body3, np.zeros((0, 6)), 0, 0, False,
                                gate[None, :], 1e-3, 0.05)[0]
        assert gate_judge.sweep_gate(pose0, pose1, body3, gate, 1e-3, 0.05) == swept
