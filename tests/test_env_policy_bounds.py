"""Issue 20, classes 4 and 5: configs at their range edges stay finite; env inputs are exact or refused.

Class 4: every env config and every baseline config inside its declared ranges gives finite observations (inside
the box), rewards and actions, also at the edges of the ranges. Class 5: no silent reinterpretation of inputs
(actuator delay, vector-env stepping before reset, ``reset_mask``, autoreset and the noise generator, action and
option types).
"""

from __future__ import annotations

import dataclasses
import datetime
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vtrack_gym  # noqa: F401  (registers the envs)
from vtrack_gym._ranges import RANGE_KEY
from vtrack_gym.baselines.configs import SMCConfig
from vtrack_gym.envs.config import MAX_NOISE_STD, EnvConfig, ResetOptions, RewardConfig
from vtrack_gym.envs.observation import OBS
from vtrack_gym.envs.tracking_env import TrackingEnv
from vtrack_gym.envs.vector_env import TrackingVectorEnv

EDGES = settings(max_examples=20, deadline=None, database=None)


def edge_values(cls: type, fixed: tuple[str, ...] = ()) -> dict[str, list[float]]:
    """Field -> its range's two numeric edges (an open bound is approached by one ulp); fields whose bounds name
    another field, or listed in ``fixed``, are left at their defaults."""
    out: dict[str, list[float]] = {}
    for f in dataclasses.fields(cls):
        rng = f.metadata.get(RANGE_KEY)
        if rng is None or f.name in fixed:
            continue
        lo = rng.ge if rng.ge is not None else rng.gt
        hi = rng.le if rng.le is not None else rng.lt
        if isinstance(lo, str) or isinstance(hi, str) or lo is None or hi is None:
            continue
        if rng.integer:
            out[f.name] = [int(lo) + (rng.gt is not None), int(hi) - (rng.lt is not None)]
        else:
            out[f.name] = [float(lo) if rng.gt is None else math.nextafter(float(lo), math.inf),
                           float(hi) if rng.lt is None else math.nextafter(float(hi), -math.inf)]
    return out


def edge_configs(cls: type, fixed: tuple[str, ...] = ()) -> st.SearchStrategy:
    """Configs of ``cls`` with every ranged field at one of its edges (a random corner of the box)."""
    edges = edge_values(cls, fixed)

    def build(kw: dict[str, float]) -> object | None:
        try:
            return cls(**kw)
        except ValueError as exc:  # only a bound naming another field (e.g. max_speed > min_speed) may refuse
            assert " = " in str(exc), str(exc)  # the text of a bound naming a field: "(min_speed_mps = 80.0, ..."
            return None

    return st.fixed_dictionaries({k: st.sampled_from(v) for k, v in edges.items()}).map(build).filter(
        lambda c: c is not None)


def _check_vec(envs, obs, reward) -> None:
    assert obs.dtype == np.float32 and np.isfinite(obs).all()
    assert envs.observation_space.contains(obs), "observation outside the box"
    assert np.isfinite(reward).all(), f"non-finite reward {reward}"


# ----------------------------------------------------------------------------------------------- class 4: env
RESET_EDGES = st.fixed_dictionaries({k: st.sampled_from([lo, hi]) for k, (lo, hi) in ResetOptions.RANGES.items()})


@EDGES
@given(reward=edge_configs(RewardConfig), noise=st.sampled_from([0.0, MAX_NOISE_STD]), options=RESET_EDGES,
       period=st.sampled_from([0.002, 0.01, 0.1]), seed=st.integers(0, 2**32 - 1),
       amplitude=st.sampled_from([0.0, 1.0, 1e300]))
