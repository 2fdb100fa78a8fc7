"""The race (``vtrack/Race-v0``, ``vtrack/RaceRing-v0``): make kwargs, observation, laps and their timing, the
reward's shaping (spinning, cutting a corner and driving backwards never pay), the race baselines against the
car's lap-time bound, and the CLI."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.race_reward import RACE_REWARD_TERMS, RaceReward
from vtrack_gym.evaluation.scoring.laps import lap_metrics


@pytest.fixture(scope="module")
def ring() -> gym.Env:
    return gym.make("vtrack/RaceRing-v0")


def drive(env: gym.Env, act, seed: int = 0, steps: int | None = None) -> tuple[float, dict, list[dict]]:
    """Run ``act(obs) -> action`` for an episode (or ``steps`` steps); (total reward, last info, every info)."""
    obs, info = env.reset(seed=seed)
    total, infos = 0.0, []
    while steps is None or len(infos) < steps:
        obs, reward, terminated, truncated, info = env.step(act(obs))
        total += reward
        infos.append(info)
        if terminated or truncated:
            break
    return total, info, infos


def test_defaults_spaces_and_observation(ring: gym.Env) -> None:
    base = ring.unwrapped
    assert ring.action_space.shape == (2,) and base.control == "steer_accel"
    layout = base.observation_layout
    assert layout.names[-5:] == ("speed_error", "time_error", "edge_left_m", "edge_right_m", "lap_fraction")
    obs, info = ring.reset(seed=0)
    assert obs.shape == ring.observation_space.shape == (layout.size,)
    half = base.paths[0].half_widths(0.0)
    assert obs[layout.index("edge_left_m")] == pytest.approx(float(half[0][()]) - obs[layout.index("e_y")], abs=1e-5)
    assert 0.0 <= obs[layout.index("lap_fraction")] < 1.0
    assert obs[layout.index("v_x")] == 0.0      # a standing start
    assert info["lap_time_bound_s"] == pytest.approx(base.lap_bound.lap_time_s) and info["laps_completed"] == 0
    assert base.scenario.time_limit_s == pytest.approx(3.0 * 2 * base.lap_time_bound_s)


def test_steer_mode_and_bad_kwargs_are_refused() -> None:
    with pytest.raises(ValueError, match="control must be one of 'steer_accel', 'steer_rate_accel'"):
        gym.make("vtrack/RaceRing-v0", control="steer")
    with pytest.raises(ValueError, match="laps"):
        gym.make("vtrack/RaceRing-v0", laps=0)
    with pytest.raises(ValueError, match="start must be one of 'standing', 'flying'"):
        gym.make("vtrack/RaceRing-v0", start="rolling")
    with pytest.raises(ValueError, match="one closed track"):
        gym.make("vtrack/Race-v0", track="step_curvature")


def test_laps_are_timed_and_the_episode_ends_after_them(ring: gym.Env) -> None:
    policy = vtrack_gym.make_policy("centreline", ring)
    total, info, infos = drive(ring, lambda o: policy.predict(o)[0])
    assert info["termination"] == "completed" and info["success"] and info["laps_completed"] == 2
    t = np.array([i["time_s"] for i in infos])
    p = np.array([i["progress_m"] for i in infos])
    assert p[-1] >= 2 * ring.unwrapped.lap_length_m
    # the env's lap times are the rows' lap times from the same progress (evaluation.scoring.laps)
    expected = lap_metrics(t, p, ring.unwrapped.lap_length_m)
    assert info["lap_times_s"] == pytest.approx(expected["lap_times_s"], rel=1e-12)
    assert info["best_lap_s"] == min(info["lap_times_s"]) < info["lap_times_s"][0]   # lap 1 starts standing
    assert info["lap_time_fraction"] == pytest.approx(info["best_lap_s"] / info["lap_time_bound_s"])
    # the observation's time error stays continuous over the line (the time law's origin moves a lap too)
    e_t = np.array([i["time_error_s"] for i in infos])
    assert np.max(np.abs(np.diff(e_t))) < 0.05
    # the reward sums its terms; the lap's progress is worth w_progress
    terms = {k: sum(i[k] for i in infos) for k in RACE_REWARD_TERMS}
    assert total == pytest.approx(sum(terms.values()))
    assert terms["race_reward_progress"] == pytest.approx(100.0 * p[-1] / ring.unwrapped.lap_length_m)


def test_flying_start_and_one_lap() -> None:
    env = gym.make("vtrack/RaceRing-v0", laps=1, start="flying")
    obs, _ = env.reset(seed=0)
    layout = env.unwrapped.observation_layout
    assert obs[layout.index("v_x")] == pytest.approx(obs[layout.index("target_speed")], rel=1e-6)
    assert obs[layout.index("v_x")] > 10.0
    policy = vtrack_gym.make_policy("raceline", env)
    _, info, _ = drive(env, lambda o: policy.predict(o)[0])
    assert info["termination"] == "completed" and len(info["lap_times_s"]) == 1


def test_spinning_in_place_earns_less_than_driving_the_line_slowly(ring: gym.Env) -> None:
    layout = ring.unwrapped.observation_layout
    slow = vtrack_gym.make_policy("centreline", ring)

    def crawl(obs):   # the centre line's steering, the pedals holding 6 m/s
        steer = slow.predict(obs)[0][0]
        return np.array([steer, np.clip(0.3 * (6.0 - obs[layout.index("v_x")]), -1, 1)], dtype=np.float32)

    circles, info_c, _ = drive(ring, lambda o: np.array([1.0, 0.15], dtype=np.float32), steps=1500)
    line, info_l, _ = drive(ring, crawl, steps=1500)
    assert info_l["termination"] == "" and info_l["progress_m"] > 50.0
    assert circles < 0.0 < line
    assert info_c["progress_m"] < 10.0


def test_cutting_a_corner_earns_less_than_staying_on(ring: gym.Env) -> None:
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.tracks.path import Path

    on = make_policy("centreline", ring, grip_scale=0.8)
    cut = make_policy("centreline", ring, grip_scale=0.8)
    centre = ring.unwrapped.paths[0]
    s = np.arange(0.0, centre.length_m, 1.0)
    row = centre.sample(s)
    half = float(centre.half_widths(0.0)[0][()])
    shift = (half + 2.0) * row.kappa / np.abs(row.kappa).max()    # 2 m beyond the inner edge mid-corner
    cut.line = Path.from_points(row.x - np.sin(row.psi) * shift, row.y + np.cos(row.psi) * shift, closed=True)
    from vtrack_gym.baselines.race_line import scaled_limits
    from vtrack_gym.tracks.gg_limits import gg_limits
    from vtrack_gym.tracks.lap_time import QuasiSteadyState

    car = ring.unwrapped.config.vehicle
    limits = scaled_limits(gg_limits(car), 0.8, cut.config.brake_scale, car)     # as the policy builds its own
    cut.table = QuasiSteadyState(limits).row_speeds(cut.line)
    cut._guess = cut._station_map()
    r_on, i_on, on_infos = drive(ring, lambda o: on.predict(o)[0])
    r_cut, i_cut, infos = drive(ring, lambda o: cut.predict(o)[0])
    m_cut = ring.unwrapped.success_metrics()
    assert i_on["success"] and i_cut["termination"] == "completed" and not i_cut["success"]
    assert m_cut["track_limit_violations"] >= 4                      # the two turns cut on both laps
    assert r_cut < r_on
    # the penalty of the cuts outweighs the whole time cost of the clean run: no time saved could pay for it
    penalty = sum(i["race_reward_limits"] for i in infos)
    assert penalty < sum(i["race_reward_time"] for i in on_infos) < 0.0


def test_driving_backwards_earns_negative(ring: gym.Env) -> None:
    terms = RaceReward().terms(-5.0, 500.0, 0.01, 25.0, 0.0, False)
    assert terms["race_reward_progress"] == pytest.approx(-1.0) and sum(terms.values()) < 0.0
    assert RaceReward().terms(-5.0, 500.0, 0.01, 25.0, 1.0, False)["race_reward_progress"] == pytest.approx(-1.0)
    # in the env: turning round on the spot loses ground and ends in a spin-out
    total, info, _ = drive(ring, lambda o: np.array([1.0, 0.3], dtype=np.float32))
    assert info["termination"] == "spin_out" and total < 0.0


@pytest.mark.parametrize("env_id", ["vtrack/RaceRing-v0", "vtrack/Race-v0"])
def test_raceline_laps_within_limits_near_the_bound_and_beats_centreline(env_id: str) -> None:
    env = gym.make(env_id)
    best = {}
    for name in ("raceline", "centreline"):
        policy = vtrack_gym.make_policy(name, env)
        _, info, _ = drive(env, lambda o, p=policy: p.predict(o)[0])
        metrics = env.unwrapped.success_metrics()
        assert info["success"] and metrics["track_limit_violations"] == 0, (name, info["termination"])
        best[name] = info["best_lap_s"]
    assert best["raceline"] <= 1.08 * env.unwrapped.lap_time_bound_s
    assert best["raceline"] < best["centreline"]


def test_race_baselines_need_the_race_env() -> None:
    with pytest.raises(ValueError, match="Race-v0"):
        vtrack_gym.make_policy("raceline", gym.make("DLC120-v0", control="steer_accel"))
    from vtrack_gym.baselines.registry import available_policies, race_policies

    assert set(race_policies()) == {"raceline", "centreline", "raceline_coupled"}
    assert not set(race_policies()) & set(available_policies())


def test_raceline_drives_the_steering_rate_mode() -> None:
    """In steer_rate_accel the baseline sends the rate towards its steering command, integrated as the env does:
    both laps of the ring within the wheels rule, the same best lap as in steer_accel to a hundredth of a second,
    and the SB3 state protocol gives the plain loop's episode."""
    env = gym.make("vtrack/RaceRing-v0", control="steer_rate_accel")
    policy = vtrack_gym.make_policy("raceline", env)
    assert policy.state_size == 1
    _, info, _ = drive(env, lambda o: policy.predict(o)[0])
    assert info["success"] and env.unwrapped.success_metrics()["track_limit_violations"] == 0
    accel = gym.make("vtrack/RaceRing-v0")
    accel_policy = vtrack_gym.make_policy("raceline", accel)
    _, accel_info, _ = drive(accel, lambda o: accel_policy.predict(o)[0])
    assert info["best_lap_s"] == pytest.approx(accel_info["best_lap_s"], abs=0.01)

    fresh = vtrack_gym.make_policy("raceline", env)
    state, start = None, True

    def with_state(obs: np.ndarray) -> np.ndarray:
        nonlocal state, start
        action, state = fresh.predict(obs, state=state, episode_start=np.array([start]))
        start = False
        return action

    _, stated, _ = drive(env, with_state, steps=400)
    policy.reset()
    _, again, _ = drive(env, lambda o: policy.predict(o)[0], steps=400)
    assert stated["x_m"] == again["x_m"] and stated["y_m"] == again["y_m"]


