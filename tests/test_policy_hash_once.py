"""A run takes one fingerprint per policy identity (``policy_hash``'s ``seen``), the same digest as probing again; and
one NMPC preset is one hash in every build (its engine holds no wall-clock statistics after its warm-up)."""

from __future__ import annotations

import gymnasium as gym
import pytest

import vtrack_gym
from vtrack_gym.evaluation.identity import probes
from vtrack_gym.evaluation.identity.fingerprint import policy_hash


def test_one_nmpc_preset_is_one_hash_in_every_build() -> None:
    env = gym.make("DLC120-v0")
    assert policy_hash(vtrack_gym.make_policy("nmpc", env), env) == \
        policy_hash(vtrack_gym.make_policy("nmpc", env), env)


def test_a_policy_seen_in_the_run_is_not_probed_again(monkeypatch: pytest.MonkeyPatch) -> None:
    env = gym.make("DLC120-v0")
    probed = []
    real = probes.behaviour_digest

    def counting(*args, **kwargs):
        probed.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(probes, "behaviour_digest", counting)
    seen: dict[str, str] = {}
    first = policy_hash(vtrack_gym.make_policy("smc", env), env, seen)
    again = policy_hash(vtrack_gym.make_policy("smc", env), env, seen)
    assert again == first and len(probed) == 1
    assert policy_hash(vtrack_gym.make_policy("smc", env), env) == first and len(probed) == 2   # no seen: probed
    other = policy_hash(vtrack_gym.make_policy("smc", env, "paper"), env, seen)
    assert other != first and len(probed) == 3                       # another identity is probed


def test_the_benchmark_rows_keep_the_hash_of_each_episode() -> None:
    from vtrack_gym.evaluation.benchmarking.benchmark import run_benchmark

    rows = run_benchmark("paper", policies=["lqr"], show_progress=False, workers=1)["rows"]
    assert len(rows) == 2
    for row in rows:
        env = gym.make(row.env_id)
        assert row.policy_hash == policy_hash(vtrack_gym.make_policy("lqr", env), env)
