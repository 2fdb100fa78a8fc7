"""The ``vtrack`` command: benchmark -> store -> leaderboard, eval, plot, and helpful errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from vtrack_gym.cli import main


def test_benchmark_then_leaderboard(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "board.sqlite"
    figures = tmp_path / "figs"
    assert main(["benchmark", "--policies", "smc,mpc", "--store", str(store), "--figures", str(figures)]) == 0
    out = capsys.readouterr().out
    assert "| DLC120-v0 | mpc |" in out and "| LateralTracking-v0 | smc |" in out
    pngs = sorted(p.name for p in figures.glob("paper/*/*.png"))  # the run's own folder
    assert "dlc120_v0_trajectories.png" in pngs and "lateraltracking_v0_mpc_vs_smc.png" in pngs
    assert main(["leaderboard", "--store", str(store), "--format", "csv"]) == 0
    csv_text = capsys.readouterr().out
    assert csv_text.startswith("env_id,policy_id") and len(csv_text.strip().splitlines()) == 5  # header + 4


def test_eval_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    store = tmp_path / "b.sqlite"
    assert main(["eval", "--policy", "stanley", "--env", "DLC120-v0", "--store", str(store)]) == 0
    assert "completed" in capsys.readouterr().out
    assert main(["eval", "--policy", "nope", "--env", "DLC120-v0", "--store", str(store)]) == 2
    assert "unknown policy 'nope'" in capsys.readouterr().err
    assert main(["eval", "--policy", str(tmp_path / "agent.zip"), "--env", "DLC120-v0", "--store", str(store)]) == 2
    assert "looks like an agent file" in capsys.readouterr().err
    assert main(["leaderboard", "--store", str(tmp_path / "missing.sqlite")]) == 2
    assert "run `vtrack benchmark` first" in capsys.readouterr().err


def test_help_explains_every_subcommand() -> None:
    out = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "benchmark", "--help"], capture_output=True,
                         text=True, check=True).stdout
    for option in ("--suite", "--policies", "--figures", "--store", "--format", "--quick"):
        assert option in out
