"""The nonlinear MPC: its model against theory, its settings' checks, its solver bookkeeping and the closed loop."""

from __future__ import annotations

import importlib
import math

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.baselines.registry import make_policy
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.vehicle.linear import lateral_matrices
from vtrack_gym.vehicle.params import DesignModel, VehicleParams

pytest.importorskip("casadi")

from vtrack_gym.baselines import nmpc_model
from vtrack_gym.baselines.nmpc import NMPC, NMPCConfig

DESIGN = DesignModel.from_vehicle(VehicleParams())
SHAPE = nmpc_model.TyreShape(1.367, 0.962, 1.365, 0.974)
PAPER_MPC_DLC_MAX_E_Y_M = 0.156
"""The paper MPC's (default preset) max |e_y| on DLC120-v0 (README benchmark table)."""


def _derivative(x: np.ndarray, u: float, v: float, kappa: float) -> np.ndarray:
    ca = importlib.import_module("casadi")
    xs, us = ca.SX.sym("x", 5), ca.SX.sym("u")
    f = ca.Function("f", [xs, us], [nmpc_model.state_derivative(ca, DESIGN, SHAPE, 0.03, xs, us, v, kappa)])
    return np.asarray(f(x, u)).reshape(-1)


def test_small_slip_dynamics_equal_the_linear_design_model() -> None:
    """Near zero slip the Pacejka axle forces have the paper's cornering stiffnesses: (v_y, r)' equals eq. (5)."""
    v = 20.0
    a, b = lateral_matrices(DESIGN, v)
    x = np.array([0.0, 0.0, 1e-4, -2e-4, 3e-5])
    got = _derivative(x, 3e-5, v, 0.0)[2:4]
    want = a @ x[2:4] + b * x[4]
    np.testing.assert_allclose(got, want, rtol=1e-3, atol=1e-9)


def test_tyre_force_saturates_at_mu_d_fz() -> None:
    """Large slip: the front axle force peaks at mu D F_zf (Pacejka), not the linear tyre's C_af alpha."""
    v = 20.0
    fzf = DESIGN.mass_kg * 9.81 * DESIGN.cg_to_rear_axle_m / DESIGN.wheelbase_m
    slips = np.linspace(0.0, 0.3, 61)
    forces = [_derivative(np.array([0, 0, 0, 0, s]), s, v, 0.0)[2] * DESIGN.mass_kg / math.cos(s) for s in slips]
    assert max(forces) == pytest.approx(DESIGN.friction_mu * SHAPE.front_d * fzf, rel=1e-3)


def test_path_kinematics_on_a_curve() -> None:
    """On the path, aligned, at the steady yaw rate v kappa: e_y and e_phi do not move."""
    v, kappa = 15.0, 0.01
    d = _derivative(np.array([0.0, 0.0, 0.0, v * kappa, 0.0]), 0.0, v, kappa)
    assert d[0] == pytest.approx(0.0, abs=1e-12) and d[1] == pytest.approx(0.0, abs=1e-12)


