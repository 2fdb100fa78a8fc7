"""The Formula Student car (``vehicle="formula_student"``), the shipped FS cone layouts (``tracks.fs_layouts``), the
feasibility of every shipped car on them (``tracks.layout_feasibility``) and the FS race ``vtrack/RaceFS-v0``."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.tracks.cones import load_cone_track
from vtrack_gym.tracks.fs_layouts import FS_LAYOUTS, fs_layout
from vtrack_gym.tracks.layout_feasibility import feasibility_table, layout_feasibility
from vtrack_gym.vehicle import list_vehicles, load_vehicle
from vtrack_gym.vehicle.catalog import load_vehicle_record
from vtrack_gym.vehicle.linear import understeer_gradient
from vtrack_gym.vehicle.params import GRAVITY_MPS2, DesignModel
from vtrack_gym.vehicle.steady_state import cornering_equilibrium, grip_limit
from vtrack_gym.vehicle.turning import kinematic_turning_radius_m, min_turning_radius_m

FS = "formula_student"


def test_the_car_is_chosen_by_name_like_every_shipped_car() -> None:
    assert FS in list_vehicles()
    car = load_vehicle(FS)
    env = gym.make("vtrack/LateralTracking-v0", vehicle=FS)
    try:
        assert env.unwrapped.config.vehicle == car
    finally:
        env.close()
    c = car.chassis
    assert c.wheelbase_m == pytest.approx(1.60) and c.mass_kg == 260.0 and c.body_width_m < 1.5
    # every value says where it comes from; the published FS data sets carry most of them
    sources = [s for g in load_vehicle_record(FS).sources.values() for s in g.values()]
    assert sum(s.startswith(("ADTM", "AMZ")) for s in sources) > len(sources) / 2


def test_min_turning_radius_under_3_m_from_the_plant() -> None:
    """The plant held at full lock at walking pace drives the kinematic circle of its CG; the FS car's is under 3 m,
    every road car's above 3.5 m."""
    for name in list_vehicles():
        car = load_vehicle(name)
        radius = min_turning_radius_m(car)
        assert radius == pytest.approx(kinematic_turning_radius_m(car), rel=2e-3)
        assert (radius < 3.0) if name == FS else (radius > 3.5)
    fs = load_vehicle(FS)
    assert min_turning_radius_m(fs) == pytest.approx(math.hypot(0.768, 1.6 / math.tan(math.radians(30.0))), rel=2e-3)
    # faster, the tyres slip and the circle widens (understeer)
    assert min_turning_radius_m(fs, 6.0) > min_turning_radius_m(fs, 2.0) > min_turning_radius_m(fs)
    with pytest.raises(ValueError, match=r"speed_mps must be in \[0.1, 10\]"):
        min_turning_radius_m(fs, 20.0)
    # at its grip limit the hatchback does not settle on a circle at full lock: no radius, a clear error
    with pytest.raises(ValueError, match=r"no steady circle at full lock at speed_mps=6.0 m/s"):
        min_turning_radius_m(load_vehicle("hatchback"), 6.0)


@pytest.mark.parametrize(("radius", "speed"), [(40.0, 5.0), (40.0, 12.0), (20.0, 8.0)])
def test_steady_cornering_follows_the_linear_single_track_theory(radius: float, speed: float) -> None:
    """In the linear range (a_y <= 0.37 g) the plant's equilibrium has the steering angle l / R + K a_y (K the
    understeer gradient of its design model) and the sideslip a2 / R - m a1 v^2 / (l C_r R)."""
    car = load_vehicle(FS)
    c, a_y = car.chassis, speed * speed / radius
    eq = cornering_equilibrium(car, radius, speed)
    k = understeer_gradient(DesignModel.from_vehicle(car))
    assert k > 0.0
    assert eq.road_wheel_angle_rad == pytest.approx(c.wheelbase_m / radius + k * a_y, rel=5e-3)
    beta = c.cg_to_rear_axle_m / radius - c.mass_kg * c.cg_to_front_axle_m * a_y / (
        c.wheelbase_m * car.tyres.rear_cornering_stiffness_npr)
    # beta is a difference of two terms (near zero at 12 m/s): compared in absolute terms, 0.02 deg; the linear
    # theory leaves out the few % of rear cornering stiffness that load transfer costs the plant's tyres
    assert eq.sideslip_rad == pytest.approx(beta, abs=4e-4)


