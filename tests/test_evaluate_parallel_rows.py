"""``vtrack_gym.evaluate(..., workers=2)`` commits each row as its episode ends: the store holds a finished
episode's row while a later episode still runs, and a failure in a later episode keeps the rows stored before it.

The ``paper`` suite's episodes are LateralTracking-v0 then DLC120-v0; the policy below drives DLC120-v0 only once
the LateralTracking-v0 row is in the store (it reads the store itself, in its worker), with a time limit."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path
from typing import Any

import pytest

import vtrack_gym
from vtrack_gym.evaluation.storage.store import ResultStore

WAIT_S = 120.0
"""How long the last episode waits for the earlier row to appear in the store [s]."""


def _stored_env_ids(store: Path) -> list[str]:
    """The env ids of the rows in ``store`` (read-only; empty while the file or its table does not exist)."""
    try:
        with sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=5.0) as db:
            return [r[0] for r in db.execute("SELECT env_id FROM results")]
    except sqlite3.Error:
        return []


class GatedLqr:
    """LQR that, on DLC120-v0, waits at its first decision until the LateralTracking-v0 row is stored, writes what
    it saw to ``seen``, then drives (``fail=False``) or raises (``fail=True``)."""

    def __init__(self, env: Any, store: str, seen: str, fail: bool) -> None:
        self.inner = vtrack_gym.make_policy("lqr", env)
        self.gated = env.spec is not None and env.spec.id.endswith("DLC120-v0")
        self.store, self.seen, self.fail = store, seen, fail
        self.policy_id = "gated_lqr"

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[Any, Any]:
        if self.gated:
            self.gated = False
            deadline = time.monotonic() + WAIT_S
            while "LateralTracking-v0" not in _stored_env_ids(Path(self.store)) and time.monotonic() < deadline:
                time.sleep(0.1)
            Path(self.seen).write_text(",".join(_stored_env_ids(Path(self.store))))
            if self.fail:
                raise RuntimeError("the last episode fails")
        return self.inner.predict(observation, state, episode_start, deterministic)


def _factory(store: Path, seen: Path, fail: bool) -> Any:
    return lambda env: GatedLqr(env, str(store), str(seen), fail)


def test_rows_are_stored_as_their_episodes_end_with_workers(tmp_path: Path) -> None:
    store, seen = tmp_path / "s.sqlite", tmp_path / "seen.txt"
    rows = vtrack_gym.evaluate(_factory(store, seen, fail=False), "paper", store=store, workers=2)
    assert seen.read_text() == "LateralTracking-v0"      # the earlier row was there while the last episode ran
    assert [r.env_id for r in rows] == ["LateralTracking-v0", "DLC120-v0"]   # returned in episode order
    assert len({r.policy_hash for r in rows}) == 1 and {r.policy_id for r in rows} == {"gated_lqr"}
    stored = ResultStore(store, read_only=True).rows()
    assert sorted(r["env_id"] for r in stored) == ["DLC120-v0", "LateralTracking-v0"]
    assert {r["policy_hash"] for r in stored} == {rows[0].policy_hash}


def test_a_failure_in_a_late_episode_keeps_the_earlier_rows(tmp_path: Path) -> None:
    store, seen = tmp_path / "s.sqlite", tmp_path / "seen.txt"
    with pytest.raises(RuntimeError, match="the last episode fails"):
        vtrack_gym.evaluate(_factory(store, seen, fail=True), "paper", store=store, workers=2)
    assert seen.read_text() == "LateralTracking-v0"
    stored = ResultStore(store, read_only=True).rows()
    assert [r["env_id"] for r in stored] == ["LateralTracking-v0"]


def test_parallel_rows_match_the_serial_ones(tmp_path: Path) -> None:
    """The fingerprint taken before the episodes is the one the serial loop records."""
    make = lambda env: vtrack_gym.make_policy("lqr", env)  # noqa: E731
    serial = vtrack_gym.evaluate(make, "paper", workers=1)
    parallel = vtrack_gym.evaluate(make, "paper", workers=2)
    assert [(r.env_id, r.policy_id, r.policy_hash, r.termination) for r in serial] == \
        [(r.env_id, r.policy_id, r.policy_hash, r.termination) for r in parallel]


def test_on_ray_each_row_is_stored_as_its_episode_ends(tmp_path: Path) -> None:
    """``backend="ray"`` (one CPU: the episodes run one after the other): the last episode starts with the first
    one's row already in the store."""
    import os
    import sys

    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        pytest.skip("Ray is already initialised in this process")
    from ray import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])   # GatedLqr reaches the Ray worker by value
    store, seen = tmp_path / "s.sqlite", tmp_path / "seen.txt"
    os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    ray.init(num_cpus=1, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        rows = vtrack_gym.evaluate(_factory(store, seen, fail=False), "paper", store=store, backend="ray")
    finally:
        ray.shutdown()
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert seen.read_text() == "LateralTracking-v0"
    assert [r.env_id for r in rows] == ["LateralTracking-v0", "DLC120-v0"]
    assert len(ResultStore(store, read_only=True).rows()) == 2
