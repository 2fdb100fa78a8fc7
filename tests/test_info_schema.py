"""One ``info`` schema (``envs.schema.INFO_KEYS``) for the single env, the vector env, the highway-env adapter and
``Trace``; the same keys at reset and step with stable types; kernel offsets derived from the named fields."""

from __future__ import annotations

from dataclasses import asdict

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.envs.config import DLC120, EnvConfig
from vtrack_gym.envs.observation import OBS
from vtrack_gym.envs.schema import ARRAY_SIGNALS, INFO_KEYS, REWARD_TERMS, SAFETY_SIGNALS, SCALAR_SIGNALS, SIGNAL_ROW
from vtrack_gym.evaluation.scoring.trace import STEP_SIGNALS, Trace


def _check_single_info(info: dict, n_sub: int) -> None:
    assert tuple(info) == INFO_KEYS
    for key in (*SCALAR_SIGNALS, *REWARD_TERMS):
        assert type(info[key]) is np.float64, key
    assert info["fz_n"].dtype == np.float64 and info["fz_n"].shape == (4,)
    assert info["acc_substeps_mps2"].dtype == np.float64 and info["acc_substeps_mps2"].shape == (n_sub, 3)
    assert type(info["termination"]) is str
    assert type(info["success"]) is bool and (info["success"] is False or info["termination"] != "")
    assert type(info["cost"]) is np.float64 and info["cost"] in (0.0, 1.0)
    assert type(info["edge_margin_m"]) is np.float64


def _check_vector_info(info: dict, n: int, n_sub: int) -> None:
    assert tuple(k for k in info if not k.startswith("_")) == INFO_KEYS
    assert all(info["_" + k].all() for k in INFO_KEYS)
    for key in (*SCALAR_SIGNALS, *REWARD_TERMS):
        assert info[key].dtype == np.float64 and info[key].shape == (n,), key
    assert info["fz_n"].dtype == np.float64 and info["fz_n"].shape == (n, 4)
    assert info["acc_substeps_mps2"].dtype == np.float64 and info["acc_substeps_mps2"].shape == (n, n_sub, 3)
    assert info["termination"].shape == (n,) and all(type(t) is str for t in info["termination"])
    assert info["success"].dtype == bool and info["success"].shape == (n,)
    for key in SAFETY_SIGNALS:
        assert info[key].dtype == np.float64 and info[key].shape == (n,), key


def test_schema_tuples_partition_the_keys() -> None:
    assert len(set(INFO_KEYS)) == len(INFO_KEYS)
    assert set(INFO_KEYS) == {*SCALAR_SIGNALS, *REWARD_TERMS, *ARRAY_SIGNALS, "termination", "success",
                              *SAFETY_SIGNALS}
    assert SIGNAL_ROW == SCALAR_SIGNALS[1:] + REWARD_TERMS
    assert STEP_SIGNALS == SCALAR_SIGNALS


def test_single_env_same_keys_at_reset_and_step_and_terms_sum_to_reward() -> None:
    env = gym.make("DLC120-v0")
    n_sub = env.unwrapped.config.n_substeps
    _, info = env.reset(seed=3)
    _check_single_info(info, n_sub)
    assert all(info[k] == 0.0 for k in REWARD_TERMS)
    infos = []
    for _ in range(5):
        obs, reward, _, _, info = env.step(np.array([0.02], dtype=np.float32))
        _check_single_info(info, n_sub)
        infos.append(info)
        assert sum(info[k] for k in REWARD_TERMS) == pytest.approx(reward, abs=1e-12)
        # the observation carries the same state at its named indices
        assert obs[OBS.V_X] == np.float32(info["v_mps"])
        assert obs[OBS.E_Y] == np.float32(info["e_y_m"])
        assert obs[OBS.TARGET_SPEED] == np.float32(info["target_speed_mps"])
        assert obs[OBS.ROAD_WHEEL_ANGLE] == np.float32(info["road_wheel_angle_rad"])
    assert info["steering_command_rad"] == pytest.approx(0.02 * env.unwrapped.config.vehicle.steering
                                                         .max_road_wheel_angle_rad)
    trace = Trace.from_infos(infos, env_id="DLC120-v0", policy_id="x", seed=3, physics_rate_hz=500.0,
                             control_period_s=0.01, termination="max_steps", wall_time_s=1.0)
    assert tuple(trace.signals) == SCALAR_SIGNALS and trace.n_steps == 5
    assert trace.acc_physics_mps2.shape == (5 * n_sub, 3)
    env.close()


