"""The leaderboard store: one SQLite file, one row per evaluated episode with full provenance.

Safe under several concurrent writers (WAL journal, busy timeout, one transaction per batch of rows) and
under a crash mid-write (SQLite's atomic commit: a killed writer leaves either all of its rows or none).
A file that is not a vtrack store, is corrupted, or comes from a newer schema raises ``StoreError`` and is
never overwritten.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
import math
import sqlite3
from collections.abc import Iterable, Sequence
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

SCHEMA_VERSION = 1
DEFAULT_STORE_PATH = Path("vtrack_results") / "leaderboard.sqlite"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS vtrack_meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS results (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    created_utc TEXT NOT NULL,
    package_version TEXT NOT NULL,
    suite TEXT NOT NULL,
    env_id TEXT NOT NULL,
    env_version TEXT NOT NULL,
    policy_id TEXT NOT NULL,
    policy_hash TEXT NOT NULL,
    seed INTEGER,
    options_json TEXT NOT NULL,
    termination TEXT NOT NULL,
    completed INTEGER NOT NULL,
    wall_time_per_step_s REAL NOT NULL,
    metrics_json TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS results_board ON results (suite, env_id, policy_id);
"""


class StoreError(RuntimeError):
    """The store file cannot be used (not a vtrack store, corrupted, or a newer schema)."""


@dataclass(frozen=True)
class ResultRow:
    """One evaluated episode and where it came from."""

    suite: str
    env_id: str
    policy_id: str
    policy_hash: str
    seed: int | None
    metrics: dict[str, Any]
    termination: str
    wall_time_per_step_s: float
    options: dict[str, Any] = field(default_factory=dict)
    env_version: str = "v0"
    package_version: str = ""
    created_utc: str = ""


