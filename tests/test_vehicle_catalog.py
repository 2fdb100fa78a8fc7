"""Vehicles as data: the shipped files load strictly, round-trip, and the default file is the paper's car."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from vtrack_gym.vehicle.catalog import (
    DEFAULT_VEHICLE,
    MAX_VEHICLE_FILE_BYTES,
    SOURCE_TAGS,
    VehicleFileError,
    list_vehicles,
    load_vehicle,
    load_vehicle_record,
    parse_vehicle,
    resolve_vehicle,
)
from vtrack_gym.vehicle.linear import understeer_gradient
from vtrack_gym.vehicle.params import DesignModel, VehicleParams

SHIPPED = list_vehicles()


def test_at_least_three_cars_are_shipped() -> None:
    assert DEFAULT_VEHICLE in SHIPPED
    assert {"hatchback", "suv", "sports"} <= set(SHIPPED)


def test_default_file_is_the_paper_car_exactly() -> None:
    assert load_vehicle(DEFAULT_VEHICLE) == VehicleParams()
    assert resolve_vehicle(None) == VehicleParams()


@pytest.mark.parametrize("name", SHIPPED)
def test_each_file_loads_validates_and_round_trips(name: str) -> None:
    record = load_vehicle_record(name)
    assert isinstance(record.params, VehicleParams)
    assert parse_vehicle(record.to_json()) == record
    assert load_vehicle(name) == record.params == resolve_vehicle(name)
    # every value has a source; modelling choices say so
    for group in record.sources.values():
        assert all(text.strip() for text in group.values())
    assert any(text.startswith("CHOICE") for group in record.sources.values() for text in group.values())
    # every shipped car understeers in the linear design model (the baselines assume a stable car)
    assert understeer_gradient(DesignModel.from_vehicle(record.params)) > 0.0


@pytest.mark.parametrize("name", SHIPPED)
def test_every_source_says_what_kind_of_source_it_is(name: str) -> None:
    """Published figures recalled from memory are marked as such, apart from estimates and modelling choices; the
    paper's car has no value of either unverified kind."""
    sources = [text for group in load_vehicle_record(name).sources.values() for text in group.values()]
    untagged = [text for text in sources if not text.startswith(SOURCE_TAGS)]
    assert not untagged
    unverified = [text for text in sources if text.startswith(("SPEC", "ESTIMATE"))]
    assert (name == DEFAULT_VEHICLE) == (not unverified)


def test_cars_differ_in_character() -> None:
    hatch, suv, sports = (load_vehicle(n) for n in ("hatchback", "suv", "sports"))
    assert suv.total_cg_height_m > hatch.total_cg_height_m + 0.1  # high-CG SUV
    assert suv.chassis.mass_kg > hatch.chassis.mass_kg > sports.chassis.mass_kg + 300.0
    assert sports.total_cg_height_m < hatch.total_cg_height_m
    assert sports.powertrain.front_drive_share == 0.0 and hatch.powertrain.front_drive_share == 1.0


def _doc(name: str = DEFAULT_VEHICLE) -> dict:
    return json.loads(load_vehicle_record(name).to_json())


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda d: d.update(colour="red"), r"unknown key colour"),
    (lambda d: d["chassis"].update(wings=1.0), r"unknown key chassis\.wings"),
    (lambda d: d["tyres"]["friction_mu"].update(note="x"), r"unknown key tyres\.friction_mu\.note"),
    (lambda d: d["chassis"].pop("mass_kg"), r"missing key chassis\.mass_kg"),
    (lambda d: d.pop("roll"), r"missing key roll"),
    (lambda d: d["roll"]["unsprung_cg_height_m"].pop("source"), r"missing key roll\.unsprung_cg_height_m\.source"),
    (lambda d: d["chassis"]["mass_kg"].update(value="1413"), r"chassis\.mass_kg\.value must be a number"),
    (lambda d: d["chassis"]["mass_kg"].update(value=True), r"chassis\.mass_kg\.value must be a number"),
    (lambda d: d["chassis"]["mass_kg"].update(value=-5.0), r"ChassisParams\.mass_kg must be > 0"),
    (lambda d: d["chassis"]["mass_kg"].update(source=""), r"chassis\.mass_kg\.source must be a non-empty string"),
    (lambda d: d.update(format="other/2"), r"format must be"),
    (lambda d: d.update(name=3), r"name must be a non-empty string"),
    (lambda d: d["chassis"].update(mass_kg=1413.0), r"chassis\.mass_kg must be a JSON object"),
])
def test_strict_parsing_names_the_key(mutate, message: str) -> None:
    doc = _doc()
    mutate(doc)
    with pytest.raises(VehicleFileError, match=message):
        parse_vehicle(json.dumps(doc))


def test_non_finite_and_duplicate_keys_are_refused() -> None:
    text = json.dumps(_doc())
    with pytest.raises(VehicleFileError, match="non-finite number NaN"):
        parse_vehicle(text.replace('"value": 1413.0', '"value": NaN', 1))
    with pytest.raises(VehicleFileError, match="non-finite number Infinity"):
        parse_vehicle(text.replace('"value": 1413.0', '"value": Infinity', 1))
    with pytest.raises(VehicleFileError, match="must be finite"):
        parse_vehicle(text.replace('"value": 1413.0', '"value": 1e999', 1))
    with pytest.raises(VehicleFileError, match="duplicate key 'mass_kg'"):
        parse_vehicle(text.replace('"chassis": {', '"chassis": {"mass_kg": {"value": 1.0, "source": "x"},', 1))
    with pytest.raises(VehicleFileError, match="not valid JSON"):
        parse_vehicle(text[:-10])


def test_cross_field_checks_are_reported() -> None:
    doc = _doc()
    doc["roll"]["roll_centre_height_m"]["value"] = 0.9
    with pytest.raises(VehicleFileError, match=r"roll_centre_height_m must be < ChassisParams\.cg_height_m"):
        parse_vehicle(json.dumps(doc))


def test_files_by_path_regular_and_capped(tmp_path: Path) -> None:
    own = tmp_path / "van.json"
    doc = _doc("suv")
    doc["name"] = "My van"
    own.write_text(json.dumps(doc))
    assert load_vehicle(own).name == "My van"
    assert load_vehicle(str(own)).chassis == load_vehicle("suv").chassis
    with pytest.raises(VehicleFileError, match=r"unknown vehicle 'truck'.*hatchback"):
        load_vehicle("truck")
    with pytest.raises(VehicleFileError, match="cannot open"):
        load_vehicle(tmp_path / "missing.json")
    with pytest.raises(VehicleFileError, match="not a regular file"):
        load_vehicle(tmp_path)
    big = tmp_path / "big.json"
    big.write_text(" " * (MAX_VEHICLE_FILE_BYTES + 1))
    with pytest.raises(VehicleFileError, match="exceeds the limit"):
        load_vehicle(big)
    if hasattr(os, "mkfifo"):
        fifo = tmp_path / "fifo.json"
        os.mkfifo(fifo)
        with pytest.raises(VehicleFileError, match="not a regular file"):
            load_vehicle(fifo)
    with pytest.raises(TypeError, match="vehicle must be"):
        resolve_vehicle(3)  # type: ignore[arg-type]
