"""The success verdict of one episode (what the leaderboard ranks by first).

Interim rule, until the scenario registry (issue 16) lets the env report ``info["success"]`` at the end of an
episode: an episode succeeds when it *completed* the course (``termination == "completed"``) and, on a gated
course (one whose metrics carry ``cones_hit``, e.g. ``DLC120-v0``), hit no cone. When the env does report
``info["success"]``, that verdict is used instead (``vtrack_gym.evaluation.rollout``).
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Any

CONES_HIT = "cones_hit"


def _no_cones(metrics: Mapping[str, Any]) -> bool:
    """True when the course has no gates or its cone count is a number equal to 0."""
    if CONES_HIT not in metrics:
        return True
    cones = metrics[CONES_HIT]
    return isinstance(cones, numbers.Real) and not isinstance(cones, bool) and cones == 0


def episode_success(env_id: str, termination: str, metrics: Mapping[str, Any]) -> bool:
    """Interim success verdict (see the module docstring).

    ``env_id`` names the scenario (kept for the registry's per-scenario criteria; the interim rule reads the
    gates from the metrics, so user tracks with gates are judged the same way). A gated course whose cone count
    is missing (None/NaN) is not a success: the criterion cannot be checked.
    """
    del env_id  # the interim rule is the same for every scenario
    return termination == "completed" and _no_cones(metrics)


def failure_reason(termination: str, metrics: Mapping[str, Any]) -> str:
    """Why a failed episode failed: its termination, ``cones_hit`` for a completed run that hit cones, else
    ``env_verdict`` (a completed run the env judged unsuccessful)."""
    if termination != "completed":
        return termination
    return "env_verdict" if _no_cones(metrics) else CONES_HIT
