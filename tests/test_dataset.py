"""Minari export: a small dataset written locally round-trips (episodes, seeds, options, the env spec), and the
recovered env replays the stored actions into the stored observations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("minari")
pytest.importorskip("h5py")

import minari

from vtrack_gym.evaluation.benchmarking.dataset import dataset_episodes, dataset_id, start_options, write_dataset
from vtrack_gym.evaluation.suite.suites import ROBUST_FRICTION, robust_options


def _replay(dataset, episode_index: int) -> None:
    """Reset the recovered env with the episode's seed and options, replay its actions: same observations."""
    env = dataset.recover_environment()
    meta = next(iter(dataset.storage.get_episode_metadata([episode_index])))
    episode = dataset[episode_index]
    options = {k: float(v) for k, v in meta["options"].items()} if "options" in meta else None
    obs, _ = env.reset(seed=int(meta["seed"]), options=options)
    np.testing.assert_array_equal(obs, episode.observations[0])
    for k, action in enumerate(episode.actions):
        obs, reward, terminated, truncated, _ = env.step(action)
        np.testing.assert_array_equal(obs, episode.observations[k + 1])
        assert reward == pytest.approx(episode.rewards[k], abs=1e-6)
        assert (terminated, truncated) == (episode.terminations[k], episode.truncations[k])
    env.close()


