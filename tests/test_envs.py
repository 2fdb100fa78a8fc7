"""The Gymnasium envs: API contracts (Gymnasium's and SB3's own checkers), determinism, vector == scalar."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.config import RewardConfig
from vtrack_gym.envs.observation import OBS

ENV_IDS = vtrack_gym.ENV_IDS


def simple_steering(obs: np.ndarray) -> np.ndarray:
    """A test-local proportional steering law (curvature feedforward + e_y / e_phi feedback), batch-aware."""
    obs = np.atleast_2d(obs)
    delta = 2.91 * obs[:, OBS.CURVATURE] - 0.1 * obs[:, OBS.E_Y] - 0.8 * obs[:, OBS.E_PHI]
    return np.clip(delta / 0.6, -1.0, 1.0).reshape(-1, 1).astype(np.float32)


@pytest.mark.parametrize("env_id", vtrack_gym.ALL_ENV_IDS)
def test_gymnasium_env_checker(env_id: str) -> None:
    from gymnasium.utils.env_checker import check_env

    env = gym.make(env_id).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)


@pytest.mark.parametrize("env_id", vtrack_gym.ALL_ENV_IDS)
def test_sb3_env_checker(env_id: str) -> None:
    from stable_baselines3.common.env_checker import check_env

    env = gym.make(env_id).unwrapped  # an older version still registered warns that a newer one exists: not checked
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, warn=True)


def test_make_without_prior_import() -> None:
    code = "import gymnasium; e = gymnasium.make('vtrack_gym:DLC120-v0'); print(e.reset(seed=0)[0].shape)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"({OBS.size},)"


def test_import_stays_light() -> None:
    """``import vtrack_gym`` must not load numba, torch or matplotlib (import time is benchmarked separately)."""
    code = ("import sys, vtrack_gym; "
            "print(sorted(m for m in ('numba', 'torch', 'matplotlib', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_make_vec_vector_entry_point(env_id: str) -> None:
    envs = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point")
    obs, info = envs.reset(seed=1)
    assert obs.shape == (3, OBS.size) and obs.dtype == np.float32
    obs, rew, term, _trunc, info = envs.step(np.zeros((3, 1), dtype=np.float32))
    assert rew.shape == (3,) and term.dtype == bool and "e_y_m" in info and "_e_y_m" in info


def run_scalar(env_id: str, seed: int, steps: int, options: dict | None = None) -> tuple[np.ndarray, ...]:
    env = gym.make(env_id)
    obs, _ = env.reset(seed=seed, options=options)
    rng = np.random.default_rng(seed)
    all_obs, rews, terms, truncs = [obs], [], [], []
    for _ in range(steps):
        action = simple_steering(obs)[0] + rng.normal(0.0, 0.05, 1).astype(np.float32)
        obs, r, te, tr, _ = env.step(action)
        all_obs.append(obs)
        rews.append(r)
        terms.append(te)
        truncs.append(tr)
        if te or tr:
            break
    return np.array(all_obs), np.array(rews), np.array(terms), np.array(truncs)


@pytest.mark.parametrize("env_id", ["DLC120-v0", "LateralTrackingRandom-v0"])
def test_vector_env_equals_scalar_envs_bit_for_bit(env_id: str) -> None:
    n, seed, steps = 4, 7, 150
    options = {"sensor_noise": 1.0, "initial_lateral_offset_m": 0.3}
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
    obs, _ = envs.reset(seed=seed, options=options)
    rngs = [np.random.default_rng(seed + i) for i in range(n)]
    v_obs, v_rew = [obs], []
    for _ in range(steps):
        noise = np.array([r.normal(0.0, 0.05, 1) for r in rngs], dtype=np.float32)
        obs, rew, term, trunc, _ = envs.step(simple_steering(obs) + noise)
        assert not (term.any() or trunc.any())
        v_obs.append(obs)
        v_rew.append(rew)
    v_obs, v_rew = np.array(v_obs), np.array(v_rew)
    for i in range(n):
        s_obs, s_rew, _, _ = run_scalar(env_id, seed + i, steps, options)
        assert np.array_equal(s_obs, v_obs[:, i])
        assert np.array_equal(s_rew, v_rew[:, i])


def test_same_seed_same_episode() -> None:
    a = run_scalar("LateralTrackingRandom-v0", 3, 300, {"sensor_noise": 2.0})
    b = run_scalar("LateralTrackingRandom-v0", 3, 300, {"sensor_noise": 2.0})
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)
    c = run_scalar("LateralTrackingRandom-v0", 4, 300, {"sensor_noise": 2.0})
    assert not np.array_equal(a[0][:50], c[0][:50])


def test_vector_autoreset_next_step() -> None:
    envs = gym.make_vec("DLC120-v0", num_envs=2, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    full_right = np.array([[-1.0], [0.0]], dtype=np.float32)
    for _ in range(500):
        obs, rew, term, trunc, info = envs.step(full_right)
        if term[0]:
            break
    assert term[0] and info["termination"][0] in ("off_road", "spin_out", "wheel_lift")
    assert rew[0] < RewardConfig().failure_penalty + 1.0  # the failure penalty, once
    obs, rew, term, trunc, info = envs.step(full_right)
    assert rew[0] == 0.0 and not term[0] and not trunc[0]
    assert abs(obs[0, OBS.E_Y]) < 1e-6  # back at the start of the track


def test_bad_actions() -> None:
    env = gym.make("DLC120-v0")
    env.reset(seed=0)
    for bad in (np.array([np.nan], dtype=np.float32), np.array([np.inf], dtype=np.float32)):
        with pytest.raises(ValueError, match="finite"):
            env.step(bad)
    with pytest.raises(ValueError, match="element"):
        env.step(np.zeros(3, dtype=np.float32))
    # Out-of-range actions are clipped: identical to the limit.
    e1, e2 = gym.make("DLC120-v0"), gym.make("DLC120-v0")
    e1.reset(seed=0)
    e2.reset(seed=0)
    for _ in range(5):
        o1 = e1.step(np.array([7.5], dtype=np.float32))[0]
        o2 = e2.step(np.array([1.0], dtype=np.float32))[0]
    assert np.array_equal(o1, o2)


def test_reset_options_validation() -> None:
    env = gym.make("LateralTracking-v0")
    with pytest.raises(ValueError, match="unknown reset option 'friction'"):
        env.reset(options={"friction": 0.5})
    with pytest.raises(ValueError, match=r"'mass_scale' must be in \[0.5, 2.0\]"):
        env.reset(options={"mass_scale": 3.0})
    obs, _ = env.reset(seed=0, options={"initial_lateral_offset_m": 1.0, "friction_mu": 0.5,
                                        "target_speed_mps": 8.0, "actuator_delay_s": 0.05})
    assert obs[OBS.E_Y] == pytest.approx(1.0, abs=1e-4)
    assert obs[OBS.TARGET_SPEED] == pytest.approx(8.0)


def test_actuator_delay_delays_the_command() -> None:
    env = gym.make("DLC120-v0")
    env.reset(seed=0, options={"actuator_delay_s": 0.05})
    deltas = []
    for _ in range(8):
        obs = env.step(np.array([0.5], dtype=np.float32))[0]
        deltas.append(obs[OBS.ROAD_WHEEL_ANGLE])
    assert deltas[4] == 0.0 and deltas[5] > 0.0  # five 10 ms periods of pure delay


def test_pdflc_from_standstill_holds_40kmh_on_the_handling_course() -> None:
    """Case 1 closed loop: 0 -> 40 km/h, then within +-1 km/h over the course's grades (a full lap)."""
    env = gym.make("LateralTracking-v0")
    obs, info = env.reset(seed=0)
    speeds, grades_seen = [], []
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(simple_steering(obs)[0])
        speeds.append(info["v_mps"])
        grades_seen.append(info["z_m"])
        done = term or trunc
    assert info["termination"] == "completed"
    speeds = np.array(speeds)
    t_settle = int(np.argmax(speeds > 40 / 3.6 - 0.28))
    assert t_settle * 0.01 < 15.0
    held = speeds[t_settle + 500:]
    assert np.abs(held - 40 / 3.6).max() < 1.0 / 3.6
    assert np.ptp(grades_seen) > 7.0  # the lap did climb and descend the course's -2.5..+5.2 m


