"""Contracts shared by every steering baseline: predict shapes/dtypes/clipping, state and episode_start,
single == batch, NaN handling, registry and from_env, SB3 evaluate_policy."""

from __future__ import annotations

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from linear_closed_loop import DESIGN, LinearPlant, curve_entry, dlc_proxy, simulate_many, straight

from vtrack_gym.baselines.base import Policy, SpeedSchedule, env_contract
from vtrack_gym.baselines.registry import available_policies, available_presets, make_policy, policy_class
from vtrack_gym.envs.observation import OBS

NAMES = ("smc", "mpc", "lqr", "stanley", "pure_pursuit", "mpc_osqp", "nmpc")
FAKE_ENV = SimpleNamespace(unwrapped=SimpleNamespace(design_model=DESIGN, observation_layout=OBS,
                                                     control_period_s=0.01))


# OSQP solves iteratively to eps = 1e-7: a row's solution depends slightly on the solver's workspace history
# (its KKT factorisation at the previous speed, its previous iterate), so single == batch only within the
# solver tolerance for mpc_osqp; the other controllers agree to float64 rounding.
ACTION_ATOL = {"mpc_osqp": 1e-5}
STATE_ATOL = {"mpc_osqp": 1e-4}


def assert_state_close(name: str, actual: np.ndarray, expected: np.ndarray, pol: Policy) -> None:
    """Compare policy memories (for mpc_osqp only u(k-1) and the hold counter: the stored warm start is an
    ADMM iterate, accurate only to the solver tolerance in the QP's flat directions)."""
    n = 2 if name == "mpc_osqp" else actual.shape[-1]
    np.testing.assert_allclose(actual[..., :n], expected[..., :n], rtol=1e-9, atol=STATE_ATOL.get(name, 1e-9))


@pytest.fixture(scope="module")
def policies() -> dict[str, Policy]:
    return {name: make_policy(name, FAKE_ENV) for name in NAMES}


