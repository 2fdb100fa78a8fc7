"""The shipped race agents ``dagger_race``, ``dagger_race_v2`` and ``sac_race`` through the public entry points:
loaded by name, bound to a race env by their observation names, and driving a held-out circuit of the race split
(never trained on) within track limits; ``dagger_race_v2`` and ``sac_race`` also the handling course, where
``dagger_race`` spins out."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines.resolve import race_agent_names
from vtrack_gym.tracks.race_circuits import RACE_SPLIT, race_circuit


def test_dagger_race_is_shipped_as_a_race_agent_with_its_recipe() -> None:
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy("dagger_race", env)
    assert "dagger_race" in race_agent_names()
    names = policy.spec["env"]["observation_names"]
    assert "lap_fraction" not in names and names[-2:] == ["edge_left_m", "edge_right_m"]
    prov = policy.provenance
    assert "train --algo dagger --env vtrack/Race-v0 --seed 0" in prov["command"]
    assert prov["warm_start"].startswith("DAgger of centreline on 24 training circuits")
    action, _ = policy.predict(env.reset(seed=0)[0])
    assert env.action_space.contains(np.asarray(action, dtype=np.float32))


def test_dagger_race_v2_is_shipped_apart_with_its_recipe_on_the_corner_circuits() -> None:
    """A second file, so its rows never merge with ``dagger_race``'s; trained on the training group with the
    corner circuits (36 circuits)."""
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy("dagger_race_v2", env)
    assert {"dagger_race", "dagger_race_v2"} <= set(race_agent_names())
    assert policy.weights_hash != vtrack_gym.make_policy("dagger_race", env).weights_hash
    assert policy.spec["env"]["observation_names"] == vtrack_gym.make_policy("dagger_race", env).spec["env"][
        "observation_names"]
    prov = policy.provenance
    assert "train --algo dagger --env vtrack/Race-v0 --seed 0" in prov["command"]
    assert prov["warm_start"].startswith(f"DAgger of centreline on {len(RACE_SPLIT['train'])} training circuits")
    assert len(RACE_SPLIT["train"]) == 36


def lap(agent: str, env: gym.Env) -> dict:
    """One race of ``agent`` on ``env`` from seed 0: the last info and the env's success metrics."""
    policy = vtrack_gym.make_policy(agent, env)
    obs, info = env.reset(seed=0)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        done = terminated or truncated
    return {**info, **env.unwrapped.success_metrics()}


def test_sac_race_is_dagger_race_v2_fine_tuned_by_its_recipe() -> None:
    """The reward-driven fine-tune of ``dagger_race_v2``: its recipe command recorded, the same observation names,
    other weights (the actor moved by SAC's updates)."""
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy("sac_race", env)
    v2 = vtrack_gym.make_policy("dagger_race_v2", env)
    assert "sac_race" in race_agent_names() and policy.weights_hash != v2.weights_hash
    assert policy.spec["env"]["observation_names"] == v2.spec["env"]["observation_names"]
    prov = policy.provenance
    assert "train --algo sac --env vtrack/Race-v0 --init-from dagger_race_v2 --seed 0" in prov["command"]
    assert prov["warm_start"].startswith(f"dagger_race_v2, fine-tuned by SAC on Race-v0's reward on "
                                         f"{len(RACE_SPLIT['train'])} training circuits")
    changes = [np.max(np.abs(a - b)) for a, b in zip(policy._weights, v2._weights) for a, b in zip(a, b)]
    assert max(changes) > 1e-3


@pytest.mark.parametrize("agent", ["dagger_race", "dagger_race_v2", "sac_race"])
def test_dagger_race_laps_a_held_out_circuit_within_track_limits(agent: str) -> None:
    """One lap of the first held-out circuit of the race split from a standing start, seed 0: completed, no step
    beyond the wheels rule (a circuit no training race and no recipe choice drove)."""
    circuit = RACE_SPLIT["held_out"][0]
    info = lap(agent, gym.make("vtrack/Race-v0", track=race_circuit(circuit), laps=1))
    assert info["termination"] == "completed" and info["success"], (circuit, info["termination"])
    assert info["laps_completed"] == 1 and info["track_limit_violations"] == 0.0
    assert 1.0 < info["lap_time_fraction"] < 2.0, json.dumps({"fraction": info["lap_time_fraction"]})


@pytest.mark.parametrize("agent", ["dagger_race_v2", "sac_race"])
def test_race_agent_laps_the_handling_course_within_track_limits(agent: str) -> None:
    """One lap of the handling course (never trained on) from a standing start, seed 0: past the 30 m corner at
    1572 m where ``dagger_race`` spins out, completed with no step beyond the wheels rule."""
    info = lap(agent, gym.make("vtrack/Race-v0", laps=1))
    assert info["termination"] == "completed" and info["success"], info["termination"]
    assert info["track_limit_violations"] == 0.0 and 1.0 < info["lap_time_fraction"] < 2.0
