"""Every default-preset baseline, closed loop on the nonlinear plant in the real envs."""

from __future__ import annotations

import gymnasium as gym
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace


@pytest.mark.parametrize("name", available_policies())
@pytest.mark.parametrize("env_id", ["LateralTracking-v0", "DLC120-v0"])
def test_default_baseline_completes(name: str, env_id: str) -> None:
    env = gym.make(env_id)
    trace = rollout(make_policy(name, env), env, seed=0)
    assert trace.termination == "completed", f"{name} on {env_id}: {trace.termination}"
    m = evaluate_trace(trace)
    assert m["constraints_ok"] == 1.0
    if env_id == "DLC120-v0" and name in ("smc", "mpc"):
        assert m["max_e_y_m"] < 0.25  # the paper reports a lateral deviation below 0.25 m


def test_paper_smc_preset_does_not_track_in_the_env() -> None:
    """Documented behaviour (paper-math 5.6): the Table-3 SMC leaves the road on the handling course."""
    env = gym.make("LateralTracking-v0")
    trace = rollout(make_policy("smc", env, preset="paper"), env, seed=0)
    assert trace.termination in ("off_road", "spin_out")
    assert trace["time_s"][-1] < 60.0
