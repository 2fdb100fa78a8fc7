"""Control modes (``control=``): actions, the throttle/brake map, the tracking errors, the reward's speed term, the
checkers and the vector envs, through ``gym.make`` / ``gym.make_vec`` and the SB3 adapter."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.config import EnvConfig, RewardConfig
from vtrack_gym.envs.observation import OBS
from vtrack_gym.tracks.time_law import time_law
from vtrack_gym.vehicle.params import VehicleParams

LONGITUDINAL = ("steer_accel", "steer_rate_accel")
MODES = ("steer", *LONGITUDINAL)
CAR = VehicleParams()


@pytest.mark.parametrize("bad", ["throttle", "", None, 1, "STEER"])
def test_an_unknown_control_mode_is_refused_naming_control_and_the_allowed_values(bad) -> None:
    for make in (lambda: gym.make("DLC120-v0", control=bad),
                 lambda: gym.make_vec("DLC120-v0", num_envs=2, vectorization_mode="vector_entry_point", control=bad)):
        with pytest.raises(ValueError, match=r"control must be one of 'steer', 'steer_accel', 'steer_rate_accel'"):
            make()


def test_steer_is_the_default_and_keeps_the_layout_and_the_action() -> None:
    env = gym.make("DLC120-v0")
    assert env.unwrapped.control == "steer"
    assert env.action_space.shape == (1,)
    assert env.unwrapped.observation_layout == OBS
    assert env.unwrapped.observation_layout.names == OBS.names
    _, info = env.reset(seed=0)
    _, reward, *_, info = env.step(np.array([0.01], dtype=np.float32))
    assert info["reward_speed"] == 0.0
    assert reward == sum(info[k] for k in vtrack_gym.envs.schema.REWARD_TERMS)


@pytest.mark.parametrize("control", LONGITUDINAL)
def test_longitudinal_modes_take_two_actions_and_append_the_tracking_errors(control: str) -> None:
    env = gym.make("DLC120-v0", control=control)
    layout = env.unwrapped.observation_layout
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    assert layout.names[:OBS.size] == OBS.names   # no index of the steer layout moves
    assert layout.names[OBS.size:] == ("speed_error", "time_error")
    assert env.observation_space.shape == (OBS.size + 2,)
    assert EnvConfig(control=control).layout == layout


def _drive(control: str, actions, env_id: str = "DLC120-v0", seed: int = 0, **kwargs):
    env = gym.make(env_id, control=control, **kwargs)
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, info)]
    for a in actions:
        obs, reward, term, trunc, info = env.step(np.asarray(a, dtype=np.float32))
        out.append((obs, reward, info))
        if term or trunc:
            break
    return env, out


def test_the_throttle_brake_map() -> None:
    """d >= 0: throttle fraction d; d < 0: brake pedal force -d x max_pedal_force_n; the PD-FLC is off."""
    _, steps = _drive("steer_accel", [(0.0, 0.5), (0.0, 0.0), (0.0, -0.25), (0.0, -1.0), (0.0, 1.0)])
    pedals = [(float(i["throttle"]), float(i["brake_n"])) for _, _, i in steps[1:]]
    f = CAR.brakes.max_pedal_force_n
    assert pedals == [(0.5, 0.0), (0.0, 0.0), (0.0, 0.25 * f), (0.0, f), (1.0, 0.0)]


def test_full_throttle_accelerates_and_full_brake_decelerates_on_a_straight() -> None:
    """Closed loop on the straight approach of the lane change: throttle 1 adds speed, brake 1 takes it away faster
    than coasting (demand 0), which itself loses speed to drag and rolling resistance only."""
    def speed_after(demand: float) -> float:
        return float(_drive("steer_accel", [(0.0, demand)] * 50)[1][-1][2]["v_mps"])

    v0 = 120.0 / 3.6
    full, coast, brake = speed_after(1.0), speed_after(0.0), speed_after(-1.0)
    assert full > v0 > coast > brake
    drag_only = v0 - coast     # 0.5 s of resistance at 33 m/s: well under 1 m/s
    assert 0.0 < drag_only < 1.0 and v0 - brake > 5.0 * drag_only


@pytest.mark.parametrize("control", MODES)
def test_speed_and_time_errors_against_the_time_law(control: str) -> None:
    """info and (longitudinal modes) the observation's last two fields: e_v = v_x - v_ref and e_t = t - (T(s0 +
    progress) - T(s0)) with T the speed table's time law, on a track with a speed profile."""
    env = gym.make("vtrack/Track-v0", track="double_lane_change", speed_profile=20.0, control=control)
    law = time_law(env.unwrapped._sim.tracks.speed_tables[0])
    rng = np.random.default_rng(3)
    obs, info = env.reset(seed=0)
    s0 = float(info["station_m"])
    for _ in range(300):
        a = rng.uniform(-0.02, 0.02, env.action_space.shape)
        if control != "steer":
            a[1] = rng.uniform(-0.3, 0.6)
        obs, _, term, trunc, info = env.step(a.astype(np.float32))
        e_t = info["time_s"] - (law.time_at(s0 + info["progress_m"]) - law.time_at(s0))
        assert info["time_error_s"] == pytest.approx(e_t, rel=1e-9, abs=1e-9)
        assert info["speed_error_mps"] == info["v_mps"] - info["target_speed_mps"]
        if control != "steer":
            assert obs[-2] == np.float32(info["speed_error_mps"]) and obs[-1] == np.float32(info["time_error_s"])
        if term or trunc:
            break


