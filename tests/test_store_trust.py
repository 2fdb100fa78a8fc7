"""Issue 19: an untrusted store is data (schema objects, integrity, checksums, read-only opening, disk errors),
policy identity, one NaN rule, the version filter, and escaping in every leaderboard format."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import random
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.leaderboard.board import aggregate, build_board
from vtrack_gym.evaluation.leaderboard.report_formats import to_csv, to_json, to_latex, to_markdown
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore, StoreError, version_sort_key

COLUMNS = ["max_e_y_m", "itae"]


def make_row(policy: str = "mpc", seed: int = 0, e_y: float = 0.1, **kw) -> ResultRow:
    base = {"suite": "paper", "env_id": "DLC120-v0", "policy_id": policy, "policy_hash": "h" + policy, "seed": seed,
            "metrics": {"max_e_y_m": e_y, "itae": 1.0 + seed}, "termination": "completed",
            "wall_time_per_step_s": 1e-5}
    base.update(kw)
    return ResultRow(**base)


def small_store(path: Path) -> Path:
    store = ResultStore(path)
    store.add([make_row("mpc", s, 0.1 * (s + 1)) for s in range(3)])
    store.add([make_row("smc", s, 0.2, policy_preset="paper") for s in range(2)])
    return path


def snapshot(folder: Path) -> dict[str, str]:
    """{file name: sha256} of every file in ``folder`` (journals included)."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


# ------------------------------------------------------------------------------------- schema objects, integrity
@pytest.mark.parametrize("ddl", [
    "CREATE TRIGGER wipe AFTER INSERT ON results BEGIN DELETE FROM results; END",
    "CREATE VIEW v AS SELECT * FROM results",
    "CREATE INDEX extra ON results (policy_id)",
    "CREATE TABLE extra (x)",
], ids=["trigger", "view", "index", "table"])
def test_unexpected_schema_objects_are_refused_and_untouched(tmp_path: Path, ddl: str) -> None:
    path = small_store(tmp_path / "s.sqlite")
    with sqlite3.connect(path) as con:
        con.execute(ddl)
    con.close()
    before = snapshot(tmp_path)
    for read_only in (True, False):
        with pytest.raises(StoreError, match="unexpected schema objects"):
            ResultStore(path, read_only=read_only)
    assert snapshot(tmp_path) == before


def test_trigger_cannot_touch_rows_because_store_is_refused(tmp_path: Path) -> None:
    """The reproduction: a received store whose trigger deletes the rows you add."""
    path = small_store(tmp_path / "s.sqlite")
    with sqlite3.connect(path) as con:
        con.execute("CREATE TRIGGER eat AFTER INSERT ON results BEGIN DELETE FROM results WHERE id = new.id; END")
    con.close()
    with pytest.raises(StoreError, match="trigger 'eat'"):
        ResultStore(path).add([make_row("new")])


def test_altered_table_definition_is_refused(tmp_path: Path) -> None:
    path = small_store(tmp_path / "s.sqlite")
    with sqlite3.connect(path) as con:
        con.execute("ALTER TABLE results ADD COLUMN note TEXT")
    con.close()
    with pytest.raises(StoreError, match="missing or altered"):
        ResultStore(path, read_only=True)


def test_payload_edit_and_lost_row_are_detected(tmp_path: Path) -> None:
    path = small_store(tmp_path / "s.sqlite")
    edited = tmp_path / "edited.sqlite"
    shutil.copy(path, edited)
    with sqlite3.connect(edited) as con:
        con.execute("UPDATE results SET metrics_json = replace(metrics_json, '0.1', '0.01') WHERE id = 1")
    con.close()
    with pytest.raises(StoreError, match="checksum"):
        ResultStore(edited, read_only=True).leaderboard("paper", COLUMNS)
    dropped = tmp_path / "dropped.sqlite"
    shutil.copy(path, dropped)
    with sqlite3.connect(dropped) as con:
        con.execute("DELETE FROM results WHERE id = 2")
    con.close()
    with pytest.raises(StoreError, match="rows were lost or altered"):
        ResultStore(dropped, read_only=True).leaderboard("paper", COLUMNS)