def _now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def _clean(value: Any) -> Any:
    """JSON-safe scalar (NaN/inf become None)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item"):
        return _clean(value.item())
    return value


class ResultStore:
    """Open (or create) the store at ``path`` (default ``vtrack_results/leaderboard.sqlite``)."""

    def __init__(self, path: str | Path = DEFAULT_STORE_PATH, timeout_s: float = 60.0) -> None:
        self.path = Path(path)
        self.timeout_s = timeout_s
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with closing(self._connect()) as con:
            self._check_or_init(con)

    def _connect(self) -> sqlite3.Connection:
        if self.path.is_dir():
            raise StoreError(f"{self.path} is a directory, not a store file; pass a file path such as "
                             f"{self.path / 'leaderboard.sqlite'}")
        try:
            con = sqlite3.connect(self.path, timeout=self.timeout_s, isolation_level=None)
        except sqlite3.Error as exc:
            raise StoreError(f"cannot open the store {self.path}: {exc}") from exc
        con.execute(f"PRAGMA busy_timeout = {int(self.timeout_s * 1000)}")
        return con

    def _check_or_init(self, con: sqlite3.Connection) -> None:
        try:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{self.path} is not a readable SQLite file ({exc}); it was left untouched. "
                             "Move it away or pass another --store path.") from exc
        if tables and "vtrack_meta" not in tables:
            raise StoreError(f"{self.path} is an SQLite file but not a vtrack_gym store (tables: {sorted(tables)}); "
                             "it was left untouched")
        if "vtrack_meta" in tables:
            row = con.execute("SELECT value FROM vtrack_meta WHERE key='schema_version'").fetchone()
            try:
                version = int(row[0]) if row else 0
            except (TypeError, ValueError):
                raise StoreError(f"{self.path} is corrupted (schema version {row[0]!r}); left untouched") from None
            if version > SCHEMA_VERSION:
                raise StoreError(f"{self.path} has schema version {version}, newer than this vtrack_gym "
                                 f"({SCHEMA_VERSION}); upgrade vtrack_gym to read it")
            if version < SCHEMA_VERSION:
                raise StoreError(f"{self.path} has an unknown old schema version {version}")
            if "results" not in tables:
                raise StoreError(f"{self.path} is corrupted (no results table); it was left untouched")
            try:
                con.execute("PRAGMA quick_check").fetchone()
            except sqlite3.DatabaseError as exc:
                raise StoreError(f"{self.path} is corrupted ({exc}); it was left untouched") from exc
            return
        con.execute("PRAGMA journal_mode = WAL")
        con.execute("BEGIN IMMEDIATE")
        try:
            for statement in filter(str.strip, _SCHEMA.split(";")):
                con.execute(statement)
            con.execute("INSERT OR IGNORE INTO vtrack_meta VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
            con.execute("COMMIT")
        except BaseException:
            con.execute("ROLLBACK")
            raise

    def add(self, rows: Iterable[ResultRow]) -> int:
        """Insert rows atomically (all or none); returns how many were written."""
        from vtrack_gym._version import __version__

        records = []
        for r in rows:
            metrics = {k: _clean(v) for k, v in r.metrics.items()}
            records.append((r.created_utc or _now(), r.package_version or __version__, r.suite, r.env_id,
                            r.env_version, r.policy_id, r.policy_hash, r.seed, json.dumps(r.options, sort_keys=True),
                            r.termination, int(r.termination == "completed"), float(r.wall_time_per_step_s),
                            json.dumps(metrics, sort_keys=True)))
        with closing(self._connect()) as con:
            con.execute("BEGIN IMMEDIATE")
            try:
                con.executemany(
                    "INSERT INTO results (created_utc, package_version, suite, env_id, env_version, policy_id, "
                    "policy_hash, seed, options_json, termination, completed, wall_time_per_step_s, metrics_json) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", records)
                con.execute("COMMIT")
            except BaseException:
                con.execute("ROLLBACK")
                raise
        return len(records)

    def suites(self) -> dict[str, int]:
        """``{suite: number of stored episodes}`` of every suite in the store, by name."""
        with closing(self._connect()) as con:
            return dict(con.execute("SELECT suite, COUNT(*) FROM results GROUP BY suite ORDER BY suite").fetchall())

    def rows(self, suite: str | None = None) -> list[dict[str, Any]]:
        """Every stored row (optionally of one suite) as dicts with the metrics unpacked."""
        query = "SELECT * FROM results" + (" WHERE suite = ?" if suite else "") + " ORDER BY id"
        with closing(self._connect()) as con:
            con.row_factory = sqlite3.Row
            out = []
            for row in con.execute(query, (suite,) if suite else ()):
                d = dict(row)
                try:
                    d["metrics"] = json.loads(d.pop("metrics_json"))
                    d["options"] = json.loads(d.pop("options_json"))
                except (TypeError, ValueError) as exc:
                    raise StoreError(f"{self.path} is corrupted (row {d.get('id')}: {exc})") from exc
                out.append(d)
        return out

    def leaderboard(self, suite: str, columns: Sequence[str], latest_only: bool = True) -> list[dict[str, Any]]:
        """Mean of ``columns`` per (env_id, policy_id) over the suite's rows (latest package version only)."""
        rows = self.rows(suite)
        if latest_only and rows:
            latest = {}
            for r in rows:  # keep, per (env, policy, seed), the newest row
                latest[(r["env_id"], r["policy_id"], r["seed"], json.dumps(r["options"], sort_keys=True))] = r
            rows = list(latest.values())
        groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
        for r in rows:
            groups.setdefault((r["env_id"], r["policy_id"]), []).append(r)
        board = []
        for (env_id, policy_id), members in sorted(groups.items()):
            entry: dict[str, Any] = {"env_id": env_id, "policy_id": policy_id, "episodes": len(members),
                                     "completed": sum(m["completed"] for m in members) / len(members)}
            for col in columns:
                vals = [m["metrics"].get(col) for m in members]
                vals = [v for v in vals if isinstance(v, (int, float)) and v is not None]
                entry[col] = sum(vals) / len(vals) if vals else math.nan
            entry["wall_time_per_step_us"] = 1e6 * sum(m["wall_time_per_step_s"] for m in members) / len(members)
            board.append(entry)
        return board


def to_markdown(board: list[dict[str, Any]], digits: int = 3) -> str:
    """A GitHub-flavoured Markdown table of a leaderboard."""
    if not board:
        return "(no results)"
    cols = list(board[0])
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for entry in board:
        cells = []
        for c in cols:
            v = entry[c]
            if isinstance(v, float):
                cells.append("–" if math.isnan(v) else f"{v:.{digits}g}")
            else:
                cells.append(str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def to_csv(board: list[dict[str, Any]]) -> str:
    """CSV text of a leaderboard."""
    buf = io.StringIO()
    if board:
        writer = csv.DictWriter(buf, fieldnames=list(board[0]))
        writer.writeheader()
        writer.writerows(board)
    return buf.getvalue()


def to_json(board: list[dict[str, Any]]) -> str:
    """JSON text of a leaderboard (NaN as null)."""
    return json.dumps([{k: _clean(v) for k, v in e.items()} for e in board], indent=2)