def random_observations(n: int, seed: int = 0) -> np.ndarray:
    """Plausible observations: random speeds, errors, motion states and curvature profiles."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        v = float(rng.uniform(0.5, 40.0))
        profile = (straight(), curve_entry(v, float(rng.uniform(50, 500)), t_start=0.0), dlc_proxy(lead=0.0))[i % 3]
        plant = LinearPlant(v, profile, e_y0=float(rng.normal(0, 0.3)), e_phi0=float(rng.normal(0, 0.05)))
        plant.x[2], plant.x[3] = float(rng.normal(0, 0.3)), float(rng.normal(0, 0.1))
        plant.x[4] = float(rng.uniform(0, 60))
        plant.delta = float(rng.uniform(-0.1, 0.1))
        rows.append(plant.observation())
    return np.array(rows)


def test_registry_names_and_errors() -> None:
    assert available_policies() == NAMES
    with pytest.raises(ValueError, match="valid: smc, mpc, lqr, stanley, pure_pursuit, mpc_osqp"):
        make_policy("pid", FAKE_ENV)
    with pytest.raises(ValueError, match="valid: default, tuned, observer, accel, paper, hand"):
        make_policy("smc", FAKE_ENV, preset="fast")
    with pytest.raises(ValueError, match="unknown SMCConfig field"):
        make_policy("smc", FAKE_ENV, pole=3.0)
    with pytest.raises(ValueError, match=r"SMCConfig\.pole_radps"):
        make_policy("smc", FAKE_ENV, pole_radps=-1.0)
    pol = make_policy("smc", FAKE_ENV, preset="paper", pole_radps=2.0)
    assert pol.config.pole_radps == 2.0 and pol.config.reaching_gain == 973.4083
    assert "paper_siso" in available_presets("mpc")
    for name in NAMES:
        assert "default" in available_presets(name)
        assert policy_class(name).name == name


def test_from_env_reads_contract() -> None:
    env = SimpleNamespace(unwrapped=SimpleNamespace(design_model=DESIGN, observation_layout=OBS,
                                                    control_period_s=0.02))
    pol = policy_class("mpc").from_env(env)
    assert pol.control_period_s == 0.02 and pol.n_hold == 1
    vec = SimpleNamespace(get_attr=lambda name: [getattr(FAKE_ENV.unwrapped, name)] * 3)
    assert env_contract(vec)[2] == 0.01
    with pytest.raises(ValueError, match="missing 'design_model'"):
        env_contract(SimpleNamespace(unwrapped=SimpleNamespace()))


@pytest.mark.parametrize("name", NAMES)
def test_shapes_dtype_and_state(name: str, policies: dict[str, Policy]) -> None:
    pol = policies[name]
    obs = random_observations(5)
    a1, s1 = pol.predict(obs[0])
    assert a1.shape == (1,) and a1.dtype == np.float32
    ab, sb = pol.predict(obs)
    assert ab.shape == (5, 1) and ab.dtype == np.float32
    a11, _ = pol.predict(obs[:1])
    assert a11.shape == (1, 1)
    assert np.all(np.abs(ab) <= 1.0)
    if pol.state_size == 0:
        assert s1 is None and sb is None
    else:
        assert s1.shape == (1, pol.state_size) and sb.shape == (5, pol.state_size)
        assert s1.dtype == np.float64


@pytest.mark.parametrize("name", NAMES)
def test_single_equals_batch_over_a_closed_loop(name: str, policies: dict[str, Policy]) -> None:
    """Stepping N plants with one batched predict equals N single-observation loops (state kept per row)."""
    pol = policies[name]
    cases = [(11.11, curve_entry(11.11, 100.0), 0.0), (33.33, dlc_proxy(), 0.2), (20.0, straight(), -0.4),
             (5.0, curve_entry(5.0, 30.0), 0.1)]
    batched = simulate_many(pol, [LinearPlant(v, p, e_y0=e) for v, p, e in cases], 1.5, batched=True)
    single = simulate_many(pol, [LinearPlant(v, p, e_y0=e) for v, p, e in cases], 1.5, batched=False)
    atol = ACTION_ATOL.get(name, 1e-6) * pol.max_steer_rad
    for b, s in zip(batched, single, strict=True):
        np.testing.assert_allclose(b.delta, s.delta, rtol=0, atol=atol)
        np.testing.assert_allclose(b.e_y, s.e_y, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_single_equals_batch_on_random_observations(name: str, policies: dict[str, Policy]) -> None:
    pol = policies[name]
    obs = random_observations(30, seed=1)
    atol = ACTION_ATOL.get(name, 1e-6)
    ab, sb = pol.predict(obs)
    for i in range(obs.shape[0]):
        a, s = pol.predict(obs[i], episode_start=True)
        np.testing.assert_allclose(a, ab[i], rtol=0, atol=atol)
        if s is not None:
            assert_state_close(name, s[0], sb[i], pol)
    if pol.state_size:   # second step from a given state
        obs2 = random_observations(30, seed=2)
        ab2, sb2 = pol.predict(obs2, sb)
        for i in range(obs2.shape[0]):
            a, s = pol.predict(obs2[i], sb[i:i + 1])
            np.testing.assert_allclose(a, ab2[i], rtol=0, atol=atol)
            assert_state_close(name, s[0], sb2[i], pol)


@pytest.mark.parametrize("name", ["mpc", "mpc_osqp"])
def test_episode_start_reinitialises_rows(name: str, policies: dict[str, Policy]) -> None:
    pol = policies[name]
    obs = random_observations(4, seed=3)
    _, state = pol.predict(obs)
    _, state = pol.predict(obs, state)
    starts = np.array([False, True, False, True])
    atol = ACTION_ATOL.get(name, 1e-6)
    a, s = pol.predict(obs, state, episode_start=starts)
    fresh_a, fresh_s = pol.predict(obs[starts], episode_start=True)
    np.testing.assert_allclose(a[starts], fresh_a, rtol=0, atol=atol)
    assert_state_close(name, s[starts], fresh_s, pol)
    kept_a, _ = pol.predict(obs[~starts], state[~starts])
    np.testing.assert_allclose(a[~starts], kept_a, rtol=0, atol=atol)
    # single observation: bool or 1-element array
    a1, _ = pol.predict(obs[1], state[1:2], episode_start=True)
    np.testing.assert_allclose(a1, fresh_a[0], rtol=0, atol=atol)
    a1, _ = pol.predict(obs[1], state[1:2], episode_start=np.array([True]))
    np.testing.assert_allclose(a1, fresh_a[0], rtol=0, atol=atol)
    with pytest.raises(ValueError, match="episode_start"):
        pol.predict(obs, state, episode_start=np.array([True, False]))
    with pytest.raises(ValueError, match="state must have shape"):
        pol.predict(obs, state[:2])


@pytest.mark.parametrize("name", NAMES)
def test_nan_and_shape_errors(name: str, policies: dict[str, Policy]) -> None:
    pol = policies[name]
    obs = random_observations(3)
    bad = obs.copy()
    bad[1, 5] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        pol.predict(bad)
    with pytest.raises(ValueError, match="NaN"):
        pol.predict(bad[1])
    bad[1, 5] = np.inf
    with pytest.raises(ValueError, match="NaN/inf"):
        pol.predict(bad[1])
    with pytest.raises(ValueError, match="observation must have"):
        pol.predict(obs[:, :-1])
    with pytest.raises(ValueError, match="observation must have"):
        pol.predict(obs[0, :-1])


@pytest.mark.parametrize("name", [n for n in NAMES if n != "nmpc"])   # nmpc: tests/test_nmpc.py (its own model)
def test_actions_clipped(name: str, policies: dict[str, Policy]) -> None:
    """Extreme demands (1 m radius, 50 m offset, huge reference yaw acceleration) give exactly +-1."""
    pol = policies[name]
    lay = pol.layout
    obs = random_observations(2)
    for row, sign in ((0, 1.0), (1, -1.0)):
        obs[row, lay.CURVATURE], obs[row, lay.preview] = sign, sign
        obs[row, lay.CURVATURE_RATE], obs[row, lay.E_Y], obs[row, lay.E_PHI] = 0.0, -50.0 * sign, 0.0
        obs[row, lay.YAW_RATE_REF], obs[row, lay.YAW_ACC_REF] = 30.0 * sign, 1e4 * sign
        if name == "pure_pursuit":   # 50 m abeam is only kappa = 2/50: use a large heading error at 2 m/s
            obs[row, lay.E_Y], obs[row, lay.E_PHI], obs[row, lay.V_X] = 0.0, -1.2 * sign, 2.0
            obs[row, lay.CURVATURE], obs[row, lay.preview] = 0.0, 0.0
        if name == "mpc":   # above 1 m/s its command stays within the front slip bound (tests/test_mpc.py)
            obs[row, lay.V_X] = 0.9
    a, s = pol.predict(obs)
    for _ in range(100):   # rate-limited controllers need a few samples to reach the limit
        a, s = pol.predict(obs, s)
    assert a.dtype == np.float32
    np.testing.assert_array_equal(np.abs(a[:, 0]), np.array([1.0, 1.0], dtype=np.float32))


def test_overflowing_checksum_of_finite_values_is_accepted() -> None:
    """The single path's NaN check sums the row; a finite overflow falls back to an exact check."""
    pol = make_policy("smc", FAKE_ENV)        # reads neither target_speed nor the speed preview
    huge = random_observations(1)[0]
    huge[pol.layout.TARGET_SPEED] = 1e308
    huge[pol.layout.speed_preview.start] = 1e308
    a, _ = pol.predict(huge)
    assert np.isfinite(a).all()