def test_integrity_check_result_rows_are_honoured(tmp_path: Path) -> None:
    """Index/table disagreement (invisible to quick reads) is found by the full integrity check."""
    path = small_store(tmp_path / "s.sqlite")
    with sqlite3.connect(path) as con:  # the meta table's primary-key index loses an entry
        root = con.execute("SELECT rootpage FROM sqlite_master WHERE name = 'sqlite_autoindex_vtrack_meta_1'"
                           ).fetchone()[0]
        page_size = con.execute("PRAGMA page_size").fetchone()[0]
    con.close()
    data = bytearray(path.read_bytes())
    header = (root - 1) * page_size
    assert data[header] == 0x0A  # a leaf index b-tree page
    data[header + 3:header + 5] = (int.from_bytes(data[header + 3:header + 5], "big") - 1).to_bytes(2, "big")
    path.write_bytes(bytes(data))  # one cell fewer in the index page
    with pytest.raises(StoreError, match="integrity check"):
        ResultStore(path, read_only=True)


def _board_or_error(path: Path) -> str:
    try:
        store = ResultStore(path, read_only=True)
        return json.dumps([store.leaderboard(s, COLUMNS, latest_only=False) for s in ("paper", "custom")]
                          + [store.rows()], sort_keys=True, default=str)
    except StoreError:
        return "StoreError"


def test_byte_flip_fuzz_reads_identically_or_raises(tmp_path: Path) -> None:
    """Every single-bit flip of a store file: the same table, or StoreError; never a different table."""
    path = tmp_path / "s.sqlite"
    store = ResultStore(path)
    store.add([make_row("mpc", s, 0.1 * (s + 1)) for s in range(6)])
    store.add([make_row("smc", s, 0.25, suite="custom", policy_preset="paper") for s in range(6)])
    reference = _board_or_error(path)
    assert reference != "StoreError"
    original = path.read_bytes()
    rng = random.Random(19)
    positions = list(range(100)) + rng.sample(range(100, len(original)), min(1500, len(original) - 100))
    flipped = tmp_path / "f.sqlite"
    outcomes = {"same": 0, "StoreError": 0}
    for pos in positions:
        data = bytearray(original)
        data[pos] ^= 1 << rng.randrange(8)
        flipped.write_bytes(bytes(data))
        result = _board_or_error(flipped)
        if result == "StoreError":
            outcomes["StoreError"] += 1
        else:
            assert result == reference, f"flip at byte {pos} changed the table without an error"
            outcomes["same"] += 1
    assert outcomes["StoreError"] > 50 and outcomes["same"] > 50, outcomes  # both kinds of byte were hit


# ------------------------------------------------------------------------------------------ read-only opening
def test_leaderboard_never_creates_or_modifies_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    empty = tmp_path / "empty.sqlite"
    empty.write_bytes(b"")
    assert main(["leaderboard", "--store", str(empty)]) == 2
    assert "empty file" in capsys.readouterr().err
    assert empty.read_bytes() == b"" and sorted(p.name for p in tmp_path.iterdir()) == ["empty.sqlite"]
    store_dir = tmp_path / "wal"
    store_dir.mkdir()
    path = small_store(store_dir / "s.sqlite")
    assert path.read_bytes()[18:20] == b"\x02\x02"  # WAL mode: plain mode=ro would create -wal and -shm
    before = snapshot(store_dir)
    for fmt in ("md", "csv", "json", "latex", "html"):
        assert main(["leaderboard", "--store", str(path), "--format", fmt]) == 0
    assert "| DLC120-v0 | mpc |" in capsys.readouterr().out
    assert snapshot(store_dir) == before


def test_foreign_file_with_hot_journal_is_left_byte_identical(tmp_path: Path) -> None:
    source = tmp_path / "src"
    source.mkdir()
    con = sqlite3.connect(source / "f.sqlite", isolation_level=None)
    con.execute("CREATE TABLE t (x)")
    con.execute("INSERT INTO t VALUES (1)")
    con.execute("PRAGMA cache_size = 1")
    con.execute("BEGIN")
    con.execute("INSERT INTO t SELECT randomblob(2000) FROM (SELECT 1 UNION SELECT 2 UNION SELECT 3)")
    con.execute("UPDATE t SET x = 2 WHERE x = 1")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    for name in ("f.sqlite", "f.sqlite-journal"):  # a copy taken mid-transaction: a hot journal
        shutil.copy(source / name, foreign / name)
    con.execute("ROLLBACK")
    con.close()
    before = snapshot(foreign)
    assert "f.sqlite-journal" in before
    for read_only in (True, False):
        with pytest.raises(StoreError, match="not a vtrack_gym store"):
            ResultStore(foreign / "f.sqlite", read_only=read_only)
        assert snapshot(foreign) == before


