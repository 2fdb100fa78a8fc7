"""The leaderboard store: one SQLite file, one row per evaluated episode with full provenance.

Safe under several concurrent writers (WAL journal, busy timeout, one transaction per batch of rows) and
under a crash mid-write (SQLite's atomic commit: a killed writer leaves either all of its rows or none).

A store file may come from someone else, so it is data, never code:

* opening verifies the schema objects exactly against the expected set (a trigger, view, index or table that
  this version does not create is refused), runs ``PRAGMA integrity_check`` and honours every result row;
* every row carries a SHA-256 of its content (``row_sha256``, not a signature: it detects corruption, not a
  deliberate edit) and the meta table the row count and the XOR of all row hashes, so a flipped payload byte
  or a lost row is a ``StoreError`` instead of a different table;
* a read-only store (``read_only=True``, what ``vtrack leaderboard`` uses) is opened through a ``mode=ro``
  URI, with ``immutable=1`` when no ``-wal`` file exists (plain ``mode=ro`` would create ``-wal``/``-shm``
  files next to a WAL database): it never creates, modifies or deletes a file, journals included;
* a writer verifies the file with the same read-only connection first, so a foreign file is never initialised or
  overwritten, and refuses a store with a rollback journal next to it (a WAL store never has one; rolling it back
  would write whatever it holds into the store);
* every row read is checked by the same rule as every row written (``vtrack_gym.evaluation.scoring.row_validation``);
* a store reached through a symlink is used with the journal files next to the file the link reaches;
* every read is one snapshot (one read transaction with a busy timeout); a lock-free ``immutable`` read that fails
  while a writer changed the file is repeated under SQLite's shared lock, and only such a locked snapshot (or a
  read of a file nobody changed) may call the store corrupted, so a healthy store being written is never accused
  (a 100,000-row store read while another process adds a row every 0.3 s: ``tests/test_store_under_writer.py``);
* a new store is created in a private temporary file next to it and linked into place complete: a creator killed
  midway leaves no half-made store;
* a full disk (also when SQLite reports it as an I/O error) or a read-only file system is a ``StoreError`` that
  says so.

Each row stores the episode's success verdict (``success`` 0/1, schema version 3); a row written without one
(``DEFAULT 0``) never counts as a success.
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import json
import math
import os
import re
import sqlite3
from collections.abc import Callable, Iterable, Sequence
from contextlib import closing
from operator import itemgetter
from pathlib import Path
from typing import Any, TypeVar

from vtrack_gym.evaluation.leaderboard.board import build_board
from vtrack_gym.evaluation.leaderboard.report_formats import to_csv, to_json, to_markdown  # noqa: F401  (re-exported)
from vtrack_gym.evaluation.scoring.row_validation import (  # noqa: F401  (MAX_SEED re-exported)
    MAX_SEED,
    checked_metrics,
    checked_row_values,
    checked_seed,
    checked_success,
    clean_scalar,
)
from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.storage.store_sqlite import (
    META_SQL,
    RESULTS_SQL,
    SCHEMA_VERSION,
    Busy,
    StoreError,
    create_schema,
    create_store_file,
    is_busy,
    storage_problem,
    write_transaction,
)

DEFAULT_STORE_PATH = Path("vtrack_results") / "leaderboard.sqlite"
T = TypeVar("T")

_COLUMNS = ("id", "created_utc", "package_version", "suite", "env_id", "env_version", "policy_id", "policy_preset",
            "policy_hash", "seed", "options_json", "termination", "completed", "success", "wall_time_per_step_s",
            "metrics_json")
READ_ATTEMPTS = 6
"""Reads of a store that changes underneath before its failure is reported (about 1.3 s of pauses in all)."""
_PLAIN_COLUMNS = tuple(c for c in _COLUMNS if not c.endswith("_json"))
"""The columns a row read keeps as they are (the JSON columns become ``metrics`` and ``options``)."""
_PLAIN_INDEX = tuple(_COLUMNS.index(c) for c in _PLAIN_COLUMNS)
_META_KEYS = frozenset({"schema_version", "row_count", "rows_digest"})
_SQL_SCALARS = frozenset({type(None), str, int, float})
"""The Python types of the values SQLite returns for NULL, TEXT, INTEGER and REAL (a BLOB is none of them)."""




def _now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def row_sha256(values: Sequence[Any]) -> str:
    """SHA-256 of one row's stored values in ``_COLUMNS`` order (the id included)."""
    return hashlib.sha256(json.dumps(list(values), ensure_ascii=True).encode("ascii")).hexdigest()