def test_accepts_lists_and_float32() -> None:
    pol = make_policy("smc", FAKE_ENV)
    obs = random_observations(1)[0]
    a64, _ = pol.predict(obs)
    a32, _ = pol.predict(obs.astype(np.float32))
    alist, _ = pol.predict(obs.tolist())
    assert a64.shape == a32.shape == alist.shape == (1,)
    np.testing.assert_allclose(a32, a64, atol=1e-4)


def test_speed_schedule_row_interpolates_every_entry_linearly() -> None:
    """The compiled schedule lookup against numpy's own linear interpolation of each entry (clamped at the ends)."""
    speeds = np.geomspace(1, 45, 7)
    table = np.random.default_rng(0).normal(size=(7, 5))
    sch = SpeedSchedule(speeds, table)
    for v in (0.5, 1.0, 3.3, 17.0, 44.9, 45.0, 60.0):
        ref = [np.interp(v, speeds, table[:, c]) for c in range(5)]
        np.testing.assert_allclose(sch.row(v), ref, rtol=1e-12, atol=1e-15)
        i, t = sch.locate(v)
        assert 0 <= i <= 5 and 0.0 <= t <= 1.0
        assert speeds[i] + t * (speeds[i + 1] - speeds[i]) == pytest.approx(min(max(v, 1.0), 45.0), rel=1e-12)
    np.testing.assert_array_equal(sch.row(1.0), table[0])
    np.testing.assert_allclose(sch.row(100.0), table[-1], rtol=1e-12)  # last interval at t = 1


class _LinearEnv(gym.Env):
    """Tiny Gymnasium env around the linear closed-loop plant (only for the SB3 integration test)."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (OBS.size,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self) -> None:
        self.design_model, self.observation_layout, self.control_period_s = DESIGN, OBS, 0.01
        self.plant = None
        self.steps = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        super().reset(seed=seed)
        self.plant = LinearPlant(11.11, curve_entry(11.11, 100.0, t_start=0.2), e_y0=0.3)
        self.steps = 0
        return self.plant.observation().astype(np.float32), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.plant.step(float(np.clip(action, -1, 1)[0]) * DESIGN.max_road_wheel_angle_rad, 0.01)
        self.steps += 1
        obs = self.plant.observation()
        return obs.astype(np.float32), -abs(float(obs[0])), False, self.steps >= 150, {}


def test_sb3_evaluate_policy_with_stateful_policy() -> None:
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([_LinearEnv, _LinearEnv])
    pol = make_policy("mpc", venv)
    rewards, lengths = evaluate_policy(pol, venv, n_eval_episodes=4, return_episode_rewards=True, warn=False)
    assert lengths == [150] * 4
    assert max(rewards) > -150 * 0.3                     # the 0.3 m initial offset is removed
    assert np.allclose(rewards, rewards[0], rtol=1e-5)    # identical episodes: state reset on episode start
