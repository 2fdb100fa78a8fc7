"""The clearance margin of a car's exact planned line (``tracks.exact_line``): a target margin, cut where it would
cost more than a bounded share of peak curvature.

The -v2 ISO 3888 ids plan their line ``MarginRule.target_m`` (2 cm) clear of every cone line: room for a
controller's tracking error (the body is judged exactly, the judge needs none). The rule (:func:`largest_margin`):
the target if its line's exact peak curvature is within ``peak_ratio`` (1.05) x the least-curvature line's (0 cm);
otherwise the largest whole number of ``step_m`` (1 mm) below the target whose line is, found on that grid: its line
meets the ratio and the line one ``step_m`` wider does not (peak curvature grows with the margin). Each trial is
the linear interpolation of peak curvature between the bracket's ends (regula falsi on the grid, then bisection's
bracket update): one plan beyond the least line and the target's when the growth is near linear, as it is.

Planning the least line costs as much as the driven one (about 6 s CPU for the default car on ISO 3888-1), so the
rule's result for the shipped cars is shipped (``STORE_FILE``), keyed by the rule's inputs (:func:`rule_inputs`:
the manoeuvre, the body rectangle, the curvature-rate bound, the rule and the exact planner's constants, every
float written exactly); ``tests/test_exact_margin.py`` recomputes each entry from the planner and asserts
equality, and ``tests/record_exact_margins.py`` writes them. Any other car (or rule) is computed on the machine
that asks, once per process (:func:`rule_margin`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path as FilePath
from typing import Any

from vtrack_gym._ranges import documented, ranged, validate

STORE_FILE = FilePath(__file__).resolve().parents[1] / "data" / "exact_margins.json"
"""The shipped results: ``{"entries": [{"inputs": <rule_inputs JSON>, "car": name, "margin_m": m,
"peak_ratio": r}, ...]}``."""
PLANNER_CONSTANTS: tuple[str, ...] = (
    "SLP_ITERATIONS", "CG_STEP_M", "FIRST_STEP_M", "PRUNE_M", "SMOOTH_WEIGHT", "RIDGE_WEIGHT", "PAD_M",
    "CHECK_TOL_M", "CHECK_STEP_M", "MARGIN_RETRIES", "FINE_STEP_M", "WORKING_ROWS", "WORKING_ADD", "QUANTUM_M")
"""The constants of ``tracks.exact_line`` a stored result holds for (part of its inputs)."""


@documented
@dataclass(frozen=True)
class MarginRule:
    """The margin rule: ``target_m`` [m] clear of the cone lines, cut to the largest multiple of ``step_m`` [m] at
    which the line's peak curvature stays within ``peak_ratio`` x the least-curvature line's. Defaults: the -v2
    ISO 3888 ids' rule (2 cm, 1.05, 1 mm)."""

    target_m: float = ranged(0.02, ge=0.0, le=0.5, unit="m")
    peak_ratio: float = ranged(1.05, ge=1.0, le=2.0)
    step_m: float = ranged(0.001, gt=0.0, le=0.05, unit="m")

    def __post_init__(self) -> None:
        validate(self)
        if abs(self.target_m / self.step_m - round(self.target_m / self.step_m)) > 1e-9:
            raise ValueError(f"MarginRule.target_m ({self.target_m} m) must be a whole number of step_m "
                             f"({self.step_m} m)")

    @property
    def steps(self) -> int:
        """The target as a number of steps."""
        return round(self.target_m / self.step_m)

    def margin_m(self, k: int) -> float:
        """The margin [m] of ``k`` steps (``steps``: exactly ``target_m``)."""
        return self.target_m if k == self.steps else round(k * self.step_m, 9)


@dataclass(frozen=True)
class MarginChoice:
    """The rule's result: ``margin_m`` [m], its line's exact peak curvature over the least line's ``peak_ratio``
    [-], and the least line's ``least_peak_per_m`` [1/m]."""

    margin_m: float
    peak_ratio: float
    least_peak_per_m: float


