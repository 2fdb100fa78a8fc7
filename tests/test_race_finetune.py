"""The race fine-tune through ``vtrack train --algo sac --env vtrack/Race-v0 --init-from AGENT``: a tiny run end to
end (the loaded actor, SAC updates on the race reward over the race split's training circuits, the exported agent)
and the options it refuses before any work."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import gymnasium as gym
import pytest

import vtrack_gym
from vtrack_gym.cli import main
from vtrack_gym.tracks.race_circuits import RACE_SPLIT

pytest.importorskip("stable_baselines3")


def test_cli_race_finetune_runs_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """One demonstration race of ``dagger_race_v2``, 400 SAC steps (the critics alone for the first 200): the actor is
    loaded exactly, moved by the actor updates, and exported as a race agent that binds to a race id by name. SB3
    logs into the run folder: nothing lands in $TMPDIR."""
    fresh = tmp_path / "tmpdir"
    fresh.mkdir()
    monkeypatch.setenv("TMPDIR", str(fresh))
    monkeypatch.setattr(tempfile, "tempdir", str(fresh))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    run = tmp_path / "ft"
    assert main(["train", "--algo", "sac", "--env", "vtrack/Race-v0", "--init-from", "dagger_race_v2",
                 "--timesteps", "400", "--set", "demo_races=1", "--set", "critic_warmup_steps=200",
                 "--set", "learning_starts=100", "--run-dir", str(run)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["load_check"] < 1e-5 and summary["demo_races"] == ["completed"]
    assert summary["actor_max_abs_change"] > 0.0
    assert list(fresh.glob("SB3-*")) == []
    config = json.loads((run / "config.json").read_text())
    assert config["circuits"] == list(RACE_SPLIT["train"]) and config["finetune"]["critic_warmup_steps"] == 200
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy(summary["agent"], env)
    assert policy.spec["env"]["observation_names"] == vtrack_gym.make_policy("dagger_race_v2", env).spec["env"][
        "observation_names"]
    assert "--init-from dagger_race_v2" in policy.provenance["command"]
    assert env.action_space.contains(policy.predict(env.reset(seed=0)[0])[0])


def test_cli_race_finetune_refuses_other_settings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "r"
    base = ["train", "--init-from", "dagger_race_v2", "--run-dir", str(run)]
    assert main([*base, "--algo", "ppo", "--env", "vtrack/Race-v0"]) == 2
    assert "--algo sac --env vtrack/Race-v0" in capsys.readouterr().err
    assert main([*base, "--algo", "sac", "--env", "DLC120-v0"]) == 2
    assert "--algo sac --env vtrack/Race-v0" in capsys.readouterr().err
    assert main([*base, "--algo", "sac", "--env", "vtrack/Race-v0", "--set", "n_steps=3"]) == 2
    assert "not a race fine-tune setting" in capsys.readouterr().err
    assert main([*base[:2], "ppo", *base[3:], "--algo", "sac", "--env", "vtrack/Race-v0"]) == 2
    assert "must be a race agent" in capsys.readouterr().err
    assert not run.exists()
