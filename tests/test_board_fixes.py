"""Evaluation and leaderboard fixes, each through a user's entry point (``vtrack_gym.evaluate``, ``cli.main``,
``ResultStore``): --out never touches a store, provenance of env objects, non-standard seed sets, canonical policy
ids, PEP 440 version order, row validation, the store checked before any rollout, ``benchmark --track`` options."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.store import ResultRow, ResultStore


def make_row(policy: str = "mpc", seed: int = 0, e_y: float = 0.1, **kw) -> ResultRow:
    fields = {"suite": "paper", "env_id": "DLC120-v0", "policy_id": policy, "policy_hash": "h", "seed": seed,
              "metrics": {"max_e_y_m": e_y}, "termination": "completed", "wall_time_per_step_s": 1e-5}
    fields.update(kw)
    return ResultRow(**fields)


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# --------------------------------------------------------------------------------------------- 1: leaderboard --out
def test_leaderboard_out_never_overwrites_the_store_or_a_database(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "s.sqlite"
    ResultStore(store).add([make_row()])
    other = tmp_path / "other.sqlite"
    ResultStore(other).add([make_row("smc")])
    before = {p: digest(p) for p in (store, other)}
    link = tmp_path / "link.md"
    link.symlink_to(store)
    for out in (store, tmp_path / "s.sqlite-wal", tmp_path / "s.sqlite-shm", tmp_path / "s.sqlite-journal",
                tmp_path / "." / "s.sqlite", link, other):
        assert main(["leaderboard", "--store", str(store), "--out", str(out)]) == 2, out
        err = capsys.readouterr().err
        assert "--out" in err and "error" in err
    assert {p: digest(p) for p in (store, other)} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.md", "other.sqlite", "s.sqlite"]
    assert main(["leaderboard", "--store", str(store), "--out", str(tmp_path / "board.md")]) == 0
    assert "| DLC120-v0 | mpc |" in (tmp_path / "board.md").read_text()
