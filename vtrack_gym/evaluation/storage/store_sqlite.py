"""The SQLite layer of the leaderboard store: its schema, its errors, write transactions and atomic creation.

``evaluation.storage.store`` builds the store on these; nothing here knows a result row. A new store is created in a
private temporary file next to its place (schema written, WAL mode set, closed) and linked to its name complete, so a
creator killed midway leaves no half-made file under the store's name (``create_store_file``).
"""

from __future__ import annotations

import contextlib
import errno
import os
import sqlite3
import tempfile
from collections.abc import Iterator
from contextlib import closing
from pathlib import Path

from vtrack_gym._io import disk_is_full, new_file_mode

SCHEMA_VERSION = 3  # 3: the per-episode success verdict (column ``success``)

META_SQL = "CREATE TABLE IF NOT EXISTS vtrack_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)"
RESULTS_SQL = """CREATE TABLE IF NOT EXISTS results (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    created_utc TEXT NOT NULL,
    package_version TEXT NOT NULL,
    suite TEXT NOT NULL,
    env_id TEXT NOT NULL,
    env_version TEXT NOT NULL,
    policy_id TEXT NOT NULL,
    policy_preset TEXT NOT NULL DEFAULT '',
    policy_hash TEXT NOT NULL,
    seed INTEGER,
    options_json TEXT NOT NULL,
    termination TEXT NOT NULL,
    completed INTEGER NOT NULL,
    success INTEGER NOT NULL DEFAULT 0,
    wall_time_per_step_s REAL NOT NULL,
    metrics_json TEXT NOT NULL,
    row_sha256 TEXT NOT NULL DEFAULT ''
)"""


class StoreError(RuntimeError):
    """The store file cannot be used (not a vtrack store, corrupted, a newer schema, disk full, read-only)."""


class Busy(StoreError):
    """A read that did not get SQLite's lock within the busy timeout (the store is healthy, a writer holds it)."""


def is_busy(exc: sqlite3.Error) -> bool:
    """SQLITE_BUSY or SQLITE_LOCKED: another connection holds the lock."""
    code = getattr(exc, "sqlite_errorcode", None)
    if code is not None:
        return code & 0xFF in (sqlite3.SQLITE_BUSY, sqlite3.SQLITE_LOCKED)
    return "locked" in str(exc) or "busy" in str(exc)


def storage_problem(exc: sqlite3.Error | OSError, folder: Path | None = None) -> str:
    """A sentence naming disk-full and read-only-file-system failures, else the error text. SQLite reports some
    failed writes on a full disk as a generic I/O error: with ``folder`` (where the store lives), such an error on a
    file system without free blocks is named a full disk."""
    code = getattr(exc, "sqlite_errorcode", None)
    number = getattr(exc, "errno", None)
    io_error = code is not None and code & 0xFF == sqlite3.SQLITE_IOERR
    full_after_io_error = io_error and folder is not None and disk_is_full(folder)
    if (code is not None and code & 0xFF == sqlite3.SQLITE_FULL) or number == 28 or full_after_io_error:
        return f"the disk is full ({exc})"
    if (code is not None and code & 0xFF == sqlite3.SQLITE_READONLY) or number == 30:
        return f"the store or its folder is read-only (read-only file system or no write permission: {exc})"
    if number == 13:
        return f"permission denied ({exc})"
    return str(exc)


@contextlib.contextmanager
def write_transaction(con: sqlite3.Connection) -> Iterator[None]:
    """``BEGIN IMMEDIATE`` ... ``COMMIT``, rolled back on any exception (unless SQLite already did, as on
    SQLITE_FULL)."""
    con.execute("BEGIN IMMEDIATE")
    try:
        yield
        con.execute("COMMIT")
    except BaseException:
        if con.in_transaction:
            con.execute("ROLLBACK")
        raise


def create_schema(file: Path, timeout_s: float, name: str | os.PathLike[str]) -> None:
    """WAL mode and the empty tables in ``file`` (missing or empty), in one transaction; errors name the store
    ``name``."""
    with closing(sqlite3.connect(file, timeout=timeout_s, isolation_level=None)) as con:
        try:
            con.execute("PRAGMA trusted_schema = OFF")
            con.execute(f"PRAGMA busy_timeout = {int(timeout_s * 1000)}")
            con.execute("PRAGMA journal_mode = WAL")
            with write_transaction(con):
                if not con.execute("SELECT count(*) FROM sqlite_master").fetchone()[0]:
                    con.execute(META_SQL)
                    con.execute(RESULTS_SQL)
                    con.executemany("INSERT INTO vtrack_meta VALUES (?, ?)",
                                    [("schema_version", str(SCHEMA_VERSION)), ("row_count", "0"),
                                     ("rows_digest", "0" * 64)])
        except sqlite3.Error as exc:
            raise StoreError(f"cannot create the store {os.fspath(name)}: "
                             f"{storage_problem(exc, Path(file).parent)}") from exc


def link_new(tmp: Path, target: Path) -> None:
    """Give ``tmp`` the name ``target`` unless ``target`` exists (another creator won: keep theirs). A hard link
    never replaces; on a file system without hard links, a rename when ``target`` is still missing."""
    try:
        os.link(tmp, target)
    except FileExistsError:
        return
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV) or os.path.lexists(target):
            raise
        os.rename(tmp, target)


def create_store_file(file: Path, timeout_s: float, name: str | os.PathLike[str]) -> None:
    """Build a store in a temporary file next to ``file``, then link it to ``file`` (never replacing a store another
    process created meanwhile); the temporary file and its journals are removed. Errors name ``name``."""
    try:
        fd, tmp_name = tempfile.mkstemp(dir=file.parent, prefix=f".{file.name}.", suffix=".creating")
        os.close(fd)
    except OSError as exc:
        raise StoreError(f"cannot create the store {os.fspath(name)}: {storage_problem(exc, file.parent)}") from exc
    tmp = Path(tmp_name)
    try:
        create_schema(tmp, timeout_s, name)
        os.chmod(tmp, new_file_mode(file))
        link_new(tmp, file)
    except OSError as exc:
        raise StoreError(f"cannot create the store {os.fspath(name)}: {storage_problem(exc, file.parent)}") from exc
    finally:
        for leftover in (tmp, *(tmp.with_name(tmp.name + suffix) for suffix in ("-wal", "-shm", "-journal"))):
            with contextlib.suppress(OSError):
                leftover.unlink()
