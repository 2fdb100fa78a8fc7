"""Registration of the env ids with Gymnasium (called by ``import vtrack_gym``; imports nothing heavy)."""

from __future__ import annotations

ENV_IDS: tuple[str, ...] = ("LateralTracking-v0", "DLC120-v0", "LateralTrackingRandom-v0")


def register_envs() -> None:
    """Register every id (idempotent). The time limit lives inside the env (``truncated``), not in a wrapper."""
    from gymnasium.envs.registration import register, registry

    for env_id in ENV_IDS:
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point="vtrack_gym.envs.tracking_env:TrackingEnv",
            vector_entry_point="vtrack_gym.envs.vector_env:TrackingVectorEnv",
            kwargs={"scenario": env_id},
            max_episode_steps=None,
            disable_env_checker=False,
        )
