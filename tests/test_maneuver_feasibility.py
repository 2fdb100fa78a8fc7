"""Every manoeuvre is feasible for every shipped car: a perfect follower of the reference line clears every gate
within the car's own grip limit (tracks.feasibility; the limit from vehicle.steady_state, not mu g)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vtrack_gym.tracks import table as tb
from vtrack_gym.tracks.dlc import double_lane_change, gate_violations
from vtrack_gym.tracks.feasibility import (
    GATED_MANEUVERS,
    body_of,
    check_body_fits,
    check_entry_speed,
    coast_check,
    coast_speed_mps,
    entry_speed_bound_kmh,
    planned_maneuver,
)
from vtrack_gym.tracks.gate_judge import path_gate_clearance_m
from vtrack_gym.tracks.maneuvers import ObstacleAvoidanceParams, build_maneuver
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle
from vtrack_gym.vehicle.params import GRAVITY_MPS2
from vtrack_gym.vehicle.steady_state import lateral_limit_mps2

CARS = list_vehicles()
ROAD_CARS = tuple(c for c in CARS if load_vehicle(c).tyres.friction_mu <= 1.0)
"""The cars on road tyres (mu <= 1): the ISO passenger-car tests' speeds are sized for limits below 1 g; a car on
racing slicks (the Formula Student car, mu 1.6) corners faster than they ask (test_slicks_outgrow_the_iso_tests)."""
KMH = 1.0 / 3.6


def _gates_hit(path, vehicle) -> int:
    """Gates the body of ``vehicle`` touches when its CG follows ``path`` exactly, heading along it."""
    t = path.table
    c = vehicle.chassis
    return gate_violations(path, t[:, tb.COL_X], t[:, tb.COL_Y], t[:, tb.COL_PSI], c.body_length_m, c.body_width_m,
                           c.cg_to_front_end_m)


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("name", GATED_MANEUVERS)
def test_perfect_follower_of_the_planned_line_clears_every_gate(name: str, car: str) -> None:
    vehicle = load_vehicle(car)
    m = planned_maneuver(name, vehicle)
    assert m.path.gates and _gates_hit(m.path, vehicle) == 0
    assert m.spec.vehicle_width_m == vehicle.chassis.body_width_m
    lane_centres = build_maneuver(name, vehicle_width_m=vehicle.chassis.body_width_m)
    assert _gates_hit(lane_centres.path, vehicle) == 0
    assert m.peak_lateral_accel_mps2 < lane_centres.peak_lateral_accel_mps2


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("name", ["iso3888_1", "slalom"])
def test_constant_speed_manoeuvres_ask_less_than_the_cars_limit(name: str, car: str) -> None:
    vehicle = load_vehicle(car)
    m = planned_maneuver(name, vehicle)
    v = m.spec.nominal_speed_mps
    assert m.peak_lateral_accel_mps2 < lateral_limit_mps2(vehicle, v)
    # with margin: a controller has room to correct errors (<= 60 % of the car's limit)
    assert m.peak_lateral_accel_mps2 < 0.6 * lateral_limit_mps2(vehicle, v)


@pytest.mark.parametrize("car", CARS)
def test_step_curvature_asks_less_than_the_cars_limit(car: str) -> None:
    vehicle = load_vehicle(car)
    m = build_maneuver("step_curvature")
    assert m.peak_lateral_accel_mps2 < 0.7 * lateral_limit_mps2(vehicle, m.spec.nominal_speed_mps)


@pytest.mark.parametrize("car", ROAD_CARS)
def test_circle_ramp_crosses_the_cars_own_limit(car: str) -> None:
    """The ISO 4138 ramp is meant to reach the limit: its end speed asks more than the car's own limit."""
    vehicle = load_vehicle(car)
    m = build_maneuver("iso4138_circle")
    v_end = m.spec.nominal_speed_mps
    assert v_end ** 2 / 40.0 > lateral_limit_mps2(vehicle, v_end)


