"""The hyperparameter files are rl_zoo3's format: rl_zoo3 trains from the shipped file as it is, every key of every
entry is one rl_zoo3 or the SB3 constructor takes, and ``vtrack train``'s reader evaluates nothing."""

from __future__ import annotations

import inspect
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("stable_baselines3")

from vtrack_gym.agents.obs_scaling import FrozenStatistics, fixed_statistics
from vtrack_gym.agents.recipes import (
    ALGOS,
    EXTENSIONS_FILE,
    HYPERPARAMS_DIR,
    RECIPE_ENV_ID,
    load_hyperparams,
    parse_policy_kwargs,
)

ROOT = Path(__file__).resolve().parents[1]
ZOO_KEYS = frozenset({"n_timesteps", "n_envs", "policy", "normalize", "callback", "env_wrapper", "vec_env_wrapper",
                      "frame_stack", "noise_type", "noise_std", "env_kwargs", "monitor_kwargs"})
"""Keys rl_zoo3 consumes itself (``ExperimentManager._preprocess_hyperparams``); every other key reaches SB3."""


def _constructor_keys(algo: str) -> set[str]:
    import stable_baselines3

    cls = getattr(stable_baselines3, algo.upper())
    return set(inspect.signature(cls.__init__).parameters) - {"self", "policy", "env"}


@pytest.mark.parametrize("algo", ALGOS)
def test_every_key_is_one_rl_zoo3_or_sb3_takes(algo: str) -> None:
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)

    data = yaml.safe_load((HYPERPARAMS_DIR / f"{algo}.yaml").read_text())
    assert RECIPE_ENV_ID in data
    for env_id, entry in data.items():
        gym.spec(env_id)  # every key is a registered id
        unknown = set(entry) - ZOO_KEYS - _constructor_keys(algo)
        assert not unknown, (algo, env_id, unknown)
        assert isinstance(entry["n_timesteps"], int) and entry["n_timesteps"] > 0
        assert entry["normalize"]["gamma"] == entry["gamma"]  # rl_zoo3 sets the VecNormalize gamma to gamma
        assert isinstance(entry["policy_kwargs"], str)  # rl_zoo3 evaluates it; vtrack parses it
        parse_policy_kwargs(entry["policy_kwargs"])
    extensions = yaml.safe_load(EXTENSIONS_FILE.read_text())
    for env_id in (extensions.get(algo) or {}):
        assert env_id in data, f"extensions.yaml: {algo}/{env_id} has no entry in {algo}.yaml"


def test_policy_kwargs_are_parsed_never_evaluated() -> None:
    assert parse_policy_kwargs("dict(net_arch=dict(pi=[64, 64], vf=[64]), activation_fn=nn.Tanh, log_std_init=-1.0)") \
        == {"net_arch": {"pi": [64, 64], "vf": [64]}, "activation_fn": "tanh", "log_std_init": -1.0}
    assert parse_policy_kwargs({"net_arch": [8]}) == {"net_arch": [8]}
    for bad, match in (("__import__('os').system('true')", "only dict"), ("dict(activation_fn=nn.GELU)", "nn.GELU"),
                       ("dict(**x)", r"\*\*"), ("dict(net_arch=[64", "not a dict"), ("[1, 2]", "mapping")):
        with pytest.raises(ValueError, match=match):
            parse_policy_kwargs(bad)


def test_extensions_merge_into_the_entry() -> None:
    params, _ = load_hyperparams("sac", RECIPE_ENV_ID)
    assert params["temporal_smoothness"] == params["spatial_smoothness"] == 0.3
    params, _ = load_hyperparams("ppo", "vtrack/LateralTrackingRandom-v0")  # the other spelling of the id
    assert params["bc_finetune"]["learning_rate"] == 1.0e-5


@pytest.mark.slow
def test_rl_zoo3_trains_from_the_shipped_file(tmp_path: Path) -> None:
    """``python -m rl_zoo3.train`` with the shipped ppo.yaml, CI-sized (256 steps, 2 cars), and the fixed
    observation scales in the VecNormalize it saves."""
    pytest.importorskip("rl_zoo3")
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", RECIPE_ENV_ID, "--gym-packages",
           "vtrack_gym", "--conf-file", str(HYPERPARAMS_DIR / "ppo.yaml"), "-n", "256", "--hyperparams", "n_envs:2",
           "n_steps:64", "batch_size:64", "n_epochs:1", "--eval-freq", "-1", "-f", str(tmp_path), "--seed", "0"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    run = tmp_path / "ppo" / "vtrack-TrainingMix20Hz-v0_1"
    assert (run / "vtrack-TrainingMix20Hz-v0.zip").is_file()
    with (run / "vtrack-TrainingMix20Hz-v0" / "vecnormalize.pkl").open("rb") as fh:
        vecnorm = pickle.load(fh)  # written by this test's own run
    import gymnasium as gym

    names = gym.make(RECIPE_ENV_ID).unwrapped.observation_layout.names
    mean, var = fixed_statistics(names)
    assert isinstance(vecnorm.obs_rms, FrozenStatistics)
    np.testing.assert_array_equal(vecnorm.obs_rms.mean, mean)
    np.testing.assert_array_equal(vecnorm.obs_rms.var, var)
