"""The shipped planned lines (``tracks.planned_line_store``): the -v1 ISO 3888 ids drive the stored line on every
machine; it is an optimum of the planner's programme; a request not shipped is planned."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.tracks import planned_line, planned_line_store
from vtrack_gym.tracks.lanes import LaneSection

sys.path.insert(0, str(Path(__file__).resolve().parent))
from record_planned_lines import planned_lines  # noqa: E402

V1_IDS = ["vtrack/ISO3888-1-v1", "vtrack/ISO3888-2-v1"]


@pytest.fixture(scope="module")
def planned_here() -> list[tuple[str, np.ndarray, float]]:
    """The lines the planner plans here for the -v1 ids (not read from the store)."""
    return planned_lines(V1_IDS)


def test_every_v1_line_is_shipped_and_an_optimum_of_the_programme(planned_here) -> None:
    assert len(planned_here) == 2
    for inputs, table, ds in planned_here:
        stored = planned_line_store.stored_table(inputs)
        assert stored is not None, json.loads(inputs)["name"]
        # the same programmes, linearised about lines a last bit apart: the peak curvature agrees within 1e-4 (2.9e-5
        # measured with numpy's AVX-512 code switched off), the line itself may be another of the optima
        peak_stored, peak_here = (float(np.max(np.abs(t[:, 3]))) for t in (stored[0], table))
        assert abs(peak_stored - peak_here) <= 1e-4 * peak_here
        here = planned_line_store.this_machine()
        if planned_line_store.recorded_on(inputs) == here:     # the machine's code paths it was recorded with
            assert stored[1] == ds and np.array_equal(stored[0], table)


def test_the_stored_line_clears_every_gate(planned_here) -> None:
    from vtrack_gym.envs.scenarios import TRACKING_MARGIN_M
    from vtrack_gym.tracks import feasibility
    from vtrack_gym.vehicle import resolve_vehicle

    car = resolve_vehicle(None)                        # the default car, the one the pins drive
    for name in ("iso3888_1", "iso3888_2"):
        path = feasibility.planned_maneuver(name, car, TRACKING_MARGIN_M).path
        body = feasibility.body_of(car)
        assert planned_line._gates_touched(path, body) == 0
        digests = {planned_line_store.table_digest(t, d) for _, t, d in planned_here}
        stored = {planned_line_store.table_digest(*planned_line_store.stored_table(i)) for i, _, _ in planned_here}
        assert planned_line_store.table_digest(path.table, path.ds_m) in stored
        assert len(digests) == 2


def test_a_request_not_shipped_is_planned() -> None:
    lanes = (LaneSection(12.0, 2.4, 0.0, "a"), LaneSection(11.0, 3.0, 3.5, "b"))
    body = planned_line.BodyRectangle(4.5, 1.8, 1.8, "own car")
    kwargs = {"approach_m": 20.0, "run_out_m": 20.0, "margin_m": 0.05}
    assert planned_line_store.stored_table(planned_line.plan_inputs(lanes, (15.0,), body, **kwargs)) is None
    line = planned_line.plan_line(lanes, (15.0,), body, **kwargs)
    assert planned_line._gates_touched(line.path, body) == 0


def test_an_entry_is_never_rewritten_and_a_damaged_one_is_refused(tmp_path: Path) -> None:
    file = tmp_path / "lines.npz"
    table = np.zeros((5, 8))
    table[:, 0] = np.arange(5.0)
    assert planned_line_store.write_entries([("k", table, 1.0)], file) == 1
    assert planned_line_store.write_entries([("k", table, 1.0)], file) == 0
    assert np.array_equal(planned_line_store.stored_table("k", file)[0], table)
    with pytest.raises(ValueError, match="already stored"):
        planned_line_store.write_entries([("k", table + 1e-16 * (table != 0), 1.0 + 2e-16)], file)
    with np.load(file) as data:
        arrays = dict(data)
    arrays["table_0"] = arrays["table_0"] * 2.0
    np.savez(file, **arrays)
    planned_line_store._entries.cache_clear()
    with pytest.raises(ValueError, match="damaged"):
        planned_line_store.stored_table("k", file)
