"""Scenario tracks: the Case-1 handling course, the Case-2 ISO 3888-1 double lane change, procedural tracks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vtrack_gym.tracks import (
    COL_DKAPPA,
    COL_GRADE,
    COL_KAPPA,
    COL_PSI,
    COL_X,
    COL_Y,
    COL_Z,
    DoubleLaneChangeSpec,
    ProceduralTrackConfig,
    build_double_lane_change,
    double_lane_change,
    gate_violations,
    handling_course,
    procedural_track,
)

G = 9.81
V_DLC = 120.0 / 3.6
W_CAR = 1.916      # the paper's car
L_CAR = 4.75
CG_TO_FRONT = 1.915


# --------------------------------------------------------------------------------------------- handling course
def test_handling_course_statistics() -> None:
    p = handling_course()
    t = p.table
    assert p.closed and p.version == "1" and p.name == "handling_course" and p.half_width_m == 3.5
    assert handling_course() is p                                      # cached
    # closure: position within 1e-6 m, heading a multiple of 2 pi (one counter-clockwise lap)
    assert math.hypot(t[-1, COL_X] - t[0, COL_X], t[-1, COL_Y] - t[0, COL_Y]) < 1e-6
    assert abs(t[-1, COL_PSI] - t[0, COL_PSI] - 2.0 * math.pi) < 1e-9
    assert abs(p.length_m - 2328.0) < 0.01 * 2328.0
    xmin, xmax, ymin, ymax = p.bounds()
    assert xmax - xmin <= 470.0 - 2 * p.half_width_m and ymax - ymin <= 360.0 - 2 * p.half_width_m
    z = t[:, COL_Z]
    assert z[0] == pytest.approx(0.0, abs=1e-12)
    assert abs(z.min() - (-2.5)) < 0.05 and abs(z.max() - 5.2) < 0.05
    assert np.max(np.abs(t[:, COL_GRADE])) < 0.05
    radius_min = 1.0 / np.max(np.abs(t[:, COL_KAPPA]))
    assert 18.0 <= radius_min <= 25.0
    assert not p.self_intersects()
    assert not p.self_intersects(clearance_m=4.0 * p.half_width_m)   # roads of distant parts stay well apart


def test_handling_course_smoothness_and_start() -> None:
    p = handling_course()
    t = p.table
    kap = t[:, COL_KAPPA]
    dk = t[:, COL_DKAPPA]
    dk_max = np.max(np.abs(dk))
    assert dk_max < 0.01
    # kappa continuous (step per sample bounded by the curvature rate), incl. across the closure
    assert np.max(np.abs(np.diff(kap))) <= dk_max * p.ds_m * 1.001
    assert np.max(np.abs(np.diff(dk))) < 1e-3
    for col in (COL_KAPPA, COL_DKAPPA, COL_Z, COL_GRADE):
        assert abs(t[-1, col] - t[0, col]) < 1e-9
    # starts on a straight (kappa = 0 for 50 m either side of s = 0)
    near = p.sample(np.linspace(-50.0, 50.0, 201))
    assert np.max(np.abs(near.kappa)) < 1e-12
    # has a hairpin (R 20), a right-hand 180, a decreasing-radius corner and S-bends
    assert np.any(kap > 0.049) and np.any(kap < -0.033) and np.any(np.abs(kap - 1 / 28) < 1e-9)
    assert np.count_nonzero(np.diff(np.sign(np.round(kap, 9))) != 0) >= 10


def test_handling_course_deterministic() -> None:
    fresh = handling_course.__wrapped__()          # bypass the cache: rebuilt from the layout data
    assert fresh is not handling_course() and np.array_equal(fresh.table, handling_course().table)


# ---------------------------------------------------------------------------------------------- double lane change
def test_dlc_gate_geometry() -> None:
    p = double_lane_change()
    assert not p.closed and p.half_width_m == 4.0 and len(p.gates) == 3
    widths = [g.width_m for g in p.gates]
    assert widths == pytest.approx([1.1 * W_CAR + 0.25, 1.2 * W_CAR + 0.25, 1.3 * W_CAR + 0.25])
    assert [g.s_end_m - g.s_start_m for g in p.gates] == pytest.approx([30.0, 50.0, 30.0])
    # global X of the gates: approach 100 m, sections 30/60/50/50/30 m
    x_ranges = [(p.sample(np.array([g.s_start_m, g.s_end_m])).x) for g in p.gates]
    assert np.allclose(x_ranges, [[100.0, 130.0], [190.0, 240.0], [290.0, 320.0]], atol=1e-9)
    assert p.sample(np.array([p.length_m])).x[0] == pytest.approx(350.0, abs=1e-9)
    # centre-line at the lane centres: lane 3 3.5 m left; lane-5 right boundary = lane-1 right boundary
    y_centre = []
    for g in p.gates:
        q = p.sample(np.linspace(g.s_start_m, g.s_end_m, 101))
        assert np.ptp(q.y) < 1e-9 and np.max(np.abs(q.psi)) < 1e-9 and np.max(np.abs(q.kappa)) < 1e-7
        y_centre.append(q.y[0])
    assert y_centre[1] - y_centre[0] == pytest.approx(3.5, abs=1e-9)
    g1, _, g5 = p.gates
    assert y_centre[2] + g5.y_right_m == pytest.approx(y_centre[0] + g1.y_right_m, abs=1e-9)


def test_dlc_peak_lateral_acceleration_at_120kmh() -> None:
    p = double_lane_change()
    kappa_peak = float(np.max(np.abs(p.table[:, COL_KAPPA])))
    ay_peak_g = V_DLC ** 2 * kappa_peak / G
    print(f"DLC x2: peak |kappa| = {kappa_peak:.5e} 1/m, peak v^2 kappa at 33.33 m/s = {ay_peak_g:.3f} g")
    assert 0.6 <= ay_peak_g <= 0.9
    assert np.max(np.abs(p.table[:, COL_DKAPPA])) < 0.005
    assert np.max(np.abs(np.diff(p.table[:, COL_KAPPA]))) < 1e-3                    # C^2 centre-line
    assert not p.self_intersects()
    iso = double_lane_change(length_scale=1.0)
    assert [g.s_end_m - g.s_start_m for g in iso.gates] == pytest.approx([15.0, 25.0, 15.0])
    assert V_DLC ** 2 * np.max(np.abs(iso.table[:, COL_KAPPA])) / G > 2.0          # why the lengths are scaled


def test_dlc_gate_violations_count_cones() -> None:
    p = double_lane_change()
    s = np.arange(0.0, p.length_m, 0.2)
    q = p.sample(s)
    assert gate_violations(p, q.x, q.y, q.psi, L_CAR, W_CAR, CG_TO_FRONT) == 0       # the car fits on the line
    margin_lane1 = p.gates[0].y_left_m - 0.5 * W_CAR
    assert gate_violations(p, q.x, q.y + margin_lane1 - 0.01, q.psi, L_CAR, W_CAR, CG_TO_FRONT) == 0
    assert gate_violations(p, q.x, q.y + margin_lane1 + 0.01, q.psi, L_CAR, W_CAR, CG_TO_FRONT) == 1
    assert gate_violations(p, q.x, q.y, q.psi, L_CAR, 2.8, CG_TO_FRONT) == 3            # too wide for every lane
    # a car that never changes lane hits lane 3 only (lane 5 overlaps lane 1)
    straight = gate_violations(p, s, np.zeros_like(s), np.zeros_like(s), L_CAR, W_CAR, CG_TO_FRONT)
    assert straight == 1
    yawed = np.full_like(s, 0.2)
    assert gate_violations(p, q.x, q.y, q.psi + yawed, L_CAR, W_CAR, CG_TO_FRONT) == 3


def test_dlc_spec_validation() -> None:
    with pytest.raises(ValueError, match=r"DoubleLaneChangeSpec\.length_scale"):
        DoubleLaneChangeSpec(length_scale=0.0)
    with pytest.raises(ValueError, match=r"DoubleLaneChangeSpec\.vehicle_width_m"):
        double_lane_change(vehicle_width_m=-1.0)
    with pytest.raises(ValueError, match="ramp_fraction"):
        DoubleLaneChangeSpec(ramp_fraction=0.25)
    p = build_double_lane_change(DoubleLaneChangeSpec(approach_m=0.0, vehicle_width_m=1.7))
    assert p.gates[0].s_start_m == 0.0 and p.gates[0].width_m == pytest.approx(1.1 * 1.7 + 0.25)


# ------------------------------------------------------------------------------------------------- procedural
def test_procedural_is_deterministic_and_seed_dependent() -> None:
    a = procedural_track(11)
    b = procedural_track(11)
    c = procedural_track(12)
    assert a is not b and np.array_equal(a.table, b.table)
    assert a.table.shape != c.table.shape or not np.allclose(a.table, c.table)
    assert a.name == "procedural-11" and a.version == "1"


@pytest.mark.parametrize("seed", range(8))
def test_procedural_bounds(seed: int) -> None:
    cfg = ProceduralTrackConfig()
    p = procedural_track(seed)
    t = p.table
    assert not p.closed and p.length_m == pytest.approx(1000.0, abs=1e-9)
    assert np.max(np.abs(t[:, COL_KAPPA])) <= cfg.max_curvature_per_m * (1.0 + 1e-12)
    assert np.max(np.abs(t[:, COL_DKAPPA])) <= cfg.max_dkappa_per_m2 * (1.0 + 1e-9)
    assert np.max(np.abs(np.diff(t[:, COL_KAPPA]))) <= cfg.max_dkappa_per_m2 * p.ds_m * 1.001
    assert np.max(np.abs(t[:, COL_GRADE])) <= 0.05 + 1e-12
    assert t[0, COL_Z] == pytest.approx(0.0, abs=1e-12)
    assert np.all(t[: int(cfg.lead_in_m / p.ds_m), COL_KAPPA] == 0.0)                 # straight lead-in
    assert not p.self_intersects(clearance_m=cfg.min_clearance_m)


def test_procedural_overrides_and_validation() -> None:
    p = procedural_track(3, length_m=400.0, max_curvature=0.02)
    assert p.length_m == pytest.approx(400.0) and np.max(np.abs(p.table[:, COL_KAPPA])) <= 0.02 + 1e-12
    cfg = dataclasses.replace(ProceduralTrackConfig(), max_grade=0.0, straight_probability=1.0)
    flat = procedural_track(3, config=cfg)
    assert np.all(flat.table[:, COL_Z] == 0.0) and np.all(flat.table[:, COL_KAPPA] == 0.0)
    with pytest.raises(ValueError, match=r"ProceduralTrackConfig\.max_curvature_per_m"):
        ProceduralTrackConfig(max_curvature_per_m=-0.1)
    with pytest.raises(ValueError, match=r"ProceduralTrackConfig\.max_hold_m"):
        ProceduralTrackConfig(min_hold_m=50.0, max_hold_m=10.0)
    with pytest.raises(ValueError, match="seed"):
        procedural_track(-1)
