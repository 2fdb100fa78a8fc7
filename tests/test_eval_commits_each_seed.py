"""``vtrack eval`` and ``evaluate`` commit each episode's row as the episode ends (one path: ``RowCommit``): a policy
that fails in a later seed leaves the seeds that finished in the store, with their track provenance, and the command
says so in one line."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.evaluation.storage.store import ResultStore

ROOT = Path(__file__).resolve().parents[1]

MODULE = textwrap.dedent('''
    import numpy as np
    from vtrack_gym.envs import OBS


    class FailsInThirdEpisode:
        """Proportional steering on e_y and e_phi; the third instance built (the third seed) raises."""

        built = 0

        def __init__(self):
            type(self).built += 1
            self.number = type(self).built

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            if self.number >= 3:
                raise RuntimeError("the policy failed in its third episode")
            obs = np.asarray(observation, dtype=np.float64)
            a = -(0.08 * obs[..., OBS.E_Y] + 0.9 * obs[..., OBS.E_PHI])
            return np.clip(a, -1.0, 1.0).astype(np.float32)[..., None], state
''')


def _road(file: Path) -> Path:
    """A 100 m road with a gentle left arc (short episodes)."""
    s = np.arange(0.0, 100.0, 2.0)
    kappa = np.where((s > 30.0) & (s < 60.0), 1.0 / 60.0, 0.0)
    psi = np.concatenate([[0.0], np.cumsum(kappa[1:] * np.diff(s))])
    x = np.concatenate([[0.0], np.cumsum(np.cos(psi[:-1]) * np.diff(s))])
    y = np.concatenate([[0.0], np.cumsum(np.sin(psi[:-1]) * np.diff(s))])
    file.write_text("x_m,y_m\n" + "\n".join(f"{a:.4f},{b:.4f}" for a, b in zip(x, y, strict=True)) + "\n")
    return file


@pytest.fixture()
def user_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest) -> str:
    """The policy module in the working directory (a fresh name per test: imports and class counters are cached)."""
    name = f"fails_third_{hashlib.sha256(request.node.nodeid.encode()).hexdigest()[:12]}"
    (tmp_path / f"{name}.py").write_text(MODULE, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    return name


def test_eval_keeps_the_seeds_that_finished_before_a_failure(tmp_path: Path, user_module: str) -> None:
    """``vtrack eval --seeds 0-3`` in its own process, the policy raising in the third seed: the first two rows are
    in the store (with the track's provenance), stderr says in one line which episode failed and what is stored,
    the exit status is 2 and no traceback is printed; ``-v`` adds the traceback."""
    store = tmp_path / "s.sqlite"
    road = _road(tmp_path / "road.csv")
    argv = ["eval", "--policy", f"{user_module}:FailsInThirdEpisode", "--trust-code", "--track", str(road),
            "--seeds", "0-3", "--store", str(store)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(tmp_path)])}
    done = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", *argv], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 2, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and done.stdout == ""   # nothing printed before the failure
    errors = [line for line in done.stderr.splitlines() if line.startswith("vtrack eval: error:")]
    assert len(errors) == 1, done.stderr[-3000:]
    assert "the episode of FailsInThirdEpisode on" in errors[0]
    assert "seed 2 failed: RuntimeError: the policy failed in its third episode" in errors[0]
    assert "2 of 4 episodes are stored in" in errors[0] and "(seeds 0, 1 of" in errors[0]
    rows = ResultStore(store, read_only=True).rows()
    assert sorted(r["seed"] for r in rows) == [0, 1]
    sha = hashlib.sha256(road.read_bytes()).hexdigest()
    assert all(r["options"]["track_sha256"] == sha and r["options"]["track_file"] == "road.csv" for r in rows)
    verbose = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "-v", *argv[:-1], str(tmp_path / "v.sqlite")],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert verbose.returncode == 2 and "Traceback" in verbose.stderr and "in predict" in verbose.stderr


def test_evaluate_applies_finish_before_each_row_is_stored(tmp_path: Path, user_module: str) -> None:
    import importlib

    policy = importlib.import_module(user_module).FailsInThirdEpisode
    store = tmp_path / "s.sqlite"
    tagged = []

    def finish(row):
        tagged.append(row.seed)
        return dataclasses.replace(row, options={**row.options, "note": f"seed {row.seed}"})

    with pytest.raises(RuntimeError, match="third episode"):
        vtrack_gym.evaluate(lambda env: policy(), "DLC120-v0", seeds=[0, 1, 2], store=store, finish=finish)
    rows = ResultStore(store, read_only=True).rows()
    assert tagged == [0, 1]
    assert sorted((r["seed"], r["options"]["note"]) for r in rows) == [(0, "seed 0"), (1, "seed 1")]


def test_a_store_that_fails_mid_run_stops_the_storing_not_the_run(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """The store refuses the second row (a full disk, simulated): the third episode still runs, and ``evaluate``
    raises ``RowsNotStored`` at the end with every row, the first one stored."""
    from vtrack_gym.evaluation.storage.commit import RowsNotStored
    from vtrack_gym.evaluation.storage.store import StoreError

    store = ResultStore(tmp_path / "s.sqlite")
    add, calls = ResultStore.add, []

    def full_after_one(self: ResultStore, rows: object) -> int:
        calls.append(1)
        if len(calls) > 1:
            raise StoreError(f"could not write rows to {self.path}: the disk is full (simulated)")
        return add(self, rows)

    monkeypatch.setattr(ResultStore, "add", full_after_one)
    with pytest.raises(RowsNotStored, match="the disk is full") as raised:
        vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy("lqr", env), "DLC120-v0", seeds=[0, 1, 2], store=store)
    assert [r.seed for r in raised.value.rows] == [0, 1, 2] and [r.seed for r in raised.value.stored] == [0]
    assert len(calls) == 2   # no write tried after the store failed
    assert [r["seed"] for r in ResultStore(store.path, read_only=True).rows()] == [0]
