"""The one rule for a leaderboard row's stored values, applied when a row is written and when it is read.

A row the store would refuse to write is refused when read (``ResultStore`` reports it as corrupted, naming the row
and the column), so a store edited by hand or by another program cannot rank absurd values or crash a reader:

* text columns: strings of at most ``MAX_TEXT_CHARS`` characters without control, format (bidi, zero-width) or
  line/paragraph separator characters; ``suite``, ``env_id``, ``policy_id``, ``policy_hash`` and
  ``package_version`` not empty; ``env_version`` ``v`` and digits; ``created_utc`` an ISO 8601 time;
* ``seed``: None or an integer in [0, 2^63 - 1]; ``completed`` 0/1 and 1 exactly when ``termination`` is
  ``completed``; ``success`` 0/1; ``wall_time_per_step_s`` a finite number >= 0;
* ``options_json`` and ``metrics_json``: JSON objects of at most ``MAX_JSON_CHARS`` characters, nested at most
  ``MAX_JSON_DEPTH`` deep, integers of at most 20 digits; metrics as :func:`checked_metrics` keeps them (within
  ``METRIC_RANGES`` where a metric has a physical range; ``LIST_METRICS``, the lap times, lists of durations).

The cost of the rule is bounded by the input and small per row: a metric's rule is looked up once per name (cached),
a finite number within its rule is accepted on a fast path, and a text column's character scan and a time's parse
are cached per distinct value (a 100,000-row store repeats a few names, ids and times; ``benchmarks/
bench_store_read.py``). Every value that could break the rule goes through the full checks, which name it.
"""

from __future__ import annotations

import datetime as dt
import functools
import json
import math
import re
import unicodedata
from typing import Any

MAX_SEED = 2**63 - 1
"""Largest storable seed (SQLite INTEGER is a signed 64-bit number)."""
MAX_TEXT_CHARS = 1000
"""Longest text column value (characters)."""
MAX_JSON_CHARS = 1 << 20
"""Longest ``options_json`` / ``metrics_json`` (characters)."""
MAX_JSON_DEPTH = 64
"""Deepest nesting of objects and arrays in ``options_json`` / ``metrics_json``."""
MAX_METRIC_INT = 2**63
"""Largest magnitude of an integer metric (beyond it a float conversion loses or overflows)."""
UNIT_SUFFIXES = ("_m", "_s", "_deg", "_rad", "_mps", "_mps2", "_n", "_per_s", "_us", "_g", "_kmh", "_degps",
                 "_degps2", "_mps3")
"""A metric whose name ends in a unit is a number."""
NON_NEGATIVE_METRICS = frozenset({"itae", "duration_s", "cones_hit", "comfort_a_v_mps2", "comfort_a_wx_mps2",
                                  "best_lap_s", "mean_lap_s", "steering_reversals_per_s",
                                  "a_y_violation_mps2", "wall_time_per_step_s", "wall_time_s", "episodes",
                                  "remaining_m", "completed", "success", "entry_speed_fraction",
                                  "above_physical_bound", "entry_speed_monotone", "entry_speed_capped",
                                  "track_limit_violations", "lap_time_fraction", "laps_completed"})
"""Error, count and duration metrics that cannot be negative (also every ``max_*`` and ``rms_*`` metric)."""
LIST_METRICS = frozenset({"lap_times_s"})
"""Metrics that are a list of durations [s] (finite numbers >= 0), one per lap, at most ``MAX_LIST_ITEMS``."""
MAX_LIST_ITEMS = 10_000
"""Longest list metric."""
FLAG_METRICS = frozenset({"completed", "success", "above_physical_bound", "entry_speed_monotone",
                          "entry_speed_capped"})
"""Metrics that are 0 or 1."""
METRIC_RANGES: dict[str, tuple[float, float]] = {"max_entry_speed_kmh": (0.0, 200.0),
                                                 "entry_speed_bound_kmh": (0.0, 200.0),
                                                 "entry_speed_fraction": (0.0, 200.0)}