def test_vector_env_same_keys_at_reset_and_step_and_matches_single_env() -> None:
    n = 3
    envs = gym.make_vec("DLC120-v0", num_envs=n, vectorization_mode="vector_entry_point")
    n_sub = envs.unwrapped.config.n_substeps
    _, info = envs.reset(seed=7)
    _check_vector_info(info, n, n_sub)
    assert all((info[k] == 0.0).all() for k in REWARD_TERMS)
    single = gym.make("DLC120-v0")
    _, s_info = single.reset(seed=8)  # car 1 of the batch
    actions = np.full((n, 1), 0.01, dtype=np.float32)
    for _ in range(3):
        _, _, _, _, info = envs.step(actions)
        _, _, _, _, s_info = single.step(actions[1])
        _check_vector_info(info, n, n_sub)
    for key in INFO_KEYS:
        assert np.array_equal(np.asarray(info[key][1]), np.asarray(s_info[key]), equal_nan=key == "edge_margin_m"), key
    envs.close()
    single.close()


def test_highway_adapter_info_schema() -> None:
    pytest.importorskip("highway_env")
    from vtrack_gym.interop.highway import HighwayLaneKeeping

    env = HighwayLaneKeeping()
    n_acc = round(env.control_period_s / env.config.physics_dt_s)
    obs, info = env.reset(seed=0)
    _check_single_info(info, n_acc)
    assert all(info[k] == 0.0 for k in REWARD_TERMS)
    obs, reward, _, _, info = env.step(np.zeros(1, dtype=np.float32))
    _check_single_info(info, n_acc)
    assert sum(info[k] for k in REWARD_TERMS) == pytest.approx(reward, abs=1e-12)
    assert obs[OBS.V_X] == np.float32(info["v_mps"]) and obs[OBS.E_Y] == np.float32(info["e_y_m"])
    env.close()


def test_kernel_cfg_offsets_follow_the_dataclass_fields() -> None:
    from vtrack_gym.envs import kernels as k

    config = EnvConfig()
    step = k.StepConstants.of(DLC120, config)
    cfg = k.pack_cfg(step, config.layout, config.reward)
    assert cfg.shape == (k.N_CFG,)
    named = {k.CFG_DT: step.physics_dt_s, k.CFG_NSUB: step.n_substeps, k.CFG_END_MARGIN: step.end_margin_m,
             k.CFG_STEER_MAX: step.max_steer_rad, k.CFG_STEER_RATIO: step.steering_ratio,
             k.CFG_NPREV: config.layout.n_preview, k.CFG_PREV_DT: config.layout.preview_dt_s,
             k.CFG_PREV_VMIN: config.layout.preview_min_speed_mps}
    for offset, value in named.items():
        assert cfg[offset] == value
    reward = asdict(config.reward)
    for name, offset in (("alive", k.RW_ALIVE), ("w_ey", k.RW_WEY), ("ey_scale_m", k.RW_EYSCALE),
                         ("w_ephi", k.RW_WEPHI), ("ephi_scale_rad", k.RW_EPHISCALE), ("w_effort", k.RW_WEFFORT),
                         ("w_rate", k.RW_WRATE), ("failure_penalty", k.RW_FAIL),
                         ("completion_bonus", k.RW_COMPLETE)):
        assert cfg[k.CFG_REWARD + offset] == reward[name]
    assert len(k.SimArrays._fields) == len(set(k.SimArrays._fields))


def test_observation_attributes_follow_the_scalar_fields() -> None:
    from vtrack_gym.envs.observation import SCALAR_FIELDS

    for name in SCALAR_FIELDS:
        assert getattr(OBS, name.upper()) == OBS.index(name)
