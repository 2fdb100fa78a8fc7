"""Training leaves nothing in the temporary directory: stable-baselines3's default logger (a ``learn()`` without a
logger) makes a ``SB3-<date>`` folder there per call; the package's training logs into the run folder, or
nowhere when there is none (``agents.sb3_logger``)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")


@pytest.fixture
def fresh_tmpdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A new, empty ``$TMPDIR`` for this process (``tempfile.gettempdir()``) and its children; SB3's default logger
    not redirected (the session's ``SB3_LOGDIR`` removed)."""
    folder = tmp_path / "tmpdir"
    folder.mkdir()
    monkeypatch.setenv("TMPDIR", str(folder))
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    return folder


def _sb3_folders(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.glob("SB3-*"))


def test_sb3s_default_logger_would_make_a_folder_there(fresh_tmpdir: Path) -> None:
    """The check below sees what SB3 does by default: one folder per logger it makes."""
    from stable_baselines3.common.utils import configure_logger

    configure_logger(verbose=0)
    assert len(_sb3_folders(fresh_tmpdir)) == 1


def test_vtrack_train_logs_into_its_run_folder_only(fresh_tmpdir: Path, tmp_path: Path) -> None:
    from vtrack_gym.cli import main

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "256", "--num-envs", "2", "--eval-freq", "0",
                 "--run-dir", str(run), "--no-progress", "--no-final-eval", "--set", "n_steps=128",
                 "--set", "batch_size=128"]) == 0
    assert _sb3_folders(fresh_tmpdir) == []
    assert "time/total_timesteps" in (run / "logs" / "progress.csv").read_text()


def test_lagrangian_ppo_logs_nowhere(fresh_tmpdir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from vtrack_gym.agents.lagrangian import train_lagrangian_ppo

    model, env = train_lagrangian_ppo("LateralTracking-v0", 256, num_envs=2, seed=0,
                                      ppo_kwargs={"n_steps": 128, "batch_size": 128, "n_epochs": 1})
    assert _sb3_folders(fresh_tmpdir) == []
    assert model.num_timesteps == 256 and len(env.history) == 1
    assert model.logger.get_dir() is None and capsys.readouterr().out == ""


def test_quiet_logger_prints_the_table_with_verbose(capsys: pytest.CaptureFixture[str],
                                                    fresh_tmpdir: Path) -> None:
    from vtrack_gym.agents.sb3_logger import quiet_logger

    for verbose in (0, 1):
        logger = quiet_logger(verbose)
        logger.record("train/value", float(np.float32(1.5)))
        logger.dump(step=1)
    out = capsys.readouterr().out
    assert out.count("value") == 1 and "1.5" in out   # one table: verbose=1 only
    assert list(fresh_tmpdir.iterdir()) == []


def test_every_trainer_that_calls_learn_sets_its_logger_first() -> None:
    """Each package module that runs an SB3 ``learn`` gives the model its logger (``log_outside_tmp``) before it, so
    no trainer falls back to SB3's default logger and its folder in $TMPDIR."""
    import ast

    import vtrack_gym

    package = Path(vtrack_gym.__file__).parent
    trainers = []
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        calls = [node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
                 for node in ast.walk(tree) if isinstance(node, ast.Call)]
        if "learn" in calls:
            trainers.append(path.name)
            assert "log_outside_tmp" in calls, f"{path.relative_to(package)} calls learn() without log_outside_tmp"
    assert {"train.py", "lagrangian.py", "race_finetune.py"} <= set(trainers)
