"""An agent file's identity is its content (its weights hash), its name the file's stem: one agent typed as a
relative path, an absolute path, through a symlink or as a copy in another folder is one row; two different
agents with one stem are two rows, named apart on the board."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines.numpy_policy import save_agent
from vtrack_gym.baselines.shipped import SHIPPED_DIR
from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultStore


def agent_files(folder: Path, shift: float = 0.0) -> Path:
    """The shipped ``ppo`` agent as ``folder/mine.json`` (+ ``.npz``), its first bias shifted by ``shift``."""
    spec = json.loads((SHIPPED_DIR / "ppo.json").read_text())
    with np.load(SHIPPED_DIR / "ppo.npz") as data:
        arrays = {k: data[k] for k in data.files}
    arrays["b0"] = arrays["b0"] + np.float32(shift)
    folder.mkdir(parents=True, exist_ok=True)
    json_path, _ = save_agent(folder / "mine", spec, arrays)
    return json_path


def test_one_agent_by_four_spellings_is_one_row(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    agent = agent_files(tmp_path / "a")
    shutil.copytree(tmp_path / "a", tmp_path / "copy")
    os.symlink(tmp_path / "a", tmp_path / "link")
    monkeypatch.chdir(tmp_path)
    store = tmp_path / "s.sqlite"
    for spec in ("a/mine.json", str(agent), "link/mine.json", str(tmp_path / "copy" / "mine.json")):
        assert main(["eval", "--policy", spec, "--env", "DLC120-v0", "--seeds", "0", "--store", str(store)]) == 0
    rows = ResultStore(store).rows()
    assert len(rows) == 4 and {(r["policy_id"], r["policy_hash"]) for r in rows} == {("mine", rows[0]["policy_hash"])}
    assert len(vtrack_gym.leaderboard(store, "custom")) == 1


def test_benchmark_by_relative_and_absolute_path_is_one_row(tmp_path: Path, monkeypatch) -> None:
    agent = agent_files(tmp_path / "a")
    monkeypatch.chdir(tmp_path)
    store = tmp_path / "s.sqlite"
    for spec in ("a/mine.json", str(agent)):
        assert main(["benchmark", "--suite", "paper", "--policies", spec, "--no-figures", "--store", str(store)]) == 0
    board = vtrack_gym.leaderboard(store, "paper")
    assert {r["policy_id"] for r in board} == {"mine"}
    assert len(board) == 2                      # one row per env of the suite


def test_two_agents_with_one_stem_are_two_rows_named_apart(tmp_path: Path, capsys) -> None:
    store = tmp_path / "s.sqlite"
    first, second = agent_files(tmp_path / "a"), agent_files(tmp_path / "b", shift=0.05)
    for spec in (first, second):
        assert main(["eval", "--policy", str(spec), "--env", "DLC120-v0", "--seeds", "0", "--store", str(store)]) == 0
    rows = ResultStore(store).rows()
    hashes = sorted({r["policy_hash"] for r in rows})
    assert len(hashes) == 2 and {r["policy_id"] for r in rows} == {"mine"}
    capsys.readouterr()
    assert main(["leaderboard", "--suite", "custom", "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert all(f"mine@{h}" in out for h in hashes)


def test_two_agents_with_one_stem_in_one_run_are_two_rows(tmp_path: Path, capsys) -> None:
    store = tmp_path / "s.sqlite"
    first, second = agent_files(tmp_path / "a"), agent_files(tmp_path / "b", shift=0.05)
    assert main(["benchmark", "--suite", "paper", "--policies", f"{first},{second}", "--no-figures",
                 "--format", "json", "--store", str(store)]) == 0
    printed = json.loads(capsys.readouterr().out)
    rows = ResultStore(store).rows()
    hashes = {r["policy_hash"] for r in rows}
    assert len(rows) == 4 and len(hashes) == 2 and {r["policy_id"] for r in rows} == {"mine"}   # rows: the stem
    assert {(e["policy_id"], e["policy_hash"]) for e in printed} == {("mine", h) for h in hashes}
    assert main(["leaderboard", "--suite", "paper", "--store", str(store)]) == 0
    shown = capsys.readouterr().out
    assert all(f"| mine@{h} |" in shown for h in hashes)   # named apart by content
    board = vtrack_gym.leaderboard(store, "paper")
    assert len(board) == 4 and {(e["policy_id"], e["policy_hash"]) for e in board} == {("mine", h) for h in hashes}
    # each agent scored alone afterwards joins its own rows (identity by content, not by the run it was in)
    assert main(["benchmark", "--suite", "paper", "--policies", str(second), "--no-figures", "--store",
                 str(store)]) == 0
    assert len(vtrack_gym.leaderboard(store, "paper")) == 4


def test_one_agent_typed_two_ways_in_one_run_is_one_row(tmp_path: Path, monkeypatch, caplog) -> None:
    agent = agent_files(tmp_path / "a")
    os.symlink(tmp_path / "a", tmp_path / "link")
    monkeypatch.chdir(tmp_path)
    store = tmp_path / "s.sqlite"
    with caplog.at_level("WARNING"):
        assert main(["benchmark", "--suite", "paper", "--policies", f"a/mine.json,{agent},link/mine.json",
                     "--no-figures", "--store", str(store)]) == 0
    assert "the same policy 'mine': scored once" in caplog.text
    rows = ResultStore(store).rows()
    assert len(rows) == 2 and {r["policy_id"] for r in rows} == {"mine"}    # one episode per env, not three
    assert len(vtrack_gym.leaderboard(store, "paper")) == 2