@pytest.mark.parametrize("car", ROAD_CARS)
def test_iso3888_2_entry_speed_bound(car: str) -> None:
    vehicle = load_vehicle(car)
    m = planned_maneuver("iso3888_2", vehicle)
    v80 = 80.0 * KMH
    # held at a constant 80 km/h the best line asks more than the car has: the test is not a constant-speed one
    assert m.peak_lateral_accel_mps2 > 1.2 * lateral_limit_mps2(vehicle, v80)
    bound = entry_speed_bound_kmh(vehicle)
    assert 60.0 < bound < 80.0
    assert coast_check(m.path, vehicle, bound * KMH).usage <= 1.0
    assert coast_check(m.path, vehicle, (bound + 0.5) * KMH).usage > 1.0


def test_paper_car_entry_speed_bound_and_coasting() -> None:
    car = load_vehicle("hatchback")
    assert entry_speed_bound_kmh(car) == pytest.approx(67.4, abs=0.5)
    # coasting: d(v^2)/ds = -(rho C_d A / m) v^2 - 2 C_rr g, checked against a fine explicit integration
    d = np.linspace(0.0, 60.0, 60001)
    v2 = np.empty_like(d)
    v2[0] = 20.0 ** 2
    a = car.powertrain.air_density_kgpm3 * car.powertrain.drag_area_m2 / car.chassis.mass_kg
    b = 2.0 * car.tyres.rolling_resistance_coeff * GRAVITY_MPS2
    for i in range(1, d.size):
        v2[i] = v2[i - 1] - (a * v2[i - 1] + b) * (d[i] - d[i - 1])
    assert coast_speed_mps(car, 20.0, d[-1:])[0] == pytest.approx(np.sqrt(v2[-1]), rel=1e-5)


def test_bad_input_names_the_field_the_limit_and_the_car() -> None:
    car = load_vehicle("suv")
    with pytest.raises(ValueError, match=r"entry_speed_kmh must be in \(0, 200\] km/h \(got 210.0 for "
                                         r"'Compact SUV"):
        check_entry_speed(210.0, car)
    with pytest.raises(ValueError, match=r"ObstacleAvoidanceParams.speed_mps must be in \(0.0, 55.5\d*\]"):
        ObstacleAvoidanceParams(speed_mps=210.0 * KMH)
    wide = dataclasses.replace(car, name="wide truck",
                               chassis=dataclasses.replace(car.chassis, body_width_m=2.5, track_width_m=2.1))
    with pytest.raises(ValueError, match=r"body_width_m = 2.5 m of 'wide truck' does not fit gate 'lane 1 \(entry\)'"
                                         r".*narrower than the gate's 2.358 m"):
        check_body_fits(double_lane_change(), wide)
    with pytest.raises(ValueError, match="no planned line for 'step_curvature'"):
        planned_maneuver("step_curvature", car)
    assert body_of(car).name == car.name


# ------------------------------------------------------------------------------------------ registered ids
def _maneuver_env_ids() -> list[str]:
    """Every registered ``vtrack/`` id built on a manoeuvre track (the -v1 ids and the -v0 ids still registered)."""
    from vtrack_gym.envs.scenarios import SCENARIOS
    from vtrack_gym.envs.track_sources import MANEUVER_TRACK_NAMES

    return sorted(s.env_id for s in SCENARIOS.values() if s.track.is_builtin and s.track.track in MANEUVER_TRACK_NAMES)


def _scenario_speed_mps(scenario, path, vehicle, s: np.ndarray) -> np.ndarray:
    """The speed [m/s] at stations ``s`` [m] of ``path`` that the scenario's protocol asks of a perfect follower:
    the profile's, or the entry speed up to the entry gate and the coasting (or held-throttle) speed after it."""
    from vtrack_gym.envs.speed import EntryThenRelease
    from vtrack_gym.tracks.feasibility import released_speed_mps
    from vtrack_gym.tracks.speed_profiles import speed_table

    if not isinstance(scenario.speed, EntryThenRelease):
        return np.interp(s, path.s_m, speed_table(path, scenario.speed).v_mps)
    gate = path.gates[0].s_start_m
    v = np.full(s.size, scenario.speed.entry_speed_mps)
    after = s >= gate
    v[after] = released_speed_mps(vehicle, scenario.speed.entry_speed_mps, s[after] - gate, scenario.speed.after_entry)
    return v


