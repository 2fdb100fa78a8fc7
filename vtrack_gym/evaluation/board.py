"""Leaderboard aggregation shared by ``vtrack benchmark`` (fresh rows) and ``vtrack leaderboard`` (stored rows).

Policy key: a board row is one (env_id, policy_id, preset, policy_hash): the same controller name with two presets
(``smc`` default vs ``smc --preset paper``) or two agent files with different weights are two rows.

NaN rule (the only one, used everywhere): a metric is *missing* in an episode when it is absent, ``None``, not a
number, NaN or infinite (the store keeps NaN/inf as JSON ``null``, so both paths see the same thing). The
aggregate of a metric is the mean over the group's episodes when it is present in every one of them, and NaN
(printed ``–``, ``null`` in JSON) when it is missing in any episode: averaging only the episodes where a metric
exists would compare policies over different subsets and could let a failed episode improve the mean.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

KEY_COLUMNS: tuple[str, ...] = ("env_id", "policy_id", "preset", "policy_hash")


def metric_value(value: Any) -> float | None:
    """``value`` as a finite float, or None when it is missing (None, not a number, NaN or +-inf)."""
    if isinstance(value, bool):
        return float(value)
    if hasattr(value, "item") and not isinstance(value, (int, float)):
        try:
            value = value.item()
        except (TypeError, ValueError):
            return None
    if isinstance(value, (int, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    return None


def aggregate(values: Iterable[Any]) -> float:
    """Mean of per-episode ``values`` under the NaN rule of this module (NaN if any is missing or none given)."""
    total, n = 0.0, 0
    for raw in values:
        v = metric_value(raw)
        if v is None:
            return math.nan
        total += v
        n += 1
    return total / n if n else math.nan


def build_board(records: Iterable[Mapping[str, Any]], columns: Sequence[str]) -> list[dict[str, Any]]:
    """One entry per policy key from episode ``records``.

    Each record has ``env_id``, ``policy_id``, ``policy_preset`` (may be empty), ``policy_hash``, ``completed``
    (0/1), ``wall_time_per_step_s`` [s] and ``metrics`` (name -> value). Entries are sorted by key and hold
    ``episodes``, the completed fraction, the aggregate of every column and ``wall_time_per_step_us`` [us].
    """
    groups: dict[tuple[str, str, str, str], list[Mapping[str, Any]]] = {}
    for r in records:
        key = (str(r["env_id"]), str(r["policy_id"]), str(r.get("policy_preset") or ""), str(r["policy_hash"]))
        groups.setdefault(key, []).append(r)
    board = []
    for key, members in sorted(groups.items()):
        entry: dict[str, Any] = dict(zip(KEY_COLUMNS, key, strict=True))
        entry["episodes"] = len(members)
        entry["completed"] = aggregate(m["completed"] for m in members)
        for col in columns:
            entry[col] = aggregate(m["metrics"].get(col) for m in members)
        entry["wall_time_per_step_us"] = 1e6 * aggregate(m["wall_time_per_step_s"] for m in members)
        board.append(entry)
    return board
