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


__all__ = ["ENV_ALIASES", "HIGHWAY_ENV_ID", "register_highway_envs", "resolve_env_id"]
