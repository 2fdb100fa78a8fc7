"""An agent file is read once: each of ``<name>.json`` and ``<name>.npz`` is read one time, the policy and its
weights hash are built from those bytes, and an agent written again while it is being read is refused.

The swap is made by the reader itself, right after its first read (the json), through the entry points a user
types: ``vtrack_gym.make_policy(path, env)``, ``vtrack_gym.evaluate`` and ``vtrack eval --policy path``."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import pytest
from test_agent_identity import agent_files

import vtrack_gym
import vtrack_gym._io as io_module
from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultStore


def swap_after_first_read(monkeypatch: pytest.MonkeyPatch, agent: Path, swap: Callable[[], None]) -> list[str]:
    """Make the file reader call ``swap`` right after its first read of a file of ``agent``; returns the names of
    that agent's files it reads, in order (the shipped agents it also reads are not counted)."""
    reader = io_module.read_regular_file_stamped
    reads: list[str] = []

    def swapping(path: str | os.PathLike[str], *args: object, **kwargs: object) -> tuple[bytes, tuple[int, ...]]:
        result = reader(path, *args, **kwargs)
        if Path(path).parent == agent.parent:
            reads.append(Path(path).name)
            if len(reads) == 1:
                swap()
        return result

    monkeypatch.setattr(io_module, "read_regular_file_stamped", swapping)
    return reads


def replace_agent(target: Path, source: Path) -> Callable[[], None]:
    """Write the agent ``source`` over ``target`` as an export does: the npz, then the json, each renamed into
    place."""
    def swap() -> None:
        for suffix in (".npz", ".json"):
            tmp = target.with_name(f".new{suffix}")
            shutil.copyfile(source.with_suffix(suffix), tmp)
            os.replace(tmp, target.with_suffix(suffix))
    return swap


def test_an_agent_written_again_while_it_is_read_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    agent, other = agent_files(tmp_path / "a"), agent_files(tmp_path / "b", shift=0.05)
    env = gym.make("DLC120-v0")
    swap_after_first_read(monkeypatch, agent, replace_agent(agent, other))
    with pytest.raises(ValueError, match="changed while it was being read"):
        vtrack_gym.make_policy(str(agent), env)
    env.close()
    agent = agent_files(tmp_path / "c")
    swap_after_first_read(monkeypatch, agent, replace_agent(agent, other))
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", str(agent), "--env", "DLC120-v0", "--store", str(store)]) == 2
    assert "changed while it was being read" in capsys.readouterr().err
    assert not store.exists()                   # refused before any episode: no row


def test_the_row_records_the_weights_that_drove(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The npz rewritten in place between the json's read and its own: the agent built is the new one (same
    description, new weights), and the row's hash is that agent's, not the old file's."""
    old, new = agent_files(tmp_path / "a"), agent_files(tmp_path / "b", shift=0.05)
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", str(new), "--env", "DLC120-v0", "--store", str(store)]) == 0
    assert main(["eval", "--policy", str(old), "--env", "DLC120-v0", "--store", str(store)]) == 0
    new_row, old_row = ResultStore(store).rows()
    assert new_row["policy_hash"] != old_row["policy_hash"]
    target = agent_files(tmp_path / "c")
    reads = swap_after_first_read(monkeypatch, target,
                                  lambda: target.with_suffix(".npz").write_bytes(new.with_suffix(".npz").read_bytes()))
    assert main(["eval", "--policy", str(target), "--env", "DLC120-v0", "--store", str(store)]) == 0
    assert reads == ["mine.json", "mine.npz"]   # each file read once
    row = ResultStore(store).rows()[-1]
    assert row["policy_hash"] == new_row["policy_hash"]
    assert row["metrics"]["max_e_y_m"] == new_row["metrics"]["max_e_y_m"]   # it drove the new weights


def test_the_normal_path_reads_each_file_once_and_records_its_content(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    agent = agent_files(tmp_path / "a")
    reads = swap_after_first_read(monkeypatch, agent, lambda: None)
    env = gym.make("DLC120-v0")
    policy = vtrack_gym.make_policy(str(agent), env)
    assert reads == ["mine.json", "mine.npz"]
    rows = vtrack_gym.evaluate(policy, env, seeds=[0])
    env.close()
    assert reads == ["mine.json", "mine.npz"]   # scoring and fingerprinting read nothing again
    copy = tmp_path / "copy"
    shutil.copytree(tmp_path / "a", copy)
    env = gym.make("DLC120-v0")
    again = vtrack_gym.evaluate(vtrack_gym.make_policy(str(copy / "mine.json"), env), env, seeds=[0])
    env.close()
    assert rows[0].policy_hash == again[0].policy_hash and rows[0].termination == "completed"


@pytest.mark.parametrize("backend", ["local", "ray"])
def test_workers_drive_the_loaded_agent_without_opening_its_files(tmp_path: Path, backend: str) -> None:
    """The files are deleted once the policy is loaded: forked workers and Ray workers still score it (they get
    the loaded policy), with the hash of a run in this process."""
    agent = agent_files(tmp_path / "a")
    env = gym.make("DLC120-v0")
    policy = vtrack_gym.make_policy(str(agent), env)
    env.close()
    serial = vtrack_gym.evaluate(policy, "paper")
    agent.unlink()
    agent.with_suffix(".npz").unlink()
    if backend == "ray":
        ray = pytest.importorskip("ray")
        if ray.is_initialized():
            pytest.skip("Ray is already initialised in this process")
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
        ray.init(num_cpus=1, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    try:
        rows = vtrack_gym.evaluate(policy, "paper", workers=2, backend=backend)
    finally:
        if backend == "ray":
            ray.shutdown()
    assert [(r.env_id, r.policy_id, r.policy_hash, r.termination) for r in rows] == \
        [(r.env_id, r.policy_id, r.policy_hash, r.termination) for r in serial]
