"""Adapters that let vtrack policies drive other simulators' cars (optional dependencies, imported lazily).

``register_highway_envs()`` registers ``vtrack_gym/HighwayLaneKeeping-v0`` (highway-env's ``lane-keeping-v0``
behind vtrack's observation/action contract, see ``vtrack_gym.interop.highway``). Registering imports neither
highway-env nor the adapter module: both load on ``gym.make``, which raises ``ImportError`` with the install hint
(``pip install vtrack_gym[highway]``) when highway-env is missing.
"""

from __future__ import annotations

HIGHWAY_ENV_ID = "vtrack_gym/HighwayLaneKeeping-v0"
"""Gymnasium id of the highway-env lane-keeping adapter."""

ENV_ALIASES: dict[str, str] = {
    "highway-env:lane-keeping-v0": HIGHWAY_ENV_ID,
    "highway_env:lane-keeping-v0": HIGHWAY_ENV_ID,
}
"""Command-line spellings of external envs -> the adapter's Gymnasium id (``resolve_env_id``)."""

HIGHWAY_SEEDS: tuple[int, ...] = (0, 1, 2)
"""Seeds of the ``highway`` leaderboard suite (one initial condition each, see ``highway_episodes``)."""

_HIGHWAY_STARTS: dict[int, dict[str, float]] = {
    0: {"initial_lateral_offset_m": -4.0},  # highway-env's own offset (4 m to the right), lane start
    1: {"initial_lateral_offset_m": 4.0, "start_station_m": 25.0},  # mirrored, a quarter period further
    2: {"initial_lateral_offset_m": 0.0, "initial_heading_error_rad": 0.2, "start_station_m": 50.0},
}


def register_highway_envs() -> None:
    """Register ``vtrack_gym/HighwayLaneKeeping-v0`` with Gymnasium (idempotent, imports nothing heavy)."""
    from gymnasium.envs.registration import register, registry

    if HIGHWAY_ENV_ID in registry:
        return
    register(
        id=HIGHWAY_ENV_ID,
        entry_point="vtrack_gym.interop.highway:HighwayLaneKeeping",
        max_episode_steps=None,  # the adapter truncates itself (max_episode_s)
        disable_env_checker=False,
    )


def resolve_env_id(env_id: str) -> str:
    """The Gymnasium id for a command-line env name (``highway-env:lane-keeping-v0`` -> the adapter's id)."""
    resolved = ENV_ALIASES.get(env_id, env_id)
    if resolved == HIGHWAY_ENV_ID:
        register_highway_envs()
    return resolved


def highway_episodes(quick: bool = False) -> list:
    """Episodes of the ``highway`` leaderboard suite: the adapter from three initial conditions (seed -> options).

    Seed 0 is highway-env's own initial offset (4 m right of the sine lane's centre line at its start); seed 1
    the mirrored offset a quarter period further; seed 2 on the centre line with a 0.2 rad heading error. Every
    episode drives to the end of the sine lane (~500 m at 8.3 m/s). ``quick`` keeps seed 0 only.
    """
    from vtrack_gym.evaluation.suites import Episode

    register_highway_envs()
    seeds = HIGHWAY_SEEDS[:1] if quick else HIGHWAY_SEEDS
    return [Episode(HIGHWAY_ENV_ID, s, dict(_HIGHWAY_STARTS[s])) for s in seeds]


__all__ = ["ENV_ALIASES", "HIGHWAY_ENV_ID", "HIGHWAY_SEEDS", "highway_episodes", "register_highway_envs",
           "resolve_env_id"]
