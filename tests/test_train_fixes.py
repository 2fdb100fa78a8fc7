"""`vtrack train` / `vtrack export` fixes, through the CLI (``vtrack_gym.cli.main``) and ``train``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)

from vtrack_gym.cli import main  # noqa: E402

FAST = ["--num-envs", "2", "--eval-freq", "0", "--no-progress", "--no-final-eval"]
"""Options of a smoke-size CLI run (2 cars, no evaluation)."""
PPO_SMALL = ["--set", "n_steps=32", "--set", "batch_size=64", "--set", "n_epochs=1"]
"""PPO hyperparameters of a smoke-size run (64 transitions per rollout with 2 cars)."""


def test_warm_start_keeps_fixed_observation_scales(tmp_path: Path) -> None:
    """With ``obs_scaling: fixed`` the exported agent carries the fixed table after a warm start, not the
    expert data's statistics (e_y 0.25 m per unit)."""
    from vtrack_gym.agents.obs_scaling import fixed_statistics

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--env", "vtrack/TrainingMix-v0", "--bc-expert", "lqr", "--bc-steps",
                 "50", "--bc-dagger-rounds", "0", "--timesteps", "64", "--run-dir", str(run), *FAST,
                 *PPO_SMALL]) == 0
    assert json.loads((run / "config.json").read_text())["hyperparams"]["obs_scaling"] == "fixed"
    spec = json.loads((run / "agent.json").read_text())
    arrays = np.load(run / "agent.npz", allow_pickle=False)
    mean, var = fixed_statistics(spec["env"]["observation_names"])
    np.testing.assert_allclose(arrays["obs_mean"], mean, rtol=1e-6)
    np.testing.assert_allclose(arrays["obs_var"], var, rtol=1e-6)
    assert float(np.sqrt(arrays["obs_var"][spec["env"]["observation_names"].index("e_y")])) == pytest.approx(0.25)