def test_render_rgb_array() -> None:
    env = gym.make("DLC120-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.zeros(1, dtype=np.float32))
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8 and frame.std() > 0
    env.close()


def test_sb3_vec_env_adapter() -> None:
    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("DLC120-v0", num_envs=2)
    venv.seed(0)
    obs = venv.reset()
    assert obs.shape == (2, OBS.size)
    actions = np.array([[-1.0], [0.0]], dtype=np.float32)
    for _ in range(500):
        obs, _rew, done, infos = venv.step(actions)
        if done[0]:
            break
    assert done[0] and "terminal_observation" in infos[0] and not infos[0]["TimeLimit.truncated"]
    assert abs(obs[0, OBS.E_Y]) < 1e-6  # reset in the same step, SB3-style
    norm = VecNormalize(venv)
    norm.reset()
    norm.step(np.zeros((2, 1), dtype=np.float32))


def test_sb3_vec_env_gives_each_car_its_own_set_options() -> None:
    """``set_options`` per sub-env, as SB3 documents it (every car used sub-env 0's options), seeded like single
    envs with s + i."""
    import gymnasium as gym

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("DLC120-v0", num_envs=3)
    venv.set_options([{"initial_lateral_offset_m": 1.0}, {"initial_lateral_offset_m": -1.0}, {}])
    venv.seed(5)
    obs = venv.reset()
    np.testing.assert_allclose(obs[:, OBS.E_Y], [1.0, -1.0, 0.0], atol=1e-9)
    for i, opts in enumerate([{"initial_lateral_offset_m": 1.0}, {"initial_lateral_offset_m": -1.0}, None]):
        single, _ = gym.make("DLC120-v0").reset(seed=5 + i, options=opts)
        np.testing.assert_array_equal(obs[i], single)
    venv.set_options({"initial_lateral_offset_m": 0.5})        # one dict: every car
    np.testing.assert_allclose(venv.reset()[:, OBS.E_Y], 0.5, atol=1e-9)
