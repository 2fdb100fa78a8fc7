"""The RL agents shipped in ``vtrack_gym/baselines/shipped``: weights-only, torch-free, as good as the README says."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import gymnasium as gym
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.numpy_policy import load_agent
from vtrack_gym.baselines.registry import available_policies, make_policy
from vtrack_gym.baselines.shipped import shipped_agent_factories, shipped_agents
from vtrack_gym.evaluation.metrics import paper_metrics
from vtrack_gym.evaluation.rollout import rollout

AGENTS = sorted(shipped_agents())
DLC_BAR = 1.5  # the bar: max|e_y| on DLC120-v0 within 1.5x of the best scripted baseline


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_a_ppo_and_a_sac_agent_ship(algo: str) -> None:
    assert algo in AGENTS
    spec = load_agent(shipped_agents()[algo]).spec
    assert spec["algo"] == algo and spec["provenance"]["timesteps"] > 0  # RL-trained, not only warm-started
    assert spec["provenance"]["env_id"] == "LateralTrackingRandom-v0"  # trained on the procedural tracks


def test_shipped_agents_load_without_torch() -> None:
    code = ("import json, sys, vtrack_gym.baselines.shipped as s; f = s.shipped_agent_factories(); "
            "print(json.dumps([sorted(f), 'torch' in sys.modules, 'stable_baselines3' in sys.modules]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    names, torch_loaded, sb3_loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert {"ppo", "sac"} <= set(names) and not torch_loaded and not sb3_loaded


@pytest.fixture(scope="module")
def best_baseline_dlc_error() -> float:
    best = math.inf
    for name in available_policies():
        if name == "mpc_osqp":
            pytest.importorskip("osqp")
        env = gym.make("DLC120-v0")
        trace = rollout(make_policy(name, env), env, seed=0)
        if trace.completed:
            best = min(best, paper_metrics(trace)["max_e_y_m"])
    return best


@pytest.mark.parametrize("name", AGENTS)
def test_shipped_agent_completes_both_paper_scenarios(name: str, best_baseline_dlc_error: float) -> None:
    policy = shipped_agent_factories()[name](None)
    traces = {env_id: rollout(policy, env_id, seed=0) for env_id in ("LateralTracking-v0", "DLC120-v0")}
    for env_id, trace in traces.items():
        assert trace.completed, f"{name} on {env_id}: {trace.termination}"
    dlc = paper_metrics(traces["DLC120-v0"])["max_e_y_m"]
    assert dlc <= DLC_BAR * best_baseline_dlc_error, json.dumps({"agent": dlc, "best": best_baseline_dlc_error})
