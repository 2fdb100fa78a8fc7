"""The store's one row rule (on write and on read), its journal check, symlinked stores, reads during writes,
disk-full messages, and outputs that cannot overwrite a store or its journal."""

from __future__ import annotations

import json
import math
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore, StoreError, row_sha256

ROOT = Path(__file__).resolve().parents[1]


def _row(seed: int = 0, **kw) -> ResultRow:
    base = {"suite": "paper", "env_id": "DLC120-v0", "policy_id": "mpc", "policy_hash": "abc123", "seed": seed,
            "metrics": {"max_e_y_m": 0.1, "itae": 1.0}, "termination": "completed", "wall_time_per_step_s": 1e-5}
    base.update(kw)
    return ResultRow(**base)


def _store(path: Path, n: int = 3) -> Path:
    ResultStore(path).add([_row(s) for s in range(n)])
    return path


@pytest.mark.parametrize(("change", "field"), [
    ({"env_version": 3}, "env_version"),
    ({"env_version": "3"}, "env_version"),
    ({"package_version": 1}, "package_version"),
    ({"metrics": {"max_e_y_m": 10**400}}, "max_e_y_m"),
    ({"metrics": {"success": 5}}, "success"),
    ({"success": 5}, "success"),
    ({"policy_id": "evil\x1b[2J"}, "policy_id"),
    ({"policy_id": "a\u202eb"}, "policy_id"),
    ({"options": {"x": object()}}, "options"),
])
def test_add_refuses_rows_it_could_not_read_back(tmp_path, change, field):
    path = _store(tmp_path / "s.sqlite")
    with pytest.raises(ValueError, match=field):
        ResultStore(path).add([_row(9, **change)])
    assert len(ResultStore(path, read_only=True).rows()) == 3     # the store stays readable


def _rewrite_row(path: Path, row_id: int, **values) -> None:
    """Edit one stored row and re-seal its hash and the store digest (a deliberate edit, not corruption)."""
    con = sqlite3.connect(path)
    cols = [c[1] for c in con.execute("PRAGMA table_info(results)")][:-1]
    for name, value in values.items():
        con.execute(f"UPDATE results SET {name} = ? WHERE id = ?", (value, row_id))
    digest = 0
    for record in con.execute(f"SELECT {', '.join(cols)} FROM results ORDER BY id").fetchall():
        h = row_sha256(list(record))
        digest ^= int(h, 16)
        con.execute("UPDATE results SET row_sha256 = ? WHERE id = ?", (h, record[0]))
    con.execute("UPDATE vtrack_meta SET value = ? WHERE key = 'rows_digest'", (f"{digest:064x}",))
    con.commit()
    con.close()


@pytest.mark.parametrize(("values", "field"), [
    ({"success": 5}, "success"),
    ({"metrics_json": json.dumps({"max_e_y_m": -1.0, "itae": 1.0})}, "max_e_y_m"),
    ({"metrics_json": '{"itae": ' + "9" * 4000 + "}"}, "metrics_json"),
    ({"options_json": '{"a": ' + "[" * 100_000 + "]" * 100_000 + "}"}, "options_json"),
    ({"env_version": "3"}, "env_version"),
    ({"policy_id": "x\x1b]0;pwned\x07"}, "policy_id"),
    ({"completed": 0}, "completed"),
    ({"wall_time_per_step_s": -1.0}, "wall_time_per_step_s"),
])
def test_rows_with_valid_hashes_but_absurd_values_are_refused_on_read(tmp_path, capsys, values, field):
    path = _store(tmp_path / "s.sqlite")
    _rewrite_row(path, 2, **values)
    with pytest.raises(StoreError, match=f"row 2.*{field}"):
        ResultStore(path, read_only=True).rows()
    assert main(["leaderboard", "--store", str(path)]) == 2
    assert "corrupted" in capsys.readouterr().err


_TEXT = st.text(max_size=30)
_ROWS = st.builds(
    ResultRow, suite=_TEXT, env_id=_TEXT, policy_id=_TEXT, policy_hash=_TEXT,
    seed=st.none() | st.integers(min_value=-5, max_value=2**64),
    metrics=st.dictionaries(st.sampled_from(["max_e_y_m", "itae", "success", "note", "cones_hit"]),
                            st.none() | st.booleans() | st.integers(min_value=-2**70, max_value=2**70)
                            | st.floats() | _TEXT, max_size=4),
    termination=st.sampled_from(["completed", "off_road", "", "x\n"]),
    wall_time_per_step_s=st.floats(min_value=-1, max_value=1e3) | st.just(math.inf),
    options=st.dictionaries(_TEXT, st.integers() | st.floats(allow_nan=False) | _TEXT, max_size=3),
    env_version=st.sampled_from(["v0", "v12", "3", "v", "v0\n"]),
    package_version=st.sampled_from(["", "1.0", "0.1.dev1", "\u200b"]),
    success=st.none() | st.booleans() | st.integers(min_value=-1, max_value=3))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(row=_ROWS)
def test_property_a_row_is_refused_on_write_or_read_back_whole(tmp_path, row):
    path = tmp_path / f"p{abs(hash(repr(row))) % 10**9}.sqlite"
    store = ResultStore(path)
    try:
        store.add([row])
    except ValueError:
        assert ResultStore(path, read_only=True).rows() == []
        return
    (back,) = ResultStore(path, read_only=True).rows()
    assert (back["policy_id"], back["seed"], back["env_version"]) == (row.policy_id, row.seed, row.env_version)


