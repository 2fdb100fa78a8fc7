"""Leaderboard aggregation shared by ``vtrack benchmark`` (fresh rows) and ``vtrack leaderboard`` (stored rows).

Policy key: a board row is one (env_id, policy_id, preset, policy_hash): the same controller name with two presets
(``smc`` default vs ``smc --preset paper``) or two agent files with different weights are two rows.

Validity first: every episode has a success verdict (its scenario's success criterion, ``envs.criteria``). The
metric columns are aggregated over the *successful* episodes only; failed episodes are counted apart (``failed``,
``failure_reasons``, ``failed_progress_m`` and the primary metric over them, ``failed_<primary>``), so a policy
that crashes early (short episode, small ITAE, few cones passed) cannot look better than one that drives the
course. The exception are metrics of the policy rather than of the episode (``POLICY_METRICS``: the ISO 3888
entry-speed search, whose row's own verdict is judged at the id's default entry speed): they are aggregated over
every episode. Rank within each env, lexicographically: success rate (higher first), the suite's primary metric over
successful episodes (lower first), completion rate (higher first), the primary metric over completed but failed
episodes (e.g. cones hit; lower first), the progress of the uncompleted episodes (further first), then the key.

NaN rule (the only one, used everywhere): a metric is *missing* in an episode when it is absent, ``None``, not a
number, NaN or infinite (the store keeps NaN/inf as JSON ``null``, so both paths see the same thing). The
aggregate of a metric is the mean over the episodes aggregated when it is present in every one of them, and NaN
(printed ``–``, ``null`` in JSON) when it is missing in any episode or there is no episode: averaging only the
episodes where a metric exists would compare policies over different subsets.

Uncertainty: every mean is an ``Estimate`` (a float) carrying a 95 % bootstrap confidence interval
(``scipy.stats.bootstrap``, percentile method, 9999 resamples, fixed generator seed 0, so the same episodes give
the same interval). With fewer than two episodes the interval is undefined (NaN, shown as the bare mean); with
zero variance it is the point value. Two entries of one env are *tied* (``tied_with``) when their success rates are
equal and their primary-metric intervals overlap (an undefined interval counts as the point value; two entries
without any successful episode are tied when their completion rates are equal). Ties are named
``policy_id[:preset]`` (no ``:default``), with ``@policy_hash`` where that is ambiguous.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

KEY_COLUMNS: tuple[str, ...] = ("env_id", "policy_id", "preset", "policy_hash")
POLICY_METRICS: frozenset[str] = frozenset({"max_entry_speed_kmh", "entry_speed_bound_kmh", "entry_speed_fraction",
                                            "above_physical_bound", "late_decision_share"})
"""Columns aggregated over every episode, failed ones too: the entry-speed search's figures, which describe the
policy on the manoeuvre at every speed, not the one run at the default speed; the share of late decisions under
compute latency (a failed episode's decisions were late all the same)."""


def clock_measured_columns() -> frozenset[str]:
    """The board columns measured from the clock: each of ``metrics.CLOCK_MEASURED`` with its interval bounds, and
    ``wall_time_per_step_us`` (``wall_time_per_step_s`` in us). The only columns two boards of the same episodes may
    differ in."""
    from vtrack_gym.evaluation.scoring.metrics import CLOCK_MEASURED

    bounds = ("", "_lo", "_hi")
    return frozenset({"wall_time_per_step_us", *(f"{m}{b}" for m in CLOCK_MEASURED for b in bounds)})


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


class Estimate(float):
    """A mean (the float value) with its 95 % confidence interval ``lo``, ``hi`` (NaN when undefined)."""

    __slots__ = ("hi", "lo")

    def __new__(cls, mean: float, lo: float = math.nan, hi: float = math.nan) -> Estimate:
        obj = super().__new__(cls, mean)
        obj.lo = float(lo)
        obj.hi = float(hi)
        return obj

    def __repr__(self) -> str:
        return f"Estimate({float(self)!r}, lo={self.lo!r}, hi={self.hi!r})"


CONFIDENCE_LEVEL = 0.95
BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_SEED = 0


@functools.lru_cache(maxsize=4096)
def _bootstrap_ci(values: tuple[float, ...]) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the mean of ``values`` (at least two, not all equal)."""
    from scipy.stats import bootstrap

    rng = np.random.default_rng(BOOTSTRAP_SEED)
    key = "rng" if "rng" in inspect.signature(bootstrap).parameters else "random_state"  # scipy < 1.15
    res = bootstrap((np.asarray(values),), np.mean, n_resamples=BOOTSTRAP_RESAMPLES, method="percentile",
                    confidence_level=CONFIDENCE_LEVEL, vectorized=True, axis=-1, **{key: rng})
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def estimate(values: Iterable[Any]) -> Estimate:
    """Mean of ``values`` under the NaN rule with its bootstrap interval (rules in the module docstring)."""
    clean = [metric_value(v) for v in values]
    if not clean or any(v is None for v in clean):
        return Estimate(math.nan)
    if min(clean) == max(clean):  # type: ignore[type-var]  # zero variance (or one episode): exact mean
        return Estimate(clean[0]) if len(clean) < 2 else Estimate(clean[0], clean[0], clean[0])  # type: ignore[arg-type]
    mean = aggregate(clean)
    lo, hi = _bootstrap_ci(tuple(clean))  # type: ignore[arg-type]
    return Estimate(mean, min(lo, mean), max(hi, mean))


def _interval(e: float) -> tuple[float, float]:
    lo, hi = (e.lo, e.hi) if isinstance(e, Estimate) and math.isfinite(e.lo) else (float(e), float(e))
    return lo, hi


def _tied(a: Mapping[str, Any], b: Mapping[str, Any], primary: str) -> bool:
    if a["success_rate"] != b["success_rate"]:
        return False
    pa, pb = a[primary], b[primary]
    if math.isnan(pa) or math.isnan(pb):  # no successful episode to compare: tied when as many completed
        return math.isnan(pa) and math.isnan(pb) and a["completed"] == b["completed"]
    (alo, ahi), (blo, bhi) = _interval(pa), _interval(pb)
    return alo <= bhi and blo <= ahi


def _labels(entries: Sequence[Mapping[str, Any]]) -> list[str]:
    """``policy_id[:preset]`` of each entry (no ``:default``), with ``@policy_hash`` where that is ambiguous."""
    short = [e["policy_id"] + (f":{e['preset']}" if e["preset"] not in ("", "default")
                               and not e["policy_id"].endswith(f":{e['preset']}") else "") for e in entries]
    return [s if short.count(s) == 1 else f"{s}@{e['policy_hash']}" for s, e in zip(short, entries, strict=True)]


def _succeeded(record: Mapping[str, Any]) -> bool:
    """A record's success verdict (``success``; records without one: ``completed``)."""
    verdict = record.get("success")
    return bool(record["completed"] if verdict is None else verdict)


def _mean_or_nan(values: list[Any]) -> float:
    return aggregate(values) if values else math.nan


def failure_reason(termination: str, metrics: Mapping[str, Any]) -> str:
    """Why a failed episode failed: its termination, ``cones_hit`` for a completed run whose body left a cone gate,
    else ``env_verdict`` (a completed run its scenario's success criterion judged unsuccessful)."""
    if termination != "completed":
        return termination
    cones = metric_value(metrics.get("cones_hit"))
    return "cones_hit" if cones is not None and cones > 0 else "env_verdict"


SETTING_OPTIONS: tuple[str, ...] = ("protocol", "env_config", "max_episode_steps", "wrappers", "env_kwargs",
                                    "half_width_m", "latency", "latency_s", "control")
"""Keys of a row's ``options`` that say how its env was set up beyond its id (``api.env_identity``: an entry speed or
reference line, config fields, a time limit, wrappers, make kwargs, a half width, compute charged in the loop:
``envs.latency``, the control mode: ``envs.control``): rows differing in any of them
never share a ranking. (Reset options of a suite's episodes, figure folders and track provenance are not settings:
the id already encodes a track file's content and profile.)"""


def board_env(record: Mapping[str, Any]) -> str:
    """The env a record is ranked in: its ``env_id`` (an alias resolved), with `` (<vehicle>)`` appended when its
    ``options`` name a car (``options["vehicle"]``, see ``benchmark.vehicle_label``) and `` [<settings>]`` when
    they record settings (``SETTING_OPTIONS``, numbers normalised), so different cars or set-ups never share a
    ranking and one set-up spelled two ways is one."""
    from vtrack_gym.evaluation.identity.env_names import canonical_env_id, normal_numbers

    options = record.get("options") or {}
    vehicle = options.get("vehicle")
    env_id = canonical_env_id(str(record["env_id"]))   # rows stored under an alias join their scenario's
    label = env_id if not vehicle else f"{env_id} ({vehicle})"
    settings = settings_label(normal_numbers(dict(options)))   # 45 and 45.0: one set-up
    return f"{label} [{settings}]" if settings else label


def settings_label(options: Mapping[str, Any]) -> str:
    """``key=value`` of every setting of ``options`` (``SETTING_OPTIONS``; a flat dict's items one by one), or ""."""
    import json

    parts: list[str] = []
    for key in SETTING_OPTIONS:
        value = options.get(key)
        if value is None or value == {} or value == []:
            continue
        if isinstance(value, Mapping) and not any(isinstance(v, (Mapping, list)) for v in value.values()):
            parts += [f"{k}={v}" for k, v in sorted(value.items())]
        else:
            parts.append(f"{key}={json.dumps(value, sort_keys=True, separators=(',', ':'), default=str)}")
    return ", ".join(parts)


def build_board(records: Iterable[Mapping[str, Any]], columns: Sequence[str],
                primary: str = "max_e_y_m", then: Sequence[str] = ()) -> list[dict[str, Any]]:
    """One entry per policy key from episode ``records``, ranked within each env (see the module docstring).

    Each record has ``env_id`` (and optionally ``options``: see ``board_env``), ``policy_id``, ``policy_preset``
    (may be empty), ``policy_hash``, ``completed``
    (0/1), ``success`` (0/1; absent: ``completed``), ``termination`` (optional), ``wall_time_per_step_s`` [s] and
    ``metrics`` (name -> value). ``primary``: the metric ranked on (lower is better); ``then``: metrics that
    order entries with the same success rate and mean primary metric, in turn (lower first). Entries are sorted by env
    and rank and hold ``rank``, ``episodes``, ``success_rate``, ``completed``, the aggregate of every column over
    the successful episodes, the failed episodes apart, ``wall_time_per_step_us`` [us] and ``tied_with``.
    """
    groups: dict[tuple[str, str, str, str], list[Mapping[str, Any]]] = {}
    for r in records:
        key = (board_env(r), str(r["policy_id"]), str(r.get("policy_preset") or ""), str(r["policy_hash"]))
        groups.setdefault(key, []).append(r)
    entries: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    for key, members in groups.items():
        good = [m for m in members if _succeeded(m)]
        bad = [m for m in members if not _succeeded(m)]
        entry: dict[str, Any] = dict(zip(KEY_COLUMNS, key, strict=True))
        entry["rank"] = 0
        entry["episodes"] = len(members)
        entry["success_rate"] = estimate(1.0 if _succeeded(m) else 0.0 for m in members)
        entry["completed"] = aggregate(m["completed"] for m in members)
        for col in dict.fromkeys([*columns, primary, *then]):
            entry[col] = estimate(m["metrics"].get(col) for m in (members if col in POLICY_METRICS else good))
        reasons: dict[str, int] = {}
        for m in bad:
            reason = failure_reason(str(m.get("termination") or ("completed" if m["completed"] else "failed")),
                                    m["metrics"])
            reasons[reason] = reasons.get(reason, 0) + 1
        entry["failed"] = len(bad)
        entry["failure_reasons"] = ", ".join(f"{k} x{n}" for k, n in sorted(reasons.items()))
        entry["failed_progress_m"] = _mean_or_nan([m["metrics"].get("progress_m") for m in bad])
        entry[f"failed_{primary}"] = _mean_or_nan([m["metrics"].get(primary) for m in bad])
        entry["wall_time_per_step_us"] = 1e6 * aggregate(m["wall_time_per_step_s"] for m in members)
        entry["tied_with"] = ""
        completed_bad = [m["metrics"].get(primary) for m in bad if m["completed"]]
        unfinished = [m["metrics"].get("progress_m") for m in bad if not m["completed"]]
        order = (key[0], -entry["success_rate"], _nan_last(entry[primary]), *(_nan_last(entry[m]) for m in then),
                 -entry["completed"],
                 _nan_last(_mean_or_nan(completed_bad)), -_nan_first(_mean_or_nan(unfinished)), key[1:])
        entries.append((order, entry))
    entries.sort(key=lambda oe: oe[0])
    board = [e for _, e in entries]
    for env_id in dict.fromkeys(e["env_id"] for e in board):
        same = [e for e in board if e["env_id"] == env_id]
        labels = _labels(same)
        for rank, (e, label) in enumerate(zip(same, labels, strict=True), 1):
            e["rank"] = rank
            e["name"] = label       # policy_id[:preset], with @policy_hash where two entries would read alike
            e["tied_with"] = ", ".join(lab for o, lab in zip(same, labels, strict=True)
                                       if o is not e and _tied(e, o, primary))
    return board


def ranking_note(primary: str, then: Sequence[str] = ()) -> str:
    """One sentence telling a reader of a board how it is ranked and what the brackets are."""
    further = "".join(f", then mean {m}" for m in then)
    return (f"Ranked per env by success rate, then mean {primary}{further} over successful episodes (lower first); "
            "metric columns aggregate the successful episodes only (failed ones: failed, failure_reasons, failed_*); "
            f"[lo, hi]: {CONFIDENCE_LEVEL:.0%} bootstrap confidence interval over the episodes (percentile, "
            f"{BOOTSTRAP_RESAMPLES} resamples; none with one episode); tied_with: not separable (equal success "
            f"rate, overlapping {primary} intervals).")


def _nan_last(value: float) -> float:
    """``value`` as a sort key with NaN after every number."""
    return math.inf if math.isnan(value) else value


def _nan_first(value: float) -> float:
    """``value`` as a (negated) sort key with NaN last: NaN maps to -inf."""
    return -math.inf if math.isnan(value) else value
