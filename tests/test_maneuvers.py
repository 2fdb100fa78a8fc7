"""Standard manoeuvres (tracks.maneuvers): geometry against the standards' tables, smoothness, gates, specs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.tracks import (
    COL_DKAPPA,
    COL_KAPPA,
    COL_PSI,
    MANEUVERS,
    SUCCESS_CRITERIA,
    ConstantSpeed,
    Gate,
    ManeuverSpec,
    Path,
    SpeedRamp,
    build_maneuver,
    gate_boundaries,
    gate_violations,
    grip_limit_speed_mps,
    speed_table,
)
from vtrack_gym.tracks.maneuvers import (
    DoubleLaneChangeParams,
    ObstacleAvoidanceParams,
    SlalomParams,
    SteadyStateCircleParams,
    StepCurvatureParams,
    iso3888_2_obstacle_avoidance,
    iso4138_steady_state_circle,
    slalom,
    step_curvature,
)

G = 9.81
W_CAR = 1.916      # the paper's car (IDSC body width), reference-data section 1
L_CAR = 4.75
CG_TO_FRONT = 1.915
V80 = 80.0 / 3.6
GATED = ("iso3888_1", "iso3888_2", "slalom")


def _lane(gate: Gate) -> tuple[float, float, float, float]:
    """(x start, x end, y centre, width) of an anchored lane gate heading +X [m]."""
    assert gate.anchor is not None and gate.anchor[2] == 0.0
    x0, y0, _ = gate.anchor
    return x0, x0 + gate.lane_length_m, y0 + 0.5 * (gate.y_left_m + gate.y_right_m), gate.width_m


def _on_line(path: Path, step_m: float = 0.1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = path.sample(np.arange(0.0, path.length_m, step_m))
    return q.x, q.y, q.psi


# ------------------------------------------------------------------------------------- geometry vs the standards
def test_iso3888_1_gates_match_the_standard() -> None:
    # ISO 3888-1 (reference-data.md section 3; Project Chrono ISO3888_Helper): lane 1 15 m x (1.1 w + 0.25) on
    # y = 0; section 2 30 m; lane 3 25 m x (1.2 w + 0.25), offset 3.5 m left; section 4 25 m; lane 5 15 m x
    # (1.3 w + 0.25), right boundary on lane 1's right boundary. Approach 100 m. The default measures the 3.5 m
    # between the lane centres (the paper's reading, a CHOICE); Chrono's reading is checked below.
    m = build_maneuver("iso3888_1")
    w = W_CAR
    expected = [(100.0, 115.0, 0.0, 1.1 * w + 0.25), (145.0, 170.0, 3.5, 1.2 * w + 0.25),
                (195.0, 210.0, 0.5 * (1.3 * w + 0.25) - 0.5 * (1.1 * w + 0.25), 1.3 * w + 0.25)]
    assert [_lane(g) for g in m.path.gates] == [pytest.approx(e, abs=1e-9) for e in expected]
    g1, _, g5 = (_lane(g) for g in m.path.gates)
    assert g5[2] - 0.5 * g5[3] == pytest.approx(g1[2] - 0.5 * g1[3], abs=1e-12)     # right boundaries aligned
    assert m.spec.nominal_speed_mps == pytest.approx(V80)
    assert m.spec.standard.startswith("ISO 3888-1") and m.spec.success_criterion == "gates"
    # Chrono (ISO3888_Helper, ISO3888_1): lane 3's right boundary 3.5 m left of lane 1's centre line (y = 0)
    chrono = build_maneuver("iso3888_1", lane_offset_m=DoubleLaneChangeParams.chrono_lane_offset_m(w))
    x0, x1, y3, w3 = _lane(chrono.path.gates[1])
    assert (x0, x1, w3) == pytest.approx((145.0, 170.0, 1.2 * w + 0.25)) and y3 - 0.5 * w3 == pytest.approx(3.5)
    assert [_lane(g) for g in chrono.path.gates[::2]] == [pytest.approx(e, abs=1e-9) for e in expected[::2]]
    assert chrono.path.name != m.path.name


@pytest.mark.parametrize("w", [1.6, W_CAR, 2.3])
def test_iso3888_2_gates_match_the_standard(w: float) -> None:
    # ISO 3888-2:2011 clause 4.1 / Table 1 (as in Project Chrono ISO3888_Helper, variant ISO3888_2): section 1
    # 12 m x (1.1 w + 0.25) on y = 0; section 2 13.5 m; section 3 11 m x (w + 1), its right boundary 1 m left of
    # lane 1's left boundary; section 4 12.5 m; section 5 12 m x (1.3 w + 0.25, not less than 3 m), right
    # boundary on lane 1's. Total 61 m.
    m = iso3888_2_obstacle_avoidance(ObstacleAvoidanceParams(vehicle_width_m=w))
    l1, l3, l5 = (_lane(g) for g in m.path.gates)
    x0 = 100.0
    assert (l1[0], l1[1]) == pytest.approx((x0, x0 + 12.0))
    assert (l3[0], l3[1]) == pytest.approx((x0 + 25.5, x0 + 36.5))
    assert (l5[0], l5[1]) == pytest.approx((x0 + 49.0, x0 + 61.0))                 # total length 61 m
    assert l1[3] == pytest.approx(1.1 * w + 0.25)
    assert l3[3] == pytest.approx(w + 1.0)
    assert l5[3] == pytest.approx(max(1.3 * w + 0.25, 3.0))
    assert l1[2] == 0.0
    assert l3[2] - 0.5 * l3[3] == pytest.approx(l1[2] + 0.5 * l1[3] + 1.0)         # 1 m lateral offset
    assert l5[2] - 0.5 * l5[3] == pytest.approx(l1[2] - 0.5 * l1[3])
    assert m.spec.nominal_speed_mps == pytest.approx(V80) and m.spec.success_criterion == "gates"


def test_exit_lane_width_floor() -> None:
    narrow = ObstacleAvoidanceParams(vehicle_width_m=1.8).lane_widths_m()[2]      # 1.3 * 1.8 + 0.25 = 2.59
    wide = ObstacleAvoidanceParams(vehicle_width_m=2.3).lane_widths_m()[2]        # 1.3 * 2.3 + 0.25 = 3.24
    assert narrow == 3.0 and wide == pytest.approx(3.24)


def test_slalom_cones_and_line() -> None:
    # CHOICE (no standard): 10 cones on y = 0, 18 m apart from x = 60 m, passed on alternate sides.
    p = SlalomParams()
    m = slalom(p)
    a = 0.5 * W_CAR + 0.5
    assert len(m.path.gates) == 10
    for i, g in enumerate(m.path.gates):
        x_cone = 60.0 + 18.0 * i
        assert g.anchor == pytest.approx((x_cone - 0.15, 0.0, 0.0)) and g.lane_length_m == pytest.approx(0.3)
        side = 1.0 if i % 2 == 0 else -1.0                       # the car on the cone's left, then right, ...
        assert (g.y_right_m if side > 0 else g.y_left_m) == pytest.approx(side * 0.15)
        q = m.path.sample(np.array([0.5 * (g.s_start_m + g.s_end_m)]))
        assert float(q.x[0]) == pytest.approx(x_cone, abs=1e-6)
        assert float(q.y[0]) == pytest.approx(side * a, abs=1e-6)
        assert float(q.psi[0]) == pytest.approx(0.0, abs=1e-6)
    assert m.spec.nominal_speed_mps == pytest.approx(40.0 / 3.6)
    assert m.peak_lateral_accel_mps2 < 0.9 * G


def test_circle_radius_ramp_and_grip_limit() -> None:
    p = SteadyStateCircleParams()
    m = iso4138_steady_state_circle(p)
    v_grip = math.sqrt(0.9 * 9.81 * 40.0)
    assert grip_limit_speed_mps(0.9, 40.0) == pytest.approx(v_grip) == pytest.approx(m.spec.grip_limit_speed_mps)
    assert grip_limit_speed_mps(1.0, 100.0, 10.0) == pytest.approx(math.sqrt(1000.0))
    start = p.lead_in_m + p.entry_m
    s = m.path.s_m
    on_circle = s >= start
    assert np.allclose(m.path.table[on_circle, COL_KAPPA], 1.0 / 40.0, atol=1e-12)
    assert np.all(m.path.table[s <= p.lead_in_m, COL_KAPPA] == 0.0)
    ramp = m.spec.speed_profile
    assert isinstance(ramp, SpeedRamp)
    tab = speed_table(m.path, ramp)
    assert float(tab.v_ref(start - 1.0)) == pytest.approx(5.0)
    assert float(tab.v_ref(m.path.length_m)) == pytest.approx(1.1 * v_grip)
    s1, s2 = start + 100.0, start + 600.0                        # constant acceleration: v^2 linear in s
    v1, v2 = float(tab.v_ref(s1)), float(tab.v_ref(s2))
    assert (v2 ** 2 - v1 ** 2) / (2.0 * (s2 - s1)) == pytest.approx(0.2, rel=1e-9)
    ramp_end = start + ramp.ramp_length_m
    assert m.path.length_m - ramp_end >= 2.0 * math.pi * 40.0                    # a lap after the ramp
    assert m.spec.time_limit_s >= start / 5.0 + ramp.ramp_duration_s
    assert m.spec.success_criterion == "circle" and m.spec.lateral_tolerance_m == 0.5


def test_step_curvature_geometry() -> None:
    p = StepCurvatureParams()
    m = step_curvature(p)
    s, kap = m.path.s_m, m.path.table[:, COL_KAPPA]
    assert np.all(kap[s <= 60.0] == 0.0)
    assert np.allclose(kap[s >= 61.0], 1.0 / 50.0, atol=1e-12)
    assert m.path.table[-1, COL_PSI] == pytest.approx(math.pi + 0.5 * 1.0 / 50.0, abs=1e-9)  # + half the blend
    assert m.spec.success_criterion == "end" and m.spec.nominal_speed_mps == 15.0


# ------------------------------------------------------------------------------------- smoothness and feasibility
@pytest.mark.parametrize("name", sorted(MANEUVERS))
def test_curvature_and_heading_are_continuous(name: str) -> None:
    path = build_maneuver(name).path
    t = path.table
    dk_max = 1.05 * float(np.max(np.abs(t[:, COL_DKAPPA])))   # the rows may miss the true max of dkappa/ds
    assert np.all(np.isfinite(t[:, COL_DKAPPA]))
    assert np.max(np.abs(np.diff(t[:, COL_KAPPA]))) <= dk_max * path.ds_m * (1.0 + 1e-6)
    assert np.max(np.abs(np.diff(t[:, COL_PSI]))) <= np.max(np.abs(t[:, COL_KAPPA])) * path.ds_m * (1.0 + 1e-6)


def test_iso3888_reference_lines_against_grip() -> None:
    # module docstring: at 80 km/h the ISO 3888-1 line asks less than mu g (0.9 g), the ISO 3888-2 line more;
    # a line straight inside the whole of every gate needs at least 4 v^2 dy / dx^2.
    assert build_maneuver("iso3888_1").peak_lateral_accel_mps2 < 0.9 * G
    assert build_maneuver("iso3888_2").peak_lateral_accel_mps2 > 0.9 * G
    stiff = iso3888_2_obstacle_avoidance(ObstacleAvoidanceParams(overlap_m=0.0))
    dy = 0.5 * (1.1 * W_CAR + 0.25) + 1.0 + 0.5 * (W_CAR + 1.0)                    # lane 1 -> lane 3 centres
    assert stiff.peak_lateral_accel_mps2 >= 4.0 * V80 ** 2 * dy / 13.5 ** 2
    assert stiff.peak_lateral_accel_mps2 > build_maneuver("iso3888_2").peak_lateral_accel_mps2
    assert all(g.anchor is None for g in stiff.path.gates)      # straight in the gates: centre-line offsets


# ------------------------------------------------------------------------------------- cones hit
@pytest.mark.parametrize("name", GATED)
def test_car_on_the_line_hits_no_gate_and_straight_through_hits(name: str) -> None:
    path = build_maneuver(name).path
    x, y, psi = _on_line(path)
    assert gate_violations(path, x, y, psi, L_CAR, W_CAR, CG_TO_FRONT) == 0
    s = np.arange(0.0, path.length_m, 0.1)
    straight = gate_violations(path, s, np.zeros_like(s), np.zeros_like(s), L_CAR, W_CAR, CG_TO_FRONT)
    assert straight == (10 if name == "slalom" else 1)           # along the cone line / never leaving lane 1
    assert gate_violations(path, x, y, psi, L_CAR, 3.5, CG_TO_FRONT) == len(path.gates)  # too wide everywhere


def test_gate_violations_counts_a_shifted_car_at_the_margin() -> None:
    path = build_maneuver("iso3888_2").path
    x, y, psi = _on_line(path)
    first = path.gates[0]
    margin = first.y_left_m - 0.5 * W_CAR                       # lane 1: (0.1 w + 0.25) / 2 each side
    shifted = y + margin + 0.02
    assert gate_violations(path, x, shifted, psi, L_CAR, W_CAR, CG_TO_FRONT) >= 1
    in_lane1 = (x >= 95.0) & (x <= 105.0)                     # on lane 1's straight part
    assert gate_violations(path, x[in_lane1], y[in_lane1] + margin - 0.01, psi[in_lane1], L_CAR, W_CAR,
                           CG_TO_FRONT) == 0


def test_a_single_cone_between_the_body_corners_counts() -> None:
    # the body's side passes the cone while both corners are outside the 0.3 m window
    path = build_maneuver("slalom").path
    x_cone = 60.0
    hit = gate_violations(path, np.array([x_cone]), np.array([0.9]), np.array([0.0]), L_CAR, W_CAR, CG_TO_FRONT)
    clear = gate_violations(path, np.array([x_cone]), np.array([1.2]), np.array([0.0]), L_CAR, W_CAR, CG_TO_FRONT)
    assert (hit, clear) == (1, 0)


def test_gate_boundaries_are_the_cone_lines() -> None:
    path = build_maneuver("iso3888_2").path
    lane3 = path.gates[1]
    left, right = gate_boundaries(path, lane3, n=5)
    assert np.allclose(left[:, 0], np.linspace(125.5, 136.5, 5)) and np.allclose(right[:, 0], left[:, 0])
    _, y0, _ = lane3.anchor
    assert np.allclose(left[:, 1], y0 + lane3.y_left_m) and np.allclose(right[:, 1], y0 + lane3.y_right_m)
    free = build_maneuver("iso3888_1", overlap_m=0.0).path                        # centre-line offsets
    left, right = gate_boundaries(free, free.gates[0], n=3)
    assert np.allclose(left[:, 0], [100.0, 107.5, 115.0]) and np.allclose(left[:, 1] - right[:, 1], 1.1 * W_CAR + 0.25)
    with pytest.raises(ValueError, match="n must be >= 2"):
        gate_boundaries(path, lane3, n=1)


# ------------------------------------------------------------------------------------- specs as data
@pytest.mark.parametrize("name", sorted(MANEUVERS))
def test_specs_are_data_with_documented_criteria(name: str) -> None:
    m = build_maneuver(name)
    spec = m.spec
    assert spec.name == name and spec.success_criterion in SUCCESS_CRITERIA
    assert spec.time_limit_s * spec.nominal_speed_mps > m.path.length_m
    assert speed_table(m.path, spec.speed_profile).v_mps.max() <= spec.nominal_speed_mps + 1e-9
    assert spec.source and spec.standard
    with pytest.raises(AttributeError):
        spec.name = "x"  # type: ignore[misc]
    assert (name in GATED) == bool(m.path.gates)


def test_spec_and_params_validation() -> None:
    base = dict(name="x", standard="none", nominal_speed_mps=10.0, speed_profile=ConstantSpeed(10.0),
                time_limit_s=10.0, source="s", vehicle_width_m=1.9)
    with pytest.raises(ValueError, match="success_criterion must be one of"):
        ManeuverSpec(**base, success_criterion="fast")
    with pytest.raises(ValueError, match="lateral_tolerance_m must be > 0"):
        ManeuverSpec(**base, success_criterion="circle")
    with pytest.raises(ValueError, match="speed_profile must be a tracks speed profile"):
        ManeuverSpec(**{**base, "speed_profile": 10.0}, success_criterion="end")
    with pytest.raises(ValueError, match="unknown manoeuvre"):
        build_maneuver("moose")
    with pytest.raises(ValueError, match=r"SlalomParams\.cone_spacing_m"):
        build_maneuver("slalom", cone_spacing_m=1.0)
    with pytest.raises(ValueError, match=r"ObstacleAvoidanceParams\.overlap_m"):
        ObstacleAvoidanceParams(overlap_m=6.0)
    with pytest.raises(ValueError, match="v_start_mps must be <"):
        iso4138_steady_state_circle(SteadyStateCircleParams(v_start_mps=30.0))
    with pytest.raises(ValueError, match="friction_mu"):
        grip_limit_speed_mps(0.0, 40.0)
    with pytest.raises(ValueError, match=r"Gate\.anchor"):
        Gate(0.0, 1.0, 1.0, -1.0, anchor=(0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"Gate\.length_m"):
        Gate(0.0, 1.0, 1.0, -1.0, length_m=2.0)


def test_speed_ramp_profile() -> None:
    ramp = SpeedRamp(v_start_mps=5.0, v_end_mps=15.0, accel_mps2=0.5, s_start_m=10.0)
    assert ramp.ramp_length_m == pytest.approx((225.0 - 25.0) / 1.0)
    assert ramp.ramp_duration_s == pytest.approx(20.0)
    assert ramp.speed_at(np.array([0.0, 10.0, 210.0, 500.0])) == pytest.approx([5.0, 5.0, 15.0, 15.0])
    down = SpeedRamp(v_start_mps=15.0, v_end_mps=5.0, accel_mps2=0.5)
    assert down.speed_at(200.0) == pytest.approx(5.0)
    with pytest.raises(ValueError, match=r"SpeedRamp\.accel_mps2"):
        SpeedRamp(v_start_mps=5.0, v_end_mps=15.0, accel_mps2=0.0)
