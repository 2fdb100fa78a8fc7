"""The row rule (``row_validation``) decided for a whole batch of stored rows at once, column by column.

A store read checks every row by the rule every write obeys. Row by row that is about 30 function calls per row;
here each column is checked as a whole: a text column's distinct values once each, a number column with numpy,
and the metrics of every row grouped by their names (one shape per group: a benchmark's rows share their metric
names) and checked a metric at a time. The answer is only ever "every row obeys the rule" or "some row may not";
in the second case the caller checks each row with ``row_validation.checked_row_values``, which names the row and
the column. So the batch check can be stricter than the rule (it then only costs the row-by-row check), never
looser: ``tests/test_store_read_speed.py`` compares the two on random and hostile rows.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from itertools import chain
from typing import Any

import numpy as np

from vtrack_gym.evaluation.scoring.row_validation import (
    _ENV_VERSION,
    LIST_METRICS,
    MAX_JSON_CHARS,
    MAX_METRIC_INT,
    MAX_SEED,
    MAX_TEXT_CHARS,
    OPTIONAL_TEXT,
    REQUIRED_TEXT,
    _bounded_int,
    _checked_metric,
    _fast_metric_ok,
    _is_iso_time,
    _json_depth_ok,
    _metric_rule,
    _numeric,
    _unsafe_char,
)

_DECODER = json.JSONDecoder(parse_int=_bounded_int)
"""What ``row_validation.parse_json_object`` parses with (``json.loads`` builds one per call)."""
_NUMBERS = frozenset({int, float})
_PLAIN_METRIC_KINDS = frozenset({int, float, type(None), str})


def parsed_objects(texts: Sequence[Any]) -> list[dict[str, Any]] | None:
    """Each text parsed as ``row_validation.parse_json_object`` parses it (bounded size, depth and integers; a JSON
    object), or None when any text breaks that rule."""
    out = []
    scan, decode = _DECODER.scan_once, _DECODER.decode
    for text in texts:
        if type(text) is not str or len(text) > MAX_JSON_CHARS or not _json_depth_ok(text):
            return None
        try:
            value, end = scan(text, 0)   # what decode does for a text without surrounding white space
            if end != len(text):
                value = decode(text)
        except StopIteration:   # white space first, or no JSON at all: decode says which
            try:
                value = decode(text)
            except (ValueError, RecursionError):
                return None
        except (ValueError, RecursionError):
            return None
        if type(value) is not dict:
            return None
        out.append(value)
    return out


def rows_obey_rule(columns: Mapping[str, Sequence[Any]], metrics: Sequence[dict[str, Any]]) -> bool:
    """True when every row obeys ``row_validation.checked_row_values``; False when some row may not.

    ``columns``: each stored column's values in row order (``id`` and the JSON columns not needed); ``metrics``:
    each row's parsed ``metrics_json`` (``parsed_objects``)."""
    return (all(_texts_ok(columns[c], required=True) for c in REQUIRED_TEXT)
            and all(_texts_ok(columns[c], required=False) for c in OPTIONAL_TEXT)
            and all(type(v) is str and _ENV_VERSION.fullmatch(v) is not None for v in set(columns["env_version"]))
            and all(_is_iso_time(v) for v in set(columns["created_utc"]))
            and _seeds_ok(columns["seed"])
            and _completed_ok(columns["completed"], columns["termination"])
            and set(zip(map(type, columns["success"]), columns["success"], strict=True)) <= {(int, 0), (int, 1)}
            and _finite_non_negative(columns["wall_time_per_step_s"])
            and metrics_obey_rule(metrics))


def _texts_ok(values: Sequence[Any], required: bool) -> bool:
    """Every distinct value a string of at most ``MAX_TEXT_CHARS`` without unsafe characters (not empty when
    ``required``)."""
    return all(type(v) is str and (v or not required) and len(v) <= MAX_TEXT_CHARS and _unsafe_char(v) is None
               for v in set(values))


def _seeds_ok(values: Sequence[Any]) -> bool:
    kinds = set(map(type, values))
    if not kinds <= {int, type(None)}:
        return False
    ints = [v for v in values if v is not None] if type(None) in kinds else values
    return not ints or (min(ints) >= 0 and max(ints) <= MAX_SEED)


def _completed_ok(completed: Sequence[Any], termination: Sequence[Any]) -> bool:
    """``completed`` an int 0/1, and 1 exactly when ``termination`` is ``completed``."""
    return all(kind is int and c in (0, 1) and bool(c) == (t == "completed")
               for kind, c, t in set(zip(map(type, completed), completed, termination, strict=True)))


def _finite_non_negative(values: Sequence[Any]) -> bool:
    if not values:
        return True
    if not set(map(type, values)) <= _NUMBERS:
        return False
    arr = np.asarray(values, dtype=np.float64)
    return bool(np.isfinite(arr).all()) and float(arr.min()) >= 0.0


def metrics_obey_rule(metrics: Sequence[dict[str, Any]]) -> bool:
    """True when every row's metrics equal what ``row_validation.checked_metrics`` keeps of them (the read rule);
    the rows are grouped by their metric names and each metric checked over its group at once."""
    for names, group in _shapes(metrics).items():
        if any(len(name) > MAX_TEXT_CHARS for name in names):
            return False
        flat = list(chain.from_iterable(map(dict.values, group)))   # the group's values, row after row
        if not all(_metric_column_ok(name, flat[j::len(names)]) for j, name in enumerate(names)):
            return False
    return True


def _shapes(metrics: Sequence[dict[str, Any]]) -> dict[tuple[str, ...], Sequence[dict[str, Any]]]:
    """The rows' metrics grouped by their names in order (one group when every row has the first row's): in a group
    every row's values come in the same order."""
    keys = list(map(tuple, metrics))
    if not keys or keys.count(keys[0]) == len(keys):
        return {keys[0]: metrics} if keys else {}
    groups: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for key, m in zip(keys, metrics, strict=True):
        groups.setdefault(key, []).append(m)
    return groups


def _exact(name: str, value: Any) -> bool:
    """``value`` is what ``checked_metrics`` keeps for metric ``name`` (the general rule, one value)."""
    try:
        return _fast_metric_ok(name, value) or _checked_metric(name, value) == value
    except ValueError:
        return False


def _metric_column_ok(name: str, values: Sequence[Any]) -> bool:
    """Every value of metric ``name`` obeys its rule: numbers within their bounds and finite, None (missing), text
    where the metric may be text; any other kind (a list, a bool) through the general rule, value by value."""
    kinds = set(map(type, values))
    if name in LIST_METRICS or not kinds <= _PLAIN_METRIC_KINDS:
        return all(_exact(name, v) for v in values)
    if str in kinds and _numeric(name):
        return False
    numbers = [v for v in values if type(v) in _NUMBERS] if kinds - _NUMBERS else values
    kinds &= _NUMBERS
    if not numbers:
        return True
    if int in kinds:
        ints = [v for v in numbers if type(v) is int] if float in kinds else numbers
        if max(ints) > MAX_METRIC_INT or min(ints) < -MAX_METRIC_INT:
            return False
    arr = np.fromiter(numbers, dtype=np.float64, count=len(numbers))
    if not np.isfinite(arr).all():
        return False
    non_negative, flag, lo, hi = _metric_rule(name)
    low, high = float(arr.min()), float(arr.max())
    if (non_negative and low < 0) or (flag and not bool(((arr == 0.0) | (arr == 1.0)).all())):
        return False
    return lo <= low and high <= hi
