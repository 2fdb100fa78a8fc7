"""The one range-validation helper (``vtrack_gym._ranges``): convention, messages, and the tables built on it."""

from __future__ import annotations

import dataclasses
import math
import re

import pytest

from vtrack_gym._ranges import Range, closed_ranges, describe, range_of, ranged, validate


@dataclasses.dataclass(frozen=True)
class _Demo:
    width_m: float = ranged(1.0, gt=0.0, le=2.0, unit="m")
    share: float = ranged(0.5, ge=0.0, lt=1.0)
    count: int = ranged(3, ge=1, integer=True)
    limit_m: float = ranged(1.5, ge="width_m", unit="m")
    flag: bool = True
    optional_mps: float | None = ranged(None, ge=1.0, le=45.0, unit="m/s")

    def __post_init__(self) -> None:
        validate(self)


@pytest.mark.parametrize(("kwargs", "ok"), [
    ({"width_m": 2.0, "limit_m": 2.0}, True), ({"width_m": 0.0}, False), ({"width_m": 2.0000001}, False),
    ({"share": 0.0}, True), ({"share": 1.0}, False), ({"share": -1e-12}, False),
    ({"count": 1}, True), ({"count": 0}, False), ({"count": 2.0}, False),
    ({"limit_m": 1.0}, True), ({"limit_m": 0.99}, False),
    ({"optional_mps": None}, True), ({"optional_mps": 0.5}, False),
])
def test_bounds_follow_their_comparison(kwargs, ok):
    if ok:
        _Demo(**kwargs)
    else:
        with pytest.raises(ValueError, match=rf"_Demo\.{next(iter(kwargs))} must be"):
            _Demo(**kwargs)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, True, "1.0", None])
def test_non_numbers_and_non_finite_values_are_refused(bad):
    with pytest.raises(ValueError, match=r"_Demo\.width_m must be a finite number in \(0\.0, 2\.0\] m"):
        _Demo(width_m=bad)


def test_message_names_field_range_unit_and_value():
    with pytest.raises(ValueError) as exc:
        _Demo(width_m=3.0)
    assert str(exc.value) == "_Demo.width_m must be in (0.0, 2.0] m (got 3.0)"
    with pytest.raises(ValueError) as exc:
        _Demo(limit_m=0.5)
    assert str(exc.value) == "_Demo.limit_m must be >= width_m = 1.0 m (got 0.5)"
    with pytest.raises(ValueError) as exc:
        _Demo(count=0)
    assert str(exc.value) == "_Demo.count must be an int >= 1 (got 0)"
    with pytest.raises(ValueError, match=r"_Demo\.flag must be a bool \(got 1\)"):
        _Demo(flag=1)  # type: ignore[arg-type]


def test_docs_and_errors_come_from_one_table():
    docs = describe(_Demo)
    assert docs == {"width_m": "in (0.0, 2.0] m", "share": "in [0.0, 1.0)", "count": "int >= 1",
                    "limit_m": ">= width_m m", "optional_mps": "in [1.0, 45.0] m/s"}
    with pytest.raises(ValueError) as exc:
        _Demo(share=2.0)
    assert docs["share"] in str(exc.value)
    assert range_of(_Demo, "share") == Range(ge=0.0, lt=1.0)
    assert closed_ranges(_Demo) == {"optional_mps": (1.0, 45.0)}


def test_range_declares_one_bound_per_side():
    with pytest.raises(ValueError, match="gt or ge"):
        Range(gt=0.0, ge=0.0)
    with pytest.raises(ValueError, match="lt or le"):
        Range(lt=1.0, le=1.0)


def test_reset_option_table_is_the_fields_declared_ranges():
    from vtrack_gym.envs.config import ResetOptions

    assert ResetOptions.RANGES == closed_ranges(ResetOptions)
    assert set(ResetOptions.RANGES) == {f.name for f in dataclasses.fields(ResetOptions)} - {"explicit"}  # bookkeeping
    with pytest.raises(ValueError, match=re.escape("ResetOptions.mass_scale must be in [0.5, 2.0] (got 3.0)")):
        ResetOptions(mass_scale=3.0)


def test_search_space_bounds_lie_inside_the_declared_ranges():
    from vtrack_gym.baselines.mpc import MPCConfig
    from vtrack_gym.baselines.smc import SMCConfig
    from vtrack_gym.envs.pdflc import PDFLCConfig
    from vtrack_gym.tuning.spaces import SPACES

    owners = {"smc": SMCConfig(), "mpc": MPCConfig()}
    for space in SPACES.values():
        for p in space.params:
            if p.index is not None:  # a tuple entry (MPC weights >= 0): checked by MPCConfig itself
                continue
            owner = PDFLCConfig() if p.target == "speed" else owners[space.controller]
            rng = range_of(owner, p.field)
            assert rng.contains(p.low, owner) and rng.contains(p.high, owner), (space.name, p.name)


def test_documented_configs_show_the_table_in_their_docstring():
    from vtrack_gym.baselines.smc import SMCConfig
    from vtrack_gym.vehicle.params import ChassisParams

    for cls in (SMCConfig, ChassisParams):
        doc = cls.__doc__ or ""
        assert "Allowed values" in doc
        for name, text in describe(cls).items():
            assert re.search(rf"^\s+{name}\s+{re.escape(text)}$", doc, re.M), (cls.__name__, name)
