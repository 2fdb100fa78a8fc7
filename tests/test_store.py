"""Leaderboard store: concurrent writers, a writer killed mid-write, foreign/corrupted files, exports."""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore, StoreError, to_csv, to_json, to_markdown


def make_row(policy: str, seed: int, e_y: float = 0.1) -> ResultRow:
    return ResultRow(suite="paper", env_id="DLC120-v0", policy_id=policy, policy_hash="abc", seed=seed,
                     metrics={"max_e_y_m": e_y, "itae": float("nan")}, termination="completed",
                     wall_time_per_step_s=1e-5)


def _writer(path: str, worker: int, batches: int) -> None:
    store = ResultStore(path)
    for b in range(batches):
        store.add([make_row(f"p{worker}", b * 5 + k) for k in range(5)])


def test_ten_concurrent_writers_lose_nothing(tmp_path: Path) -> None:
    path = str(tmp_path / "board.sqlite")
    ResultStore(path)
    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=_writer, args=(path, w, 10)) for w in range(10)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
        assert p.exitcode == 0
    rows = ResultStore(path).rows()
    assert len(rows) == 10 * 10 * 5
    assert len({(r["policy_id"], r["seed"]) for r in rows}) == 500


KILLED_WRITER = """
import sys, time
from vtrack_gym.evaluation.storage.store import ResultStore, ResultRow
store = ResultStore(sys.argv[1])
rows = [ResultRow('paper', 'DLC120-v0', 'victim', 'h', i, {'x': 1.0}, 'completed', 1e-5) for i in range(200000)]
print('writing', flush=True)
store.add(rows)
print('done', flush=True)
"""


def test_writer_killed_mid_write_leaves_store_consistent(tmp_path: Path) -> None:
    path = tmp_path / "board.sqlite"
    store = ResultStore(path)
    store.add([make_row("survivor", s) for s in range(3)])
    proc = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "writing"
    time.sleep(0.3)
    os.kill(proc.pid, signal.SIGKILL)
    rest, _ = proc.communicate()
    assert "done" not in rest, "the writer finished before it was killed; make the batch larger"
    rows = ResultStore(path).rows()
    victims = [r for r in rows if r["policy_id"] == "victim"]
    assert len(victims) == 0  # killed inside its transaction: none of its rows
    assert sum(r["policy_id"] == "survivor" for r in rows) == 3
    with sqlite3.connect(path) as con:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"


def test_foreign_and_corrupted_files_are_refused_and_untouched(tmp_path: Path) -> None:
    junk = tmp_path / "junk.sqlite"
    junk.write_bytes(b"this is not a database" * 100)
    before = junk.read_bytes()
    with pytest.raises(StoreError, match="not a readable SQLite file"):
        ResultStore(junk)
    assert junk.read_bytes() == before
    other = tmp_path / "other.sqlite"
    with sqlite3.connect(other) as con:
        con.execute("CREATE TABLE users (name TEXT)")
    with pytest.raises(StoreError, match="not a vtrack_gym store"):
        ResultStore(other)
    newer = tmp_path / "newer.sqlite"
    ResultStore(newer)
    with sqlite3.connect(newer) as con:
        con.execute("UPDATE vtrack_meta SET value='99' WHERE key='schema_version'")
    with pytest.raises(StoreError, match="newer than this vtrack_gym"):
        ResultStore(newer)


def test_leaderboard_and_exports(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "b.sqlite")
    store.add([make_row("mpc", 0, 0.1), make_row("mpc", 1, 0.3), make_row("smc", 0, 0.2)])
    board = store.leaderboard("paper", ["max_e_y_m", "itae"])
    assert [e["policy_id"] for e in board] == ["mpc", "smc"]
    assert board[0]["max_e_y_m"] == pytest.approx(0.2) and board[0]["episodes"] == 2
    md = to_markdown(board)
    assert md.splitlines()[0].startswith("| env_id | policy_id") and "mpc" in md
    assert to_csv(board).splitlines()[0].startswith("env_id,policy_id")
    data = json.loads(to_json(board))
    assert data[0]["itae"] is None  # NaN exported as null
