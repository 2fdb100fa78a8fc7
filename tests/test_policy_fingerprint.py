"""The leaderboard's ``policy_hash`` tells policies apart by what determines their actions (a user's class by its
attributes, an SB3 model by its weights and normalisation statistics), and keeps one hash per ``evaluate`` call."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.identity.fingerprint import policy_hash
from vtrack_gym.evaluation.storage.store import ResultStore


class Gain:
    """Proportional steering on e_y and e_phi; the gains are its parameters."""

    def __init__(self, k_y: float, k_phi: float = 1.0) -> None:
        self.k = np.array([k_y, k_phi])

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        o = np.asarray(obs, dtype=float)
        u = -(self.k[0] * o[OBS.index("e_y")] + self.k[1] * o[OBS.index("e_phi")])
        return np.clip(np.array([u], dtype=np.float32), -1.0, 1.0), state


class Counting(Gain):
    """A policy that changes an attribute while it drives (a step counter)."""

    def __init__(self) -> None:
        super().__init__(0.3)
        self.steps = 0

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        self.steps += 1
        return super().predict(obs, state, episode_start, deterministic)


def test_user_policies_with_other_parameters_get_other_hashes_and_equal_ones_the_same() -> None:
    assert policy_hash(Gain(0.3)) == policy_hash(Gain(0.3))
    assert policy_hash(Gain(0.3)) != policy_hash(Gain(0.5))
    assert policy_hash(Gain(0.3, 2.0)) != policy_hash(Gain(0.3, 1.0))
    a = Gain(0.3)
    a.self_ref = [a, {"me": a}]          # cycles are read once, not forever
    assert policy_hash(a) == policy_hash(a)


def test_two_user_policies_of_one_class_are_two_leaderboard_entries(tmp_path: Path) -> None:
    store = tmp_path / "board.sqlite"
    for k in (0.3, 0.6, 0.3):            # the third run is the first policy again: it joins its entry
        vtrack_gym.evaluate(Gain(k), "DLC120-v0", store=store)
    rows = ResultStore(store).rows()
    assert len(rows) == 3 and {r["policy_id"] for r in rows} == {"Gain"}
    hashes = [r["policy_hash"] for r in rows]
    assert hashes[0] == hashes[2] != hashes[1]


def test_a_policy_changing_its_attributes_while_driving_keeps_one_hash_per_call(tmp_path: Path) -> None:
    policy = Counting()
    rows = vtrack_gym.evaluate(policy, "DLC120-v0", seeds=[0, 1, 2])
    assert policy.steps > 0
    assert len({r.policy_hash for r in rows}) == 1


def test_sb3_models_are_told_apart_by_their_weights_and_statistics(tmp_path: Path) -> None:
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    env = gym.make("DLC120-v0")
    first, second = PPO("MlpPolicy", env, seed=1), PPO("MlpPolicy", env, seed=2)
    assert policy_hash(first) != policy_hash(second)
    first.save(tmp_path / "first.zip")
    assert policy_hash(PPO.load(tmp_path / "first.zip")) == policy_hash(first)   # the weights, not the run state
    stats = VecNormalize(DummyVecEnv([lambda: gym.make("DLC120-v0")]))
    plain = vtrack_gym.evaluate(first, "DLC120-v0", vecnormalize=stats, policy_id="agent")[0].policy_hash
    stats.obs_rms.mean = stats.obs_rms.mean + 0.5
    shifted = vtrack_gym.evaluate(first, "DLC120-v0", vecnormalize=stats, policy_id="agent")[0].policy_hash
    assert plain != shifted


@pytest.mark.parametrize("name", ["lqr", "ppo"])
def test_baselines_and_shipped_agents_keep_their_hash_rules(name: str) -> None:
    """One preset or agent file is one hash (in every instance); its declared identity (the agent's weights hash,
    the baseline's config) is part of it, never all of it: another declaration is another hash."""
    import copy
    import dataclasses

    import gymnasium as gym

    from vtrack_gym.evaluation.identity.fingerprint import identity_parts

    env = gym.make("DLC120-v0")
    policy = vtrack_gym.make_policy(name, env)
    digest = policy_hash(policy, env)
    assert digest == policy_hash(vtrack_gym.make_policy(name, env), env)
    parts = identity_parts(policy)
    if name == "ppo":
        assert parts["weights_hash"] == policy.weights_hash
        relabelled = copy.deepcopy(policy)
        relabelled._weights_hash = "0" * 64
    else:
        assert parts["config"] == json.loads(json.dumps(dataclasses.asdict(policy.config)))
        relabelled = copy.deepcopy(policy)
        object.__setattr__(relabelled, "config", dataclasses.replace(policy.config))
        assert policy_hash(relabelled, env) == digest          # an equal config: the same policy
        object.__setattr__(relabelled, "config", dataclasses.replace(policy.config, **{
            f.name: getattr(policy.config, f.name) * 1.5 for f in dataclasses.fields(policy.config)
            if type(getattr(policy.config, f.name)) is float and getattr(policy.config, f.name) > 0}))
    assert policy_hash(relabelled, env) != digest


def test_the_wall_time_per_step_leaves_out_a_one_off_stall(monkeypatch: pytest.MonkeyPatch) -> None:
    """A kernel compiled on first use mid-episode (or a hiccup of a shared machine) stalls one step: the recorded
    wall time per step is the typical step's, not the stall spread over the episode (a fake clock, no timing)."""
    from vtrack_gym.evaluation.rollouts import rollout as rollout_module

    def wall_per_step(stall_call: int | None) -> float:
        clock = {"t": 0.0, "calls": 0}

        def fake_perf_counter() -> float:
            clock["calls"] += 1
            clock["t"] += 1.0 if clock["calls"] == stall_call else 1e-5  # one call of the episode takes a second
            return clock["t"]

        monkeypatch.setattr(rollout_module.time, "perf_counter", fake_perf_counter)
        trace = rollout_module.rollout(Gain(0.3), "DLC120-v0", seed=0)
        assert trace.n_steps > 500
        return trace.wall_time_per_step_s

    steady = wall_per_step(None)
    assert steady < 1e-4  # a few clock ticks of 10 us per step
    assert wall_per_step(41) == pytest.approx(steady, rel=1e-6)  # a stall some steps in is left out


def test_a_bad_suite_or_env_is_refused_before_the_store_is_created(tmp_path: Path) -> None:
    store = tmp_path / "new.sqlite"
    with pytest.raises(ValueError):
        vtrack_gym.evaluate(Gain(0.3), "no-such-suite", store=store)
    with pytest.raises(ValueError):
        vtrack_gym.evaluate(Gain(0.3), 42, store=store)
    assert not store.exists()


def test_one_track_file_read_two_ways_is_two_leaderboard_entries(tmp_path: Path) -> None:
    """``gym.make("vtrack/Track-v0", track=f, smoothing_m=...)`` or ``closed=...`` reads the file differently: its
    rows must not merge with the default reading's."""
    import math

    import gymnasium as gym

    t = np.linspace(0.0, 2.0 * math.pi, 300, endpoint=False)
    file = tmp_path / "loop.csv"
    file.write_text("x_m,y_m\n" + "\n".join(f"{100 * math.cos(a):.4f},{60 * math.sin(a):.4f}" for a in t) + "\n")
    ids = set()
    for extra in ({}, {"smoothing_m": 0.5}, {"closed": True}):
        env = gym.make("vtrack/Track-v0", track=str(file), **extra)
        row, = vtrack_gym.evaluate(Gain(0.3), env)
        ids.add((row.env_id, repr(sorted(row.options.items()))))
    assert len(ids) == 3