def test_env_configs_at_range_edges_give_finite_observations_and_rewards(reward, noise, options, period, seed,
                                                                         amplitude):
    """Reward weights, scales and penalties at their edges, the largest noise, every reset option at an edge of its
    range (sensor noise 0 or 5, delay 0 or 0.5 s, friction 0.1 or 1.5, ...) and control periods of 2 ms to 100 ms:
    150 steps of random actions on 4 cars (through failures and autoresets) keep observations finite and inside
    the box and rewards finite."""
    config = EnvConfig(reward=reward, noise_std=(noise,) * 8, control_period_s=period)
    envs = TrackingVectorEnv("LateralTrackingRandom-v0", num_envs=4, config=config)
    obs, _ = envs.reset(seed=seed, options=options)
    _check_vec(envs, obs, np.zeros(4))
    rng = np.random.default_rng(seed)
    for _ in range(150):
        obs, reward_, *_ = envs.step(rng.uniform(-1.0, 1.0, (4, 1)) * amplitude)
        _check_vec(envs, obs, reward_)


@pytest.mark.parametrize("kwargs", [
    {"noise_std": (math.inf,) * 8}, {"noise_std": (1e300,) * 8}, {"noise_std": (1.5,) * 8},
    {"noise_std": (True,) * 8}, {"reward": {"failure_penalty": -math.inf}}, {"reward": {"failure_penalty": -1e7}},
    {"reward": {"w_ey": 1e308}}, {"reward": {"alive": 1e7}}, {"reward": {"ey_scale_m": 5e-324}},
])
def test_configs_that_could_overflow_are_refused(kwargs):
    with pytest.raises(ValueError, match=r"noise_std|RewardConfig"):
        if "reward" in kwargs:
            RewardConfig(**kwargs["reward"])
        else:
            EnvConfig(**kwargs)


# ------------------------------------------------------------------------------------------- class 4: policies
def _observations(seed: int) -> np.ndarray:
    """Observations of a random-action rollout (terminations included) plus random points of the box."""
    envs = TrackingVectorEnv("LateralTrackingRandom-v0", num_envs=8)
    obs, _ = envs.reset(seed=seed, options={"sensor_noise": 1.0})
    rows = [obs]
    rng = np.random.default_rng(seed)
    for _ in range(60):
        obs, *_ = envs.step(rng.uniform(-1.0, 1.0, (8, 1)))
        rows.append(obs)
    low, high = envs.single_observation_space.low, envs.single_observation_space.high
    rows.append(rng.uniform(low, high, (32, low.size)).astype(np.float32))
    rows.append(np.zeros((1, low.size), dtype=np.float32))
    return np.concatenate(rows)


_ROLLOUT: list[np.ndarray] = []


def _obs() -> np.ndarray:
    """The observations of ``_observations(3)``, computed once per test session."""
    if not _ROLLOUT:
        _ROLLOUT.append(_observations(3))
    return _ROLLOUT[0]


def _policy_configs() -> st.SearchStrategy:
    from vtrack_gym.baselines.configs import MPCConfig
    from vtrack_gym.baselines.lqr import LQRConfig
    from vtrack_gym.baselines.pure_pursuit import PurePursuitConfig
    from vtrack_gym.baselines.stanley import StanleyConfig

    # The sample time must be a multiple of the env's 10 ms period; 2 speeds keep the gain tables quick to build.
    mpc = st.tuples(edge_configs(MPCConfig, fixed=("n_speeds", "sample_time_s")), st.sampled_from([0.0, 1e6]),
                    st.sampled_from([0.01, 0.2])).map(
        lambda c: dataclasses.replace(c[0], weights=(c[1],) * 12, sample_time_s=c[2], n_speeds=2))
    return st.one_of(st.tuples(st.just("smc"), edge_configs(SMCConfig)),
                     st.tuples(st.just("mpc"), mpc),
                     st.tuples(st.just("lqr"), edge_configs(LQRConfig, fixed=("n_speeds",)).map(
                         lambda c: dataclasses.replace(c, n_speeds=2))),
                     st.tuples(st.just("stanley"), edge_configs(StanleyConfig)),
                     st.tuples(st.just("pure_pursuit"), edge_configs(PurePursuitConfig)))