def test_grip_limit_is_a_racing_slicks_one() -> None:
    """Above any road car's, below mu g (load transfer on a 1.2 m track, degressive tyres)."""
    fs = grip_limit(load_vehicle(FS), 20.0).a_y_mps2
    road = max(grip_limit(load_vehicle(n), 20.0).a_y_mps2 for n in list_vehicles() if n != FS)
    mu_g = load_vehicle(FS).tyres.friction_mu * GRAVITY_MPS2
    assert 1.3 * road < fs and 0.8 * mu_g < fs < mu_g


@pytest.mark.parametrize("name", FS_LAYOUTS)
def test_each_layout_loads_as_a_cone_lined_loop(name: str) -> None:
    path = load_cone_track(fs_layout(name))
    widths = path.half_widths_rows().sum(axis=1)
    assert path.closed and path.cones_m is not None and len(path.cones_m) > 100
    assert 3.0 < widths.min() and widths.max() < 5.5       # FS tracks: at least 3 m between the cone lines
    assert 90.0 < path.length_m < 400.0


def test_unknown_layout_names_the_shipped_ones() -> None:
    with pytest.raises(ValueError, match=r"unknown Formula Student layout 'fsg\.csv'; shipped: amz_fsi\.csv"):
        fs_layout("fsg.csv")


def test_feasibility_table_on_the_tightest_layout() -> None:
    """The peanut, every shipped car: all fit and, on paper, turn (the racing line opens its bends to ~4.9-5.3 m,
    above even the hatchback's 4.66 m circle); the FS car turns 2.4 m tighter than its line needs and its bound is
    more than 20 % below every road car's. A car as wide as the track does not fit and gets no bound."""
    track = fs_layout("eufs_peanut.csv")
    rows = {r.vehicle: r for r in feasibility_table([track], list(list_vehicles()))}
    fs = rows[load_vehicle(FS).name]
    assert all(r.fits and r.drivable for r in rows.values())
    assert fs.min_turning_radius_m < 3.0 < fs.line_min_radius_m - 2.0
    assert fs.body_width_m + 2.0 < fs.min_track_width_m
    assert 8.0 < fs.lap_time_bound_s < 0.8 * min(r.lap_time_bound_s for r in rows.values() if r is not fs)
    car = load_vehicle("suv")
    wide = dataclasses.replace(car, chassis=dataclasses.replace(car.chassis, body_width_m=3.6))
    too_wide = layout_feasibility(track, wide)
    assert not too_wide.fits and not too_wide.drivable and math.isnan(too_wide.lap_time_bound_s)


def test_fs_race_laps_clean_with_a_baseline() -> None:
    """vtrack/RaceFS-v0 (the FS car on AMZ's FSI cones): the centre-line baseline laps within the wheels rule and
    touches no cone."""
    env = gym.make("vtrack/RaceFS-v0", laps=1)
    try:
        assert env.unwrapped.config.vehicle == load_vehicle(FS)
        row = vtrack_gym.evaluate(lambda e: vtrack_gym.make_policy("centreline", e), env)[0]
    finally:
        env.close()
    m = row.metrics
    assert row.termination == "completed" and m["laps_completed"] == 1
    assert m["track_limit_violations"] == 0 and m["cones_hit"] == 0
    assert 1.0 < m["lap_time_fraction"] < 1.5 and np.isfinite(m["best_lap_s"])
