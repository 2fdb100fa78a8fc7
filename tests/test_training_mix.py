"""The RL training distribution (``vtrack/TrainingMix-v0``): every evaluation regime inside it, per-road speed
profiles within their limits, domain randomisation drawn per episode only where the reset options leave a knob at
its default, and scenarios without ranges untouched."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401
from vtrack_gym.envs.randomisation import Randomisation
from vtrack_gym.envs.scenarios import SCENARIOS, TRAINING_MIX
from vtrack_gym.tracks.training_mix import KINDS, TrainingMixProfile, training_bank
from vtrack_gym.vehicle import layout as VL

G = 9.81


@pytest.fixture(scope="module")
def bank():
    return training_bank(TRAINING_MIX.track.bank_seed, TRAINING_MIX.track.bank_size, 1.916)


def test_bank_covers_the_evaluation_regimes(bank) -> None:
    kinds = [p.name.split("-")[0].removeprefix("mix_") for p in bank]
    assert [kinds.count(k) for k in KINDS] == [10, 10, 10, 30]
    profile = TrainingMixProfile()
    tightest = {k: 0.0 for k in KINDS}
    fastest_lane_change = 0.0
    for path, kind in zip(bank, kinds, strict=True):
        kappa = np.abs(path.table[:, 3])
        tightest[kind] = max(tightest[kind], float(kappa.max()))
        v = profile.row_speeds(path)
        assert np.all(v > 0.0) and np.all(v <= 36.0 + 1e-9)
        if kind == "lanechange":
            assert len(path.gates) == 8 and np.ptp(v) == 0.0  # cone-lined lanes at a constant speed
            fastest_lane_change = max(fastest_lane_change, float(v[0]))
            assert 0.3 * G < float(np.max(v ** 2 * kappa)) <= 0.95 * G
        else:
            # curvature-limited: the centre-line never asks for more than 0.85 g
            assert float(np.max(v ** 2 * kappa)) <= 0.85 * G * 1.02
    assert 1.0 / tightest["hairpin"] < 6.0          # hairpins tighter than the 6 m the circuits ask for
    assert 1.0 / tightest["twisty"] < 20.0          # Case 1's tightest corner is ~20 m
    assert fastest_lane_change > 120.0 / 3.6        # DLC120-v0's speed is inside the lane-change range


def test_randomisation_is_drawn_per_episode_within_ranges() -> None:
    env = gym.make("vtrack/TrainingMix-v0")
    sim = env.unwrapped._sim
    seen: dict[str, list] = {"mu": [], "noise": [], "delay": [], "rate": []}
    nominal_rate = env.unwrapped.config.vehicle.steering.max_road_wheel_rate_radps
    for seed in range(12):
        env.reset(seed=seed)
        seen["mu"].append(float(sim.plant.param_rows[0, VL.P_MU]))  # the friction the plant was given
        seen["noise"].append(float(sim.noise.scale[0]))
        seen["delay"].append(int(sim.delay.steps[0]))
        seen["rate"].append(float(sim.plant.param_rows[0, VL.P_DELTA_RATE]) / nominal_rate)
    lo, hi = TRAINING_MIX.randomisation.friction_range
    assert all(lo - 1e-9 <= m <= hi + 1e-9 for m in seen["mu"]) and len(set(seen["mu"])) > 6
    lo, hi = TRAINING_MIX.randomisation.sensor_noise_range
    assert all(lo <= n <= hi for n in seen["noise"]) and len(set(seen["noise"])) > 6
    assert set(seen["delay"]) <= {0, 1, 2, 3, 4, 5} and len(set(seen["delay"])) > 2  # 0-50 ms at 10 ms
    lo, hi = TRAINING_MIX.randomisation.steering_rate_scale_range
    assert all(lo - 1e-9 <= k <= hi + 1e-9 for k in seen["rate"]) and len(set(seen["rate"])) > 6
    # an explicit reset option wins over the scenario's draw
    env.reset(seed=0, options={"sensor_noise": 2.5, "actuator_delay_s": 0.02})
    assert sim.noise.scale[0] == 2.5 and sim.delay.steps[0] == 2


def test_an_explicit_reset_option_wins_even_at_its_default_value() -> None:
    """Asking the training mix for a 0 m start offset, no noise, no delay and the nominal car gives exactly that (a
    given value equal to the default was taken as "not given" and drawn afresh: e_y 1.24 / -0.23 / 0.69 m)."""
    from vtrack_gym.envs.observation import OBS

    env = gym.make("vtrack/TrainingMix-v0")
    sim = env.unwrapped._sim
    nominal_rate = env.unwrapped.config.vehicle.steering.max_road_wheel_rate_radps
    given = {"initial_lateral_offset_m": 0.0, "initial_heading_error_rad": 0.0, "sensor_noise": 0.0,
             "actuator_delay_s": 0.0, "mass_scale": 1.0, "steering_rate_scale": 1.0}
    drawn = []
    for seed in range(4):
        obs, _ = env.reset(seed=seed, options=given)
        assert obs[OBS.index("e_y")] == 0.0 and obs[OBS.index("e_phi")] == 0.0
        assert sim.noise.scale[0] == 0.0 and sim.delay.steps[0] == 0
        assert float(sim.plant.param_rows[0, VL.P_DELTA_RATE]) == pytest.approx(nominal_rate)
        obs, _ = env.reset(seed=seed)            # not given: drawn
        drawn.append(float(obs[OBS.index("e_y")]))
    assert max(abs(e) for e in drawn) > 0.1


def test_same_seed_same_randomised_episode() -> None:
    def run(seed: int) -> np.ndarray:
        env = gym.make("vtrack/TrainingMix-v0")
        obs, _ = env.reset(seed=seed)
        rows = [obs]
        for _ in range(100):
            obs, *_ = env.step(np.array([0.05], dtype=np.float32))
            rows.append(obs)
        return np.array(rows)

    np.testing.assert_array_equal(run(7), run(7))


def test_scenarios_without_ranges_draw_nothing() -> None:
    for name, sc in SCENARIOS.items():
        if name not in ("TrainingMix-v0", "TrainingMixNominal-v0"):
            assert sc.randomisation == Randomisation() and sc.randomisation.is_off
    nominal = SCENARIOS["TrainingMixNominal-v0"].randomisation   # friction and mass only: nothing the expert fails on
    assert nominal == Randomisation(friction_range=(0.7, 1.1), mass_scale_range=(0.8, 1.25))
    env = gym.make("DLC120-v0")
    env.reset(seed=0)
    assert env.unwrapped._sim.noise.scale[0] == 0.0 and env.unwrapped._sim.delay.steps[0] == 0


@pytest.mark.parametrize("field, value", [("friction_range", (0.05, 1.0)), ("mass_scale_range", (1.5, 1.2)),
                                          ("sensor_noise_range", (0.0, 9.0)), ("friction_range", [0.7, 1.0]),
                                          ("mass_scale_range", (True, 1.0)),
                                          ("steering_rate_scale_range", (0.1, 2.0))])
def test_bad_randomisation_ranges_are_refused(field: str, value: object) -> None:
    with pytest.raises(ValueError, match=f"Randomisation.{field}"):
        Randomisation(**{field: value})


def test_steering_rate_scale_speeds_up_the_road_wheel() -> None:
    """The reset option multiplies the actuator's rate limit: from straight running, a full-lock command turns the
    road wheel at most rate x t; four times the rate gets it there correspondingly sooner."""
    def wheel_after(options: dict, steps: int) -> float:
        env = gym.make("vtrack/DLC120-v0")
        env.reset(seed=0, options=options)
        for _ in range(steps):
            env.step(np.array([1.0], dtype=np.float32))
        return float(env.unwrapped._sim.plant.state[0, VL.S_DELTA])

    rate = gym.make("vtrack/DLC120-v0").unwrapped.config.vehicle.steering.max_road_wheel_rate_radps
    t = 0.1  # s, 10 control periods
    nominal, fast = wheel_after({}, 10), wheel_after({"steering_rate_scale": 4.0}, 10)
    assert 0.5 * rate * t < nominal <= rate * t + 1e-9
    assert 2.5 * nominal < fast <= 4.0 * rate * t + 1e-9
    with pytest.raises(ValueError, match="steering_rate_scale"):
        gym.make("vtrack/DLC120-v0").reset(seed=0, options={"steering_rate_scale": 20.0})


def test_start_offsets_are_drawn_and_observed() -> None:
    """TrainingMix-v0 starts each episode off the path (offset and heading error drawn within the scenario's ranges)
    and the first observation reports them; on another scenario the reset options set them exactly."""
    from vtrack_gym.envs.observation import OBS

    env = gym.make("vtrack/TrainingMix-v0")
    lo_y, hi_y = TRAINING_MIX.randomisation.initial_lateral_offset_range_m
    lo_p, hi_p = TRAINING_MIX.randomisation.initial_heading_error_range_rad
    seen_y, seen_p = [], []
    for seed in range(10):
        obs, _ = env.reset(seed=seed)
        seen_y.append(float(obs[OBS.E_Y]))
        seen_p.append(float(obs[OBS.E_PHI]))
    assert all(lo_y - 0.05 <= e <= hi_y + 0.05 for e in seen_y) and np.ptp(seen_y) > 0.5
    assert all(lo_p - 0.01 <= e <= hi_p + 0.01 for e in seen_p) and np.ptp(seen_p) > 0.05
    straight = gym.make("vtrack/DLC120-v0")  # the lane change starts on a straight approach
    obs, _ = straight.reset(seed=0, options={"initial_lateral_offset_m": 0.8, "initial_heading_error_rad": -0.2})
    assert obs[OBS.E_Y] == pytest.approx(0.8, abs=1e-3) and obs[OBS.E_PHI] == pytest.approx(-0.2, abs=1e-3)
    obs, _ = straight.reset(seed=0)
    assert obs[OBS.E_Y] == 0.0 and obs[OBS.E_PHI] == 0.0


def test_randomisation_spans_are_the_reset_options_ranges() -> None:
    """``RANDOMISED_RANGES`` (in randomisation.py, which config.py imports through scenarios.py) repeats the
    matching reset options' declared ranges: they must agree, so that every drawn value is a valid reset option."""
    from vtrack_gym.envs.config import ResetOptions
    from vtrack_gym.envs.randomisation import RANDOMISED_RANGES

    option_of = {"friction_range": "friction_mu", "mass_scale_range": "mass_scale",
                 "sensor_noise_range": "sensor_noise", "steering_rate_scale_range": "steering_rate_scale",
                 "initial_lateral_offset_range_m": "initial_lateral_offset_m",
                 "initial_heading_error_range_rad": "initial_heading_error_rad"}
    assert set(RANDOMISED_RANGES) == set(option_of)
    for range_name, option in option_of.items():
        assert RANDOMISED_RANGES[range_name] == ResetOptions.RANGES[option], range_name
