"""The single env's fast paths give the same numbers as the general ones.

``check_action`` reads a one-element float array directly; ``BatchSim.step_one`` skips the delay, noise and
per-step criterion branches while none is active (re-derived at every reset).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.envs.tracking_env import _as_float_array, check_action

VALUES = (0.0, -0.0, 0.3, -0.7, 1.0, -1.0, 1.5, -3.0, 1e-300, 0.1 + 1e-17, 2.0 ** -1074, 1e308)


def _general(action: object) -> float:
    """The general path of ``check_action`` (without the fast branch), for comparison."""
    a = float(_as_float_array(action).reshape(-1)[0])
    return -1.0 if a < -1.0 else (1.0 if a > 1.0 else a)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, np.longdouble])
@pytest.mark.parametrize("value", VALUES)
def test_fast_action_read_equals_general_read(dtype, value) -> None:
    with np.errstate(over="ignore"):
        action = np.array([value], dtype=dtype)
    if not np.isfinite(action).all():
        with pytest.raises(ValueError, match="finite"):
            check_action(action)
        return
    got = check_action(action)
    assert type(got) is float
    assert np.float64(got).tobytes() == np.float64(_general(action)).tobytes()


@pytest.mark.parametrize("bad", [np.array([np.nan], np.float32), np.array([np.inf]), np.array([-np.inf], np.float16)])
def test_fast_action_read_refuses_non_finite(bad) -> None:
    with pytest.raises(ValueError, match="finite"):
        check_action(bad)


def test_other_shapes_and_subclasses_take_the_general_path() -> None:
    assert check_action(np.array([[0.25]], np.float32)) == 0.25
    with pytest.raises(ValueError, match="1 element"):
        check_action(np.zeros(2, np.float32))
    with pytest.raises(ValueError):
        check_action(np.ma.masked_array([0.1], mask=[True]))


def _episode(env: gym.Env, seed: int, options: dict | None, steps: int = 120) -> np.ndarray:
    obs, _ = env.reset(seed=seed, options=options)
    rows = [obs]
    for k in range(steps):
        obs, _, term, trunc, _ = env.step(np.array([0.2 * np.sin(0.05 * k)], np.float32))
        rows.append(obs)
        if term or trunc:
            break
    return np.array(rows)


@pytest.mark.parametrize("options", [{"sensor_noise": 1.0}, {"actuator_delay_s": 0.05}])
def test_noise_and_delay_switch_on_and_off_between_episodes(options) -> None:
    """An episode with noise or delay after a plain one (and a plain one after it) equals a fresh env's."""
    env = gym.make("LateralTracking-v0")
    plain = _episode(env, 1, None)
    with_knob = _episode(env, 2, options)
    plain_again = _episode(env, 1, None)
    fresh = gym.make("LateralTracking-v0")
    np.testing.assert_array_equal(with_knob, _episode(fresh, 2, options))
    np.testing.assert_array_equal(plain, plain_again)
    assert not np.array_equal(with_knob, _episode(fresh, 2, None))  # the knob acted
