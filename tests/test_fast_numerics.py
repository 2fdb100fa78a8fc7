"""The ``fast`` numerics mode (``vehicle.numerics``): its maths functions' error bounds, its plant against the
default one, and the env mode a user reaches with ``gym.make(..., numerics="fast")``."""

from __future__ import annotations

import math

import gymnasium as gym
import numba
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.vehicle import fast_math as fm
from vtrack_gym.vehicle.params import TyreParams, VehicleParams
from vtrack_gym.vehicle.plant import Plant

mp = pytest.importorskip("mpmath")


@numba.njit
def _evaluate(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """sin, cos of ``x``, atan_ratio(x, y), tanh of ``x`` (rows)."""
    out = np.empty((4, x.size))
    for i in range(x.size):
        out[0, i], out[1, i] = fm.sin_cos(x[i])
        out[2, i] = fm.atan_ratio(x[i], y[i])
        out[3, i] = fm.tanh_bounded(x[i])
    return out


def _max_error(values: np.ndarray, reference, args) -> float:
    mp.mp.dps = 40
    return max(float(abs(mp.mpf(float(v)) - reference(*a))) for v, a in zip(values, args, strict=True))


def test_sin_cos_error_bounds() -> None:
    rng = np.random.default_rng(1)
    near = np.concatenate([np.linspace(-4 * np.pi, 4 * np.pi, 4001), rng.uniform(-4 * np.pi, 4 * np.pi, 4000),
                           np.arange(-8, 9) * (np.pi / 4)])
    far = rng.uniform(-1e3, 1e3, 3000)
    for x, bound in ((near, 4e-16), (far, 3e-13)):
        args = [(mp.mpf(float(v)),) for v in x]
        out = _evaluate(x, np.ones_like(x))
        assert _max_error(out[0], mp.sin, args) <= bound
        assert _max_error(out[1], mp.cos, args) <= bound


def test_atan_ratio_error_bound_and_symmetry() -> None:
    rng = np.random.default_rng(2)
    y = np.concatenate([np.linspace(-3.0, 3.0, 3001), np.sign(rng.uniform(-1, 1, 3000)) * 10 ** rng.uniform(-8, 6, 3000),
                        [0.0, math.tan(math.pi / 8), math.tan(3 * math.pi / 8)]])
    x = np.concatenate([np.ones(3001), rng.uniform(0.5, 60.0, 3000), np.ones(3)])
    args = [(mp.mpf(float(a)), mp.mpf(float(b))) for a, b in zip(y, x, strict=True)]
    out = _evaluate(y, x)
    assert _max_error(out[2], mp.atan2, args) <= 4e-16
    assert np.array_equal(_evaluate(-y, x)[2], -out[2])


def test_tanh_error_bound_and_saturation() -> None:
    y = np.concatenate([np.linspace(-25.0, 25.0, 5001), [0.0, 1e-9, 19.999999, 20.0]])
    inside = np.abs(y) < 20.0
    out = _evaluate(y, np.ones_like(y))[3]
    assert _max_error(out[inside], mp.tanh, [(mp.mpf(float(v)),) for v in y[inside]]) <= 1e-14
    assert np.all(out[~inside] == np.sign(y[~inside]))


def test_the_shipped_coefficients_are_the_documented_fits() -> None:
    from vtrack_gym.vehicle.fast_math_fit import fitted

    for name, (coefficients, fit_error) in fitted().items():
        assert np.allclose(getattr(fm, f"{name}_COEFFS"), coefficients, rtol=1e-12, atol=0.0), name
        assert fit_error < 1e-17


def _drive(plant: Plant, periods: int) -> tuple[np.ndarray, np.ndarray]:
    """States after each period and all outputs of a fixed input sequence (steering wave, a car braking)."""
    n = plant.n
    states, outputs = [], []
    for k in range(periods):
        inputs = np.column_stack([0.08 * np.sin(0.05 * k + np.arange(n)), np.full(n, 0.3), np.zeros(n)])
        inputs[::3, 2] = 150.0
        outputs.append(plant.step(inputs, 5).copy())
        states.append(plant.state.copy())
    return np.array(states), np.array(outputs)


def _cars(n: int) -> list[VehicleParams]:
    """Varied cars: relaxation length on and off, lower friction."""
    base = VehicleParams()
    lagged = VehicleParams(tyres=TyreParams(relaxation_length_m=0.4))
    return [lagged if i % 2 else base.with_friction(0.6 if i % 5 == 0 else 0.9) for i in range(n)]


@pytest.fixture(scope="module")
def plant_runs() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    runs = {}
    for numerics in ("default", "fast"):
        plant = Plant(_cars(40), n=40, numerics=numerics, model=["linear" if i == 7 else "nonlinear"
                                                                  for i in range(40)])
        plant.state[:, 3] = np.linspace(0.0, 35.0, 40)   # standstill, the low-speed blend, speed
        runs[numerics] = _drive(plant, 300)
    return runs


def test_fast_plant_agrees_with_the_default_one(plant_runs) -> None:
    """One control period (5 RK4 steps) from the same states, every 10th period of the default plant's 3 s run of
    40 cars (0 to 35 m/s: standstill, the low-speed blend, brakes, relaxation length, mu 0.6 and 0.9, one
    linear-model car): every state entry and output of the fast plant within 1e-10 of its scale. The largest
    measured is 1.9e-11 (the yaw rate of a car on mu 0.6 whose lightly loaded front wheel's drive force sits at the
    friction cap: there the ellipse sqrt(1 - (F_x / mu F_z)^2) takes the root of a rounding-sized difference, so
    either mode's own rounding moves that wheel's lateral force by up to ~1e-8 of it). Over the whole open-loop
    run the difference grows where a car slides (1.3e-7 of the scale after 3 s); closed loop, see the mpc test."""
    states, outputs = plant_runs["default"]
    state_scale = np.abs(states).max(axis=(0, 1)) + 1e-3
    out_scale = np.abs(outputs).max(axis=(0, 1, 2)) + 1e-3
    cars = _cars(40)
    models = ["linear" if i == 7 else "nonlinear" for i in range(40)]
    for k in range(0, 299, 10):
        inputs = np.column_stack([0.08 * np.sin(0.05 * (k + 1) + np.arange(40)), np.full(40, 0.3), np.zeros(40)])
        inputs[::3, 2] = 150.0
        for numerics in ("default", "fast"):
            plant = Plant(cars, n=40, numerics=numerics, model=models)
            plant.state[:] = states[k]
            out = plant.step(inputs, 5)
            if numerics == "default":
                ref_state, ref_out = plant.state.copy(), out.copy()
        assert np.max(np.abs(plant.state - ref_state) / state_scale) < 1e-10, k
        assert np.max(np.abs(out - ref_out) / out_scale) < 1e-10, k
        assert np.array_equal(plant.state[7], ref_state[7])   # the linear-model car: the default kernel


def test_fast_car_does_not_depend_on_its_batch(plant_runs) -> None:
    """Car i of the 40-car batch (SIMD lanes; the second block's scalar remainder) equals the same car alone."""
    states, outputs = plant_runs["fast"]
    cars = _cars(40)
    for i in (0, 3, 33):
        alone = Plant(cars[i], n=1, numerics="fast")
        alone.state[0, 3] = np.linspace(0.0, 35.0, 40)[i]
        n_states, n_outputs = [], []
        for k in range(300):
            inputs = np.array([[0.08 * np.sin(0.05 * k + i), 0.3, 150.0 if i % 3 == 0 else 0.0]])
            n_outputs.append(alone.step(inputs, 5).copy())
            n_states.append(alone.state.copy())
        assert np.array_equal(np.array(n_states)[:, 0], states[:, i])
        assert np.array_equal(np.array(n_outputs)[:, 0], outputs[:, i])


def _mpc_episode(numerics: str):
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.evaluation.rollouts.rollout import rollout

    env = gym.make("DLC120-v0", numerics=numerics)
    return rollout(make_policy("mpc", env), env, seed=0)


def test_fast_env_tracks_like_the_default_one_in_closed_loop() -> None:
    """The mpc baseline on DLC120-v0: same steps and outcome; e_y within 1e-6 m at every step."""
    ref, fast = _mpc_episode("default"), _mpc_episode("fast")
    assert fast.termination == ref.termination == "completed"
    assert len(fast["e_y_m"]) == len(ref["e_y_m"])
    assert np.max(np.abs(np.asarray(fast["e_y_m"]) - np.asarray(ref["e_y_m"]))) < 1e-6


def test_numerics_is_part_of_the_env_identity() -> None:
    from vtrack_gym.evaluation.identity.env_identity import env_identity

    assert env_identity(gym.make("DLC120-v0", numerics="fast")) == ("DLC120-v0",
                                                                      {"env_config": {"numerics": "fast"}})
    assert env_identity(gym.make("DLC120-v0")) == ("DLC120-v0", {})


def test_bad_numerics_names_the_field() -> None:
    with pytest.raises(ValueError, match="numerics must be one of 'default', 'fast'"):
        gym.make("DLC120-v0", numerics="turbo")
    with pytest.raises(ValueError, match="numerics"):
        Plant(numerics="FAST")


def test_fast_vector_env_car_equals_a_single_fast_env() -> None:
    """Car i of the native vector env seeded s equals a single env seeded s + i, bit for bit, in fast mode too."""
    envs = gym.make_vec("DLC120-v0", num_envs=3, vectorization_mode="vector_entry_point", numerics="fast")
    single = gym.make("DLC120-v0", numerics="fast")
    obs, _ = envs.reset(seed=5)
    one, _ = single.reset(seed=6)
    for k in range(200):
        actions = np.clip(-0.5 * obs[:, :1] - 1.5 * obs[:, 1:2], -1, 1).astype(np.float32)
        obs, _, terminated, truncated, _ = envs.step(actions)
        one, *_ = single.step(actions[1])
        assert np.array_equal(obs[1], one), k
        if terminated[1] or truncated[1]:
            break