def test_a_per_episode_set_speed_is_the_time_reference() -> None:
    """A held set speed the table does not hold (a reset option): T(s) = s / v_set."""
    env = gym.make("DLC120-v0", control="steer_accel")
    env.reset(seed=0, options={"target_speed_mps": 25.0})
    for _ in range(100):
        *_, info = env.step(np.array([0.0, 0.0], dtype=np.float32))
    assert info["time_error_s"] == pytest.approx(info["time_s"] - info["progress_m"] / 25.0, abs=1e-12)


@pytest.mark.parametrize("control", LONGITUDINAL)
def test_the_reward_speed_term_is_bounded_and_sums(control: str) -> None:
    reward = RewardConfig()
    _, steps = _drive(control, [(0.02, 1.0)] * 200, reward=reward)
    for _, r, info in steps[1:]:
        ev = abs(info["speed_error_mps"])
        assert info["reward_speed"] == pytest.approx(-reward.w_speed * ev / (ev + reward.speed_scale_mps), rel=1e-12)
        assert -reward.w_speed < info["reward_speed"] <= 0.0
        assert r == pytest.approx(sum(info[k] for k in vtrack_gym.envs.schema.REWARD_TERMS), abs=1e-12)
    assert steps[-1][2]["reward_speed"] < -0.05   # 200 steps of full throttle: well above the set speed


def test_the_steering_rate_is_integrated_into_the_command() -> None:
    """steer_rate_accel: command_{k+1} = clip(command_k + rate x max_rate x T / max_angle, -1, 1) (x max_angle in
    info's steering_command_rad), 0 at reset."""
    steering = CAR.steering
    step = steering.max_road_wheel_rate_radps * 0.01
    rates = [1.0] * 10 + [-0.5] * 4
    _, steps = _drive("steer_rate_accel", [(r, 0.0) for r in rates])
    commands = [float(i["steering_command_rad"]) for _, _, i in steps[1:]]
    expected = np.cumsum(np.array(rates) * step / steering.max_road_wheel_angle_rad) * \
        steering.max_road_wheel_angle_rad
    np.testing.assert_allclose(commands, expected, rtol=1e-9, atol=1e-12)
    _, steps = _drive("steer_rate_accel", [(1.0, 0.0)] * 120)
    assert max(abs(float(i["steering_command_rad"])) for _, _, i in steps) <= steering.max_road_wheel_angle_rad


@pytest.mark.parametrize("control", LONGITUDINAL)
def test_bad_actions_get_clear_errors_naming_the_shape(control: str) -> None:
    env = gym.make("DLC120-v0", control=control)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must have 2 elements \(shape \(1, 2\) for a batch, \(2,\) for one"):
        env.step(np.array([0.1], dtype=np.float32))
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        env.step(np.zeros(3, dtype=np.float32))
    for bad in ([np.nan, 0.0], [0.0, np.inf]):
        with pytest.raises(ValueError, match="action must be finite"):
            env.step(np.array(bad))
    with pytest.raises(ValueError, match="action must be a number"):
        env.step("0.1, 0.2")
    *_, info = env.step(np.array([0.0, 7.0]))   # out of range: clipped
    assert info["throttle"] == 1.0


@pytest.mark.parametrize("control", MODES)
def test_gymnasium_and_sb3_checkers_pass(control: str) -> None:
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    gym_check(gym.make("DLC120-v0", control=control).unwrapped, skip_render_check=True)
    sb3_check(gym.make("DLC120-v0", control=control))


@pytest.mark.parametrize("control", MODES)
def test_vector_env_car_i_is_the_single_env_seeded_seed_plus_i(control: str) -> None:
    n, seed = 3, 11
    envs = gym.make_vec("vtrack/TrainingMix-v0", num_envs=n, vectorization_mode="vector_entry_point",
                        control=control)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-0.1, 0.6, (60, n, *envs.single_action_space.shape)).astype(np.float32)
    obs, _ = envs.reset(seed=seed)
    batch = [obs]
    for a in actions:
        obs, *_ = envs.step(a)
        batch.append(obs)
    for i in range(n):
        env = gym.make("vtrack/TrainingMix-v0", control=control)
        single = [env.reset(seed=seed + i)[0]]
        for a in actions:
            obs, _, term, trunc, _ = env.step(a[i])
            single.append(obs)
            if term or trunc:
                break
        np.testing.assert_array_equal(np.array(single), np.array(batch)[:len(single), i])