def test_store_errors_say_disk_full_or_read_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = small_store(tmp_path / "s.sqlite")
    store = ResultStore(path)
    connect_rw = ResultStore._connect_rw

    def tiny_disk(self: ResultStore) -> sqlite3.Connection:
        con = connect_rw(self)
        pages = con.execute("PRAGMA page_count").fetchone()[0]
        con.execute(f"PRAGMA max_page_count = {pages}")  # SQLite's own SQLITE_FULL when the file must grow
        return con

    monkeypatch.setattr(ResultStore, "_connect_rw", tiny_disk)
    with pytest.raises(StoreError, match="disk is full"):
        store.add([make_row("big", s, metrics={"blob": "x" * 5000}) for s in range(20)])

    def read_only_fs(self: ResultStore) -> sqlite3.Connection:
        return sqlite3.connect(self._uri(immutable=False), uri=True, isolation_level=None)

    monkeypatch.setattr(ResultStore, "_connect_rw", read_only_fs)
    with pytest.raises(StoreError, match="read-only"):
        store.add([make_row("x")])
    monkeypatch.undo()
    assert len(ResultStore(path, read_only=True).rows()) == 5  # nothing half-written


def test_results_are_printed_before_a_store_failure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    def full(self: ResultStore, rows: object) -> int:
        raise StoreError(f"could not write rows to {self.path}: the disk is full (simulated)")

    monkeypatch.setattr(ResultStore, "add", full)
    store = str(tmp_path / "s.sqlite")
    assert main(["eval", "--policy", "stanley", "--env", "DLC120-v0", "--store", store]) == 2
    captured = capsys.readouterr()
    assert "| 0 | completed |" in captured.out and "the disk is full" in captured.err
    assert main(["benchmark", "--policies", "stanley", "--no-figures", "--store", store]) == 2
    captured = capsys.readouterr()
    assert "| DLC120-v0 | stanley |" in captured.out and "the disk is full" in captured.err


# ------------------------------------------------------------------------------------------ identity
def test_presets_and_agent_weights_are_distinct_policy_keys(tmp_path: Path) -> None:
    import gymnasium as gym

    from vtrack_gym.baselines.numpy_policy import load_agent, save_agent
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.baselines.shipped import SHIPPED_DIR
    from vtrack_gym.evaluation.benchmarking.benchmark import policy_preset
    from vtrack_gym.evaluation.identity.fingerprint import policy_hash

    env = gym.make("DLC120-v0")
    default, paper = make_policy("smc", env), make_policy("smc", env, preset="paper")
    env.close()
    assert (policy_preset(default), policy_preset(paper)) == ("default", "paper")
    assert policy_hash(default) != policy_hash(paper)
    spec = json.loads((SHIPPED_DIR / "ppo.json").read_text())
    with np.load(SHIPPED_DIR / "ppo.npz") as data:
        arrays = {k: data[k] for k in data.files}
    save_agent(tmp_path / "same", spec, arrays)
    changed = dict(arrays, b0=arrays["b0"] + np.float32(1e-3))
    save_agent(tmp_path / "changed", spec, changed)
    shipped, same, other = (load_agent(p) for p in (SHIPPED_DIR / "ppo.json", tmp_path / "same.json",
                                                    tmp_path / "changed.json"))
    assert policy_hash(shipped) == policy_hash(same) != policy_hash(other)
    assert policy_preset(shipped) == ""


def test_eval_presets_are_two_leaderboard_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = str(tmp_path / "s.sqlite")
    for preset in ("paper", "default"):
        assert main(["eval", "--policy", "smc", "--preset", preset, "--env", "DLC120-v0", "--store", store]) == 0
    capsys.readouterr()
    assert main(["leaderboard", "--suite", "custom", "--store", store, "--format", "json"]) == 0
    board = json.loads(capsys.readouterr().out)
    assert sorted((e["policy_id"], e["preset"]) for e in board) == [("smc", "default"), ("smc:paper", "paper")]
    assert board[0]["policy_hash"] != board[1]["policy_hash"] and all(e["episodes"] == 1 for e in board)


