"""A policy's fingerprint covers all of its state at any depth and size (bounded by bytes), handles cycles, is
stable across processes and hash seeds; a policy it cannot read completely is refused by ``evaluate`` unless
named; an agent file given by two paths is one leaderboard row."""

from __future__ import annotations

import collections
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vtrack_gym
from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.identity.fingerprint import IncompleteFingerprint, policy_hash, state_digest
from vtrack_gym.evaluation.storage.store import ResultStore

ROOT = Path(__file__).resolve().parents[1]


class Box:
    """A plain holder (the nesting in the tests)."""

    def __init__(self, inner: object) -> None:
        self.inner = inner


class Deep:
    """Steering gain ``k`` held ``depth`` plain objects deep."""

    def __init__(self, k: float, depth: int = 4) -> None:
        node: object = k
        for _ in range(depth):
            node = Box(node)
        self.params = node

    def gain(self) -> float:
        node = self.params
        while isinstance(node, Box):
            node = node.inner
        return float(node)

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        u = -self.gain() * float(np.asarray(obs)[OBS.index("e_y")])
        return np.clip(np.array([u], dtype=np.float32), -1.0, 1.0), state


def test_gains_four_and_ten_thousand_objects_deep_are_told_apart():
    assert policy_hash(Deep(0.3)) != policy_hash(Deep(0.5))
    assert policy_hash(Deep(0.3, 10_000)) != policy_hash(Deep(0.5, 10_000))
    assert policy_hash(Deep(0.3, 10_000)) == policy_hash(Deep(0.3, 10_000))


def test_an_element_past_the_first_hundred_thousand_counts():
    a, b = [0.0] * 200_000, [0.0] * 200_000
    b[-1] = 1.0
    assert state_digest(a) != state_digest(b)


def test_nested_lists_a_hundred_thousand_deep_and_cycles():
    deep: list = []
    for _ in range(100_000):
        deep = [deep]
    assert len(state_digest(deep)) == 64
    a = Deep(0.3)
    a.self_ref = [a, {"me": a}]
    b = Deep(0.5)
    b.self_ref = [b, {"me": b}]
    assert policy_hash(a) != policy_hash(b) and policy_hash(a) == policy_hash(a)


def test_closures_sets_deques_and_big_ints_are_state():
    def law(k):
        return lambda e: -k * e

    assert state_digest(Box(law(0.3))) != state_digest(Box(law(0.5)))
    assert state_digest({0.3, "a"}) != state_digest({0.5, "a"})
    assert state_digest(collections.deque([1, 2])) != state_digest(collections.deque([1, 3]))
    assert state_digest(10**4000) != state_digest(10**4000 + 1)


def test_state_beyond_the_byte_budget_or_unreadable_is_incomplete():
    with pytest.raises(IncompleteFingerprint, match="larger than"):
        state_digest(np.zeros(1000), budget=1000)
    with pytest.raises(IncompleteFingerprint, match="lock"):
        state_digest(Box(threading.Lock()))


_SCRIPT = ("import sys; sys.path.insert(0, {root!r}); sys.path.insert(0, {tests!r}); "
           "from test_fingerprint_complete import Deep; from vtrack_gym.evaluation.identity.fingerprint import "
           "policy_hash; "
           "p = Deep(0.3); p.table = {{'b': {{1, 2, 'x'}}, 'a': frozenset({{('k', 2.5)}}), 3: None}}; "
           "print(policy_hash(p))")


def test_stable_across_processes_and_hash_seeds():
    script = _SCRIPT.format(root=str(ROOT), tests=str(ROOT / "tests"))
    out = set()
    for seed in ("0", "1", "12345"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True)
        out.add(done.stdout.strip())
    assert len(out) == 1 and len(out.pop()) == 12


@settings(max_examples=60, deadline=None)
@given(st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(),
                    lambda kids: st.lists(kids) | st.dictionaries(st.text(), kids), max_leaves=30))
