"""vtrack train -> vtrack export -> vtrack eval --policy agent.json, end to end through the CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from vtrack_gym.cli import main


def test_train_export_eval_agent_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "512", "--num-envs", "2", "--eval-freq", "0",
                 "--run-dir", str(run), "--no-progress", "--no-final-eval"]) == 0
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "exported")]) == 0
    a = np.load(run / "agent.npz", allow_pickle=False)
    b = np.load(tmp_path / "exported.npz", allow_pickle=False)
    assert sorted(a.files) == sorted(b.files)
    for key in a.files:  # re-export of the saved model = the agent written at the end of training
        assert np.array_equal(a[key], b[key]), key
    capsys.readouterr()
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", str(tmp_path / "exported.json"), "--env", "DLC120-v0",
                 "--store", str(store)]) == 0
    assert "| seed |" in capsys.readouterr().out
    assert main(["export", "--run-dir", str(tmp_path / "nope"), "--out", str(tmp_path / "x")]) == 2
    assert "not a `vtrack train` run folder" in capsys.readouterr().err
