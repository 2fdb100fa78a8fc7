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
                 "--run-dir", str(run), "--no-progress", "--no-final-eval", "--set", "batch_size=256"]) == 0
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


def test_train_set_overrides_hyperparameters(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "256", "--num-envs", "2", "--eval-freq", "0",
                 "--run-dir", str(run), "--no-progress", "--no-final-eval", "--set", "n_steps=128",
                 "--set", "batch_size=128",
                 "--set", "policy_kwargs={net_arch: {pi: [8], vf: [8]}, activation_fn: relu}",
                 "--set", "max_grad_norm=null", "--set", "learning_rate=3e-5"]) == 0
    config = json.loads((run / "config.json").read_text())
    assert config["hyperparams"]["n_steps"] == 128 and "max_grad_norm" not in config["hyperparams"]
    assert config["hyperparams"]["learning_rate"] == 3e-5  # a float, though YAML 1.1 reads "3e-5" as a string
    spec = json.loads((run / "agent.json").read_text())
    assert spec["hidden_sizes"] == [8] and spec["activation"] == "relu"
    capsys.readouterr()
    bad = {"learning_rate": "KEY=VALUE", "not-a-name=1": "KEY=VALUE", "n_steps=[1,": "not valid YAML",
           "no_such_option=1": "ppo hyperparameters", "clip_range=abc": "clip_range must be a number or 'lin_X'"}
    for item, message in bad.items():
        assert main(["train", "--algo", "ppo", "--timesteps", "64", "--num-envs", "2", "--eval-freq", "0",
                     "--run-dir", str(tmp_path / "bad"), "--no-progress", "--no-final-eval", "--set", "batch_size=64",
                     "--set", item]) == 2
        assert message in capsys.readouterr().err, item
    assert main(["train", "--algo", "sac", "--timesteps", "64", "--run-dir", str(tmp_path / "bad"),
                 "--bc-dagger-rounds", "3"]) == 2
    assert "apply to a --bc-expert warm start only" in capsys.readouterr().err
