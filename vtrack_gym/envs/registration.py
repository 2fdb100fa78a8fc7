"""Registration of the env ids with Gymnasium (called by ``import vtrack_gym``; imports nothing heavy).

The ids are generated from the scenario registry (``envs.scenarios.SCENARIOS``): ``vtrack/<name>`` per scenario,
plus the historical un-namespaced ids (``LEGACY_IDS``) as aliases with the same entry points and arguments, so
``gym.make("DLC120-v0")`` and ``gym.make("vtrack/DLC120-v0")`` give identical episodes.

``spec.max_episode_steps`` is the scenario's time limit at the default 10 ms control period (``None`` for
Track-v0, whose limit depends on the track). The env truncates itself at the same step, so Gymnasium's
``TimeLimit`` wrapper never changes an episode; an env made with a shorter ``control_period_s`` should be made
with ``max_episode_steps=`` scaled accordingly (or ``None`` to leave the truncation to the env).
"""

from __future__ import annotations

from vtrack_gym.envs.scenarios import LEGACY_IDS, SCENARIOS

ENV_IDS: tuple[str, ...] = LEGACY_IDS
"""The paper scenarios' historical ids (aliases of ``vtrack/<id>``)."""
NAMESPACED_IDS: tuple[str, ...] = tuple(s.env_id for s in SCENARIOS.values())
"""Every registered ``vtrack/`` id, one per scenario (``vtrack/Track-v0`` takes ``track=``, ``speed_profile=``)."""
ALL_ENV_IDS: tuple[str, ...] = NAMESPACED_IDS + ENV_IDS
"""Every id this package registers for its own envs."""


def register_envs() -> None:
    """Register every id (idempotent)."""
    from gymnasium.envs.registration import register, registry

    by_id = {s.env_id: s for s in SCENARIOS.values()}
    by_id.update({name: SCENARIOS[name] for name in LEGACY_IDS})
    for env_id, scenario in by_id.items():
        if env_id in registry:
            continue
        register(
            id=env_id,
            entry_point="vtrack_gym.envs.tracking_env:TrackingEnv",
            vector_entry_point="vtrack_gym.envs.vector_env:TrackingVectorEnv",
            kwargs={"scenario": scenario.name},
            max_episode_steps=scenario.max_episode_steps,
            disable_env_checker=False,
        )
