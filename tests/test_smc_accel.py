"""smc in the longitudinal control modes: ``make_policy("smc", env)`` builds the ``accel`` preset (the steer mode's
GA result with high-speed gains: above v_s = 13 m/s eta v_s / v and p (v_s / v)^0.375), which completes both paper
scenarios within 25 % of the steer mode's max |e_y| and the lane change over a band of held speeds; the steer mode
keeps its preset."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines.configs import ACCEL_HIGH_SPEED_MPS, ACCEL_POLE_SPEED_EXPONENT
from vtrack_gym.baselines.decoupled import Decoupled
from vtrack_gym.baselines.registry import available_presets
from vtrack_gym.baselines.smc import SMC


def episode(env_id: str, control: str, preset: str | None = None, speed: float | None = None,
            **make_kwargs: object) -> dict:
    """One seed-0 episode of ``vtrack_gym.make_policy("smc", env)`` (or ``smc:<preset>``): verdict, max |e_y| [m]
    and RMS speed error [m/s]."""
    env = gym.make(env_id, control=control, **make_kwargs)
    policy = vtrack_gym.make_policy("smc" if preset is None else f"smc:{preset}", env)
    obs, info = env.reset(seed=0, options=None if speed is None else {"target_speed_mps": speed})
    e_y, e_v, done = [], [], False
    while not done:
        action, _ = policy.predict(obs)
        obs, _, terminated, truncated, info = env.step(action)
        e_y.append(abs(info["e_y_m"]))
        e_v.append(info["speed_error_mps"])
        done = terminated or truncated
    return {"success": bool(info["success"]), "termination": info["termination"], "max_e_y": max(e_y),
            "rms_e_v": float(np.sqrt(np.mean(np.square(e_v))))}


def test_the_longitudinal_modes_build_the_accel_preset_and_steer_keeps_its_own() -> None:
    steer = vtrack_gym.make_policy("smc", gym.make("vtrack/DLC120-v0"))
    assert isinstance(steer, SMC) and steer.config == SMC.make_config("tuned")
    assert steer.config.high_speed_mps == 0.0
    for control in ("steer_accel", "steer_rate_accel"):
        paired = vtrack_gym.make_policy("smc", gym.make("vtrack/DLC120-v0", control=control))
        assert isinstance(paired, Decoupled) and paired.lateral.config == SMC.make_config("accel")
        assert paired.lateral.config.high_speed_mps == ACCEL_HIGH_SPEED_MPS
    tuned = vtrack_gym.make_policy("smc:tuned", gym.make("vtrack/DLC120-v0", control="steer_accel"))
    assert tuned.lateral.config == steer.config          # the steer mode's preset, asked for by name
    assert "accel" in available_presets("smc")


def test_the_accel_preset_completes_the_lane_change_in_steer_accel() -> None:
    """DLC120-v0 through gymnasium.make and make_policy: completed, max |e_y| within 1.25x of the steer mode's
    (where the steer-mode preset spins out), RMS speed error under 0.5 m/s."""
    steer = episode("vtrack/DLC120-v0", "steer")
    accel = episode("vtrack/DLC120-v0", "steer_accel")
    assert steer["success"] and accel["success"], (steer, accel)
    assert accel["max_e_y"] <= 1.25 * steer["max_e_y"], (steer, accel)
    assert accel["rms_e_v"] < 0.5, accel
    assert not episode("vtrack/DLC120-v0", "steer_accel", preset="tuned")["success"]


@pytest.mark.slow
def test_the_accel_preset_follows_the_powertrain_launch_as_closely_as_steer() -> None:
    """LateralTracking-v0 (40 km/h, below v_s: the reaching gain is the steer preset's) with launch="powertrain"."""
    steer = episode("vtrack/LateralTracking-v0", "steer")
    accel = episode("vtrack/LateralTracking-v0", "steer_accel", launch="powertrain")
    assert steer["success"] and accel["success"], (steer, accel)
    assert accel["max_e_y"] <= 1.25 * steer["max_e_y"], (steer, accel)
    assert accel["rms_e_v"] < 0.5, accel


@pytest.mark.parametrize("control", ["steer", "steer_accel", "steer_rate_accel"])
def test_the_accel_preset_completes_the_lane_change_over_a_band_of_held_speeds(control: str) -> None:
    """Held set speeds 31 to 35 m/s: every lane change completed (the steer-mode preset completes it at few)."""
    for speed in (31.0, 32.0, 33.0, 34.0, 35.0):
        found = episode("vtrack/DLC120-v0", control, preset="accel", speed=speed)
        assert found["success"], (speed, found)


def test_above_v_s_the_law_is_the_steer_presets_with_scaled_gains() -> None:
    """On observations of the lane change (about 33 m/s) the accel preset acts as the steer preset's law with
    eta v_s / v and p (v_s / v)^a on each row (``rows``: per-row gains); below v_s the two are equal to the bit."""
    env = gym.make("vtrack/DLC120-v0")
    tuned, accel = SMC.from_env(env, preset="tuned"), SMC.from_env(env, preset="accel")
    obs, _ = env.reset(seed=0)
    rows = []
    for step in range(600):
        action, _ = tuned.predict(obs)
        obs, *_ = env.step(action)
        if step >= 400:
            rows.append(obs)
    batch = np.asarray(rows, dtype=np.float64)
    v_index = env.unwrapped.observation_layout.index("v_x")
    ratio = ACCEL_HIGH_SPEED_MPS / batch[:, v_index]
    assert np.all(ratio < 1.0)
    cfg = tuned.config
    scaled = SMC(tuned.design, cfg, tuned.layout, tuned.control_period_s,
                 rows=(cfg.pole_radps * ratio ** ACCEL_POLE_SPEED_EXPONENT, cfg.reaching_gain * ratio,
                       np.full(len(ratio), cfg.boundary_layer)))
    found, expected = accel.act(batch, None)[0], scaled.act(batch, None)[0]
    np.testing.assert_allclose(found, expected, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(found - tuned.act(batch, None)[0])) > 1e-3       # the scaling acts
    slow = batch.copy()
    slow[:, v_index] = ACCEL_HIGH_SPEED_MPS - 0.5
    np.testing.assert_array_equal(accel.act(slow, None)[0], tuned.act(slow, None)[0])


def test_the_two_presets_are_two_policies_on_the_board() -> None:
    """Rows of the steer mode's preset and of the accel preset in steer_accel never share a policy hash."""
    rows = [vtrack_gym.evaluate(make, "DLC120-v0", [0], control="steer_accel")[0]
            for make in (lambda env: vtrack_gym.make_policy("smc", env),
                         lambda env: vtrack_gym.make_policy("smc:tuned", env))]
    assert rows[0].policy_hash != rows[1].policy_hash
    assert rows[0].success and not rows[1].success