"""Physical ranges [lo, hi] of bounded metrics: an ISO 3888 env's entry speeds lie in (0, 200] km/h (and the bound
is at least 1 km/h, so the fraction is at most 200)."""
REQUIRED_TEXT = ("suite", "env_id", "policy_id", "policy_hash", "package_version")
OPTIONAL_TEXT = ("policy_preset", "termination")
_UNSAFE_CATEGORIES = frozenset({"Cc", "Cf", "Zl", "Zp", "Cs"})
_ENV_VERSION = re.compile(r"v[0-9]{1,9}")


def clean_scalar(value: Any) -> Any:
    """JSON-safe scalar (numpy scalars as Python values; NaN/inf become None)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item") and not isinstance(value, (bool, int, float, str)):
        return clean_scalar(value.item())
    return value


def _non_negative(name: str) -> bool:
    return name in NON_NEGATIVE_METRICS or name.startswith(("max_", "rms_"))


def _numeric(name: str) -> bool:
    """A metric that must be a number (or missing): every error, count and duration, and every name with a unit
    suffix (every metric a suite ranks on is one: ``suite_parts.Suite`` checks it); others (``termination``,
    ``comfort_band``, notes) may also be text."""
    return _non_negative(name) or name.endswith(UNIT_SUFFIXES)


def is_numeric_metric(name: str) -> bool:
    """``name`` is a metric every stored row holds as a number (or missing): what a board can rank on."""
    return _numeric(name)


def checked_success(value: Any) -> bool | None:
    """``ResultRow.success`` as a bool (None: derived); ``ValueError`` unless a bool, 0 or 1."""
    if value is None or isinstance(value, bool):
        return value
    if hasattr(value, "dtype") and getattr(value, "shape", None) == () and value.dtype.kind in "bui":
        value = value.item()
    if isinstance(value, (bool, int)) and value in (0, 1):
        return bool(value)
    raise ValueError(f"success must be a bool (True/False), 0 or 1, or None to derive it (got {value!r})")


def checked_seed(value: Any) -> int | None:
    """``ResultRow.seed`` as an int in [0, 2^63 - 1] (or None); ``ValueError`` otherwise."""
    if value is None:
        return None
    if hasattr(value, "dtype") and getattr(value, "shape", None) == () and value.dtype.kind in "ui":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, 2^63 - 1 = {MAX_SEED}] or None (got {value!r:.60})")
    return value


def _checked_list(name: str, raw: Any) -> list[float]:
    """A ``LIST_METRICS`` value: a list of finite numbers >= 0 [s]; ``ValueError`` naming the metric otherwise."""
    items = raw.tolist() if hasattr(raw, "tolist") else raw
    if not isinstance(items, (list, tuple)) or len(items) > MAX_LIST_ITEMS:
        raise ValueError(f"metric {name!r} must be a list of at most {MAX_LIST_ITEMS} durations [s] (got "
                         f"{type(raw).__name__} {str(raw)[:60]!r})")
    out = []
    for item in items:
        v = clean_scalar(item)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise ValueError(f"metric {name!r} must hold finite durations >= 0 s (got {str(item)[:60]!r})")
        out.append(float(v))
    return out


RULE_CACHE = 4096
"""Distinct metric names, text values and times whose rule or verdict is kept (least recently used beyond)."""


@functools.lru_cache(maxsize=RULE_CACHE)
def _metric_rule(name: str) -> tuple[bool, bool, float, float]:
    """(must be >= 0, must be 0 or 1, lowest, highest) of a number stored as metric ``name``."""
    lo, hi = METRIC_RANGES.get(name, (-math.inf, math.inf))
    return _non_negative(name), name in FLAG_METRICS, lo, hi


def _fast_metric_ok(name: str, value: Any) -> bool:
    """True when ``value`` (an exact int or a finite float) obeys metric ``name``'s rule as it is: the common case,
    decided without ``_checked_metric``'s general path (which decides every other case and names the problem)."""
    if name in LIST_METRICS:   # a list metric is never a bare number
        return False
    kind = type(value)
    if kind is float:
        if not math.isfinite(value):
            return False
    elif kind is not int or abs(value) > MAX_METRIC_INT:
        return False
    non_negative, flag, lo, hi = _metric_rule(name)
    return not (non_negative and value < 0) and not (flag and value not in (0, 1)) and lo <= value <= hi


