"""The coupled NMPC (``nmpc_coupled``): its model's Jacobians and the condensed problem against finite differences,
its speed row against the plant, the control modes it takes, the state protocol and the closed loop through
``make_policy`` and the CLI."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines import nmpc_coupled_kernels as kernels
from vtrack_gym.baselines import nmpc_coupled_model as model
from vtrack_gym.baselines.nmpc_kernels import model_constants
from vtrack_gym.baselines.nmpc_model import TyreShape
from vtrack_gym.baselines.registry import available_policies, known_policies, pedal_policies
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.vehicle.params import DesignModel, paper_vehicle

VEHICLE = paper_vehicle()
DESIGN = DesignModel.from_vehicle(VEHICLE)
MC = model_constants(DESIGN, TyreShape(1.367, 0.962, 1.365, 0.974), 0.03)
LC = model.longitudinal_constants(VEHICLE, 4.0, 1.0)
N = 12


def _central(fn, base: np.ndarray, j: int) -> np.ndarray:
    """Central difference of ``fn`` in entry ``j`` of ``base``."""
    h = 1e-6 * max(1.0, abs(base[j]))
    up, down = base.copy(), base.copy()
    up[j] += h
    down[j] -= h
    return (fn(up) - fn(down)) / (2.0 * h)


@pytest.mark.parametrize("demand", [0.4, -0.3])
@pytest.mark.parametrize("speed", [25.0, 2.5, 0.05])
def test_model_jacobian_matches_finite_differences(demand: float, speed: float) -> None:
    """d x' / d(x, c, d, kappa, v_ref): throttle and brake, above and below the lateral model's speed floor."""
    base = np.array([0.3, 0.05, 0.4, 0.1, 0.03, speed, 0.2, 0.02, demand, 0.01, 15.0])

    def rate(a: np.ndarray) -> np.ndarray:
        return model.derivative(a[:7], a[7], a[8], a[9], a[10], MC, LC)[0]

    _, jac = model.derivative(base[:7], base[7], base[8], base[9], base[10], MC, LC)
    for j in range(model.N_SENS):
        np.testing.assert_allclose(jac[:, j], _central(rate, base, j), rtol=1e-6, atol=1e-7 * max(1.0, abs(jac).max()))


def test_stage_sensitivities_are_the_derivatives_of_the_rk4_map() -> None:
    base = np.array([0.3, 0.05, 0.4, 0.1, 0.03, 20.0, 0.2, 0.02, 0.4, 0.01, 15.0])

    def stage(a: np.ndarray) -> np.ndarray:
        out = np.empty(model.N_X)
        model.rk4_stage(a[:7], a[7:9], a[9:], MC, LC, 0.05, 2, out, np.empty((model.N_X, model.N_SENS)))
        return out

    out, sens = np.empty(model.N_X), np.empty((model.N_X, model.N_SENS))
    model.rk4_stage(base[:7], base[7:9], base[9:], MC, LC, 0.05, 2, out, sens)
    for j in range(model.N_SENS):
        np.testing.assert_allclose(sens[:, j], _central(stage, base, j), rtol=1e-6, atol=1e-8)


def _linearised(which: str):
    """The condensed residuals as a function of one block (plan, x0 or params) at a point on a curve."""
    k = np.arange(N)
    plan = np.concatenate((0.03 * np.sin(k / 3.0), 0.3 * np.cos(k / 4.0)))
    x0 = np.array([0.1, 0.02, 0.3, 0.05, 0.01, 22.0, 0.4])
    params = np.concatenate((0.01 * np.cos(k / 5.0), np.linspace(24.0, 20.0, N)))
    weights = np.array([3.0, 3.0, 0.3, 1.0, 0.3, 14.0, 1.0, 0.2, 3.0])
    parts = {"plan": plan, "x0": x0, "params": params}

    def residuals(a: np.ndarray) -> np.ndarray:
        args = {**parts, which: a}
        return kernels.linearise(args["plan"], args["x0"], args["params"], np.array([0.01, 0.2]), weights, MC, LC,
                                 0.05, 2)[0]

    _, ju, jx, jp, *_ = kernels.linearise(plan, x0, params, np.array([0.01, 0.2]), weights, MC, LC, 0.05, 2)
    return residuals, parts[which], {"plan": ju, "x0": jx, "params": jp}[which]


@pytest.mark.parametrize("which", ["plan", "x0", "params"])
def test_condensed_jacobians_match_finite_differences(which: str) -> None:
    """The single-shooting Jacobians of the 8N residuals in the 2N commands, the initial state and the 2N stage
    parameters (what the QP and the feedback's first-order correction use)."""
    residuals, base, jac = _linearised(which)
    for j in range(base.size):
        np.testing.assert_allclose(jac[:, j], _central(residuals, base, j), rtol=1e-5,
                                   atol=1e-6 * max(1.0, np.abs(jac).max()))


@pytest.mark.parametrize("demand", [0.6, -0.2, -0.8])
def test_the_speed_row_predicts_the_plant_on_a_straight(demand: float) -> None:
    """One second of constant demand on the lane change's straight: the model's speed change within 1 % of the
    plant's (light braking, and braking past the grip)."""
    env = gym.make("DLC120-v0", control="steer_accel")
    obs, _ = env.reset(seed=0)
    v0 = float(obs[env.unwrapped.observation_layout.index("v_x")])
    for _ in range(100):
        obs, *_ = env.step(np.array([0.0, demand], dtype=np.float32))
    v1 = float(obs[env.unwrapped.observation_layout.index("v_x")])
    x = np.array([0.0, 0.0, 0.0, 0.0, 0.0, v0, 0.0])
    predicted = model.advance(x, np.array([0.0, demand]), np.array([0.0, v0]), MC, LC, 1.0, 100)[5]
    assert abs(v1 - v0) > 0.5
    assert abs((predicted - v0) / (v1 - v0) - 1.0) < 0.01


def test_it_is_a_pedal_policy_not_a_steering_baseline() -> None:
    assert "nmpc_coupled" in pedal_policies() and "nmpc_coupled" in known_policies()
    assert "nmpc_coupled" not in available_policies()   # every env takes those; this one needs steer_accel


@pytest.mark.parametrize("control", ["steer", "steer_rate_accel"])
def test_other_control_modes_are_refused_naming_the_supported_one(control: str) -> None:
    with pytest.raises(ValueError, match="steer_accel"):
        vtrack_gym.make_policy("nmpc_coupled", gym.make("DLC120-v0", control=control))


def test_batch_single_and_state_protocol_give_the_same_action() -> None:
    env = gym.make("DLC120-v0", control="steer_accel")
    policy = vtrack_gym.make_policy("nmpc_coupled", env)
    obs, _ = env.reset(seed=0)
    single, _ = policy.predict(obs)
    batch, state = policy.predict(np.stack((obs, obs)), state=None, episode_start=True)
    assert single.shape == (2,) and batch.shape == (2, 2) and state.shape == (2, policy.state_size)
    np.testing.assert_array_equal(batch[0], single)
    np.testing.assert_array_equal(batch[1], single)
    assert set(policy.last_solver_stats) >= {"feedback_s", "preparation_s", "qp_iterations", "cold_starts"}


def test_deferred_preparation_gives_the_same_commands() -> None:
    """The prepared record is only a cache: prepared in the call or by ``prepare()`` afterwards, same actions."""
    env = gym.make("DLC120-v0", control="steer_accel")
    policy = vtrack_gym.make_policy("nmpc_coupled", env)
    obs, _ = env.reset(seed=0, options={"initial_lateral_offset_m": 0.5})
    observations = [obs]
    for _ in range(20):
        obs, *_ = env.step(np.array([0.01, 0.1], dtype=np.float32))
        observations.append(obs)
    runs = []
    for deferred in (False, True):
        policy.defer_preparation, state, actions = deferred, None, []
        for i, o in enumerate(observations):
            action, state = policy.predict(o, state=state, episode_start=i == 0)
            if deferred:
                policy.prepare()
            actions.append(action)
        runs.append(np.array(actions))
    assert np.abs(runs[0]).max() > 1e-3
    np.testing.assert_array_equal(runs[1], runs[0])


def test_closed_loop_lane_change_tracks_path_and_speed() -> None:
    """DLC120-v0 in steer_accel: passes, max |e_y| within 25 % of the steering NMPC's steer-mode 0.108 m, RMS
    speed error under 0.5 m/s, no failed QP, solver statistics in the row."""
    env = gym.make("DLC120-v0", control="steer_accel")
    metrics = evaluate_trace(rollout(vtrack_gym.make_policy("nmpc_coupled", env), env, seed=0))
    assert metrics["success"] == 1.0 and metrics["solver_failures"] == 0.0
    assert metrics["max_e_y_m"] <= 1.25 * 0.108
    assert metrics["rms_e_v_mps"] < 0.5
    assert metrics["feedback_time_p95_us"] >= metrics["feedback_time_p50_us"] > 0.0


def test_the_cli_evaluates_it(tmp_path) -> None:
    from vtrack_gym.cli import main

    assert main(["eval", "--policy", "nmpc_coupled", "--env", "DLC120-v0", "--control", "steer_accel",
                 "--seeds", "0", "--store", str(tmp_path / "store")]) == 0


def test_with_compute_charged_only_the_feedback_is_charged() -> None:
    """``latency="measured"``: the harness defers the preparation to ``prepare()`` and charges the feedback."""
    env = gym.make("DLC120-v0", control="steer_accel", latency="measured")
    policy = vtrack_gym.make_policy("nmpc_coupled", env)
    trace = rollout(policy, env, seed=0, max_steps=30)
    stats = trace.solver_stats
    assert policy.defer_preparation is False                 # restored after the episode
    assert stats["cold_starts"][0] == 1 and not stats["cold_starts"][1:].any()   # every deferred one was used
    assert np.all(stats["preparation_s"][1:] > 0.0) and np.all(stats["qp_s"] <= stats["feedback_s"])


def test_the_coupled_race_form_laps_the_ring_within_the_wheels_rule() -> None:
    """``raceline_coupled`` on ``vtrack/RaceRing-v0``, seed 0: both laps, no track-limit excursion, the flying lap
    within 5 % of the car's lap-time bound (measured 3.7 %)."""
    env = gym.make("vtrack/RaceRing-v0")
    policy = vtrack_gym.make_policy("raceline_coupled", env)
    obs, info = env.reset(seed=0)
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        if terminated or truncated:
            break
    metrics = env.unwrapped.success_metrics()
    assert len(info["lap_times_s"]) == 2 and metrics["track_limit_violations"] == 0
    assert info["lap_time_fraction"] < 1.05
    assert policy.solver_failures == 0


def test_the_coupled_race_form_needs_steer_accel() -> None:
    with pytest.raises(ValueError, match="control='steer_accel'"):
        vtrack_gym.make_policy("raceline_coupled", gym.make("vtrack/RaceRing-v0", control="steer_rate_accel"))
