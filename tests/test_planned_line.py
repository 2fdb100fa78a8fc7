"""Planned reference lines: least peak curvature through cone lanes for the car's body (tracks.planned_line)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.dlc import DoubleLaneChangeSpec, build_double_lane_change, gate_violations
from vtrack_gym.tracks.lanes import LaneSection
from vtrack_gym.tracks.maneuvers import (
    DoubleLaneChangeParams,
    ObstacleAvoidanceParams,
    build_maneuver,
    iso3888_1_double_lane_change,
)
from vtrack_gym.tracks.planned_line import BodyRectangle, curvature_rate_limit_per_m2, plan_line


def _bang_bang_peak_curvature(dy_m: float, gap_m: float, slack_m: float) -> float:
    """Least peak curvature of a point that leaves the corridor |y| <= slack (x <= 0) and enters |y - dy| <= slack
    (x >= gap) with zero heading in both (small angles): the parabola y = -slack + K u^2 / 2 starts inside the
    first corridor, touches y = +slack at its end, switches at mid-gap; the exact answer of the problem."""
    def excess(k: float) -> float:
        return -slack_m + 0.5 * k * (0.5 * gap_m + 2.0 * math.sqrt(slack_m / k)) ** 2 - 0.5 * dy_m
    return brentq(excess, 1e-7, 1.0)


@pytest.mark.parametrize(("dy", "gap", "slack", "margin"), [(2.0, 60.0, 0.01, 0.005), (3.0, 80.0, 0.05, 0.005),
                                                            (1.0, 40.0, 0.0075, 0.0025)])
def test_lane_change_peak_curvature_is_the_bang_bang_answer(dy: float, gap: float, slack: float,
                                                           margin: float) -> None:
    body = BodyRectangle(0.6, 0.6, 0.3, "small body")
    lanes = [LaneSection(20.0, 0.6 + 2.0 * slack, 0.0), LaneSection(20.0, 0.6 + 2.0 * slack, dy)]
    line = plan_line(lanes, [gap], body, approach_m=10.0, run_out_m=10.0, margin_m=margin)
    expected = _bang_bang_peak_curvature(dy, gap, slack - margin)
    assert line.peak_curvature_per_m == pytest.approx(expected, rel=3e-3)
    assert line.peak_curvature_per_m < 4.0 * dy / gap ** 2        # the slack in the lanes is used


def test_planned_iso3888_2_beats_the_lane_centre_line_and_clears_every_gate() -> None:
    rate = curvature_rate_limit_per_m2(math.radians(800.0) / 16.0, 2.91, 80.0 / 3.6)
    body = BodyRectangle(4.75, 1.916, 1.915, "paper car")
    planned = build_maneuver("iso3888_2", reference="planned", body=body, max_curvature_rate_per_m2=rate)
    centres = build_maneuver("iso3888_2")
    t = planned.path.table
    assert gate_violations(planned.path, t[:, tb.COL_X], t[:, tb.COL_Y], t[:, tb.COL_PSI], 4.75, 1.916, 1.915) == 0
    assert len(planned.path.gates) == 3 and all(g.anchor is not None for g in planned.path.gates)
    g = 9.81
    # an independent minimum-peak-curvature optimisation through the same cones gives 1.13 g at 80 km/h
    assert planned.peak_lateral_accel_mps2 / g == pytest.approx(1.13, abs=0.02)
    assert centres.peak_lateral_accel_mps2 / planned.peak_lateral_accel_mps2 > 1.5
    assert np.max(np.abs(t[:, tb.COL_DKAPPA])) <= rate * (1.0 + 1e-3)


def test_planned_line_is_c2_and_starts_straight() -> None:
    m = build_maneuver("slalom", reference="planned")
    t = m.path.table
    assert np.all(t[:40, tb.COL_KAPPA] == pytest.approx(0.0, abs=1e-9))
    assert abs(t[-1, tb.COL_KAPPA]) < 1e-9 and abs(t[-1, tb.COL_PSI]) < 1e-9
    step = np.max(np.abs(np.diff(t[:, tb.COL_KAPPA])))           # curvature continuous: no jumps between rows
    assert step <= np.max(np.abs(t[:, tb.COL_DKAPPA])) * m.path.ds_m * 1.01
    # the table is consistent: a chord's heading differs from the mean of its end headings by dkappa/ds ds^2 / 12
    chord = np.arctan2(np.diff(t[:, tb.COL_Y]), np.diff(t[:, tb.COL_X]))
    bound = np.max(np.abs(t[:, tb.COL_DKAPPA])) * m.path.ds_m ** 2 / 12.0
    assert np.max(np.abs(chord - 0.5 * (t[1:, tb.COL_PSI] + t[:-1, tb.COL_PSI]))) <= 1.02 * bound + 1e-12
    assert gate_violations(m.path, t[:, tb.COL_X], t[:, tb.COL_Y], t[:, tb.COL_PSI], 4.75, 1.916, 1.915) == 0


def test_iso3888_1_lane_offset_readings() -> None:
    w = 1.916
    cone = DoubleLaneChangeParams(lane_offset_from="cone_line")
    assert cone.lane3_centre_offset_m() == pytest.approx(3.5 + 0.5 * (1.2 * w + 0.25)) == pytest.approx(4.7746)
    assert DoubleLaneChangeParams.chrono_lane_offset_m(w) == cone.lane3_centre_offset_m()
    default = iso3888_1_double_lane_change()
    legacy = build_double_lane_change(DoubleLaneChangeSpec(vehicle_width_m=w, length_scale=1.0, approach_m=100.0,
                                                           overlap_m=7.0, lane_offset_m=3.5))
    assert np.array_equal(default.path.table, legacy.table)       # the centre reading stays the default
    side = iso3888_1_double_lane_change(cone).path.gates[1]
    assert side.anchor is not None and side.anchor[1] - 0.5 * side.width_m == pytest.approx(3.5)  # cone line
    with pytest.raises(ValueError, match="lane_offset_from must be one of"):
        DoubleLaneChangeParams(lane_offset_from="kerb")


def test_too_wide_a_car_is_refused_naming_the_field_the_limit_and_the_car() -> None:
    lanes = [LaneSection(15.0, 2.0, 0.0, "lane 1 (entry)"), LaneSection(15.0, 2.0, 3.0, "lane 3")]
    body = BodyRectangle(4.6, 2.1, 2.0, "wide van")
    with pytest.raises(ValueError, match=r"vehicle_width_m = 2.1 m of 'wide van'.*lane 1 \(entry\).*narrower than "
                                         r"1.980 m"):
        plan_line(lanes, [20.0], body, approach_m=10.0, run_out_m=10.0)


def test_reference_options_are_validated() -> None:
    with pytest.raises(ValueError, match="reference must be one of"):
        ObstacleAvoidanceParams(reference="racing")
    with pytest.raises(ValueError, match=r"body.width_m \(1.8 m, 'car'\) must equal vehicle_width_m"):
        ObstacleAvoidanceParams(reference="planned", body=BodyRectangle(4.5, 1.8, 2.0))
    with pytest.raises(ValueError, match=r"BodyRectangle\.cg_to_front_m must be"):
        BodyRectangle(4.5, 1.8, 5.0)
    with pytest.raises(ValueError, match=r"speed_mps must be a finite number > 0"):
        curvature_rate_limit_per_m2(1.0, 2.9, 0.0)