def _checked_metric(name: str, raw: Any) -> Any:
    if name in LIST_METRICS:
        return _checked_list(name, raw)
    value = clean_scalar(raw)
    if value is None or (isinstance(value, str) and not _numeric(name)):
        return value
    if isinstance(value, (bool, int, float)) and not isinstance(value, str):
        if isinstance(value, int) and abs(value) > MAX_METRIC_INT:
            raise ValueError(f"metric {name!r} must be a number of magnitude <= 2^63 (got an integer of "
                             f"{value.bit_length()} bits)")
        if _non_negative(name) and value < 0:
            raise ValueError(f"metric {name!r} must be a number >= 0 (an error, count or duration; got {raw!r})")
        if name in FLAG_METRICS and value not in (0, 1):
            raise ValueError(f"metric {name!r} must be 0 or 1 (got {raw!r})")
        lo, hi = METRIC_RANGES.get(name, (-math.inf, math.inf))
        if not lo <= value <= hi:
            raise ValueError(f"metric {name!r} must be in [{lo:g}, {hi:g}] (got {raw!r})")
        return value
    kind = "a number" if _numeric(name) else "a number or text"
    raise ValueError(f"metric {name!r:.80} must be {kind} (NaN/inf or None: missing), got "
                     f"{type(raw).__name__} {str(raw)[:60]!r}")


def checked_metrics(metrics: Any) -> dict[str, Any]:
    """``ResultRow.metrics`` as JSON-safe values; ``ValueError`` naming the metric when a value is of the wrong kind
    or out of range: numeric metrics real numbers (NaN/inf stored as None: missing), ``>= 0`` for error, count and
    duration metrics, 0/1 for flags, ``METRIC_RANGES`` for bounded ones, integers within 2^63, ``LIST_METRICS``
    lists of finite durations >= 0; other metrics a number or text."""
    if not isinstance(metrics, dict):
        raise ValueError(f"metrics must be a dict of name -> value (got {type(metrics).__name__})")
    out: dict[str, Any] = {}
    for name, raw in metrics.items():
        if not isinstance(name, str) or len(name) > MAX_TEXT_CHARS:
            raise ValueError(f"metric names must be strings of at most {MAX_TEXT_CHARS} characters (got "
                             f"{str(name)[:60]!r})")
        out[name] = raw if _fast_metric_ok(name, raw) else _checked_metric(name, raw)
    return out


def _checked_text(column: str, value: Any, required: bool) -> None:
    if not isinstance(value, str):
        raise ValueError(f"{column} must be a string (got {type(value).__name__} {str(value)[:60]!r})")
    if required and not value:
        raise ValueError(f"{column} must not be empty")
    if len(value) > MAX_TEXT_CHARS:
        raise ValueError(f"{column} must be at most {MAX_TEXT_CHARS} characters (got {len(value)})")
    bad = _unsafe_char(value)
    if bad is not None:
        raise ValueError(f"{column} must not hold control, format or separator characters (found "
                         f"U+{ord(bad):04X} in {value[:60]!r})")


@functools.lru_cache(maxsize=RULE_CACHE)
def _unsafe_char(value: str) -> str | None:
    """The first control, format or separator character of ``value`` (None: there is none)."""
    return next((c for c in value if unicodedata.category(c) in _UNSAFE_CATEGORIES), None)