def test_sb3_adapter_steps_two_actions() -> None:
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("DLC120-v0", num_envs=2, control="steer_accel")
    assert venv.action_space.shape == (2,)
    venv.reset()
    venv.step_async(np.array([[0.0, 0.5], [0.0, -0.5]], dtype=np.float32))
    obs, reward, done, _ = venv.step_wait()
    assert obs.shape == (2, OBS.size + 2) and np.isfinite(reward).all() and not done.any()
    assert venv.venv.sim.inputs[0, 1] == 0.5 and venv.venv.sim.inputs[1, 2] == 0.5 * CAR.brakes.max_pedal_force_n
    with pytest.raises(ValueError, match=r"shape \(2, 2\) for a batch"):
        venv.step_async(np.zeros(2))
        venv.step_wait()


def test_highway_lane_keeping_takes_steer_only() -> None:
    pytest.importorskip("highway_env")
    assert gym.make("vtrack_gym/HighwayLaneKeeping-v0", control="steer").unwrapped.control == "steer"
    with pytest.raises(ValueError, match="control must be 'steer' on HighwayLaneKeeping-v0"):
        gym.make("vtrack_gym/HighwayLaneKeeping-v0", control="steer_accel")


def test_vtrack_eval_records_the_control_mode(tmp_path, capsys) -> None:
    """Rows of another control mode are another set-up (``options["control"]``, ranked apart on the board); steer
    rows keep their identity (no ``control`` option)."""
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.leaderboard.board import board_env
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "rows.db"
    for extra in ([], ["--control", "steer_accel"]):
        assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--store", str(store), *extra]) == 0
    rows = ResultStore(store).rows()
    assert [r["options"] for r in rows] == [{}, {"control": "steer_accel"}]
    assert [board_env(r) for r in rows] == ["DLC120-v0", 'DLC120-v0 [control="steer_accel"]']
    assert all(r["success"] for r in rows)


def test_the_cli_refuses_an_unknown_mode_and_control_with_a_track_file(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--control", "accel"])
    assert exit_info.value.code == 2 and "--control: invalid choice: 'accel'" in capsys.readouterr().err
    track = tmp_path / "t.csv"
    track.write_text("x_m,y_m\n" + "".join(f"{x},0\n" for x in range(0, 200, 5)))
    code = main(["benchmark", "--policies", "lqr", "--track", str(track), "--control", "steer_accel",
                 "--store", str(tmp_path / "b.db"), "--no-figures"])
    assert code != 0 and "--control applies to a suite's episodes" in capsys.readouterr().err


def test_env_identity_records_the_mode() -> None:
    from vtrack_gym.evaluation.identity.env_identity import env_identity

    assert env_identity(gym.make("DLC120-v0")) == ("DLC120-v0", {})
    assert env_identity(gym.make("DLC120-v0", control="steer_rate_accel")) == ("DLC120-v0",
                                                                               {"control": "steer_rate_accel"})


@pytest.mark.slow
def test_vtrack_train_control_steer_accel_exports_a_two_output_agent(tmp_path) -> None:
    """``vtrack train --control steer_accel``: the agent file takes the mode's layout and outputs the demand too, so
    it is used as it is in that mode (not paired with the PD-FLC) and refused by a steer env, naming the field."""
    import json

    from vtrack_gym.cli import main

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--env", "LateralTrackingRandom-v0", "--control", "steer_accel",
                 "--timesteps", "256", "--num-envs", "2", "--eval-freq", "0", "--run-dir", str(run),
                 "--set", "n_steps=128", "--set", "batch_size=64", "--no-progress", "--no-final-eval"]) == 0
    spec = json.loads((run / "agent.json").read_text())
    assert spec["action_dim"] == 2 and spec["env"]["observation_names"][-2:] == ["speed_error", "time_error"]
    assert json.loads((run / "config.json").read_text())["hyperparams"]["env_kwargs"]["control"] == "steer_accel"
    env = gym.make("DLC120-v0", control="steer_accel")
    agent = vtrack_gym.make_policy(str(run / "agent.json"), env)
    assert agent.predict(env.reset(seed=0)[0])[0].shape == (2,)
    with pytest.raises(ValueError, match="entry 43 is 'speed_error' for the agent"):
        vtrack_gym.make_policy(str(run / "agent.json"), gym.make("DLC120-v0"))