_ROW_ENCODER = json.JSONEncoder(ensure_ascii=True)
"""``row_sha256``'s encoding (``json.dumps``'s defaults), kept for the read of many rows."""


@functools.lru_cache(maxsize=1)
def expected_schema() -> frozenset[tuple[str, str, str, str | None]]:
    """(type, name, tbl_name, sql) of every object in ``sqlite_master`` of a current, valid store."""
    with closing(sqlite3.connect(":memory:")) as con:
        con.execute(META_SQL)
        con.execute(RESULTS_SQL)
        return frozenset(con.execute("SELECT type, name, tbl_name, sql FROM sqlite_master"))


def _stored_values(r: ResultRow, package_version: str) -> list[Any]:
    """``r``'s column values in ``_COLUMNS`` order (without the id), checked by the row rule
    (``vtrack_gym.evaluation.scoring.row_validation``); ``ValueError`` naming the field otherwise."""
    wall = clean_scalar(r.wall_time_per_step_s)
    if isinstance(wall, (bool, str)) or not (isinstance(wall, (int, float)) and math.isfinite(wall) and wall >= 0.0):
        raise ValueError(f"wall_time_per_step_s must be a finite number >= 0 s (got {r.wall_time_per_step_s!r})")
    metrics = checked_metrics(r.metrics)
    seed = checked_seed(r.seed)
    success = checked_success(r.success)
    verdict = success if success is not None else r.verdict()
    if not isinstance(r.options, dict):
        raise ValueError(f"options must be a dict (got {type(r.options).__name__})")
    try:
        options_json = json.dumps(r.options, sort_keys=True)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"options must be JSON data (numbers, strings, lists, dicts): {exc}") from None
    values = [r.created_utc or _now(), r.package_version or package_version, r.suite, r.env_id, r.env_version,
              r.policy_id, r.policy_preset, r.policy_hash, seed, options_json, r.termination,
              int(r.termination == "completed"), int(verdict), float(wall), json.dumps(metrics, sort_keys=True)]
    checked_row_values(dict(zip(_COLUMNS[1:], values, strict=True)))
    return values


