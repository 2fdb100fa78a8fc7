"""Roll inertia: vehicle files give it about the sprung mass's CG; the plant's roll-axis value is derived."""

from __future__ import annotations

import json

import pytest

from vtrack_gym.vehicle.catalog import (
    FORMAT,
    FORMAT_V1,
    ROLL_CG_FIELD,
    VehicleFileError,
    list_vehicles,
    load_vehicle_record,
    parse_vehicle,
    record_from_params,
    roll_axis_inertia_kgm2,
)
from vtrack_gym.vehicle.params import VehicleParams

CG_RANGES = {"hatchback": (200.0, 250.0), "suv": (350.0, 480.0), "sports": (150.0, 250.0),
             "formula_student": (50.0, 150.0)}
"""Published roll inertias about the sprung mass's CG [kg m^2] for the class of each shipped car (C-segment cars
200-250, vans and SUVs 350-480; a light roadster below the C-segment; a Formula Student car with its driver about
100, the published template's value)."""


@pytest.mark.parametrize("name", list_vehicles())
def test_roll_axis_value_is_the_cg_value_plus_the_parallel_axis_term(name: str) -> None:
    record = load_vehicle_record(name)
    p = record.params
    h_s = p.chassis.cg_height_m - p.roll.roll_centre_height_m
    assert record.roll_inertia_cg_kgm2 is not None
    assert p.roll.roll_inertia_kgm2 == record.roll_inertia_cg_kgm2 + p.sprung_mass_kg * h_s * h_s
    lo, hi = CG_RANGES[name]
    assert lo <= record.roll_inertia_cg_kgm2 <= hi
    assert json.loads(record.to_json())["format"] == FORMAT
    assert record.sources["roll"][ROLL_CG_FIELD].startswith(("CHOICE", "ESTIMATE", "ADTM"))


def test_paper_car_keeps_its_roll_axis_inertia_exactly() -> None:
    record = load_vehicle_record("hatchback")
    assert record.params.roll.roll_inertia_kgm2 == 450.0 == VehicleParams().roll.roll_inertia_kgm2


def test_earlier_format_is_read_as_the_roll_axis_value() -> None:
    suv = load_vehicle_record("suv").params
    record = record_from_params(suv, "a derived car", "CHOICE: test")
    text = record.to_json()
    assert json.loads(text)["format"] == FORMAT_V1 and "roll_inertia_kgm2" in json.loads(text)["roll"]
    again = parse_vehicle(text)
    assert again == record and again.params == suv and again.roll_inertia_cg_kgm2 is None


def test_bad_cg_inertia_is_refused_naming_the_key() -> None:
    doc = json.loads(load_vehicle_record("hatchback").to_json())
    doc["roll"][ROLL_CG_FIELD]["value"] = 0.0
    with pytest.raises(VehicleFileError, match=rf"roll\.{ROLL_CG_FIELD} must be > 0"):
        parse_vehicle(json.dumps(doc))
    doc["roll"][ROLL_CG_FIELD]["value"] = 200.0
    doc["roll"]["roll_inertia_kgm2"] = {"value": 450.0, "source": "CHOICE: both"}
    with pytest.raises(VehicleFileError, match=r"unknown key roll\.roll_inertia_kgm2"):
        parse_vehicle(json.dumps(doc))


def test_parallel_axis_helper() -> None:
    assert roll_axis_inertia_kgm2(200.0, 1000.0, 0.5) == 450.0
