"""Property-based fuzzing of the env API: actions, reset options, seeds, the native vector env.

Contract under test (README "Use it", ``TrackingEnv`` docstring): every ``step``/``reset`` either succeeds with a
finite observation inside ``observation_space``, a finite reward and bool flags, or raises ``ValueError`` naming
the problem. Never a NaN observation, never another exception type, never a hang.
"""

from __future__ import annotations

import math
import numbers

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.envs.config import ResetOptions

TERMINATIONS = {"", "completed", "off_road", "spin_out", "wheel_lift"}  # README: the documented set
FUZZ = settings(max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
N_VEC = 4


UNMEASURED_INF_KEYS = frozenset({"edge_margin_m"})
"""Info keys that are +inf where the scenario does not measure them (``envs.schema``: no edge in the rule)."""


def _finite_or_unmeasured(key: str, value: object) -> bool:
    """Finite, or +inf for a key that documents +inf as "not measured" (never NaN, never -inf)."""
    arr = np.asarray(value, dtype=float)
    if key in UNMEASURED_INF_KEYS:
        return bool(np.all(np.isfinite(arr) | (arr == np.inf)))
    return bool(np.isfinite(arr).all())


# --------------------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def env():
    e = gym.make("LateralTracking-v0")
    e.reset(seed=0)
    yield e
    e.close()


@pytest.fixture(scope="module")
def random_env():
    e = gym.make("LateralTrackingRandom-v0")
    e.reset(seed=0)
    yield e
    e.close()


@pytest.fixture(scope="module")
def venv():
    e = gym.make_vec("LateralTrackingRandom-v0", num_envs=N_VEC, vectorization_mode="vector_entry_point")
    e.reset(seed=0)
    yield e
    e.close()


# --------------------------------------------------------------------------------------------- strategies
SPECIAL = [math.nan, math.inf, -math.inf, 0.0, -0.0, 1.0, -1.0, 1e308, -1e308, 5e-324, 1e-300]
scalars = st.one_of(
    st.floats(),                                    # any double: NaN, inf, huge, subnormal
    st.sampled_from(SPECIAL),
    st.integers(-(2**70), 2**70),
    st.booleans(),
    st.floats(width=32).map(np.float32),
    st.integers(-100, 100).map(np.int64),
)
arrays = hnp.arrays(
    dtype=st.sampled_from([np.float64, np.float32, np.float16, np.int8, np.int64, np.uint8, np.bool_]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=3),
)
single_actions = st.one_of(
    scalars,
    arrays,
    scalars.map(np.asarray),                        # 0-d arrays
    st.lists(scalars, max_size=3),
    scalars.map(lambda v: [[v]]),
    st.tuples(scalars),
)


def _expected_ok(action, n: int) -> bool:
    """True when the documented contract says the action is acceptable (n finite numbers)."""
    arr = np.asarray(action, dtype=np.float64)
    return arr.size == n and bool(np.isfinite(arr).all())


def _check_obs(space: gym.spaces.Box, obs: np.ndarray) -> None:
    assert obs.dtype == np.float32
    assert obs.shape == space.shape
    assert np.isfinite(obs).all(), f"non-finite observation {obs}"
    assert space.contains(obs), f"observation outside the box: {obs}"


def _check_step(env, out) -> None:
    obs, reward, terminated, truncated, info = out
    _check_obs(env.observation_space, obs)
    assert isinstance(reward, float) and math.isfinite(reward)
    assert type(terminated) is bool and type(truncated) is bool
    assert info["termination"] in TERMINATIONS
    assert (info["termination"] != "") == terminated
    for key, value in info.items():
        if key != "termination":
            assert _finite_or_unmeasured(key, value), f"info[{key!r}] not finite: {value}"
    assert 0.0 <= info["throttle"] <= 1.0
    assert info["brake_n"] >= 0.0


# --------------------------------------------------------------------------------------------- single env
@FUZZ
@given(seed=st.integers(0, 2**32 - 1), actions=st.lists(single_actions, min_size=1, max_size=25))
def test_step_fuzzed_actions_valid_or_valueerror(env, seed, actions):
    env.reset(seed=seed)
    for action in actions:
        if _expected_ok(action, 1):
            out = env.step(action)
            _check_step(env, out)
            if out[2] or out[3]:
                env.reset(seed=seed)
        else:
            with pytest.raises(ValueError, match="action"):
                env.step(action)


@FUZZ
@given(seed=st.integers(0, 2**32 - 1),
       value=st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.integers(-(2**70), 2**70)))
def test_out_of_range_action_is_clipped(env, seed, value):
    """A finite action gives exactly the same step as the same action clipped to [-1, 1]."""
    env.reset(seed=seed)
    a = env.step(np.array([value]))
    env.reset(seed=seed)
    b = env.step(np.array([min(max(float(value), -1.0), 1.0)]))
    assert np.array_equal(a[0], b[0])
    assert a[1] == b[1]
    assert a[4]["road_wheel_angle_rad"] == b[4]["road_wheel_angle_rad"]


