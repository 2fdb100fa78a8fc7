"""A store read checks the row rule column by column (``row_batch``) and falls back to the row-by-row rule only to
name a bad row: the batch verdict equals the row rule's on hostile values of every column and on random metrics,
and a store whose rows were edited with valid hashes is still refused naming the row."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vtrack_gym.evaluation.scoring.row_batch import parsed_objects, rows_obey_rule
from vtrack_gym.evaluation.scoring.row_validation import checked_row_values
from vtrack_gym.evaluation.storage import store as store_module
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore, StoreError

COLUMNS = store_module._COLUMNS[1:]   # every stored column but the id
VALID = {"created_utc": "2026-01-01T00:00:00+00:00", "package_version": "0.3.0", "suite": "custom",
         "env_id": "DLC120-v0", "env_version": "v0", "policy_id": "lqr", "policy_preset": "default",
         "policy_hash": "ab12", "seed": 3, "options_json": '{"vehicle": "paper"}', "termination": "completed",
         "completed": 1, "success": 1, "wall_time_per_step_s": 1e-4,
         "metrics_json": '{"max_e_y_m": 0.2, "cones_hit": 0, "comfort_band": "ok", "lap_times_s": [1.5, 2]}'}
HOSTILE: dict[str, list[Any]] = {
    **{c: ["", "a\x1bb", "a\u202eb", "x" * 1001, 5, 1.5, None]
       for c in ("suite", "env_id", "policy_id", "policy_hash", "package_version", "policy_preset", "termination")},
    "env_version": ["v", "v0 ", "x1", 0, "v1234567890"],
    "created_utc": ["yesterday", 1, "2026-13-01", "2026-01-01"],
    "seed": [-1, 2**63, 1.5, "3", None, 0],
    "completed": [2, 1.0, "1", 0, None],
    "success": [2, 1.0, None, 0, "1"],
    "wall_time_per_step_s": [-1.0, float("inf"), "x", 5, 0, -0.0, None],
    "metrics_json": ['{"max_e_y_m": -1}', '{"cones_hit": NaN}', '{"success": 2}', "[]", '{"a": 1',
                     '{"max_entry_speed_kmh": 250}', '{"lap_times_s": [1, -2]}', '{"note": "text"}',
                     '{"max_e_y_m": "x"}', '{"max_e_y_m": true}', '{"x_m": 1e400}', '{"n": 123456789012345678901}',
                     '{"big": 9223372036854775809}', '{"big": -9223372036854775808}', '{"max_e_y_m": null}',
                     '{"a": {"b": 1}}', '{"completed": 1.0}', '{"completed": 0.5}', '{"a": ' + "[" * 70 + "]" * 70
                     + "}", '{"lap_times_s": 3}', '{"max_e_y_m": 0.1, "max_e_y_m": -0.1}', ' {"a": 1} ', "{}"],
    "options_json": ["[]", "{}", "nope", '{"a": ' + "[" * 70 + "]" * 70 + "}", '{"x": NaN}', "null"],
}


def _row_rule_holds(rows: list[dict[str, Any]]) -> bool:
    try:
        for row in rows:
            checked_row_values(row)
    except ValueError:
        return False
    return True


def _batch_rule_holds(rows: list[dict[str, Any]]) -> bool:
    columns = {c: [r[c] for r in rows] for c in COLUMNS}
    metrics, options = parsed_objects(columns["metrics_json"]), parsed_objects(columns["options_json"])
    return metrics is not None and options is not None and rows_obey_rule(columns, metrics)


@pytest.mark.parametrize("column", sorted(HOSTILE))
def test_the_batch_verdict_equals_the_row_rule_on_hostile_values(column: str) -> None:
    for value in HOSTILE[column]:
        rows = [dict(VALID), {**VALID, column: value}, dict(VALID, seed=None)]
        if column == "termination" and isinstance(value, str):
            rows[1]["completed"] = 0   # the completed flag follows the termination
        assert _batch_rule_holds(rows) == _row_rule_holds(rows), (column, value)


METRIC_VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**70, 2**70), st.none(),
                          st.booleans(), st.text(max_size=5), st.lists(st.floats(-5, 5), max_size=3))
METRIC_NAMES = st.sampled_from(["max_e_y_m", "rms_e_y_m", "cones_hit", "completed", "success", "itae", "note",
                                "comfort_band", "lap_times_s", "entry_speed_fraction", "x_m", "offset"])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.dictionaries(METRIC_NAMES, METRIC_VALUES, max_size=6), min_size=1, max_size=6))
def test_property_the_batch_verdict_equals_the_row_rule_on_random_metrics(metrics: list[dict[str, Any]]) -> None:
    rows = [{**VALID, "metrics_json": json.dumps(m)} for m in metrics]
    assert _batch_rule_holds(rows) == _row_rule_holds(rows)


def test_an_edited_row_with_a_valid_hash_is_named(tmp_path: Path) -> None:
    """A row rewritten with a fresh hash (and the store's digest fixed) is refused, naming the row and column."""
    path = tmp_path / "s.sqlite"
    ResultStore(path).add([ResultRow("custom", "DLC120-v0", "lqr", "h", s, {"max_e_y_m": 0.2}, "completed", 1e-4)
                           for s in range(50)])
    with sqlite3.connect(path) as con:
        values = list(con.execute(f"SELECT {', '.join(store_module._COLUMNS)} FROM results WHERE id = 30").fetchone())
        values[store_module._COLUMNS.index("metrics_json")] = '{"max_e_y_m": -0.2}'
        old = con.execute("SELECT row_sha256 FROM results WHERE id = 30").fetchone()[0]
        new = store_module.row_sha256(values)
        digest = int(con.execute("SELECT value FROM vtrack_meta WHERE key = 'rows_digest'").fetchone()[0], 16)
        con.execute("UPDATE results SET metrics_json = ?, row_sha256 = ? WHERE id = 30",
                    (values[store_module._COLUMNS.index("metrics_json")], new))
        con.execute("UPDATE vtrack_meta SET value = ? WHERE key = 'rows_digest'",
                    (f"{digest ^ int(old, 16) ^ int(new, 16):064x}",))
    with pytest.raises(StoreError, match=r"row 30: metrics_json holds|row 30: metric 'max_e_y_m' must be"):
        ResultStore(path, read_only=True).rows()