def test_version_filter_keeps_only_the_newest_package_version(tmp_path: Path) -> None:
    store = ResultStore(tmp_path / "s.sqlite")
    store.add([make_row("mpc", 0, 9.0, package_version="0.9.0"), make_row("mpc", 1, 9.0, package_version="0.9.0")])
    store.add([make_row("mpc", 0, 1.0, package_version="0.10.0")])
    latest = store.leaderboard("paper", COLUMNS)
    assert [(e["episodes"], e["max_e_y_m"]) for e in latest] == [(1, 1.0)]
    everything = store.leaderboard("paper", COLUMNS, latest_only=False)
    assert [(e["episodes"], e["max_e_y_m"]) for e in everything] == [(3, pytest.approx(19.0 / 3))]
    assert version_sort_key("0.10.0") > version_sort_key("0.9.1") > version_sort_key("0.9.1.dev3")
    assert version_sort_key("1.0") == version_sort_key("1.0.0")


# ------------------------------------------------------------------------------------------ NaN rule
def test_one_nan_rule_for_benchmark_and_leaderboard(tmp_path: Path) -> None:
    from vtrack_gym.evaluation.benchmarking.benchmark import summarise

    rows = [make_row("mpc", 0, 0.1), make_row("mpc", 1, float("nan")), make_row("smc", 0, float("inf")),
            make_row("lqr", 0, 0.3), make_row("lqr", 1, 0.5)]
    store = ResultStore(tmp_path / "s.sqlite")
    store.add(rows)
    fresh = summarise(rows, COLUMNS)
    stored = store.leaderboard("paper", COLUMNS)
    assert to_json(fresh) == to_json(stored)
    by_policy = {e["policy_id"]: e for e in stored}
    assert math.isnan(by_policy["mpc"]["max_e_y_m"]) and math.isnan(by_policy["smc"]["max_e_y_m"])
    assert by_policy["lqr"]["max_e_y_m"] == pytest.approx(0.4) and by_policy["mpc"]["itae"] == pytest.approx(1.5)
    assert math.isnan(aggregate([])) and aggregate([1, 2]) == 1.5 and math.isnan(aggregate([1.0, None]))


# ------------------------------------------------------------------------------------------ escaping, formats
EVIL_ID = "x | 1 | 2 |\n| forged | 0 | 0 |"
FORMULA = '=HYPERLINK("http://evil.example","click")'


def evil_board() -> list[dict]:
    records = [{"env_id": "DLC120-v0", "policy_id": pid, "policy_preset": "", "policy_hash": "h",
                "completed": 1, "wall_time_per_step_s": 1e-5, "metrics": {"max_e_y_m": -0.5, "itae": float("nan")}}
               for pid in (EVIL_ID, FORMULA, "+1", "-2", "@SUM(A1)", "<script>alert(1)</script>", "a&b_%$#{}~^\\")]
    return build_board(records, COLUMNS)


def test_markdown_cannot_forge_rows() -> None:
    board = evil_board()
    lines = to_markdown(board).splitlines()
    assert len(lines) == 2 + len(board)
    unescaped_pipes = [line.replace("\\|", "").count("|") for line in lines]
    assert len(set(unescaped_pipes)) == 1
    assert not any(line.startswith("| forged") for line in lines)
    assert "<script>" not in "\n".join(lines)


def test_csv_neutralises_formulas_and_keeps_numbers() -> None:
    board = evil_board()
    parsed = list(csv.DictReader(io.StringIO(to_csv(board))))
    assert len(parsed) == len(board)
    ids = {r["policy_id"] for r in parsed}
    assert {"'" + FORMULA, "'+1", "'-2", "'@SUM(A1)", EVIL_ID} <= ids
    assert all(r["max_e_y_m"] == "-0.5" and r["itae"] == "" for r in parsed)  # numbers stay numbers, NaN empty


def test_latex_escapes_specials() -> None:
    tex = to_latex(evil_board())
    assert tex.startswith("\\begin{tabular}") and "\\toprule" in tex and "\\bottomrule" in tex
    assert r"a\&b\_\%\$\#\{\}\textasciitilde{}\textasciicircum{}\textbackslash{}" in tex
    body = tex.split("\\midrule")[1]
    assert all(line.count(" & ") == len(evil_board()[0]) - 1 for line in body.splitlines()[1:-2])


def test_html_escapes_and_is_self_contained(tmp_path: Path) -> None:
    from vtrack_gym.evaluation.leaderboard.html_report import to_html

    page = to_html(evil_board(), figures=[_tiny_png(tmp_path / "fig.png"), tmp_path / "nope.png"])
    assert page.count("<script>") == 1 and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "data:image/png;base64," in page and "http://" not in page.replace("http://evil.example", "")
    assert "Content-Security-Policy" in page


def _tiny_png(path: Path) -> Path:
    image = pytest.importorskip("PIL.Image")
    image.new("RGB", (40, 20), (200, 30, 30)).save(path)
    return path