def test_a_rollback_journal_next_to_a_store_is_refused_for_writing_and_left_alone(tmp_path):
    path = _store(tmp_path / "s.sqlite")
    journal = tmp_path / "s.sqlite-journal"
    journal.write_bytes(b"\xd9\xd5\x05\xf9\x20\xa1\x63\xd7" + b"\0" * 504)   # a rollback journal's header
    before = (path.read_bytes(), journal.read_bytes())
    with pytest.raises(StoreError, match="rollback journal"):
        ResultStore(path)
    assert len(ResultStore(path, read_only=True).rows()) == 3
    assert (path.read_bytes(), journal.read_bytes()) == before


def test_a_symlinked_store_sees_the_rows_in_its_wal(tmp_path):
    real = _store(tmp_path / "real" / "s.sqlite")
    (tmp_path / "link").mkdir()
    link = tmp_path / "link" / "s.sqlite"
    link.symlink_to(real)
    holder = sqlite3.connect(real)                      # keeps the WAL from being checkpointed away
    holder.execute("SELECT count(*) FROM results").fetchone()
    ResultStore(real).add([_row(7)])
    assert (tmp_path / "real" / "s.sqlite-wal").exists()
    try:
        assert len(ResultStore(link, read_only=True).rows()) == 4
        ResultStore(link).add([_row(8)])                # the writer through the link uses the same WAL
        assert len(ResultStore(real, read_only=True).rows()) == 5
    finally:
        holder.close()
    assert not (tmp_path / "link" / "s.sqlite-wal").exists()


def test_out_cannot_overwrite_a_store_or_its_wal(tmp_path, capsys):
    path = _store(tmp_path / "s.sqlite")
    link = tmp_path / "link.sqlite"
    link.symlink_to(path)
    holder = sqlite3.connect(path)
    holder.execute("SELECT count(*) FROM results").fetchone()
    ResultStore(path).add([_row(7)])
    wal = tmp_path / "s.sqlite-wal"
    wal_bytes = wal.read_bytes()
    try:
        assert main(["leaderboard", "--store", str(link), "--out", str(wal)]) == 2
        assert "wal file of the database" in capsys.readouterr().err
        assert wal.read_bytes() == wal_bytes
        other = _store(tmp_path / "other.sqlite")
        assert main(["leaderboard", "--store", str(path), "--out", str(other)]) == 2
        assert main(["tune", "--controller", "smc", "--budget", "quick", "--out", str(other)]) == 2
        assert "SQLite database" in capsys.readouterr().err
        assert len(ResultStore(other, read_only=True).rows()) == 3
    finally:
        holder.close()


class _FullDiskConnection:
    """A connection whose writes fail the way SQLite reports some full-disk writes: a generic I/O error."""

    def __init__(self, con: sqlite3.Connection) -> None:
        self._con = con

    def execute(self, sql: str, *args):
        if sql.startswith("INSERT"):
            exc = sqlite3.OperationalError("disk I/O error")
            exc.sqlite_errorcode = 778          # SQLITE_IOERR_WRITE
            raise exc
        return self._con.execute(sql, *args)

    def executemany(self, sql: str, *args):
        return self.execute(sql, *args)

    def __getattr__(self, name: str):
        return getattr(self._con, name)


def test_a_disk_io_error_on_a_full_disk_says_the_disk_is_full(tmp_path, monkeypatch):
    import vtrack_gym.evaluation.storage.store_sqlite as store_module  # the SQLite layer names a full disk

    path = _store(tmp_path / "s.sqlite")
    store = ResultStore(path)
    connect = ResultStore._connect_rw
    monkeypatch.setattr(ResultStore, "_connect_rw", lambda self: _FullDiskConnection(connect(self)))
    monkeypatch.setattr(store_module, "disk_is_full", lambda folder: True)
    with pytest.raises(StoreError, match=r"disk is full.*nothing was written"):
        store.add([_row(9)])
    monkeypatch.setattr(store_module, "disk_is_full", lambda folder: False)
    with pytest.raises(StoreError, match="disk I/O error"):
        store.add([_row(9)])
    monkeypatch.undo()
    assert len(ResultStore(path, read_only=True).rows()) == 3


_WRITER = """
import sys, time
sys.path.insert(0, {root!r})
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore
store = ResultStore({path!r})
end = time.time() + {seconds}
i = 100
while time.time() < end:
    store.add([ResultRow('paper', 'DLC120-v0', 'w', 'abc', i, {{'max_e_y_m': 0.1}}, 'completed', 1e-5)])
    i += 1
"""


def test_reads_while_another_process_writes_never_report_corruption(tmp_path):
    path = _store(tmp_path / "s.sqlite")
    script = _WRITER.format(root=str(ROOT), path=str(path), seconds=6)
    writer = subprocess.Popen([sys.executable, "-c", script])
    reads = 0
    try:
        end = time.time() + 5
        while time.time() < end:
            ResultStore(path, read_only=True).rows()
            reads += 1
    finally:
        writer.wait(timeout=60)
    assert writer.returncode == 0 and reads > 5
    assert len(ResultStore(path, read_only=True).rows()) > 3