def _json_depth_ok(text: str) -> bool:
    """True if ``text`` nests objects/arrays at most ``MAX_JSON_DEPTH`` deep (strings skipped)."""
    if text.count("[") + text.count("{") <= MAX_JSON_DEPTH:
        return True
    depth, in_string, escaped = 0, False, False
    for ch in text:
        if in_string:
            escaped = not escaped and ch == "\\"
            in_string = escaped or ch != '"'
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            if depth > MAX_JSON_DEPTH:
                return False
        elif ch in "]}":
            depth -= 1
    return True


def _is_iso_time(value: Any) -> bool:
    if not isinstance(value, str) or len(value) > 40:
        return False
    return _parses_as_iso_time(value)


@functools.lru_cache(maxsize=RULE_CACHE)
def _parses_as_iso_time(value: str) -> bool:
    try:
        dt.datetime.fromisoformat(value)
    except ValueError:
        return False
    return True


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > 20:
        raise ValueError(f"an integer of {len(text)} digits")
    return int(text)


def parse_json_object(column: str, text: Any) -> dict[str, Any]:
    """``text`` (``options_json`` / ``metrics_json``) as a dict; ``ValueError`` naming ``column`` when it is not a
    bounded JSON object (see the module docstring)."""
    if not isinstance(text, str) or len(text) > MAX_JSON_CHARS:
        raise ValueError(f"{column} must be JSON text of at most {MAX_JSON_CHARS} characters")
    if not _json_depth_ok(text):
        raise ValueError(f"{column} nests deeper than {MAX_JSON_DEPTH} levels")
    try:
        value = json.loads(text, parse_int=_bounded_int)
    except (ValueError, RecursionError) as exc:
        raise ValueError(f"{column} is not valid JSON ({str(exc)[:120]})") from None
    if not isinstance(value, dict):
        raise ValueError(f"{column} must be a JSON object (got {type(value).__name__})")
    return value


def checked_row_values(row: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Check one row's stored column values (every column of the results table but ``id`` and ``row_sha256``);
    returns its (metrics, options). ``ValueError`` naming the column and the allowed values."""
    for column in REQUIRED_TEXT:
        _checked_text(column, row.get(column), required=True)
    for column in OPTIONAL_TEXT:
        _checked_text(column, row.get(column), required=False)
    if not isinstance(row.get("env_version"), str) or not _ENV_VERSION.fullmatch(row["env_version"]):
        raise ValueError(f"env_version must be 'v' and digits, e.g. 'v0' (got {row.get('env_version')!r:.60})")
    if not _is_iso_time(row.get("created_utc")):
        raise ValueError(f"created_utc must be an ISO 8601 time (got {row.get('created_utc')!r:.60})")
    checked_seed(row.get("seed"))
    if row.get("completed") not in (0, 1) or isinstance(row.get("completed"), float) \
            or bool(row["completed"]) != (row["termination"] == "completed"):
        raise ValueError(f"completed must be 1 when termination is 'completed', else 0 (got {row.get('completed')!r})")
    if row.get("success") not in (0, 1) or isinstance(row.get("success"), float):
        raise ValueError(f"success must be 0 or 1 (got {row.get('success')!r:.60})")
    wall = row.get("wall_time_per_step_s")
    if isinstance(wall, bool) or not isinstance(wall, (int, float)) or not math.isfinite(wall) or wall < 0:
        raise ValueError(f"wall_time_per_step_s must be a finite number >= 0 s (got {wall!r:.60})")
    metrics = parse_json_object("metrics_json", row.get("metrics_json"))
    if checked_metrics(metrics) != metrics:
        raise ValueError("metrics_json holds a value a write would have changed (NaN or infinity)")
    return metrics, parse_json_object("options_json", row.get("options_json"))


def stored_row_problem(row: dict[str, Any]) -> str | None:
    """Why a row read from a store breaks the row rule (None if it does not)."""
    try:
        checked_row_values(row)
    except ValueError as exc:
        return str(exc)
    return None