def test_dataset_round_trip(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MINARI_DATASETS_PATH", raising=False)
    ids = write_dataset("lqr", env="DLC120-v0", episodes=2, seed=3, root=tmp_path)
    assert ids == ["vtrack/DLC120/lqr-env-v0"]
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(ids[0])
    assert dataset.total_episodes == 2
    assert dataset.spec.env_spec.id == "DLC120-v0"
    assert dataset.spec.env_spec.entry_point == "vtrack_gym.envs.tracking_env:TrackingEnv"
    assert [m["seed"] for m in dataset.storage.get_episode_metadata([0, 1])] == [3, 4]
    first = dataset[0]
    assert first.observations.shape == (len(first.actions) + 1, 43) and first.actions.shape[1] == 1
    assert first.terminations[-1] or first.truncations[-1]
    assert np.all(np.abs(first.actions) <= 1.0)
    assert not np.array_equal(first.observations[0], dataset[1].observations[0])  # two seeds, two episodes
    assert first.infos["e_y_m"].shape == (len(first.actions) + 1,)
    np.testing.assert_allclose(first.infos["e_y_m"][0], start_options(3)["initial_lateral_offset_m"], atol=1e-9)
    assert first.infos["success"].dtype == bool and "termination" not in first.infos
    _replay(dataset, 1)
    with pytest.raises(ValueError, match="already exist"):  # Minari never overwrites: refused before driving
        write_dataset("lqr", env="DLC120-v0", episodes=1, root=tmp_path)


def test_suite_episodes_keep_their_options(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    grouped = dataset_episodes(suite="robust", episodes=2, seed=5)
    assert list(grouped) == ["LateralTracking-v0", "DLC120-v0"]
    dlc = grouped["DLC120-v0"]
    assert [ep.seed for ep in dlc] == [5, 6]
    assert dlc[0].options == {**robust_options(5, dlc_speed(), ROBUST_FRICTION["DLC120-v0"]), **start_options(5)}
    monkeypatch.setattr("vtrack_gym.evaluation.benchmarking.dataset.dataset_episodes",
                        lambda *a, **k: {"DLC120-v0": dlc[:1]})  # drive only the short scenario
    ids = write_dataset("lqr", suite="robust", episodes=1, root=tmp_path)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset = minari.load_dataset(ids[0])
    meta = next(iter(dataset.storage.get_episode_metadata([0])))
    assert {k: float(v) for k, v in meta["options"].items()} == pytest.approx(dlc[0].options)
    _replay(dataset, 0)


def dlc_speed() -> float:
    from vtrack_gym.envs.config import DLC120

    return DLC120.speed.target_speed_mps


def test_bad_requests_are_refused() -> None:
    with pytest.raises(ValueError, match="exactly one of suite"):
        dataset_episodes()
    with pytest.raises(ValueError, match="exactly one of suite"):
        dataset_episodes(suite="paper", env="DLC120-v0")
    with pytest.raises(ValueError, match="suite must be one of"):
        dataset_episodes(suite="highway")
    with pytest.raises(ValueError, match=r"episodes must be an integer in \[1, 10000\]"):
        dataset_episodes(env="DLC120-v0", episodes=0)
    with pytest.raises(ValueError, match="registered vtrack env id"):
        dataset_episodes(env="CartPole-v1")
    assert dataset_id("vtrack/ISO3888-1-v0", "mpc:paper") == "vtrack/ISO3888-1/mpc_paper-v0"


def test_vtrack_dataset_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                capsys: pytest.CaptureFixture[str]) -> None:
    from vtrack_gym.cli import main

    assert main(["dataset", "--policy", "lqr", "--env", "DLC120-v0", "--episodes", "1", "--name", "cli",
                 "--root", str(tmp_path), "--no-progress"]) == 0
    assert capsys.readouterr().out.split() == ["vtrack/DLC120/cli-v0"]
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    assert minari.load_dataset("vtrack/DLC120/cli-v0").total_episodes == 1
    assert main(["dataset", "--policy", "lqr", "--env", "CartPole-v1", "--root", str(tmp_path)]) == 2
    assert "registered vtrack env id" in capsys.readouterr().err


def test_dataset_root_is_checked_and_a_half_written_dataset_never_blocks_a_rerun(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """``--root`` that is a file is refused before any episode; a write that dies midway leaves no dataset under
    its id (only a hidden staging folder), so the same command run again writes it."""
    from vtrack_gym.cli import main

    a_file = tmp_path / "not_a_folder"
    a_file.write_text("x")
    argv = ["dataset", "--policy", "lqr", "--env", "DLC120-v0", "--name", "retry", "--no-progress"]
    assert main([*argv, "--root", str(a_file / "sub")]) == 2
    assert "--root" in capsys.readouterr().err

    real = minari.create_dataset_from_buffers

    def dies_midway(dataset_id: str, *args: object, **kwargs: object) -> None:
        from minari.storage.datasets_root_dir import get_dataset_path

        (get_dataset_path(dataset_id) / "data").mkdir(parents=True)   # what a killed writer leaves
        raise KeyboardInterrupt

    root = tmp_path / "datasets"
    monkeypatch.setattr(minari, "create_dataset_from_buffers", dies_midway)
    assert main([*argv, "--root", str(root)]) == 130
    monkeypatch.setattr(minari, "create_dataset_from_buffers", real)
    assert main([*argv, "--root", str(root)]) == 0
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    assert minari.load_dataset("vtrack/DLC120/retry-v0").total_episodes == 1
    assert not [p for p in root.iterdir() if p.name.startswith(".vtrack-writing-")]


def test_vtrack_dataset_records_a_class_of_your_own(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from vtrack_gym.cli import main

    (tmp_path / "my_steer.py").write_text(
        "import numpy as np\n\n"
        "class Steer:\n"
        "    def __init__(self, k_y=0.1):\n"
        "        self.k_y = k_y\n\n"
        "    def predict(self, obs, state=None, episode_start=None, deterministic=True):\n"
        "        return np.array([-self.k_y * obs[0]], dtype=np.float32), None\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("MINARI_DATASETS_PATH", raising=False)
    args = ["dataset", "--policy", "my_steer:Steer", "--policy-kwargs", '{"k_y": 0.2}', "--env", "DLC120-v0",
            "--episodes", "2", "--root", str(tmp_path / "ds"), "--no-progress"]
    assert main(args) == 2 and "--trust-code" in capsys.readouterr().err
    assert main([*args, "--trust-code"]) == 0
    assert capsys.readouterr().out.split() == ["vtrack/DLC120/my_steer_Steer-env-v0"]
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path / "ds"))
    dataset = minari.load_dataset("vtrack/DLC120/my_steer_Steer-env-v0")
    assert dataset.total_episodes == 2 and dataset.storage.metadata["algorithm_name"] == "my_steer:Steer"
