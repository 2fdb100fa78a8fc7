"""The from-scratch RL recipes, end to end at CI size: `vtrack train` on the training mix (the default env) with the
shipped hyperparameters, the periodic paper evaluation, the export, and the agent driving a paper env at 100 Hz.

The full runs (millions of steps) are ``benchmarks/rl_recipes.py``; these check that the recipe is what the README
says: fixed observation scales that never move, the 20 Hz decision period recorded in the agent, a bounded
reward that pays every step of driving, and success verdicts in the training evaluations.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import vtrack_gym
from vtrack_gym.agents.obs_scaling import CLIP, fixed_statistics
from vtrack_gym.agents.recipes import FIXED_SCALING_CALLBACK
from vtrack_gym.agents.train import DEFAULT_ENV_ID, load_hyperparams
from vtrack_gym.cli import main
from vtrack_gym.envs.config import RewardConfig


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_recipe_trains_exports_and_drives(algo: str, tmp_path: Path, caplog: pytest.LogCaptureFixture,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / algo
    extra = ["--set", "learning_starts=256"] if algo == "sac" else ["--set", "n_steps=64"]
    assert main(["train", "--algo", algo, "--timesteps", "2048", "--eval-freq", "2048", "--case1-max-steps", "300",
                 "--run-dir", str(run), "--no-progress", "--no-final-eval", *extra]) == 0
    capsys.readouterr()
    config = json.loads((run / "config.json").read_text())
    assert config["env_id"] == DEFAULT_ENV_ID == "vtrack/TrainingMix20Hz-v0"
    assert config["hyperparams"]["callback"] == FIXED_SCALING_CALLBACK
    assert config["bc"] is None  # from scratch: no warm start
    rows = [json.loads(line) for line in (run / "evaluations.jsonl").read_text().splitlines()]
    assert rows and all(isinstance(r["results"]["DLC120-v0"]["success"], bool) for r in rows)

    spec = json.loads((run / "agent.json").read_text())
    assert spec["env"]["control_period_s"] == pytest.approx(0.05)
    arrays = np.load(run / "agent.npz", allow_pickle=False)
    mean, var = fixed_statistics(spec["env"]["observation_names"])
    # the fixed scales went into the agent unchanged after 2048 steps of training
    np.testing.assert_allclose(arrays["obs_mean"], mean.astype(np.float32))
    np.testing.assert_allclose(arrays["obs_var"], var.astype(np.float32))
    assert float(arrays["clip_obs"][0]) == CLIP

    env = gym.make("DLC120-v0")  # the paper env at its own 100 Hz
    with caplog.at_level(logging.WARNING):
        policy = vtrack_gym.make_policy(str(run / "agent.json"), env)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]  # a faster period is not a warning
    obs, _ = env.reset(seed=0)
    for _ in range(50):
        action, _ = policy.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(action)
        assert np.isfinite(reward) and -1.0 <= float(action[0]) <= 1.0
        if terminated or truncated:
            break


def test_recipe_hyperparameters_are_from_scratch_and_20hz() -> None:
    for algo in ("ppo", "sac"):
        params, _ = load_hyperparams(algo, "vtrack/TrainingMix20Hz-v0")
        assert "bc_finetune" not in params and "bc_weight" not in params and "env_kwargs" not in params
        assert params["callback"] == FIXED_SCALING_CALLBACK
    assert gym.spec("vtrack/TrainingMix20Hz-v0").kwargs == {"scenario": "TrainingMix-v0", "control_period_s": 0.05}


def test_reward_pays_every_step_of_driving() -> None:
    """With the default weights no step of driving earns less than 0.15, however large the errors or the
    steering jerk, so ending an episode early (and taking the failure penalty) never pays."""
    r = RewardConfig()
    worst = r.alive - r.w_ey - r.w_ephi - r.w_effort - r.w_rate
    assert worst == pytest.approx(0.15)
    env = gym.make("vtrack/TrainingMix-v0")
    env.reset(seed=3)
    rewards = []
    for k in range(200):  # bang-bang steering: large errors, full effort and rate
        _, reward, terminated, truncated, info = env.step(np.array([1.0 if k % 2 else -1.0], dtype=np.float32))
        if terminated or truncated:
            assert info["termination"] != "completed"
            assert info["reward_terminal"] == r.failure_penalty
            break
        rewards.append(reward)
    assert min(rewards) >= worst - 1e-12


def test_learning_rate_schedules() -> None:
    from vtrack_gym.agents.train import _schedule

    assert _schedule("learning_rate", 3e-4) == 3e-4
    lin = _schedule("learning_rate", "lin_3e-4")
    assert lin(1.0) == pytest.approx(3e-4) and lin(0.5) == pytest.approx(1.5e-4) and lin(0.0) == 0.0
    for bad in ("lin_", "lin_-1", "exp_3e-4", "lin_nan", "lin_inf"):
        with pytest.raises(ValueError, match="learning_rate must be a number or 'lin_X'"):
            _schedule("learning_rate", bad)


def test_readme_plain_sb3_recipe_runs_at_smoke_size(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """The RL tutorial's plain-SB3 block, as typed, with its STEPS line cut to a smoke run (the full run is
    ``benchmarks/rl_recipes.py``'s `plain` ablation)."""
    import re

    readme = (Path(__file__).resolve().parents[1] / "docs" / "tutorials" / "rl-training.md").read_text(encoding="utf-8")
    blocks = [b for b in re.findall(r"```python\n(.*?)```", readme, re.DOTALL) if "TrackingSB3VecEnv(" in b]
    assert len(blocks) == 1
    code, n = re.subn(r"^STEPS = .*$", "STEPS = 1024", blocks[0], flags=re.MULTILINE)
    assert n == 1
    code = code.replace('"paper"', '"DLC120-v0"')  # one short episode instead of the 215 s Case-1 lap
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/tutorials/rl-training.md (plain SB3 recipe)", "exec"), {"__name__": "__readme__"})
    assert "DLC120-v0" in capsys.readouterr().out
