"""BCRegularisedSAC: its BC term pulls the actor to the demonstrations, it saves/loads as plain SAC, bad input."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)


def _model(bc_weight: float, seed: int = 0, **kwargs):
    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym.agents.regularised_sac import BCRegularisedSAC
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("LateralTrackingRandom-v0", num_envs=4)
    venv.seed(seed)
    vecnorm = VecNormalize(venv, norm_obs=True, norm_reward=False)
    params = {"learning_starts": 0, "buffer_size": 5000, "batch_size": 64, "learning_rate": 3e-3,
              "policy_kwargs": {"net_arch": [32, 32]}, **kwargs}
    return BCRegularisedSAC("MlpPolicy", vecnorm, bc_weight=bc_weight, seed=seed, device="cpu", **params), venv


def _demo(venv, n: int = 400, target: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    obs = venv.reset()
    rows = [obs]
    for _ in range(n // obs.shape[0] - 1):
        obs, *_ = venv.step(np.zeros((venv.num_envs, 1), dtype=np.float32))
        rows.append(obs)
    states = np.concatenate(rows)
    return states, np.full((states.shape[0], 1), target, dtype=np.float32)


def _mean_demo_action(model, states: np.ndarray) -> float:
    action, _ = model.predict(model.get_vec_normalize_env().normalize_obs(states), deterministic=True)
    return float(np.mean(action))


def test_bc_term_pulls_the_actor_to_the_demonstrated_action():
    """Demonstrations that all say 0.3: with a strong BC weight the deterministic action goes there; with
    bc_weight = 0 (the normalised SAC loss alone) it does not."""
    results = {}
    for weight in (0.0, 100.0):
        model, venv = _model(weight)
        states, labels = _demo(venv)
        model.set_demonstrations(states, labels)
        model.learn(total_timesteps=600)  # 150 vector steps, 150 gradient steps
        results[weight] = _mean_demo_action(model, states)
        logged = model.logger.name_to_value
        assert ("train/bc_mse" in logged) == (weight > 0.0)
        venv.close()
    assert abs(results[100.0] - 0.3) < 0.05, results
    assert abs(results[0.0] - 0.3) > 0.1, results


def test_saves_and_loads_as_plain_sac(tmp_path):
    from stable_baselines3 import SAC

    model, venv = _model(10.0)
    states, labels = _demo(venv, n=80)
    model.set_demonstrations(states, labels)
    model.learn(total_timesteps=200)
    model.save(tmp_path / "m.zip")
    loaded = SAC.load(tmp_path / "m.zip", device="cpu")
    x = model.get_vec_normalize_env().normalize_obs(states)
    np.testing.assert_array_equal(model.predict(x, deterministic=True)[0], loaded.predict(x, deterministic=True)[0])
    assert not hasattr(loaded, "_demo_obs")  # the demonstrations are not saved
    venv.close()


def test_bad_settings_are_refused():
    from vtrack_gym.agents.regularised_sac import BCRegularisedSAC

    with pytest.raises(ValueError, match="bc_weight must be a finite number >= 0"):
        BCRegularisedSAC("MlpPolicy", "Pendulum-v1", bc_weight=-1.0)
    with pytest.raises(ValueError, match="bc_batch_size must be a positive int"):
        BCRegularisedSAC("MlpPolicy", "Pendulum-v1", bc_batch_size=0)
    model, venv = _model(1.0)
    with pytest.raises(ValueError, match="demonstrations must be a non-empty finite"):
        model.set_demonstrations(np.full((3, venv.observation_space.shape[0]), np.nan), np.zeros(3))
    venv.close()
    with pytest.raises(ValueError, match="gSDE"):
        _model(1.0, use_sde=True)


def test_bc_weight_needs_sac_and_a_warm_start(tmp_path):
    from vtrack_gym.agents.train import train

    with pytest.raises(ValueError, match="bc_weight applies to --algo sac with a --bc-expert warm start"):
        train("sac", timesteps=100, run_dir=tmp_path, num_envs=2, overrides={"bc_weight": 1.0}, eval_freq=0,
              final_eval=False, progress_bar=False)
