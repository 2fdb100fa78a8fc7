"""``highway``: highway-env's ``lane-keeping-v0`` through ``vtrack_gym.interop`` (three starts; needs the ``highway``
extra). Ranks on ITAE [m s^2]: every policy starts 4 m off the lane centre, so the largest error is the initial
offset for all of them; ITAE weights the error by time and measures how fast and how well it is removed."""

from __future__ import annotations

from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.suite.suite_parts import Suite

HIGHWAY_SEEDS: tuple[int, ...] = (0, 1, 2)
"""Seeds of the ``highway`` leaderboard suite (one initial condition each, see ``highway_episodes``)."""

HIGHWAY_STARTS: dict[int, dict[str, float]] = {
    0: {"initial_lateral_offset_m": -4.0},  # highway-env's own offset (4 m to the right), lane start
    1: {"initial_lateral_offset_m": 4.0, "start_station_m": 25.0},  # mirrored, a quarter period further
    2: {"initial_lateral_offset_m": 0.0, "initial_heading_error_rad": 0.2, "start_station_m": 50.0},
}
"""Reset options of the ``highway`` suite's episodes, by seed."""


def highway_episodes(seeds: tuple[int, ...] = HIGHWAY_SEEDS) -> list[Episode]:
    """The adapter from one initial condition per seed (seed 0: highway-env's own offset, 4 m right of the sine
    lane's centre line at its start; seed 1 the mirrored offset a quarter period further; seed 2 on the centre line
    with a 0.2 rad heading error). Every episode drives to the end of the sine lane (~500 m at 8.3 m/s)."""
    from vtrack_gym.interop import HIGHWAY_ENV_ID, register_highway_envs

    register_highway_envs()
    if not set(seeds) <= set(HIGHWAY_STARTS):
        raise ValueError(f"highway suite seeds must be among {sorted(HIGHWAY_STARTS)} (got {list(seeds)})")
    return [Episode(HIGHWAY_ENV_ID, s, dict(HIGHWAY_STARTS[s])) for s in seeds]


HIGHWAY = Suite(name="highway", description="highway-env's lane-keeping-v0 (needs the 'highway' extra)",
                episodes=highway_episodes, seeds=HIGHWAY_SEEDS, quick_seeds=HIGHWAY_SEEDS[:1], primary_metric="itae",
                dataset=False, needs=("highway_env",))