@settings(max_examples=40, deadline=None, database=None)
@given(named=_policy_configs())
def test_policies_at_range_edges_predict_finite_actions(named):
    """Each baseline with every ranged field at an edge (MPC: all weights 0 or 1e6, input weight 1e-6 or 1e6):
    finite actions in [-1, 1] on rollout observations, random points of the observation box and all-zero rows,
    on the batch and the single-observation paths."""
    from vtrack_gym.baselines.lqr import LQR
    from vtrack_gym.baselines.mpc import MPC
    from vtrack_gym.baselines.pure_pursuit import PurePursuit
    from vtrack_gym.baselines.smc import SMC
    from vtrack_gym.baselines.stanley import Stanley

    name, config = named
    env = TrackingEnv("LateralTrackingRandom-v0")
    cls = {"smc": SMC, "mpc": MPC, "lqr": LQR, "stanley": Stanley, "pure_pursuit": PurePursuit}[name]
    base = cls.from_env(env)
    try:
        policy = cls(base.design, config, layout=base.layout, control_period_s=base.control_period_s)
    except np.linalg.LinAlgError as exc:  # LQR weights with no stabilising DARE solution: refused at construction
        assert name == "lqr" and isinstance(exc, ValueError), (name, exc)
        return
    obs = _obs()
    actions, _ = policy.predict(obs)
    assert np.isfinite(actions).all() and np.abs(actions).max() <= 1.0
    for row in obs[::37]:
        policy.reset()
        a, _ = policy.predict(row)
        assert np.isfinite(a).all()


def test_smc_just_below_the_singular_speed_is_finite():
    """The guard band may not be 0 (it was a division by zero one ulp below v*); the smallest band is finite."""
    from vtrack_gym.baselines.laws import smc_singular_speed
    from vtrack_gym.baselines.smc import SMC

    with pytest.raises(ValueError, match="guard_band_mps"):
        SMCConfig(guard_band_mps=0.0)
    env = TrackingEnv("LateralTracking-v0")
    base = SMC.from_env(env)
    policy = SMC(base.design, SMCConfig(guard_band_mps=0.05), layout=base.layout,
                 control_period_s=base.control_period_s)
    v_star = smc_singular_speed(base.design)
    obs = np.zeros((5, base.layout.size))
    obs[:, base.layout.index("v_x")] = [math.nextafter(v_star, 0.0), v_star, math.nextafter(v_star, 99.0),
                                        v_star - 0.05, v_star + 0.05]
    obs[:, base.layout.index("e_y")] = 0.1
    actions, _ = policy.predict(obs)
    assert np.isfinite(actions).all()


# ----------------------------------------------------------------------------------------- class 5: the delay
def _deltas(options: dict, steps: int = 8) -> list[float]:
    env = TrackingEnv("DLC120-v0")
    env.reset(seed=0, options=options)
    return [float(env.step([0.5])[0][OBS.ROAD_WHEEL_ANGLE]) for _ in range(steps)]


@pytest.mark.parametrize("delay_s", [0.005, 0.025, 0.015, 0.0001, 0.4999])
def test_delay_that_is_not_a_whole_number_of_periods_is_refused(delay_s):
    """Delays are applied exactly in control periods (10 ms): 5 ms and 25 ms are refused, not rounded to 0 and
    20 ms; the single env, the vector env and its reset loop refuse before changing anything."""
    env = TrackingEnv("LateralTracking-v0")
    with pytest.raises(ValueError, match="actuator_delay_s"):
        env.reset(seed=0, options={"actuator_delay_s": delay_s})
    envs = TrackingVectorEnv("LateralTracking-v0", num_envs=2)
    with pytest.raises(ValueError, match="actuator_delay_s"):
        envs.reset(seed=0, options={"actuator_delay_s": delay_s})


@pytest.mark.parametrize("periods", [0, 1, 2, 3, 5])
def test_whole_period_delays_delay_the_command_exactly(periods):
    """A delay of k periods (the robust suite's 0-50 ms) holds the command back exactly k steps."""
    deltas = _deltas({"actuator_delay_s": round(0.01 * periods, 3)})
    assert all(d == 0.0 for d in deltas[:periods])
    assert deltas[periods] != 0.0


