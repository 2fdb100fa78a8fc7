"""``paper``: the paper's two nominal scenarios, one episode each (seed 0, deterministic without noise)."""

from __future__ import annotations

from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

PAPER_ENV_IDS: tuple[str, ...] = ("LateralTracking-v0", "DLC120-v0")


def paper_episodes(seeds: tuple[int, ...]) -> list[Episode]:
    """Both nominal scenarios at each seed."""
    return [Episode(env_id, s) for s in seeds for env_id in PAPER_ENV_IDS]


PAPER = Suite(name="paper", description="the two nominal scenarios", episodes=paper_episodes,
              trace_every_seed=True)
"""The ``paper`` suite: ranks on the largest lateral error |e_y| [m], the worst case that decides whether the car
stays in its lane or clears the cones."""
