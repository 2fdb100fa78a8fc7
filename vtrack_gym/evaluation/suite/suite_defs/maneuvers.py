"""``maneuvers``: the standard manoeuvres at their current versions (``envs.scenarios.MANEUVER_IDS``), each with its
own speed protocol (the ISO 3888 ids: entry speed, then the throttle held or released), seed 0 (deterministic
without noise), judged by its own success criterion; an ISO 3888 episode also searches its highest passing entry
speed."""

from __future__ import annotations

from typing import Any

from vtrack_gym.envs.scenarios import MANEUVER_SCENARIOS
from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

MANEUVER_ENV_IDS: tuple[str, ...] = tuple(sc.env_id for sc in MANEUVER_SCENARIOS)
"""Env ids of the ``maneuvers`` suite, in library order."""
ENTRY_SPEED_COLUMNS: tuple[str, ...] = ("max_entry_speed_kmh", "entry_speed_bound_kmh", "entry_speed_fraction",
                                         "above_physical_bound")
"""The ISO 3888-1/-2 rows' entry-speed search (``entry_speed.max_entry_speed_kmh``): the highest passing entry speed
[km/h], the car's physical bound [km/h], their ratio [-] and whether some speed above the bound passed (0/1)."""


def maneuver_episodes(seeds: tuple[int, ...]) -> list[Episode]:
    """Every manoeuvre at each seed."""
    return [Episode(env_id, s) for s in seeds for env_id in MANEUVER_ENV_IDS]


def entry_speed_scorer(make: Any) -> Any:
    """``entry_speed.EntrySpeedScore``: the usual row plus, on the ISO 3888 episodes, the entry-speed search with
    fresh policies from ``make``."""
    from vtrack_gym.evaluation.rollouts.entry_speed import EntrySpeedScore

    return EntrySpeedScore(make)


MANEUVERS = Suite(name="maneuvers", description="the standard manoeuvres (ISO 3888-1/-2, ISO 4138 circle, slalom, "
                  "step curvature), one figure each", episodes=maneuver_episodes, figures="maneuver",
                  columns=("max_steady_a_y_mps2", "grip_limit_a_y_mps2", "mu_g_mps2", *ENTRY_SPEED_COLUMNS),
                  scorer=entry_speed_scorer)
"""Extra columns: ISO 4138's lateral acceleration reached on the circle and mu g, and the ISO 3888 entry-speed
search (missing for the other manoeuvres)."""
