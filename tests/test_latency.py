"""Compute in the loop: ``latency="measured"`` / ``latency_s=`` delay each command by its decision's compute,
rounded up to the physics step; late decisions are counted. Deterministic through an injected clock."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.envs.latency import CommandSchedule, Latency
from vtrack_gym.vehicle import layout as L

ENV = "DLC120-v0"   # 10 ms control period, 2 ms physics step: 5 physics steps a period


class FakeClock:
    """A clock that only moves when a test says so [s]."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _actions(n: int) -> list[float]:
    """Distinct steering actions, one per decision."""
    return [0.01 * (k + 1) for k in range(n)]


def _commands(env: gym.Env, actions: list[float], before_step=None) -> list[float]:
    """``info["steering_command_rad"]`` (the command in force at each period's end) for ``actions``."""
    out = []
    for a in actions:
        if before_step is not None:
            before_step()
        _, _, term, trunc, info = env.step(np.array([a], dtype=np.float32))
        assert not (term or trunc)
        out.append(float(info["steering_command_rad"]))
    return out


def test_a_policy_that_sleeps_25_ms_acts_two_periods_late() -> None:
    clock = FakeClock()
    env = gym.make(ENV, latency="measured", latency_clock=clock)
    env.reset(seed=0)
    max_rad = env.unwrapped.config.vehicle.steering.max_road_wheel_angle_rad
    actions = _actions(8)

    def sleep_25_ms() -> None:
        clock.t += 0.025

    cmds = _commands(env, actions, sleep_25_ms)
    # 25 ms -> 13 physics steps (26 ms): decision k is in force from period k + 2 on
    assert cmds[:2] == [0.0, 0.0]
    np.testing.assert_array_equal(cmds[2:], np.array(actions[:6], dtype=np.float32).astype(float) * max_rad)
    stats = env.unwrapped.latency_stats()
    assert stats == {"latency": "measured", "decisions": 8, "late_decisions": 8, "late_share": 1.0,
                     "max_latency_s": pytest.approx(0.025)}


def test_a_real_sleep_is_measured_by_the_default_clock() -> None:
    env = gym.make(ENV, latency="measured")
    env.reset(seed=0)
    cmds = _commands(env, _actions(4), lambda: time.sleep(0.025))
    assert cmds[:2] == [0.0, 0.0]   # at least two periods late on any machine (a sleep never returns early)
    stats = env.unwrapped.latency_stats()
    assert stats["late_share"] == 1.0 and stats["max_latency_s"] >= 0.025


def test_the_switch_happens_inside_the_period_at_the_rounded_up_physics_step() -> None:
    """3 ms -> 2 physics steps: the new command drives the last 3 of 5 physics steps of its own period, so the
    car ends between a car commanded at once and one commanded a period late."""
    ends = []
    for kwargs in ({}, {"latency_s": 0.003}, {"latency_s": 0.004}, {"latency_s": 0.010}):
        env = gym.make(ENV, **kwargs)
        env.reset(seed=0)
        _commands(env, [0.5, 0.5, 0.5])
        ends.append(float(env.unwrapped._sim.plant.state[0, L.S_DELTA]))  # road-wheel angle [rad]
    assert ends[0] > ends[1] > ends[3]
    assert ends[1] == ends[2]   # 3 ms and 4 ms both round up to 4 ms (2 physics steps)


def test_fixed_latency_of_a_whole_period_equals_the_actuator_delay() -> None:
    a = gym.make(ENV, latency_s=0.01)
    b = gym.make(ENV)
    oa, _ = a.reset(seed=3)
    ob, _ = b.reset(seed=3, options={"actuator_delay_s": 0.01})
    np.testing.assert_array_equal(oa, ob)
    for act in _actions(20):
        oa, ra, *_ = a.step(np.array([act], dtype=np.float32))
        ob, rb, *_ = b.step(np.array([act], dtype=np.float32))
        np.testing.assert_array_equal(oa, ob)
        assert ra == rb
    assert a.unwrapped.latency_stats()["late_share"] == 0.0   # exactly one period is not late


def test_latency_is_off_by_default_and_zero_latency_changes_nothing() -> None:
    plain = gym.make(ENV)
    zero = gym.make(ENV, latency="measured", latency_clock=FakeClock())
    np.testing.assert_array_equal(plain.reset(seed=1)[0], zero.reset(seed=1)[0])
    for act in _actions(30):
        op, rp, *_ = plain.step(np.array([act], dtype=np.float32))
        oz, rz, *_ = zero.step(np.array([act], dtype=np.float32))
        np.testing.assert_array_equal(op, oz)
        assert rp == rz
    assert plain.unwrapped.latency_stats()["latency"] == "off"


def test_reset_option_sets_the_episode_latency_and_harness_charge_wins() -> None:
    clock = FakeClock()
    env = gym.make(ENV, latency_clock=clock)
    env.reset(seed=0, options={"latency": "measured"})
    assert env.unwrapped.latency.mode == "measured"
    clock.t += 1.0                              # the env's clock says 1 s ...
    env.unwrapped.charge_compute(0.012)         # ... the harness timed the policy call: 12 ms
    env.step(np.array([0.2], dtype=np.float32))
    assert env.unwrapped.latency_stats()["max_latency_s"] == pytest.approx(0.012)
    env.reset(seed=0, options={"latency_s": 0.02})
    assert env.unwrapped.latency.label == "0.02"
    env.reset(seed=0)
    assert env.unwrapped.latency.mode == "off"   # back to the make-time setting


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"latency": "sometimes"}, "latency must be"),
    ({"latency_s": -0.01}, "latency_s must be"),
    ({"latency_s": 2.0}, "latency_s must be"),
    ({"latency": "measured", "latency_s": 0.01}, "not both"),
])
def test_bad_latency_is_refused_naming_the_argument(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        Latency.parse(kwargs.get("latency"), kwargs.get("latency_s"))


def test_schedule_newer_decision_replaces_older_waiting_one() -> None:
    flags = np.zeros(1)
    s = CommandSchedule(1, 5, 0.002, flags)
    assert s.schedule(0, 0, 1.0, 0.030) == 0.0    # lands at physics step 15
    row = s.schedule(0, 1, 2.0, 0.004)             # lands at physics step 7, before the first
    assert row == 2.0 and flags[0] == 1.0
    np.testing.assert_array_equal(s.cmds[0], [0.0, 0.0, 2.0, 2.0, 2.0])
    s.schedule(0, 2, 2.0, 0.0)
    s.schedule(0, 3, 2.0, 0.0)
    np.testing.assert_array_equal(s.cmds[0], [2.0] * 5)   # the older decision was dropped, never applied
    assert flags[0] == 0.0


@pytest.mark.parametrize("where", ["make", "reset"])
def test_the_vector_env_refuses_latency_clearly(where) -> None:
    if where == "make":
        with pytest.raises(ValueError, match="single env"):
            gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point", latency="measured")
        return
    envs = gym.make_vec(ENV, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match="single env"):
        envs.reset(seed=0, options={"latency_s": 0.01})