def largest_margin(peak_of: Callable[[float], float], rule: MarginRule) -> MarginChoice:
    """The rule applied to ``peak_of`` (margin [m] -> the line's exact peak curvature [1/m]): the target when its
    peak is within ``rule.peak_ratio`` x ``peak_of(0)``, else the largest grid margin below it that is, with the
    next grid margin beyond the ratio (module docstring)."""
    least = peak_of(0.0)
    limit = rule.peak_ratio * least
    lo, hi = 0, rule.steps
    peaks = {lo: least, hi: peak_of(rule.margin_m(hi))}
    if peaks[hi] <= limit:
        lo = hi
    while hi - lo > 1:
        guess = lo + math.floor((hi - lo) * (limit - peaks[lo]) / (peaks[hi] - peaks[lo]))
        k = min(max(guess, lo + 1), hi - 1)
        peaks[k] = peak_of(rule.margin_m(k))
        lo, hi = (k, hi) if peaks[k] <= limit else (lo, k)
    return MarginChoice(rule.margin_m(lo), peaks[lo] / least if least > 0.0 else 1.0, least)


def _check_maneuver(name: str) -> None:
    from vtrack_gym.tracks.feasibility import EXACT_GATED_MANEUVERS

    if name not in EXACT_GATED_MANEUVERS:
        raise ValueError(f"the margin rule applies to the exact lines of {', '.join(EXACT_GATED_MANEUVERS)} "
                         f"(got {name!r})")


@lru_cache(maxsize=32)
def rule_margin(name: str, vehicle: Any, rule: MarginRule = MarginRule()) -> MarginChoice:
    """The rule's result for ``vehicle`` (``VehicleParams``) on manoeuvre ``name``, computed here from its exact
    lines (``feasibility.planned_maneuver``, planner version 2; the least line and the target's at least)."""
    from vtrack_gym.tracks.feasibility import planned_maneuver

    _check_maneuver(name)
    return largest_margin(lambda m: planned_maneuver(name, vehicle, m, 2).line.peak_curvature_per_m, rule)


def rule_inputs(name: str, vehicle: Any, rule: MarginRule = MarginRule()) -> str:
    """Canonical JSON of what the rule's result depends on for ``vehicle`` on ``name`` (floats exact): equal
    strings, equal results."""
    from vtrack_gym.tracks import exact_line
    from vtrack_gym.tracks.feasibility import body_of, curvature_rate_for

    _check_maneuver(name)
    body = body_of(vehicle)
    record = {"maneuver": name, "body": [float(body.length_m).hex(), float(body.width_m).hex(),
                                         float(body.cg_to_front_m).hex()],
              "max_curvature_rate_per_m2": float(curvature_rate_for(name, vehicle)).hex(),
              "rule": [float(rule.target_m).hex(), float(rule.peak_ratio).hex(), float(rule.step_m).hex()],
              "planner": {k: float(getattr(exact_line, k)).hex() for k in PLANNER_CONSTANTS}}
    return json.dumps(record, sort_keys=True)


@lru_cache(maxsize=1)
def stored_margins(file: FilePath = STORE_FILE) -> dict[str, float]:
    """``rule_inputs`` JSON -> the shipped margin [m] (empty if ``file`` does not exist)."""
    if not file.exists():
        return {}
    return {e["inputs"]: float(e["margin_m"]) for e in json.loads(file.read_text(encoding="utf-8"))["entries"]}


def exact_margin_m(name: str, vehicle: Any, rule: MarginRule = MarginRule()) -> float:
    """The margin [m] the rule gives ``vehicle`` (``VehicleParams``) on manoeuvre ``name``: the shipped result
    when one is stored for exactly these inputs, else :func:`rule_margin`'s."""
    stored = stored_margins().get(rule_inputs(name, vehicle, rule))
    return stored if stored is not None else rule_margin(name, vehicle, rule).margin_m


__all__ = ["PLANNER_CONSTANTS", "STORE_FILE", "MarginChoice", "MarginRule", "exact_margin_m", "largest_margin",
           "rule_inputs", "rule_margin", "stored_margins"]
