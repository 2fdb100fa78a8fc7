"""Rollout -> trace -> metrics on the real envs, single and batched, with a test-local steering policy."""

from __future__ import annotations

import numpy as np
import pytest

from vtrack_gym.envs.observation import OBS
from vtrack_gym.evaluation.rollouts.rollout import rollout, rollout_batch
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace


class ProportionalSteering:
    """Curvature feedforward + e_y/e_phi feedback (SB3 predict signature), only for these tests."""

    policy_id = "test-proportional"

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.atleast_2d(observation)
        delta = 2.91 * obs[:, OBS.CURVATURE] - 0.1 * obs[:, OBS.E_Y] - 0.8 * obs[:, OBS.E_PHI]
        action = np.clip(delta / 0.6, -1.0, 1.0).astype(np.float32).reshape(-1, 1)
        return (action[0] if np.ndim(observation) == 1 else action), state


def test_rollout_trace_and_metrics_on_dlc() -> None:
    # 90 km/h: this naive test controller spins out at the scenario's 120 km/h (the baselines do not).
    trace = rollout(ProportionalSteering(), "DLC120-v0", seed=0, options={"target_speed_mps": 25.0})
    assert trace.completed and trace.n_steps > 900
    assert trace.acc_physics_mps2.shape == (trace.n_steps * 5, 3)  # 500 Hz physics, 100 Hz control
    m = evaluate_trace(trace)
    assert 0.3 * 9.81 < m["max_a_y_mps2"] < 9.0  # the lane change needs ~0.45 g at 90 km/h
    assert m["max_hand_wheel_deg"] == pytest.approx(np.degrees(np.abs(trace["road_wheel_angle_rad"]).max()) * 16)
    assert m["min_fz_n"] > 0 and m["constraints_ok"] == 1.0
    assert 0.0 < m["comfort_a_v_mps2"] < 5.0 and isinstance(m["comfort_band"], str)
    assert m["itae"] > 0.0


def test_batched_rollout_equals_single_rollouts() -> None:
    policy = ProportionalSteering()
    batch = rollout_batch(policy, "DLC120-v0", seeds=[3, 4], options={"sensor_noise": 1.0})
    for tr in batch:
        single = rollout(policy, "DLC120-v0", seed=tr.seed, options={"sensor_noise": 1.0})
        assert single.termination == tr.termination
        for name in ("e_y_m", "hand_wheel_angle_rad", "a_y_mps2", "min_fz_n"):
            assert np.array_equal(single[name], tr[name]), name
        assert np.array_equal(single.acc_physics_mps2, tr.acc_physics_mps2)