def test_steering_angle_and_rate_are_limited(env):
    """Full-lock bang-bang commands: |delta| <= 0.6 rad, |d delta| per 10 ms <= 800 deg/s / 16 x 0.01 s."""
    steering = env.unwrapped.config.vehicle.steering
    rate = steering.max_road_wheel_rate_radps * env.unwrapped.control_period_s
    env.reset(seed=0)
    delta = [0.0]
    for k in range(150):
        _, _, term, trunc, info = env.step([1e9 if (k // 40) % 2 == 0 else -1e9])
        delta.append(info["road_wheel_angle_rad"])
        if term or trunc:
            break
    d = np.array(delta)
    assert np.abs(d).max() <= steering.max_road_wheel_angle_rad + 1e-12
    assert np.abs(np.diff(d)).max() <= rate + 1e-12
    assert np.abs(d).max() > 0.5 * steering.max_road_wheel_angle_rad  # the command did reach the actuator


def test_step_before_reset_and_after_the_end_raises_runtimeerror():
    from vtrack_gym.envs.tracking_env import TrackingEnv

    e = TrackingEnv("DLC120-v0")
    with pytest.raises(RuntimeError, match="reset"):
        e.step([0.0])
    e.reset(seed=0)
    for _ in range(3000):
        _, _, term, trunc, _ = e.step([1.0])  # full lock at 120 km/h: leaves the road quickly
        if term or trunc:
            break
    assert term or trunc
    with pytest.raises(RuntimeError, match="reset"):
        e.step([0.0])
    e.close()


@pytest.mark.filterwarnings("ignore::numpy.exceptions.ComplexWarning")
@pytest.mark.parametrize("action", [{"a": 1}, 1 + 1j, object(), np.array([1 + 1j]), "abc"],
                         ids=["dict", "complex", "object", "complex_array", "str"])
def test_step_non_numeric_action_is_valueerror_naming_action(env, action):
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(action)


# --------------------------------------------------------------------------------------------- reset options
VALID_KEYS = sorted(ResetOptions.RANGES)
option_values = st.one_of(
    st.floats(),
    st.sampled_from(SPECIAL),
    st.integers(-(10**6), 10**6),
    st.booleans(),
    st.none(),
    st.text(max_size=6),
    st.lists(st.floats(), max_size=2),
    st.floats(-3, 3).map(str),
    st.floats(-3, 3).map(lambda v: np.array([v])),
    st.floats(-3, 3).map(np.float32),
)
in_range_values = st.sampled_from(VALID_KEYS).flatmap(
    lambda k: st.tuples(st.just(k), st.floats(*ResetOptions.RANGES[k])))
option_dicts = st.dictionaries(
    st.one_of(st.sampled_from(VALID_KEYS), st.text(max_size=12), st.integers(), st.none()),
    option_values, max_size=4,
) | st.lists(in_range_values, max_size=6).map(dict)


def _option_ok(key, value) -> bool:
    if key not in ResetOptions.RANGES:
        return False
    lo, hi = ResetOptions.RANGES[key]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return False  # only real numbers (issue 20: True, numeric strings and arrays are refused)
    v = float(value)
    if not (math.isfinite(v) and lo <= v <= hi):
        return False  # checked first: the period test below overflows on huge values (1.8e306 / 0.01 is inf)
    return key != "actuator_delay_s" or abs(v / 0.01 - round(v / 0.01)) <= 1e-9  # whole 10 ms periods, never rounded


@FUZZ
@given(seed=st.integers(0, 2**32 - 1), options=option_dicts)
def test_reset_fuzzed_options_valid_or_valueerror_naming_option(random_env, seed, options):
    bad = [k for k, v in options.items() if not _option_ok(k, v)]
    if bad:
        with pytest.raises(ValueError) as exc:
            random_env.reset(seed=seed, options=options)
        assert any(repr(k) in str(exc.value) or str(k) in str(exc.value) for k in bad), str(exc.value)
        return
    obs, info = random_env.reset(seed=seed, options=options)
    _check_obs(random_env.observation_space, obs)
    if "target_speed_mps" in options:
        assert info["target_speed_mps"] == float(options["target_speed_mps"])
    for _ in range(3):
        out = random_env.step([0.0])
        _check_step(random_env, out)
        if out[2] or out[3]:
            break


@settings(max_examples=25, deadline=None, database=None)
@given(options=st.one_of(st.lists(st.integers(), min_size=1), st.text(min_size=1), st.integers(1, 10),
                         st.tuples(st.just(("friction_mu", 0.5)))))
def test_reset_non_dict_options_raise_valueerror(random_env, options):
    with pytest.raises(ValueError, match="options must be a dict"):
        random_env.reset(seed=0, options=options)


@settings(max_examples=30, deadline=None, database=None)
@given(seed=st.one_of(st.integers(0, 2**64), st.integers(2**64, 2**200)))
def test_random_seeds_reset_reproducibly(random_env, seed):
    obs_a, info_a = random_env.reset(seed=seed)
    step_a = random_env.step([0.1])
    obs_b, info_b = random_env.reset(seed=seed)
    step_b = random_env.step([0.1])
    _check_obs(random_env.observation_space, obs_a)
    assert np.array_equal(obs_a, obs_b)
    assert info_a["target_speed_mps"] == info_b["target_speed_mps"]
    assert np.array_equal(step_a[0], step_b[0]) and step_a[1] == step_b[1]


# --------------------------------------------------------------------------------------------- vector env
vec_good = hnp.arrays(np.float64, st.sampled_from([(N_VEC, 1), (N_VEC,)]),
                      elements=st.floats(allow_nan=False, allow_infinity=False))
vec_any = st.one_of(
    vec_good,
    hnp.arrays(st.sampled_from([np.float64, np.float32, np.int64, np.bool_]),
               hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=5)),
    st.lists(st.lists(scalars, min_size=1, max_size=1), min_size=0, max_size=6),
    scalars,
)


def _check_vec_step(envs, out) -> None:
    obs, reward, terminated, truncated, info = out
    assert obs.shape == (N_VEC, *envs.single_observation_space.shape) and obs.dtype == np.float32
    assert np.isfinite(obs).all()
    assert envs.observation_space.contains(obs)
    assert reward.shape == (N_VEC,) and np.isfinite(reward).all()
    assert terminated.dtype == np.bool_ and truncated.dtype == np.bool_
    assert terminated.shape == truncated.shape == (N_VEC,)
    assert set(info["termination"].tolist()) <= TERMINATIONS
    for key, value in info.items():
        if not key.startswith("_") and key != "termination":
            assert _finite_or_unmeasured(key, value), f"info[{key!r}] not finite"


@FUZZ
@given(seed=st.integers(0, 2**32 - 1), actions=st.lists(vec_any, min_size=1, max_size=20))
def test_vector_step_fuzzed_actions_valid_or_valueerror(venv, seed, actions):
    venv.reset(seed=seed)
    for action in actions:
        if _expected_ok(action, N_VEC):
            _check_vec_step(venv, venv.step(action))
        else:
            with pytest.raises(ValueError, match="action"):
                venv.step(action)


@settings(max_examples=20, deadline=None, database=None)
@given(seed=st.integers(0, 2**32 - 1), amplitude=st.floats(0.0, 1e6))
def test_vector_long_random_run_stays_finite(venv, seed, amplitude):
    """300 steps of random (N, 1) actions, through terminations and autoresets."""
    rng = np.random.default_rng(seed)
    venv.reset(seed=seed, options={"sensor_noise": 1.0})
    for _ in range(300):
        _check_vec_step(venv, venv.step(rng.uniform(-amplitude, amplitude, (N_VEC, 1))))


@settings(max_examples=30, deadline=None, database=None)
@given(mask=st.one_of(hnp.arrays(np.bool_, st.integers(0, 8)), st.lists(st.booleans(), max_size=8), st.none(),
                      st.text(max_size=3)))
def test_vector_reset_mask_shape_checked(venv, mask):
    try:
        ok = np.asarray(mask, dtype=bool).shape == (N_VEC,)
    except ValueError:
        ok = False
    if ok:
        obs, _ = venv.reset(seed=1, options={"reset_mask": mask})
        assert np.isfinite(obs).all()
    else:
        with pytest.raises(ValueError, match="reset_mask"):
            venv.reset(seed=1, options={"reset_mask": mask})


# --------------------------------------------------------------------------------------------- wheel loads
@pytest.mark.parametrize("mass_scale", [0.7, 1.0, 1.5])
def test_wheel_loads_sum_to_weight_after_first_step_from_rest(mass_scale):
    """LateralTracking-v0 starts at rest: after one zero-steer step sum(F_z) = m g cos(grade) + m a_z,road."""
    e = gym.make("LateralTracking-v0")
    e.reset(seed=0, options={"mass_scale": mass_scale})
    sim = e.unwrapped._sim
    grade, a_z = sim.road[0, 0], sim.road[0, 1]  # road inputs applied during the first control period
    _, _, _, _, info = e.step([0.0])
    mass = e.unwrapped.config.vehicle.chassis.mass_kg * mass_scale
    expected = mass * (9.81 * math.cos(grade) + a_z)
    assert info["fz_n"].sum() == pytest.approx(expected, rel=1e-3)
    assert info["v_mps"] < 0.1
    e.close()


def test_reset_info_reports_static_wheel_loads():
    e = gym.make("LateralTracking-v0")
    _, info = e.reset(seed=0)
    mass = e.unwrapped.config.vehicle.chassis.mass_kg
    assert info["fz_n"].sum() == pytest.approx(mass * 9.81, rel=1e-2)
    assert info["min_fz_n"] > 0.0
    e.close()