class ResultStore:
    """Open (or, unless ``read_only``, create) the store at ``path`` (default ``vtrack_results/leaderboard.sqlite``).

    ``StoreError`` if the file is not a valid vtrack store of this schema version (see the module docstring).
    """

    def __init__(self, path: str | Path = DEFAULT_STORE_PATH, timeout_s: float = 60.0, read_only: bool = False) -> None:
        self.path = Path(path)
        self._file = Path(os.path.realpath(self.path))   # the store file itself; its journals live next to it
        self.timeout_s = timeout_s
        self.read_only = read_only
        self._last_read: tuple[tuple[str | None, str | None], list[dict[str, Any]]] | None = None
        if self.path.is_dir():
            raise StoreError(f"{self.path} is a directory, not a store file; pass a file path such as "
                             f"{self.path / 'leaderboard.sqlite'}")
        exists = self.path.exists()
        if exists and not self.path.is_file():  # a FIFO would block SQLite, a device would be written into
            raise StoreError(f"{self.path} is not a regular file (a FIFO, device or socket), not a store; it was "
                             "left untouched")
        if read_only and not exists:
            raise StoreError(f"no store at {self.path}")
        if exists and self.path.stat().st_size > 0:
            self._read(self._verify)
            if not read_only:
                self._check_no_rollback_journal()
                self._check_writable()
            return
        if read_only:
            raise StoreError(f"{self.path} is an empty file, not a vtrack store; it was left untouched")
        if exists:
            self._check_writable()
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StoreError(f"cannot create the store folder {self.path.parent}: {storage_problem(exc)}") from exc
        self._initialise()

    def _companion(self, suffix: str) -> Path:
        """The store's ``-wal``, ``-shm`` or ``-journal`` file (next to the file a symlinked path reaches)."""
        return self._file.with_name(self._file.name + suffix)

    def _check_no_rollback_journal(self) -> None:
        """``StoreError`` if a rollback journal lies next to the store: a store in WAL mode never has one, and the
        next writer would roll it back into the file (whatever it holds); it is left untouched for a human."""
        journal = self._companion("-journal")
        if os.path.lexists(journal):
            raise StoreError(f"the store {self.path} has a rollback journal {journal} next to it, which a vtrack "
                             "store never writes (a crashed foreign program left it, or it was planted); opening the "
                             "store for writing would roll it into the store. Nothing was changed: inspect it, then "
                             "move it away (the store stays readable: `vtrack leaderboard`)")

    def _check_writable(self) -> None:
        """``StoreError`` unless the existing store file can be opened for writing and its folder can hold the
        ``-wal``/``-shm`` files; checked without SQLite, so a read-only store is left without new files."""
        import tempfile

        try:
            fd = os.open(self._file, os.O_RDWR | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
            os.close(fd)
        except OSError as exc:
            raise StoreError(f"the store {self.path} cannot be written: {storage_problem(exc)}; it was left "
                             "untouched (pass a writable --store / store path)") from exc
        try:
            fd, probe = tempfile.mkstemp(dir=self._file.parent, prefix=".vtrack-probe-")
            os.close(fd)
            os.unlink(probe)
        except OSError as exc:
            raise StoreError(f"the store {self.path} cannot be written: its folder {self._file.parent} does not "
                             f"accept the store's journal files ({storage_problem(exc)})") from exc

    # ------------------------------------------------------------------------------------------ connections
    def _uri(self, immutable: bool) -> str:
        return self._file.as_uri() + ("?mode=ro&immutable=1" if immutable else "?mode=ro")

    def _read(self, fn: Callable[[sqlite3.Connection], T]) -> T:
        """``fn(con)`` in one read transaction on a read-only connection (see the module docstring).

        Without a ``-wal`` file the first read opens the database ``immutable`` (no lock, no file created). Its
        failure is believed only if the store did not change meanwhile; otherwise (a writer started, committed or
        checkpointed during the read) the read is repeated as a locked snapshot: a read transaction that holds
        SQLite's shared lock (WAL read mark) with a busy timeout, so no writer changes what it reads. A store is
        called corrupted only by such a snapshot, whose integrity check and row checks say so, or by a read of a
        file nobody changed. A snapshot that cannot get its lock in ``timeout_s`` is "busy", never "corrupted".
        """
        import time

        immutable = not self._companion("-wal").exists()
        before = self._file_state()
        try:
            return self._read_once(fn, immutable)
        except StoreError:
            if not immutable or self._file_state() == before:
                raise
        for attempt in range(READ_ATTEMPTS):   # a writer was active: read under its lock
            try:
                return self._read_once(fn, immutable=False)
            except Busy:
                if attempt == READ_ATTEMPTS - 1:
                    raise StoreError(f"{self.path} is busy: a writer held it for more than {self.timeout_s:g} s; "
                                     "nothing was read, try again") from None
            time.sleep(0.02 * 2**attempt)
        raise AssertionError("unreachable")

    def _file_state(self) -> tuple[Any, ...]:
        """What changes when a writer touches the store: the file's and its ``-wal``'s size, time and inode."""
        state: list[Any] = []
        for file in (self._file, self._companion("-wal")):
            try:
                st = os.stat(file)
                state.append((st.st_ino, st.st_size, st.st_mtime_ns))
            except OSError:
                state.append(None)
        return tuple(state)

    def _read_once(self, fn: Callable[[sqlite3.Connection], T], immutable: bool) -> T:
        """``fn(con)`` inside one read transaction (``BEGIN`` ... ``COMMIT``): every query sees one snapshot."""
        with closing(self._connect_ro(immutable)) as con:
            try:
                con.execute("BEGIN")
                result = fn(con)
                con.execute("COMMIT")
                return result
            except sqlite3.OperationalError as exc:
                if is_busy(exc):
                    raise Busy(str(exc)) from exc
                raise self._unreadable(exc) from exc
            except (sqlite3.Error, UnicodeError, TypeError, ValueError, KeyError) as exc:  # e.g. non-UTF-8
                raise StoreError(f"{self.path} is corrupted ({type(exc).__name__}: {exc}); it was left "
                                 "untouched") from exc

    def _unreadable(self, exc: sqlite3.Error) -> StoreError:
        """The error for a read that SQLite refused: a full disk or read-only folder said as such, else
        corruption."""
        problem = storage_problem(exc, self._file.parent)
        if problem != str(exc):
            return StoreError(f"{self.path} cannot be read now: {problem}; the store was left untouched")
        return StoreError(f"{self.path} is corrupted ({type(exc).__name__}: {exc}); it was left untouched")

    def _connect_ro(self, immutable: bool) -> sqlite3.Connection:
        try:
            con = sqlite3.connect(self._uri(immutable), uri=True, timeout=self.timeout_s, isolation_level=None)
            con.execute("PRAGMA trusted_schema = OFF")
            con.execute("PRAGMA query_only = ON")
            con.execute(f"PRAGMA busy_timeout = {int(self.timeout_s * 1000)}")
        except sqlite3.Error as exc:
            raise StoreError(f"cannot open the store {self.path}: {storage_problem(exc, self._file.parent)}") \
                from exc
        return con

    def _connect_rw(self) -> sqlite3.Connection:
        try:
            con = sqlite3.connect(self._file, timeout=self.timeout_s, isolation_level=None)
            con.execute("PRAGMA trusted_schema = OFF")
            con.execute(f"PRAGMA busy_timeout = {int(self.timeout_s * 1000)}")
        except sqlite3.Error as exc:
            raise StoreError(f"cannot open the store {self.path}: {storage_problem(exc, self._file.parent)}") from exc
        return con

    # ------------------------------------------------------------------------------------------ verification
    def _verify(self, con: sqlite3.Connection) -> None:
        """Schema objects exactly as expected, integrity check clean, meta keys exact; else ``StoreError``."""
        try:
            objects = set(con.execute("SELECT type, name, tbl_name, sql FROM sqlite_master"))
        except sqlite3.DatabaseError as exc:
            if is_busy(exc):
                raise
            problem = storage_problem(exc, self._file.parent)
            if problem != str(exc):   # a full disk or a read-only folder: the file itself may be fine
                raise StoreError(f"{self.path} cannot be read now: {problem}; the store was left untouched") from exc
            raise StoreError(f"{self.path} is not a readable SQLite file ({exc}); it was left untouched. "
                             "Move it away or pass another --store path.") from exc
        if not objects:
            raise StoreError(f"{self.path} is an empty SQLite file, not a vtrack_gym store; it was left untouched")
        tables = sorted(str(o[1]) for o in objects if o[0] == "table")
        meta_def = next(o for o in expected_schema() if o[1] == "vtrack_meta")
        if meta_def not in objects:
            raise StoreError(f"{self.path} is an SQLite file but not a vtrack_gym store (tables: {tables}); "
                             "it was left untouched")
        try:
            meta = dict(con.execute("SELECT key, value FROM vtrack_meta"))
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{self.path} is corrupted ({exc}); it was left untouched") from exc
        raw = meta.get("schema_version")
        try:
            version = int(raw) if raw is not None else 0
        except (TypeError, ValueError):
            raise StoreError(f"{self.path} is corrupted (schema version {raw!r}); left untouched") from None
        if version > SCHEMA_VERSION:
            raise StoreError(f"{self.path} has schema version {version}, newer than this vtrack_gym "
                             f"({SCHEMA_VERSION}); upgrade vtrack_gym to read it")
        if version < SCHEMA_VERSION:
            raise StoreError(f"{self.path} has schema version {version}, older than this vtrack_gym's "
                             f"({SCHEMA_VERSION}, rows with policy presets, checksums and success verdicts); it was "
                             "left untouched: move it away (or pass another --store) and rerun the evaluations")
        unexpected = objects - expected_schema()
        missing = expected_schema() - objects
        if unexpected or missing:
            names = [f"{o[0]} {o[1]!r}" for o in sorted(unexpected, key=str)]
            lost = [f"{o[0]} {o[1]!r}" for o in sorted(missing, key=str)]
            raise StoreError(f"{self.path} is not a valid vtrack_gym store: unexpected schema objects "
                             f"{names or 'none'}, missing or altered {lost or 'none'} (triggers, views and extra "
                             "tables or indices are refused); it was left untouched")
        try:
            problems = [r[0] for r in con.execute("PRAGMA integrity_check")]
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{self.path} is corrupted ({exc}); it was left untouched") from exc
        if problems != ["ok"]:
            shown = "; ".join(str(p) for p in problems[:5]) + (" ..." if len(problems) > 5 else "")
            raise StoreError(f"{self.path} is corrupted (integrity check: {shown}); it was left untouched")
        if set(meta) != _META_KEYS:
            raise StoreError(f"{self.path} is corrupted (meta keys {sorted(meta)}, expected {sorted(_META_KEYS)})")

    def _initialise(self) -> None:
        """Create the schema: a missing store is built in a private temporary file in the same folder and linked
        into place complete (``store_sqlite.create_store_file``: a creator killed midway leaves no half-made store);
        an existing empty file is initialised in place. Concurrent creators: the first one wins and the others use
        its store."""
        if os.path.lexists(self._file):
            create_schema(self._file, self.timeout_s, self.path)
        else:
            create_store_file(self._file, self.timeout_s, self.path)
        self._read(self._verify)  # a concurrent initialiser may have written something else

    # ------------------------------------------------------------------------------------------ writing
    def add(self, rows: Iterable[ResultRow]) -> int:
        """Insert rows atomically (all or none); returns how many were written.

        ``StoreError`` on a read-only store, a full disk or a read-only file system (nothing is written then).
        """
        from vtrack_gym._version import __version__

        if self.read_only:
            raise StoreError(f"{self.path} was opened read-only")
        pending = [_stored_values(r, __version__) for r in rows]
        self._check_no_rollback_journal()
        try:
            with closing(self._connect_rw()) as con, write_transaction(con):
                self._insert(con, pending)
        except sqlite3.Error as exc:
            raise StoreError(f"could not write {len(pending)} rows to {self.path}: "
                             f"{storage_problem(exc, self._file.parent)}; "
                             "nothing was written") from exc
        return len(pending)

    @staticmethod
    def _insert(con: sqlite3.Connection, pending: list[list[Any]]) -> None:
        """Insert ``pending`` with explicit ids, their row hashes, and update the count and digest (in a txn)."""
        meta = dict(con.execute("SELECT key, value FROM vtrack_meta"))
        seq = con.execute("SELECT seq FROM sqlite_sequence WHERE name = 'results'").fetchone()
        top = con.execute("SELECT max(id) FROM results").fetchone()[0]
        next_id = max(seq[0] if seq else 0, top or 0) + 1
        digest = int(meta["rows_digest"], 16)
        records = []
        for i, values in enumerate(pending):
            full = [next_id + i, *values]
            h = row_sha256(full)
            digest ^= int(h, 16)
            records.append((*full, h))
        con.executemany(f"INSERT INTO results ({', '.join(_COLUMNS)}, row_sha256) "
                        f"VALUES ({', '.join('?' * (len(_COLUMNS) + 1))})", records)
        con.executemany("UPDATE vtrack_meta SET value = ? WHERE key = ?",
                        [(str(int(meta["row_count"]) + len(records)), "row_count"), (f"{digest:064x}", "rows_digest")])

    # ------------------------------------------------------------------------------------------ reading
    def suites(self) -> dict[str, int]:
        """``{suite: number of stored episodes}`` of every suite in the store, by name (rows verified)."""
        import collections

        return dict(sorted(collections.Counter(r["suite"] for r in self._snapshot()).items()))

    def rows(self, suite: str | None = None) -> list[dict[str, Any]]:
        """Every stored row (optionally of one suite) as dicts with the metrics unpacked.

        All rows are read in one snapshot and checked against their hashes, the row rule, the row count and the
        digest. A snapshot whose count and digest (the XOR of every row's SHA-256) equal those of this object's
        previous read holds the same rows: they are not read and checked again (a command that reads a store
        several times pays for one read; ``benchmarks/bench_store_read.py``).
        """
        return [dict(r) for r in self._snapshot() if suite is None or r["suite"] == suite]

    def _snapshot(self) -> list[dict[str, Any]]:
        """The verified rows of the store's current snapshot, as this object keeps them (never handed out: callers
        get copies, ``rows``)."""
        return self._read(self._verified_rows)

    def _verified_rows(self, con: sqlite3.Connection) -> list[dict[str, Any]]:
        """Every row of ``con``'s snapshot, verified (``verified_rows``), or those of the previous read when the
        snapshot's row count and digest are the same (inside ``_read``'s one read transaction)."""
        meta = dict(con.execute("SELECT key, value FROM vtrack_meta"))
        key = (meta.get("row_count"), meta.get("rows_digest"))
        if self._last_read is not None and self._last_read[0] == key:
            return self._last_read[1]
        raw = con.execute(f"SELECT {', '.join(_COLUMNS)}, row_sha256 FROM results ORDER BY id").fetchall()
        rows = verified_rows(self.path, meta, raw)
        self._last_read = (key, rows)
        return rows

    def older_versions(self, suite: str) -> tuple[str, int]:
        """(newest package version among the suite's rows, number of the suite's rows of older versions): what
        ``leaderboard(latest_only=True)`` leaves out; ``("", 0)`` for a suite without rows."""
        rows = [r for r in self._snapshot() if r["suite"] == suite]
        if not rows:
            return "", 0
        newest = max((r["package_version"] for r in rows), key=version_sort_key)
        return newest, sum(version_sort_key(r["package_version"]) != version_sort_key(newest) for r in rows)

    def leaderboard(self, suite: str, columns: Sequence[str], latest_only: bool = True) -> list[dict[str, Any]]:
        """Aggregates of ``columns`` per policy key (``vtrack_gym.evaluation.leaderboard.board``) over the suite's rows,
        ranked validity first on the suite's primary metric (``vtrack_gym.evaluation.suite.suites.primary_metric``).

        ``latest_only``: only rows written by the newest package version present in the suite, and of those the
        newest row per (env, policy key, seed, options); otherwise every row of every version.
        """
        from vtrack_gym.evaluation.suite.suites import primary_metric, then_metrics

        return build_board(self.board_rows(suite, latest_only), columns, primary_metric(suite), then_metrics(suite))

    def board_rows(self, suite: str, latest_only: bool = True) -> list[dict[str, Any]]:
        """The stored rows ``leaderboard`` aggregates (see there); the run's figure folder
        (``options["figures"]``) does not distinguish two rows of one episode."""
        rows = [r for r in self._snapshot() if r["suite"] == suite]
        return [dict(r) for r in (latest_rows(rows) if latest_only else rows)]


def verified_rows(path: Path, meta: dict[str, str], raw: list[tuple[Any, ...]]) -> list[dict[str, Any]]:
    """The rows of one snapshot of the store at ``path`` (``raw``: ``_COLUMNS`` and the row hash), each checked
    against its hash and the row rule, all against the meta table's count and digest; ``StoreError`` naming the row
    otherwise (inside ``_read``: a snapshot torn by a concurrent writer is read again).

    The hashes, the count and the digest are checked row by row; the row rule column by column
    (``row_batch.rows_obey_rule``), and row by row (naming the row) only when a column may break it."""
    from vtrack_gym.evaluation.scoring.row_batch import parsed_objects, rows_obey_rule

    columns = dict(zip((*_COLUMNS, "row_sha256"), zip(*raw, strict=True), strict=True)) if raw else {}
    if not all(_SQL_SCALARS.issuperset(set(map(type, values))) for values in columns.values()):
        return _verified_row_by_row(path, meta, raw)   # a BLOB somewhere: the row is named there
    digest = 0
    encode = _ROW_ENCODER.encode
    for values in raw:
        stored_hash = values[-1]
        if hashlib.sha256(encode(values[:-1]).encode("ascii")).hexdigest() != stored_hash:
            raise StoreError(f"{path} is corrupted (row {values[0]!r} does not match its checksum)")
        digest ^= int(stored_hash, 16)
    _check_count_and_digest(path, meta, len(raw), digest)
    if not raw:
        return []
    metrics = parsed_objects(columns["metrics_json"])
    options = parsed_objects(columns["options_json"])
    if metrics is None or options is None or not rows_obey_rule(columns, metrics):
        return _verified_row_by_row(path, meta, raw)   # some row breaks the rule: name it
    plain = itemgetter(*_PLAIN_INDEX)
    return [{**dict(zip(_PLAIN_COLUMNS, plain(values), strict=True)), "metrics": m, "options": o}
            for values, m, o in zip(raw, metrics, options, strict=True)]


def _verified_row_by_row(path: Path, meta: dict[str, str], raw: list[tuple[Any, ...]]) -> list[dict[str, Any]]:
    """``verified_rows`` one row at a time: the first row that breaks its hash or the row rule is named."""
    digest = 0
    out = []
    for values in raw:
        stored_hash = values[-1]
        if not _SQL_SCALARS.issuperset(map(type, values)) or row_sha256(values[:-1]) != stored_hash:
            raise StoreError(f"{path} is corrupted (row {values[0]!r} does not match its checksum)")
        digest ^= int(stored_hash, 16)
        d = dict(zip(_COLUMNS, values[:-1], strict=True))
        try:   # the rule every write obeys
            d["metrics"], d["options"] = checked_row_values(d)
        except ValueError as exc:
            raise StoreError(f"{path} is corrupted (row {d.get('id')!r:.30}: {exc}); it was left untouched") from None
        del d["metrics_json"], d["options_json"]
        out.append(d)
    _check_count_and_digest(path, meta, len(raw), digest)
    return out


def _check_count_and_digest(path: Path, meta: dict[str, str], count: int, digest: int) -> None:
    """``StoreError`` unless the meta table's row count and digest are ``count`` and ``digest``."""
    if meta.get("row_count") != str(count) or meta.get("rows_digest") != f"{digest:064x}":
        raise StoreError(f"{path} is corrupted (it holds {count} rows, its record says "
                         f"{meta.get('row_count')!r}, or the rows' digest differs): rows were lost or altered")


def latest_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """``rows`` (stored rows, ordered by id) reduced to those of the newest package version present, and of those the
    newest row per episode: env set-up (the id with its alias resolved, ``env_names.canonical_env_id``, so a row
    stored under ``vtrack/DLC120-v0`` and one under ``DLC120-v0`` are one episode), policy key, seed and options
    (numbers normalised: ``45`` and ``45.0`` are one setting; the run's figure folder left out)."""
    from vtrack_gym.evaluation.identity.env_names import canonical_env_id, normal_numbers

    if not rows:
        return []
    newest = max(version_sort_key(r["package_version"]) for r in rows)
    latest: dict[tuple[Any, ...], dict[str, Any]] = {}
    for r in rows:  # ordered by id: a later row replaces an earlier one
        if version_sort_key(r["package_version"]) == newest:
            options = normal_numbers({k: v for k, v in r["options"].items() if k != "figures"})
            latest[(canonical_env_id(r["env_id"]), r["policy_id"], r["policy_preset"], r["policy_hash"], r["seed"],
                    json.dumps(options, sort_keys=True))] = r
    return list(latest.values())


_PEP440 = re.compile(
    r"v?(?:(?P<epoch>\d+)!)?(?P<release>\d+(?:\.\d+)*)"
    r"(?:[-_.]?(?P<pre_l>alpha|beta|preview|pre|rc|a|b|c)[-_.]?(?P<pre_n>\d+)?)?"
    r"(?:-(?P<post_n1>\d+)|[-_.]?(?P<post_l>post|rev|r)[-_.]?(?P<post_n2>\d+)?)?"
    r"(?:[-_.]?(?P<dev_l>dev)[-_.]?(?P<dev_n>\d+)?)?"
    r"(?:\+(?P<local>[a-z0-9]+(?:[-_.][a-z0-9]+)*))?",
    re.IGNORECASE)
_PRE_RANK = {"a": 0, "alpha": 0, "b": 1, "beta": 1, "c": 2, "rc": 2, "pre": 2, "preview": 2}


@functools.lru_cache(maxsize=1024)
def version_sort_key(version: str) -> tuple[Any, ...]:
    """Sort key of a package version string in PEP 440 order: epoch, release (``1.0 == 1.0.0``), then
    ``1.0.dev1 < 1.0a1 < 1.0b2.dev1 < 1.0b2 < 1.0rc1 < 1.0 < 1.0+local < 1.0.post1.dev1 < 1.0.post1``
    (a local label sorts after its public version; numeric local segments after alphanumeric ones). A string
    that is not a PEP 440 version sorts before every version (by its text)."""
    m = _PEP440.fullmatch(version.strip())
    if not m:
        return (0, version)
    release = tuple(int(x) for x in m["release"].split("."))
    while release and release[-1] == 0:
        release = release[:-1]  # 1.0 == 1.0.0
    has_post = m["post_n1"] is not None or m["post_l"] is not None
    if m["pre_l"] is not None:
        pre: tuple[int, ...] = (1, _PRE_RANK[m["pre_l"].lower()], int(m["pre_n"] or 0))
    elif m["dev_l"] is not None and not has_post:
        pre = (0,)  # 1.0.dev1 before 1.0a1
    else:
        pre = (2,)  # a final release after its pre-releases
    post = (1, int(m["post_n1"] or m["post_n2"] or 0)) if has_post else (0,)
    dev = (0, int(m["dev_n"] or 0)) if m["dev_l"] is not None else (1,)
    local: tuple[tuple[int, int, str], ...] = ()
    if m["local"]:
        local = tuple((1, int(part), "") if part.isdigit() else (0, 0, part.lower())
                      for part in re.split(r"[-_.]", m["local"]))
    return (1, int(m["epoch"] or 0), release, pre, post, dev, (1, local) if m["local"] else (0,))
