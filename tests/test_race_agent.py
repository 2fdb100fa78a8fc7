"""The shipped race agent ``dagger_race`` through the public entry points: loaded by name, bound to a race env by
its observation names, and driving a held-out circuit of the race split (never trained on) within track limits."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np

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


def test_dagger_race_laps_a_held_out_circuit_within_track_limits() -> None:
    """One lap of the first held-out circuit of the race split from a standing start, seed 0: completed, no step
    beyond the wheels rule (a circuit no training race and no recipe choice drove)."""
    circuit = RACE_SPLIT["held_out"][0]
    env = gym.make("vtrack/Race-v0", track=race_circuit(circuit), laps=1)
    policy = vtrack_gym.make_policy("dagger_race", env)
    obs, info = env.reset(seed=0)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        done = terminated or truncated
    metrics = env.unwrapped.success_metrics()
    assert info["termination"] == "completed" and info["success"], (circuit, info["termination"])
    assert info["laps_completed"] == 1 and metrics["track_limit_violations"] == 0.0
    assert 1.0 < info["lap_time_fraction"] < 2.0, json.dumps({"fraction": info["lap_time_fraction"]})
