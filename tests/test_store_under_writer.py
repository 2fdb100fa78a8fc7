"""Readers never accuse a healthy store: a 100,000-row store read while another process adds a row every 0.3 s is
never called corrupted (each read is one snapshot; a torn lock-free read is repeated under SQLite's lock), and a
store creator killed midway leaves no file that later commands refuse."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore

ROOT = Path(__file__).resolve().parents[1]

WRITER = textwrap.dedent('''
    import sys, time
    from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore

    store = ResultStore(sys.argv[1])
    i = 0
    while True:
        store.add([ResultRow("bulk", "DLC120-v0", "writer", "h", 10**6 + i, {"rms_e_y_m": 0.1}, "completed", 1e-4)])
        i += 1
        time.sleep(0.3)
''')


def _rows(n: int, start: int = 0) -> list[ResultRow]:
    return [ResultRow("bulk", "DLC120-v0", "lqr", "h", start + i, {"rms_e_y_m": 0.1, "max_e_y_m": 0.2},
                      "completed", 1e-4) for i in range(n)]


@pytest.mark.slow
def test_100k_row_store_under_a_writer_is_never_called_corrupted(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "big.sqlite"
    ResultStore(path).add(_rows(100_000))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], env=env, stderr=subprocess.PIPE)
    try:
        time.sleep(1.0)
        counts = []
        for _ in range(2):
            counts.append(len(ResultStore(path, read_only=True).rows()))   # raises StoreError if "corrupted"
        assert main(["leaderboard", "--suite", "bulk", "--store", str(path), "--format", "csv"]) == 0
        assert "corrupted" not in capsys.readouterr().err
        assert writer.poll() is None, writer.stderr.read().decode()[-2000:]
    finally:
        writer.kill()
        writer.wait()
    assert 100_000 < counts[0] <= counts[1]   # the writer's rows were there, in order of the reads
    assert len(ResultStore(path, read_only=True).rows()) >= counts[1]


CREATOR = textwrap.dedent('''
    import os, sqlite3, sys
    from vtrack_gym.evaluation.storage import store, store_sqlite

    def killed_midway(file, timeout_s, name):
        with sqlite3.connect(file) as con:   # the schema half made, then the creator is killed
            con.execute("PRAGMA journal_mode = WAL")
            con.execute(store_sqlite.META_SQL)
        os.kill(os.getpid(), 9)

    store_sqlite.create_schema = killed_midway
    store.ResultStore(sys.argv[1])
''')


def test_a_creator_killed_midway_leaves_no_store_that_later_commands_refuse(tmp_path: Path) -> None:
    path = tmp_path / "results" / "s.sqlite"
    path.parent.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", CREATOR, str(path)], env=env, capture_output=True, timeout=120)
    assert done.returncode == -9
    assert not path.exists()                 # only a temporary file, never the store's name
    store = ResultStore(path)                # the next command creates the store normally
    store.add(_rows(2))
    assert len(ResultStore(path, read_only=True).rows()) == 2


def test_a_read_refused_on_a_full_disk_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A store with a ``-wal`` file needs room for SQLite's shared-memory file to be read: on a full disk the read
    fails with an I/O error, which is said as a full disk (not "not a readable SQLite file ... Move it away")."""
    import sqlite3

    import vtrack_gym.evaluation.storage.store_sqlite as store_module

    path = tmp_path / "s.sqlite"
    ResultStore(path).add(_rows(3))
    real = ResultStore._connect_ro

    class _FullDiskConnection:
        def __init__(self, con: sqlite3.Connection) -> None:
            self.con = con

        def execute(self, sql: str, *args: object) -> object:
            if "sqlite_master" in sql:
                exc = sqlite3.OperationalError("disk I/O error")
                exc.sqlite_errorcode = sqlite3.SQLITE_IOERR
                raise exc
            return self.con.execute(sql, *args)

        def close(self) -> None:
            self.con.close()

    monkeypatch.setattr(ResultStore, "_connect_ro", lambda self, immutable: _FullDiskConnection(real(self,
                                                                                                    immutable)))
    monkeypatch.setattr(store_module, "disk_is_full", lambda folder: True)
    assert main(["leaderboard", "--suite", "bulk", "--store", str(path)]) == 2
    err = capsys.readouterr().err
    assert "the disk is full" in err and "Move it away" not in err and "corrupted" not in err
