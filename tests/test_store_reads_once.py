"""A store is read and checked once per command: ``vtrack leaderboard`` checks each row once (not once per
question it asks the store), a second read of an unchanged store reuses the first one's checked rows and a store
that changed is read again; rows stored under an alias and under the id are one episode on the board."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage import store as store_module
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore


def _rows(n: int, suite: str = "bulk", start: int = 0, **kwargs) -> list[ResultRow]:
    return [ResultRow(suite, "DLC120-v0", "lqr", "h", start + i, {"max_e_y_m": 0.2, "rms_e_y_m": 0.1}, "completed",
                      1e-4, **kwargs) for i in range(n)]


def test_leaderboard_checks_each_row_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "s.sqlite"
    ResultStore(path).add(_rows(40) + _rows(10, suite="custom"))
    checked = []
    verify = store_module.verified_rows

    def counting(path, meta, raw):
        checked.extend(values[0] for values in raw)
        return verify(path, meta, raw)

    monkeypatch.setattr(store_module, "verified_rows", counting)
    assert main(["leaderboard", "--store", str(path), "--suite", "bulk", "--format", "json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert [e["episodes"] for e in board] == [40]
    assert sorted(checked) == list(range(1, 51))   # every row checked, each once, for the whole command


def test_a_changed_store_is_read_again(tmp_path: Path) -> None:
    path = tmp_path / "s.sqlite"
    ResultStore(path).add(_rows(3))
    reader = ResultStore(path, read_only=True)
    assert len(reader.rows()) == 3
    first = reader.rows()
    first[0]["seed"] = 99                   # a caller's edit of its rows does not reach the next read
    assert sorted(r["seed"] for r in reader.rows()) == [0, 1, 2]
    ResultStore(path).add(_rows(2, start=3))
    assert sorted(r["seed"] for r in reader.rows()) == [0, 1, 2, 3, 4]
    assert reader.suites() == {"bulk": 5}


def test_a_store_tampered_between_reads_is_refused_by_a_new_reader(tmp_path: Path) -> None:
    import sqlite3

    path = tmp_path / "s.sqlite"
    ResultStore(path).add(_rows(3))
    assert len(ResultStore(path, read_only=True).rows()) == 3
    with sqlite3.connect(path) as con:   # a payload byte changed, its checksum not
        con.execute("UPDATE results SET metrics_json = replace(metrics_json, '0.2', '0.3') WHERE id = 2")
    with pytest.raises(store_module.StoreError, match="does not match its checksum"):
        ResultStore(path, read_only=True).rows()


def test_an_alias_and_its_id_are_one_episode_on_the_board(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Rows of 0.2.0 stored one seed under ``vtrack/DLC120-v0`` with ``entry_speed_kmh=45`` and again under
    ``DLC120-v0`` with ``45.0``: one set-up, one episode, the later row counts."""
    path = tmp_path / "s.sqlite"
    store = ResultStore(path)
    for env_id, speed, error in (("vtrack/DLC120-v0", 45, 0.1), ("DLC120-v0", 45.0, 0.3)):
        store.add([ResultRow("custom", env_id, "lqr", "h1", 0, {"max_e_y_m": error}, "completed", 1e-4,
                             package_version="0.2.0", options={"entry_speed_kmh": speed})])
    assert main(["leaderboard", "--store", str(path), "--suite", "custom", "--format", "json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert [(e["env_id"], e["episodes"], e["max_e_y_m"]) for e in board] == [("DLC120-v0",
                                                                              1, 0.3)]
    rows = vtrack_gym.leaderboard(path, "custom")
    assert [(r["episodes"], r["max_e_y_m"]) for r in rows] == [(1, 0.3)]
    assert len(ResultStore(path, read_only=True).board_rows("custom")) == 1
    assert len(ResultStore(path, read_only=True).board_rows("custom", latest_only=False)) == 2


def test_each_seed_under_both_spellings_is_one_episode(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Seeds 0-2, each stored under ``vtrack/DLC120-v0`` and again under ``DLC120-v0`` (and seed 3 under the alias
    only): four episodes on the board, one per seed, each its later row; the leaderboard, ``leaderboard()`` and
    ``board_rows`` agree."""
    path = tmp_path / "s.sqlite"
    store = ResultStore(path)
    for seed in range(3):
        for env_id, error in (("vtrack/DLC120-v0", 0.1), ("DLC120-v0", 0.3)):
            store.add([ResultRow("custom", env_id, "lqr", "h1", seed, {"max_e_y_m": error}, "completed", 1e-4,
                                 package_version="0.3.0")])
    store.add([ResultRow("custom", "vtrack/DLC120-v0", "lqr", "h1", 3, {"max_e_y_m": 0.7}, "completed", 1e-4,
                         package_version="0.3.0")])
    assert main(["leaderboard", "--store", str(path), "--suite", "custom", "--format", "json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert [(e["env_id"], e["episodes"]) for e in board] == [("DLC120-v0", 4)]
    assert board[0]["max_e_y_m"] == pytest.approx((0.3 * 3 + 0.7) / 4)
    kept = ResultStore(path, read_only=True).board_rows("custom")
    assert sorted((r["seed"], r["metrics"]["max_e_y_m"]) for r in kept) == [(0, 0.3), (1, 0.3), (2, 0.3), (3, 0.7)]
    assert [r["episodes"] for r in vtrack_gym.leaderboard(path, "custom")] == [4]
