"""The margin rule of the -v2 ISO 3888 lines (``tracks.exact_margin``): 2 cm, cut to the largest whole millimetre
whose line asks at most 1.05 x the least-curvature line's peak curvature; its shipped results are the planner's."""

from __future__ import annotations

import dataclasses
import json

import pytest

from vtrack_gym.envs.scenarios import EXACT_PEAK_RATIO, EXACT_TRACKING_MARGIN_M, PlannedLine
from vtrack_gym.tracks import exact_margin
from vtrack_gym.tracks.exact_margin import MarginRule, exact_margin_m, largest_margin, rule_inputs, rule_margin
from vtrack_gym.tracks.feasibility import EXACT_GATED_MANEUVERS, planned_maneuver
from vtrack_gym.vehicle.catalog import list_vehicles, load_vehicle

RULE = MarginRule(target_m=EXACT_TRACKING_MARGIN_M, peak_ratio=EXACT_PEAK_RATIO)


class _Counted:
    """A peak-curvature function of the margin [m] that records the margins it was asked for."""

    def __init__(self, peak) -> None:
        self.peak, self.asked = peak, []

    def __call__(self, margin_m: float) -> float:
        self.asked.append(margin_m)
        return self.peak(margin_m)


def test_the_ids_rule_is_the_default_rule() -> None:
    assert RULE == MarginRule() and RULE.steps == 20 and RULE.margin_m(20) == 0.02 and RULE.margin_m(19) == 0.019


def test_a_target_within_the_ratio_is_kept_exactly_after_two_plans() -> None:
    peak = _Counted(lambda m: 0.03 * (1.0 + 2.0 * m))         # 2 cm: 1.04 x
    choice = largest_margin(peak, RULE)
    assert choice.margin_m == 0.02 and peak.asked == [0.0, 0.02]
    assert choice.peak_ratio == pytest.approx(1.04) and choice.least_peak_per_m == 0.03


def test_a_near_linear_cost_is_cut_with_one_more_plan() -> None:
    """2.54 % per cm (the Formula Student car's ISO 3888-1 line): 2 cm asks 1.0508 x, 1.9 cm 1.0483 x."""
    peak = _Counted(lambda m: 0.03 * (1.0 + 2.54 * m))
    choice = largest_margin(peak, RULE)
    assert choice.margin_m == 0.019 and peak.asked == [0.0, 0.02, 0.019]
    assert choice.peak_ratio <= 1.05 < 1.0 + 2.54 * 0.02


@pytest.mark.parametrize("peak", [lambda m: 1.0 + 900.0 * m * m, lambda m: 1.0 + 0.06 * (m > 0.0123),
                                  lambda m: 1.0 + 10.0 * m ** 0.5])
def test_the_margin_meets_the_ratio_and_one_millimetre_more_does_not(peak) -> None:
    choice = largest_margin(peak, RULE)
    k = round(choice.margin_m / RULE.step_m)
    assert choice.margin_m == RULE.margin_m(k) and 0 <= k < RULE.steps
    assert peak(choice.margin_m) <= 1.05 * peak(0.0) < peak(RULE.margin_m(k + 1))


def test_bad_rules_and_requests_are_refused() -> None:
    with pytest.raises(ValueError, match=r"MarginRule\.peak_ratio must be in"):
        MarginRule(peak_ratio=0.9)
    with pytest.raises(ValueError, match="must be a whole number of step_m"):
        MarginRule(target_m=0.0205)
    with pytest.raises(ValueError, match="the margin rule applies to the exact lines of iso3888_1, iso3888_2"):
        exact_margin_m("slalom", load_vehicle("hatchback"))
    with pytest.raises(ValueError, match=r"PlannedLine\.peak_ratio applies to planner_version 2"):
        PlannedLine(peak_ratio=1.05)
    with pytest.raises(ValueError, match="must be a whole number of step_m"):
        PlannedLine(margin_m=0.0205, planner_version=2, peak_ratio=1.05)


def test_every_shipped_car_has_a_shipped_result_and_a_name_is_not_an_input() -> None:
    stored = exact_margin.stored_margins()
    for car in list_vehicles():
        vehicle = load_vehicle(car)
        for name in EXACT_GATED_MANEUVERS:
            assert rule_inputs(name, vehicle) in stored, f"no shipped margin for {car} on {name}"
            renamed = dataclasses.replace(vehicle, name=f"my {car}")
            assert rule_inputs(name, renamed) == rule_inputs(name, vehicle)
    longer = dataclasses.replace(vehicle, chassis=dataclasses.replace(vehicle.chassis, body_length_m=4.9))
    assert rule_inputs("iso3888_1", longer) not in stored


@pytest.mark.parametrize("car", list_vehicles())
@pytest.mark.parametrize("name", EXACT_GATED_MANEUVERS)
def test_the_shipped_margin_is_the_planners_and_the_largest_within_the_ratio(name: str, car: str) -> None:
    """Recomputed here from the exact planner: equal to the shipped result; its line asks at most 1.05 x the least
    line's peak curvature, and the line 1 mm wider more (or the margin is the whole 2 cm)."""
    vehicle = load_vehicle(car)
    margin = exact_margin_m(name, vehicle)
    assert rule_margin(name, vehicle).margin_m == margin
    least = planned_maneuver(name, vehicle, 0.0, 2).line.peak_curvature_per_m
    assert planned_maneuver(name, vehicle, margin, 2).line.peak_curvature_per_m <= 1.05 * least
    assert margin <= EXACT_TRACKING_MARGIN_M
    if margin < EXACT_TRACKING_MARGIN_M:
        wider = planned_maneuver(name, vehicle, RULE.margin_m(round(margin / RULE.step_m) + 1), 2)
        assert wider.line.peak_curvature_per_m > 1.05 * least


def test_a_car_not_shipped_is_computed_on_the_machine(monkeypatch: pytest.MonkeyPatch) -> None:
    """A request without a shipped entry gets the rule's result computed from the planner."""
    vehicle = load_vehicle("formula_student")
    monkeypatch.setattr(exact_margin, "stored_margins", dict)
    assert exact_margin_m("iso3888_1", vehicle) == rule_margin("iso3888_1", vehicle).margin_m
    shipped = json.loads(exact_margin.STORE_FILE.read_text())["entries"]
    assert {e["margin_m"] for e in shipped if e["inputs"] == rule_inputs("iso3888_1", vehicle)} == \
        {exact_margin_m("iso3888_1", vehicle)}
