"""The NMPC's compiled real-time iteration: its model and condensed QP against CasADi's, its QP solver against a
reference solver, the preparation/feedback split (statistics, caching, what the harness charges) and the closed
loop against the CasADi iteration it replaced as the default."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.baselines import dense_qp, nmpc_kernels, nmpc_rti, rti_engine
from vtrack_gym.baselines.nmpc import NMPC
from vtrack_gym.evaluation.rollouts.rollout import rollout, rollout_batch
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.vehicle.params import DesignModel, VehicleParams

DESIGN = DesignModel.from_vehicle(VehicleParams())
N = 40


def _point() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A plan, an initial state and stage parameters away from the origin (a curve at 25-30 m/s)."""
    k = np.arange(N)
    return (0.05 * np.sin(k / 5.0), np.array([0.1, 0.02, 0.3, 0.05, 0.01]), np.linspace(30.0, 25.0, N),
            0.01 * np.cos(k / 7.0))


def _policy(preset: str = "default") -> tuple[gym.Env, NMPC]:
    env = gym.make("DLC120-v0")
    return env, NMPC.from_env(env, preset)


def test_condensed_gauss_newton_data_equal_casadis() -> None:
    """The compiled Jacobians (analytic, through RK4) give CasADi's residuals, Jacobian and rate rows."""
    pytest.importorskip("casadi")
    from vtrack_gym.baselines import nmpc_model

    shape = nmpc_model.TyreShape(1.367, 0.962, 1.365, 0.974)
    plan, x0, v, kappa = _point()
    weights = nmpc_model.HorizonWeights(math.sqrt(10.0), math.sqrt(10.0), math.sqrt(0.1), math.sqrt(200.0), 3.0)
    fns = nmpc_model.horizon_functions(DESIGN, shape, 0.03, 0.05, 2, N, False)
    ref = nmpc_model.linearise_horizon(fns, weights, 0.03, plan, x0, v, kappa, 0.02)
    w = np.array([weights.e_y, weights.e_phi, weights.yaw_rate, weights.move, weights.terminal_scale])
    mc = nmpc_kernels.model_constants(DESIGN, shape, 0.03)
    res, ju, _, _, delta, delta_u, _ = nmpc_kernels._linearise(plan, x0, v, kappa, 0.02, w, mc, 0.05, 2)
    np.testing.assert_allclose(res, ref.res, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ju, ref.jac, rtol=1e-9, atol=1e-10 * np.abs(ref.jac).max())
    np.testing.assert_allclose((plan - delta) / 0.03, ref.rate, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose((np.eye(N) - delta_u) / 0.03, ref.rate_jac, atol=1e-12)


@pytest.mark.parametrize("which", ["x0", "p"])
def test_embedded_sensitivities_match_finite_differences(which: str) -> None:
    """d residuals / d x0 and d residuals / d (v, kappa): the first-order corrections the feedback applies."""
    plan, x0, v, kappa = _point()
    w = np.array([3.0, 3.0, 0.3, 14.0, 3.0])
    mc = nmpc_kernels.model_constants(DESIGN, nmpc_rti.TyreShape(1.367, 0.962, 1.365, 0.974), 0.03)
    _, _, jx, jp, *_ = nmpc_kernels._linearise(plan, x0, v, kappa, 0.02, w, mc, 0.05, 2)
    base = np.concatenate((x0, v, kappa))
    cols = range(5) if which == "x0" else (5, 5 + 17, 5 + N + 3, 5 + 2 * N - 1)
    for c in cols:
        h = 1e-6 * max(1.0, abs(base[c]))
        up, down = base.copy(), base.copy()
        up[c] += h
        down[c] -= h
        r_up = nmpc_kernels._linearise(plan, up[:5], up[5:5 + N], up[5 + N:], 0.02, w, mc, 0.05, 2)[0]
        r_down = nmpc_kernels._linearise(plan, down[:5], down[5:5 + N], down[5 + N:], 0.02, w, mc, 0.05, 2)[0]
        analytic = jx[:, c] if c < 5 else jp[:, c - 5]
        np.testing.assert_allclose(analytic, (r_up - r_down) / (2 * h), atol=1e-6 * max(1.0, np.abs(analytic).max()))


def _random_qp(rng: np.random.Generator, n: int = 12) -> tuple[np.ndarray, ...]:
    m = rng.normal(size=(3 * n, n))
    hess = m.T @ m + 1e-3 * np.eye(n)
    a = np.eye(n) - np.tril(rng.uniform(0.0, 0.3, size=(n, n)), -1)
    return (hess, rng.normal(size=n) * 10.0, a, -rng.uniform(0.1, 1.0, n), rng.uniform(0.1, 1.0, n),
            -rng.uniform(0.2, 1.0, n), rng.uniform(0.2, 1.0, n))


def _kkt_residual(hess: np.ndarray, g: np.ndarray, a: np.ndarray, lo: np.ndarray, hi: np.ndarray, lb: np.ndarray,
                  ub: np.ndarray, x: np.ndarray) -> float:
    """Largest violation of the optimality conditions at x (multipliers by least squares on the active set)."""
    ax = a @ x
    viol = max(0.0, np.max(lo - ax), np.max(ax - hi), np.max(lb - x), np.max(x - ub))
    rows = [a[i] for i in range(len(lo)) if min(ax[i] - lo[i], hi[i] - ax[i]) < 1e-9]
    rows += [np.eye(len(x))[j] for j in range(len(x)) if min(x[j] - lb[j], ub[j] - x[j]) < 1e-9]
    grad = hess @ x + g
    if not rows:
        return max(viol, float(np.abs(grad).max()))
    normals = np.array(rows).T
    mult, *_ = np.linalg.lstsq(normals, -grad, rcond=None)
    return max(viol, float(np.abs(normals @ mult + grad).max()))


@pytest.mark.parametrize("seed", range(6))
def test_the_active_set_solver_meets_the_optimality_conditions(seed: int) -> None:
    """Random strictly convex QPs with many active constraints: feasible, stationary on its active set."""
    rng = np.random.default_rng(seed)
    hess, g, a, lo, hi, lb, ub = _random_qp(rng)
    x = np.empty(g.size)
    inv_chol_t = np.linalg.inv(np.linalg.cholesky(hess)).T.copy()
    status, iterations, active = dense_qp.solve_qp(inv_chol_t, g, a, lo, hi, lb, ub, x, 1000)
    assert status == dense_qp.QP_SOLVED and active > 0 and iterations >= active
    assert _kkt_residual(hess, g, a, lo, hi, lb, ub, x) < 1e-9


def _constrained_decision() -> tuple[NMPC, np.ndarray, np.ndarray]:
    """A policy and an observation where the plan hits both limits (a car 2 m off, steering hard the wrong way)."""
    env, policy = _policy()
    env.reset(seed=0, options={"initial_lateral_offset_m": 2.0})
    obs, *_ = env.step(np.array([-1.0], dtype=np.float32))
    return policy, obs, policy._initial_state_batch(obs[None, :])[0]


def test_the_first_command_equals_a_reference_solve_of_the_same_qp() -> None:
    """The feedback QP at a state where the rate limit binds, solved by qpOASES (CasADi): same plan to 1e-9."""
    ca = pytest.importorskip("casadi")
    from vtrack_gym.baselines.nmpc_casadi import silenced_stdout

    policy, obs, row = _constrained_decision()
    rti = policy._engine
    x0 = obs[rti._x_idx]
    speeds, kappa = np.empty(N), np.empty(N)
    nmpc_rti.stage_parameters(obs, rti._idx, rti._lay, rti._stage, speeds, kappa)
    p = np.concatenate((speeds, kappa))
    prep = rti._prepare(np.concatenate((row[:2 + N], x0, p)))
    g, lo, hi, lb, ub = (np.empty(N) for _ in range(5))
    nmpc_rti.qp_data(prep.record, x0, p, prep.point, rti._max_steer, rti._max_rate, g, lo, hi, lb, ub)
    o_j, o_g, _, _, _, o_ru, o_rd, _ = rti._offsets
    inv_chol_t = prep.record[o_j:o_g].reshape(N, N)
    hess = np.linalg.inv(inv_chol_t @ inv_chol_t.T)
    a = prep.record[o_ru:o_rd].reshape(N, N)
    with silenced_stdout():
        solver = ca.conic("ref", "qpoases", {"h": ca.Sparsity.dense(N, N), "a": ca.Sparsity.dense(N, N)},
                          {"printLevel": "none", "error_on_fail": False})
    ref = np.asarray(solver(h=(hess + hess.T) / 2, g=g, a=a, lba=lo, uba=hi, lbx=lb, ubx=ub)["x"]).reshape(-1)
    policy.reset()
    _, state = policy.predict(obs)
    assert policy.last_solver_stats["qp_iterations"] > 0          # constraints were active
    plan = state[0, 2:2 + N]
    expected = np.clip(prep.point[:N] + ref, -DESIGN.max_road_wheel_angle_rad, DESIGN.max_road_wheel_angle_rad)
    assert abs(plan[0] - expected[0]) < 1e-9
    np.testing.assert_allclose(plan, expected, atol=1e-9)


def test_statistics_are_recorded_per_decision_and_reach_the_row() -> None:
    env, policy = _policy()
    trace = rollout(policy, env, seed=0, max_steps=60)
    stats = trace.solver_stats
    assert set(stats) == set(nmpc_rti.STAT_NAMES)
    assert all(v.shape == (trace.n_steps,) for v in stats.values())
    assert stats["cold_starts"][0] == 1 and not stats["cold_starts"][1:].any()   # prepared after the first one
    assert np.all(stats["sqp_iterations"] == 1) and np.all(stats["qp_iterations"] >= 0)
    assert np.all(stats["qp_iterations"] == np.round(stats["qp_iterations"]))
    assert np.all(stats["qp_s"] <= stats["feedback_s"])                  # the QP runs inside the feedback
    assert np.all(stats["feedback_s"] + stats["preparation_s"] <= trace.policy_time_s)   # nested in the call
    metrics = evaluate_trace(trace)
    for name in ("feedback_time", "preparation_time", "qp_time"):
        assert metrics[f"{name}_p95_us"] >= metrics[f"{name}_p50_us"] >= 0.0
    assert metrics["sqp_iterations_mean"] == 1.0 and metrics["cold_starts_max"] == 1.0


def test_the_batch_rollout_records_the_statistics_as_the_single_one() -> None:
    """``rollout_batch`` takes its decisions through the same code as ``rollout``: one car gives the single
    rollout's actions and statistics (their counts exactly); two cars record the batch's figures per car (the mean
    of the two), one entry per recorded step."""
    env, policy = _policy()
    single = rollout(policy, env, seed=3, max_steps=30)
    one, = rollout_batch(NMPC.from_env(env), "DLC120-v0", [3], max_steps=30)
    assert set(one.solver_stats) == set(nmpc_rti.STAT_NAMES)
    for name in ("qp_iterations", "sqp_iterations", "cold_starts"):
        np.testing.assert_array_equal(one.solver_stats[name], single.solver_stats[name])
    np.testing.assert_array_equal(one["e_y_m"], single["e_y_m"])
    pair = rollout_batch(NMPC.from_env(env), "DLC120-v0", [3, 4], max_steps=30)
    for trace in pair:
        stats = trace.solver_stats
        assert all(v.shape == (trace.n_steps,) for v in stats.values())
        assert stats["cold_starts"][0] == 1.0 and not stats["cold_starts"][1:].any()   # both cars cold, once
        assert np.all(stats["feedback_s"] + stats["preparation_s"] <= trace.policy_time_s)   # per car, nested
    assert evaluate_trace(pair[0])["sqp_iterations_mean"] == 1.0


def test_with_compute_charged_the_preparation_is_deferred_and_not_charged() -> None:
    """``latency="measured"``: the harness sets ``defer_preparation``, charges ``predict`` (the feedback) and calls
    ``prepare()`` after it; the policy's own setting is restored afterwards."""
    env = gym.make("DLC120-v0", latency="measured")
    policy = NMPC.from_env(env)
    charged: list[float] = []
    real = env.unwrapped.charge_compute

    def spy(seconds: float) -> None:
        charged.append(seconds)
        real(seconds)

    env.unwrapped.charge_compute = spy
    trace = rollout(policy, env, seed=0, max_steps=40)
    assert policy.defer_preparation is False and len(charged) == trace.n_steps
    stats = trace.solver_stats
    assert not stats["cold_starts"][1:].any()              # every deferred preparation was used
    warm = ~np.asarray(stats["cold_starts"], dtype=bool)   # a cold start prepares inside the charged feedback
    assert np.all(np.asarray(charged) >= stats["feedback_s"])
    assert np.all((np.asarray(charged) + stats["preparation_s"])[warm] <= trace.policy_time_s[warm])


def _actions(policy: NMPC, observations: list[np.ndarray], mode: str) -> np.ndarray:
    state, out = None, []
    for i, obs in enumerate(observations):
        if mode == "fresh":   # a new policy object for every decision: nothing prepared, the state carries all
            policy = NMPC(policy.design, policy.config, policy.layout, policy.control_period_s)
        policy.defer_preparation = mode == "deferred"
        action, state = policy.predict(obs, state=state, episode_start=i == 0)
        if mode == "deferred":
            policy.prepare()
        out.append(action[0])
    return np.array(out)


def test_the_prepared_record_is_only_a_cache() -> None:
    """Prepared in the call, deferred to ``prepare()``, or prepared in the feedback by a fresh object: the same
    commands bit for bit (the linearisation point is a function of the state row)."""
    env, policy = _policy()
    obs, _ = env.reset(seed=0, options={"initial_lateral_offset_m": 0.5})
    observations = [obs]
    for _ in range(25):
        obs, *_ = env.step(np.array([0.01], dtype=np.float32))
        observations.append(obs)
    inline = _actions(policy, observations, "inline")
    assert np.abs(inline).max() > 1e-3
    np.testing.assert_array_equal(_actions(policy, observations, "deferred"), inline)
    np.testing.assert_array_equal(_actions(policy, observations, "fresh"), inline)


def test_a_failed_qp_is_counted_and_the_shifted_plan_applied(monkeypatch: pytest.MonkeyPatch) -> None:
    env, policy = _policy()
    obs, _ = env.reset(seed=0)
    _, state = policy.predict(obs)
    monkeypatch.setattr(rti_engine, "solve_qp", lambda *args: (dense_qp.QP_INFEASIBLE, 3, 0))
    plan = state[0, 2:2 + N]
    action, state2 = policy.predict(obs, state=state)
    shifted = nmpc_rti.shifted(plan, 0.05, 0.01)
    assert policy.solver_failures == 1
    np.testing.assert_allclose(state2[0, 2:2 + N], shifted)
    assert action[0] == pytest.approx(shifted[0] / DESIGN.max_road_wheel_angle_rad, rel=1e-6)


def test_closed_loop_tracking_within_5_percent_of_the_casadi_iteration() -> None:
    """DLC120-v0: the compiled RTI (default) against CasADi's one Gauss-Newton step a decision (the old default)."""
    pytest.importorskip("casadi")
    env, new = _policy()
    _, old = _policy("casadi")
    m_new = evaluate_trace(rollout(new, env, seed=0))
    m_old = evaluate_trace(rollout(old, env, seed=0))
    assert m_new["success"] == 1.0 and m_new["solver_failures"] == 0.0
    assert m_new["max_e_y_m"] <= 1.05 * m_old["max_e_y_m"]
    assert abs(m_new["rms_e_y_m"] / m_old["rms_e_y_m"] - 1.0) < 0.05


def test_the_paired_nmpc_defers_its_preparation_in_the_accel_modes() -> None:
    """In ``control="steer_accel"`` the nmpc is paired with a speed law (``Decoupled``); under
    ``latency="measured"`` the harness's ``defer_preparation`` reaches the nmpc itself: every warm decision used
    the preparation deferred after the previous one, and the nmpc's own setting is restored afterwards."""
    env = gym.make("DLC120-v0", latency="measured", control="steer_accel")
    paired = vtrack_gym.make_policy("nmpc", env)
    assert paired.lateral.defer_preparation is False
    engine = paired.lateral._engine
    pending: list[int] = []
    real = engine.prepare_pending

    def spy() -> float:
        pending.append(len(engine._pending))
        return real()

    engine.prepare_pending = spy
    trace = rollout(paired, env, seed=0, max_steps=40)
    stats = trace.solver_stats
    assert trace.n_steps == 40 and not stats["cold_starts"][1:].any()
    assert pending == [1] * 40   # each decision left its preparation to the harness's prepare() call
    assert paired.lateral.defer_preparation is False and paired.defer_preparation is False