def test_the_maneuver_ids_are_the_current_and_the_kept_versions() -> None:
    assert _maneuver_env_ids() == sorted(["vtrack/ISO3888-1-v0", "vtrack/ISO3888-1-v1", "vtrack/ISO3888-2-v1",
                                          "vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2",
                                          "vtrack/ISO4138-Circle-v0", "vtrack/Slalom-v0", "vtrack/Slalom-v1",
                                          "vtrack/StepCurvature-v0"])


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("env_id", _maneuver_env_ids())
def test_every_registered_maneuver_is_feasible_for_every_car(env_id: str, car: str) -> None:
    """A perfect kinematic follower (the body's pose on the env's reference line) clears every gate, and the peak
    v^2 kappa at the scenario's speed (coasting or held-throttle speed after the entry gate) is below the car's own
    steady-state limit. The ISO 4138 circle is the exception by design: its ramp starts below the limit and ends
    above it (it measures the limit)."""
    import gymnasium as gym

    env = gym.make(env_id, vehicle=car)
    try:
        vehicle, scenario = env.unwrapped.config.vehicle, env.unwrapped.scenario
        (path,) = env.unwrapped.paths
    finally:
        env.close()
    if scenario.success.__class__.__name__ == "ConeGates" and scenario.success.exact:
        c = vehicle.chassis      # judged exactly: the body rectangle swept along the line, 1 cm steps
        body = np.array([c.cg_to_front_end_m, c.cg_to_front_end_m - c.body_length_m, 0.5 * c.body_width_m])
        margin = scenario.reference.margin_for(scenario.track, vehicle)   # 2 cm, or less by the margin rule
        assert path.gates and np.min(path_gate_clearance_m(path, body)) >= margin - 3e-4
    elif scenario.success.__class__.__name__ == "ConeGates":
        assert path.gates and _gates_hit(path, vehicle) == 0
    s = np.arange(0.0, path.length_m, 0.05)   # the line as the env interpolates it, between its rows too
    kappa = np.abs(path.sample(s).kappa)
    v = _scenario_speed_mps(scenario, path, vehicle, s)
    usage = v * v * kappa / np.asarray(lateral_limit_mps2(vehicle, v))
    if env_id == "vtrack/ISO4138-Circle-v0" and car in ROAD_CARS:
        on_circle = kappa > 0.99 / 40.0
        assert usage[on_circle][0] < 0.5 and usage[on_circle].max() > 1.0
    else:
        assert usage.max() < 1.0, f"{env_id} asks {usage.max():.3f} of {car}'s lateral limit"


@pytest.mark.parametrize("car", ROAD_CARS)
def test_iso3888_1_hold_throttle_bound(car: str) -> None:
    """Holding the throttle the car keeps its entry speed (the approximation of ``released_speed_mps``), so the
    bound is where the planned line's peak v^2 kappa meets the car's limit, above the standard's 80 km/h; coasting
    (slower on the line) never has a lower bound."""
    vehicle = load_vehicle(car)
    bound = entry_speed_bound_kmh(vehicle, "iso3888_1", "hold_throttle")
    m = planned_maneuver("iso3888_1", vehicle)
    v = bound * KMH
    assert m.path.gates[1].anchor[1] - 0.5 * m.path.gates[1].width_m == pytest.approx(3.5)  # cone-line reading
    s = np.arange(m.path.gates[0].s_start_m, m.path.gates[-1].s_end_m, 0.05)
    peak = v * v * np.max(np.abs(m.path.sample(s).kappa))
    assert peak == pytest.approx(lateral_limit_mps2(vehicle, v), rel=2e-3)
    assert 80.0 < bound < 120.0
    assert entry_speed_bound_kmh(vehicle, "iso3888_1", "coast") >= bound
    with pytest.raises(ValueError, match="after_entry must be one of coast, hold_throttle"):
        entry_speed_bound_kmh(vehicle, "iso3888_1", "brake")


def test_a_car_too_wide_for_the_lanes_is_refused_naming_the_field_the_limit_and_the_car() -> None:
    car = load_vehicle("suv")
    wide = dataclasses.replace(car, name="wide truck", chassis=dataclasses.replace(car.chassis, body_width_m=4.5))
    with pytest.raises(ValueError, match=r"ChassisParams.body_width_m = 4.5 m of 'wide truck' is too wide for "
                                         r"iso3888_2: its cone lanes are sized for cars up to 4 m wide"):
        planned_maneuver("iso3888_2", wide)