def test_condensed_jacobians_match_finite_differences() -> None:
    n = 12
    fns = nmpc_model.horizon_functions(DESIGN, SHAPE, 0.03, 0.05, 2, n, False)
    weights = nmpc_model.HorizonWeights(3.0, 2.0, 0.5, 10.0, 2.0)
    plan = np.linspace(0.0, 0.04, n)
    x0, speeds, kappa = np.array([0.3, 0.02, 0.1, 0.05, 0.01]), np.full(n, 25.0), np.full(n, 0.004)
    lin = nmpc_model.linearise_horizon(fns, weights, 0.03, plan, x0, speeds, kappa, 0.005)
    eps = 1e-6
    for j in range(n):
        bumped = plan.copy()
        bumped[j] += eps
        other = nmpc_model.linearise_horizon(fns, weights, 0.03, bumped, x0, speeds, kappa, 0.005)
        np.testing.assert_allclose((other.res - lin.res) / eps, lin.jac[:, j], rtol=1e-4, atol=1e-3)
        np.testing.assert_allclose((other.rate - lin.rate) / eps, lin.rate_jac[:, j], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize(("overrides", "field"), [
    ({"horizon_steps": 0}, "horizon_steps"), ({"horizon_steps": 101}, "horizon_steps"),
    ({"stage_time_s": 0.0}, "stage_time_s"), ({"weight_e_y": -1.0}, "weight_e_y"),
    ({"weight_move": float("nan")}, "weight_move"), ({"sqp_iterations": 0}, "sqp_iterations"),
    ({"qp_solver": "cplex"}, "qp_solver"), ({"actuator_lag_s": 0.0}, "actuator_lag_s"),
])
def test_bad_settings_are_refused_naming_the_field(overrides: dict, field: str) -> None:
    with pytest.raises(ValueError, match=f"NMPCConfig.{field}"):
        NMPCConfig(**overrides)


def test_a_horizon_beyond_the_curvature_preview_is_refused() -> None:
    env = gym.make("DLC120-v0")
    with pytest.raises(ValueError, match=r"horizon_steps x stage_time_s must be in \(0, 2\] s"):
        make_policy("nmpc", env, horizon_steps=50, stage_time_s=0.05)


def test_missing_casadi_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.import_module

    def no_casadi(name: str, *args: object) -> object:
        if name == "casadi":
            raise ImportError("No module named 'casadi'")
        return real(name, *args)

    monkeypatch.setattr(importlib, "import_module", no_casadi)
    with pytest.raises(ImportError, match=r'pip install "vtrack_gym\[nmpc\]"'):
        nmpc_model.import_casadi()


class FailingQP:
    """A QP solver stand-in that never succeeds."""

    def __call__(self, **kwargs: object) -> dict:
        return {"x": np.full(np.asarray(kwargs["g"]).shape, np.nan)}

    def stats(self) -> dict:
        return {"success": False, "return_status": "forced failure"}


def test_failed_solves_are_counted_and_the_shifted_plan_is_applied() -> None:
    """The CasADi iteration (preset ``casadi``; the compiled one: tests/test_nmpc_rti.py)."""
    env = gym.make("DLC120-v0")
    policy = NMPC.from_env(env, "casadi")
    obs, _ = env.reset(seed=0)
    _, state = policy.predict(obs)
    engine = policy._engine
    engine._qp = FailingQP()
    plan = state[0, 1:].copy()
    action2, state2 = policy.predict(obs, state=state)
    assert policy.solver_failures == 1
    np.testing.assert_allclose(state2[0, 1:], engine._shifted(plan))
    assert action2[0] == pytest.approx(engine._shifted(plan)[0] / DESIGN.max_road_wheel_angle_rad, rel=1e-6)


def test_nmpc_reads_only_the_env_contract() -> None:
    """Built from the env's design model, layout and control period (no simulator state)."""
    env = gym.make("DLC120-v0")
    policy = make_policy("nmpc", env)
    assert isinstance(policy, NMPC) and policy.design == env.unwrapped.design_model
    assert policy.layout == env.unwrapped.observation_layout and policy.control_period_s == 0.01


def test_nmpc_beats_the_paper_mpc_on_the_double_lane_change() -> None:
    env = gym.make("DLC120-v0")
    policy = make_policy("nmpc", env)
    trace = rollout(policy, env, seed=0)
    m = evaluate_trace(trace)
    assert trace.termination == "completed" and trace.success
    assert m["max_e_y_m"] < PAPER_MPC_DLC_MAX_E_Y_M
    assert m["solver_failures"] == 0.0 and trace.solver_failures == 0
    assert m["policy_time_p50_us"] > 0.0


@pytest.mark.parametrize("preset", ["default", "casadi"])
def test_batch_and_single_observations_give_the_same_plan(preset: str) -> None:
    env = gym.make("DLC120-v0")
    policy = NMPC.from_env(env, preset)
    env.reset(seed=0, options={"initial_lateral_offset_m": 0.5})
    obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    single, _ = policy.predict(obs, episode_start=True)
    assert abs(single[0]) > 1e-3
    policy.reset()
    batch, state = policy.predict(np.stack((obs, obs)), episode_start=np.ones(2, dtype=bool))
    assert state.shape == (2, policy.state_size)
    np.testing.assert_allclose(batch[:, 0], single[0], rtol=1e-6)


def test_an_extreme_demand_gives_exactly_full_lock() -> None:
    """A car far right of a 1 m-radius left turn, wheel at the lock and turning at 2 rad/s (front slip below the
    tyre's peak): the plan asks beyond the lock and the action is exactly +1 (and -1 mirrored)."""
    env = gym.make("DLC120-v0")
    policy = make_policy("nmpc", env)
    lay = policy.layout
    for sign in (1.0, -1.0):
        obs = np.zeros(lay.size)
        obs[lay.V_X], obs[lay.TARGET_SPEED], obs[lay.speed_preview] = 1.0, 1.0, 1.0
        obs[lay.ROAD_WHEEL_ANGLE], obs[lay.YAW_RATE], obs[lay.E_Y] = 0.6 * sign, 2.0 * sign, -50.0 * sign
        obs[lay.CURVATURE], obs[lay.preview] = sign, sign
        policy.reset()
        action, _ = policy.predict(obs)
        assert action.dtype == np.float32 and action[0] == sign