# ---------------------------------------------------------------------------------- class 5: the vector env
def test_vector_step_before_reset_and_never_reset_cars_are_refused():
    envs = TrackingVectorEnv("LateralTracking-v0", num_envs=3)
    with pytest.raises(RuntimeError, match="reset"):
        envs.step(np.zeros((3, 1)))
    envs.reset(seed=0, options={"reset_mask": np.array([True, False, True])})
    with pytest.raises(RuntimeError, match=r"\[1\]"):
        envs.step(np.zeros((3, 1)))
    envs.reset(seed=0, options={"reset_mask": np.array([False, True, False])})
    obs, reward, *_ = envs.step(np.zeros((3, 1)))
    assert np.isfinite(obs).all() and np.isfinite(reward).all()


@pytest.mark.parametrize("mask", ["TTF", "abc", None, math.nan, [1, 0, 1], np.array([1, 0, 1]),
                                  np.array([np.nan, 0, 1]), np.array(["a", "b", "c"]), [True, False],
                                  np.ma.array([True, False, True]), np.array([[True, False, True]]), True])
def test_reset_mask_must_be_bools_of_shape_n(mask):
    envs = TrackingVectorEnv("LateralTracking-v0", num_envs=3)
    with pytest.raises(ValueError, match="reset_mask"):
        envs.reset(seed=0, options={"reset_mask": mask})


def test_vector_env_with_noise_matches_single_envs_across_episodes():
    """With sensor noise on, car i of a vector env seeded s matches a single env seeded s + i over several episodes
    (the discarded autoreset step draws no noise), bit for bit."""
    n, seed, steps = 3, 11, 1500
    opts = {"sensor_noise": 2.0}
    envs = TrackingVectorEnv("LateralTrackingRandom-v0", num_envs=n)
    obs, _ = envs.reset(seed=seed, options=opts)
    rng = np.random.default_rng(0)
    actions = np.repeat(rng.choice([-1.0, 1.0], (steps // 50, n, 1)), 50, axis=0)  # full lock, 0.5 s each way
    vec_obs, vec_rew, vec_done = [obs], [], []
    for t in range(steps):
        o, r, term, trunc, _ = envs.step(actions[t])
        vec_obs.append(o)
        vec_rew.append(r)
        vec_done.append(term | trunc)
    episodes = np.sum(vec_done, axis=0)
    assert episodes.min() >= 2, f"want at least 2 episode ends per car (got {episodes})"
    for i in range(n):
        env = TrackingEnv("LateralTrackingRandom-v0")
        o, _ = env.reset(seed=seed + i, options=opts)
        assert np.array_equal(o, vec_obs[0][i])
        reset_next = False
        for t in range(steps):
            if reset_next:  # the vector env's autoreset step: its first observation, reward 0
                o, _ = env.reset(options=opts)
                assert np.array_equal(o, vec_obs[t + 1][i]) and vec_rew[t][i] == 0.0, (i, t)
                reset_next = False
                continue
            o, r, term, trunc, _ = env.step(actions[t, i])
            assert np.array_equal(o, vec_obs[t + 1][i]) and r == vec_rew[t][i], (i, t)
            reset_next = term or trunc


# ------------------------------------------------------------------------------- class 5: action/option types
@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("action", [
    np.datetime64("2020-01-01"), datetime.datetime(2020, 1, 1), datetime.timedelta(seconds=1), np.timedelta64(1),
    b"0.5", bytearray(b"1"), "1_0", "0.5", ["0.5"], np.array(["0.5"]), np.ma.array([0.5]),
    np.ma.array([0.5], mask=[True]), [[0.1], [0.2, 0.3]], 10**400, [datetime.date(2020, 1, 1)]],
    ids=lambda a: type(a).__name__)
def test_non_real_actions_are_refused_naming_the_action(action):
    env = TrackingEnv("LateralTracking-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)
    envs = TrackingVectorEnv("LateralTracking-v0", num_envs=1)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        envs.step(action)


@pytest.mark.parametrize("value", [True, False, np.bool_(True), "1.0", "1_0", b"1", np.array([1.0]), [1.0]])
def test_reset_option_values_must_be_real_numbers(value):
    env = TrackingEnv("LateralTracking-v0")
    with pytest.raises(ValueError, match="mass_scale"):
        env.reset(seed=0, options={"mass_scale": value})
