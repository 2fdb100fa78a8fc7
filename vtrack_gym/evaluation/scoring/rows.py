"""``ResultRow``: one scored episode, what every scorer produces and the store persists.

The row knows nothing of storage: ``evaluation.storage.store`` writes and reads rows (checking their values with
``evaluation.scoring.row_validation``, the one rule for stored values), scorers (``episode_score``, ``entry_speed``, the
GA's tuning job) build them; neither imports the other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class ResultRow:
    """One evaluated episode and where it came from (``policy_preset``: preset name, empty for agents).

    ``success``: the episode's success verdict (the scenario's success criterion, ``info["success"]``, which the
    benchmark records); a row given without one (None: the GA's tuning rows, rows written by other code) is judged
    by completion alone (``termination == "completed"``).
    """

    suite: str
    env_id: str
    policy_id: str
    policy_hash: str
    seed: int | None
    metrics: dict[str, Any]
    termination: str
    wall_time_per_step_s: float
    options: dict[str, Any] = field(default_factory=dict)
    env_version: str = "v0"
    package_version: str = ""
    created_utc: str = ""
    policy_preset: str = ""
    success: bool | None = None

    def verdict(self) -> bool:
        """``success``, or the episode's completion when the row has no verdict."""
        return bool(self.success) if self.success is not None else self.termination == "completed"