@pytest.mark.parametrize("car", [c for c in CARS if c not in ROAD_CARS])
def test_slicks_outgrow_the_iso_tests(car: str) -> None:
    """A car on slicks stays below its own limit where the passenger-car tests ask road cars for more than theirs:
    the ISO 4138 ramp's end speed on R 40 m, ISO 3888-2 held at 80 km/h, and its ISO 3888-1 bound is above 120 km/h."""
    vehicle = load_vehicle(car)
    v_end = build_maneuver("iso4138_circle").spec.nominal_speed_mps
    assert v_end ** 2 / 40.0 < lateral_limit_mps2(vehicle, v_end)
    assert planned_maneuver("iso3888_2", vehicle).peak_lateral_accel_mps2 < lateral_limit_mps2(vehicle, 80.0 * KMH)
    assert entry_speed_bound_kmh(vehicle, "iso3888_1", "hold_throttle") > 120.0


# ------------------------------------------------------------------------------------------ exact lines (-v2)
def _exact_clearance_m(path, vehicle) -> float:
    b = body_of(vehicle)
    return float(np.min(path_gate_clearance_m(path, np.array([b.cg_to_front_m, b.cg_to_front_m - b.length_m,
                                                                0.5 * b.width_m]))))


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize("name", ["iso3888_1", "iso3888_2"])
def test_the_driven_exact_line_is_within_five_percent_of_the_least_curvature(name: str, car: str) -> None:
    """The line a -v2 id drives (2 cm clear or, by the margin rule, the largest whole millimetre below that keeps
    within 5 %, judged exactly) asks at most 5 % more peak curvature than the least-curvature line (0 cm), and both
    keep their clearance through the path's own interpolation, swept exactly."""
    import gymnasium as gym

    from vtrack_gym.envs.scenarios import EXACT_TRACKING_MARGIN_M, MANEUVER_IDS

    env = gym.make(f"vtrack/{MANEUVER_IDS[name]}", vehicle=car)
    try:
        scenario, vehicle, (path,) = env.unwrapped.scenario, env.unwrapped.config.vehicle, env.unwrapped.paths
        margin = scenario.reference.margin_for(scenario.track, vehicle)
    finally:
        env.close()
    least = planned_maneuver(name, vehicle, 0.0, 2)
    driven = planned_maneuver(name, vehicle, margin, 2)
    assert np.array_equal(path.table, driven.path.table) and path.name.endswith(f"_m{margin:g}_exact")
    assert 0.0 < margin <= EXACT_TRACKING_MARGIN_M
    assert driven.line.peak_curvature_per_m <= 1.05 * least.line.peak_curvature_per_m
    assert driven.line.peak_curvature_per_m >= least.line.peak_curvature_per_m
    assert _exact_clearance_m(least.path, vehicle) >= -3e-4
    assert _exact_clearance_m(driven.path, vehicle) >= margin - 3e-4
    old = planned_maneuver(name, vehicle)          # version 1's 1 cm line: stiffer than the exact least one
    assert np.max(np.abs(old.path.table[:, tb.COL_KAPPA])) > least.line.peak_curvature_per_m


@pytest.mark.parametrize("car", CARS)
@pytest.mark.parametrize(("name", "after"), [("iso3888_1", "hold_throttle"), ("iso3888_2", "coast")])
def test_the_exact_bound_is_where_the_exact_curvature_meets_the_cars_limit(name: str, after: str, car: str) -> None:
    vehicle = load_vehicle(car)
    bound = entry_speed_bound_kmh(vehicle, name, after, planner_version=2)
    m = planned_maneuver(name, vehicle, 0.0, 2)
    assert coast_check(m.path, vehicle, bound * KMH, after, m.line.kappa_at).usage <= 1.0
    assert coast_check(m.path, vehicle, (bound + 0.05) * KMH, after, m.line.kappa_at).usage > 1.0
    assert bound >= entry_speed_bound_kmh(vehicle, name, after)     # no interpolation overshoot, no 1 cm margin