def test_equal_state_equal_digest_and_a_changed_leaf_changes_it(state):
    import copy

    assert state_digest(state) == state_digest(copy.deepcopy(state))
    assert state_digest([state, 1]) != state_digest([state, 2])


def test_evaluate_refuses_an_unreadable_policy_without_a_policy_id(tmp_path):
    policy = Deep(0.3)
    policy.lock = threading.Lock()
    store = tmp_path / "s.sqlite"
    with pytest.raises(ValueError, match="policy_id"):
        vtrack_gym.evaluate(policy, "DLC120-v0", store=store)
    rows = vtrack_gym.evaluate(policy, "DLC120-v0", store=store, policy_id="locked-gain-0.3")
    assert rows[0].policy_id == "locked-gain-0.3" and len(ResultStore(store).rows()) == 1


def test_two_deep_gains_are_two_leaderboard_rows(tmp_path):
    store = tmp_path / "s.sqlite"
    for k in (0.3, 0.6):
        vtrack_gym.evaluate(Deep(k), "DLC120-v0", store=store)
    board = ResultStore(store).leaderboard("custom", ["max_e_y_m"], latest_only=False)
    assert len({r["policy_hash"] for r in ResultStore(store).rows()}) == 2 and len(board) == 2


def test_an_agent_file_by_relative_and_absolute_path_is_one_row(tmp_path, monkeypatch):
    from vtrack_gym.cli import main

    steering = {"ppo", "ppo_bc", "sac", "sac_bc"}   # one-output agents: they drive the steer env DLC120-v0
    shipped = sorted(p for p in (ROOT / "vtrack_gym" / "baselines" / "shipped").glob("*.json") if p.stem in steering)
    if not shipped:
        pytest.skip("no shipped agent file")
    agent = shipped[0]
    monkeypatch.chdir(agent.parent)
    store = tmp_path / "s.sqlite"
    for spec in (agent.name, str(agent)):
        assert main(["eval", "--policy", spec, "--env", "DLC120-v0", "--seeds", "0",
                     "--store", str(store)]) == 0
    rows = ResultStore(store).rows()
    assert {(r["policy_id"], r["policy_hash"]) for r in rows} == {(agent.stem, rows[0]["policy_hash"])}


def test_reading_is_bounded_by_depth_and_object_count_with_a_clear_error(monkeypatch):
    """Beyond ``MAX_DEPTH`` levels or ``MAX_OBJECTS`` objects the fingerprint refuses (naming the bound and where),
    instead of reading on until the machine's memory runs out; at the bounds it still reads (the object bound
    lowered here: a million objects take seconds to build)."""
    from vtrack_gym.evaluation.identity import fingerprint

    deep: list = []
    for _ in range(fingerprint.MAX_DEPTH - 1):   # MAX_DEPTH lists, each in the next
        deep = [deep]
    assert len(state_digest(deep)) == 64
    with pytest.raises(IncompleteFingerprint, match=f"nested more than {fingerprint.MAX_DEPTH} levels"):
        state_digest([deep])
    monkeypatch.setattr(fingerprint, "MAX_OBJECTS", 10_000)
    wide = [Box(i) for i in range(fingerprint.MAX_OBJECTS)]   # with the list: one object past the bound
    with pytest.raises(IncompleteFingerprint, match=f"more than {fingerprint.MAX_OBJECTS} objects"):
        state_digest(wide)
    assert len(state_digest(wide[:-1])) == 64


def test_sets_nested_in_sets_are_bounded_too():
    from vtrack_gym.evaluation.identity import fingerprint

    nested: frozenset = frozenset()
    for _ in range(fingerprint.MAX_UNORDERED_NESTING):
        nested = frozenset({nested})
    assert len(state_digest(nested)) == 64
    with pytest.raises(IncompleteFingerprint, match="sets or non-text dict keys nested"):
        state_digest(frozenset({nested}))