def test_the_racing_line_is_solved_once_per_content() -> None:
    """A second make of a race id finds the line and the bound in the process's cache; a car of other content
    (same name) does not; the cached arrays are read-only."""
    import dataclasses

    from vtrack_gym.tracks.race_bound_cache import bound_cache
    from vtrack_gym.vehicle.params import VehicleParams

    cache = bound_cache()
    first = gym.make("vtrack/RaceRing-v0").unwrapped
    hits, misses = cache.hits, cache.misses
    second = gym.make("vtrack/RaceRing-v0").unwrapped
    assert (cache.hits, cache.misses) == (hits + 1, misses)
    assert second.lap_time_bound_s == first.lap_time_bound_s and second.race_line.path is first.race_line.path
    assert not second.race_line.path.table.flags.writeable
    car = VehicleParams()
    heavier = dataclasses.replace(car, chassis=dataclasses.replace(car.chassis, mass_kg=car.chassis.mass_kg * 1.1))
    assert heavier.name == car.name
    other = gym.make("vtrack/RaceRing-v0", vehicle=heavier).unwrapped
    assert cache.misses == misses + 1 and other.lap_time_bound_s != first.lap_time_bound_s


def test_cli_eval_reports_the_lap_figures(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    store = tmp_path / "store"
    assert main(["eval", "--policy", "raceline", "--env", "vtrack/RaceRing-v0", "--store", str(store)]) == 0
    out = capsys.readouterr().out
    assert "lap_time_fraction" in out and "lap_time_bound_s" in out
    rows = [json.loads(line) for f in sorted(store.rglob("*.jsonl")) for line in f.read_text().splitlines()]
    if rows:
        metrics = rows[-1]["metrics"]
        assert metrics["lap_time_bound_s"] > 0 and math.isfinite(metrics["lap_time_fraction"])
        assert metrics["track_limit_violations"] == 0 and len(metrics["lap_times_s"]) == 2


def test_cli_benchmark_race_suite(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    assert main(["benchmark", "--suite", "race", "--policies", "raceline,centreline", "--quick", "--no-figures",
                 "--store", str(tmp_path / "store")]) == 0
    out = capsys.readouterr().out
    assert "vtrack/Race-v0" in out and "vtrack/RaceRing-v0" in out and "lap_time_fraction" in out


def test_race_baselines_have_one_fingerprint_per_circuit() -> None:
    """Two envs of one id give two policies of one hash (the board ranks a policy's seeds together)."""
    from vtrack_gym.evaluation.identity.fingerprint import policy_hash

    for name in ("raceline", "centreline"):
        hashes = set()
        for _ in range(2):
            env = gym.make("vtrack/RaceRing-v0")
            hashes.add(policy_hash(vtrack_gym.make_policy(name, env), env))
        assert len(hashes) == 1, name
