"""Speed profiles the powertrain can follow: EnvelopeLimited bound to a car's drive force, drag and rolling
resistance at a throttle authority, its top speed, the warnings for requests beyond the car, and the PD-FLC
following the default track profile closed-loop."""

from __future__ import annotations

import dataclasses
import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.pdflc import PDFLCConfig, speed_loop_throttle_authority
from vtrack_gym.tracks import CurvatureProfile, Path, speed_table
from vtrack_gym.tracks.feasibility import envelope_profile
from vtrack_gym.tracks.speed_profiles import EnvelopeLimited, FileSpeed, profile_parameters
from vtrack_gym.vehicle.catalog import load_vehicle
from vtrack_gym.vehicle.longitudinal import forward_accel_limit_mps2, top_speed_mps

CAR = load_vehicle("hatchback")
PAPER_SPEED_LOOP = 0.5225 * 2.0 / 3.0     # G3 x the Mamdani surface at e_hat = -1, de_hat = 0 (level 2, peak 2/3)


def _straight(length_m: float) -> Path:
    return Path.from_curvature(CurvatureProfile.from_segments(0.0, [(length_m, 0.0)]))


def _course() -> Path:
    """Straights, a hairpin and a fast sweeper: every regime of the forward pass."""
    return Path.from_curvature(CurvatureProfile.from_segments(0.0, [
        (400.0, 0.0), (10.0, 1 / 20), (40.0, 1 / 20), (10.0, 0.0), (600.0, 0.0), (20.0, -1 / 150),
        (200.0, -1 / 150), (20.0, 0.0), (300.0, 0.0)]))


def _rk4_speed(vehicle, authority: float, v0: float, s_end: float, h: float = 0.05) -> float:
    """v(s_end) [m/s] of dv/ds = a(v) / v from v0 at s = 0 (a: the powertrain's forward limit), fine RK4."""
    def f(v: float) -> float:
        return float(forward_accel_limit_mps2(vehicle, v, authority)) / v

    v, s = v0, 0.0
    while s < s_end - 1e-12:
        step = min(h, s_end - s)
        k1 = f(v)
        k2 = f(v + 0.5 * step * k1)
        k3 = f(v + 0.5 * step * k2)
        k4 = f(v + step * k3)
        v += step * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
        s += step
    return v


def test_the_speed_loops_authority_is_what_the_pd_flc_holds() -> None:
    assert speed_loop_throttle_authority(PDFLCConfig()) == pytest.approx(PAPER_SPEED_LOOP, abs=1e-6)
    assert speed_loop_throttle_authority(PDFLCConfig(method="sugeno")) == pytest.approx(PAPER_SPEED_LOOP, abs=1e-9)
    assert speed_loop_throttle_authority(PDFLCConfig(g3=3.0)) == 1.0          # clipped to a full throttle


@pytest.mark.parametrize("authority", [1.0, PAPER_SPEED_LOOP, 0.2])
def test_forward_acceleration_never_exceeds_the_powertrain(authority: float) -> None:
    path = _course()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)                 # a cap above the top speed at 0.2
        profile = envelope_profile(CAR, 60.0, 6.0, None, throttle_authority=authority, start_speed_mps=1.0)
    v = speed_table(path, profile).v_mps
    a_x = np.diff(v ** 2) / (2.0 * path.ds_m)                         # constant on each row interval
    faster = np.maximum(v[1:], v[:-1])                                # the powertrain gives least at the faster end
    limit = forward_accel_limit_mps2(CAR, faster, authority)
    assert np.all(a_x <= limit + 1e-9)
    assert np.all(a_x <= forward_accel_limit_mps2(CAR, v[:-1], authority) + 1e-9)
    assert np.max(v) <= top_speed_mps(CAR, authority) + 1e-9
    assert np.max(a_x / limit) > 0.95                                 # and it is the binding limit somewhere


@pytest.mark.parametrize("authority", [1.0, PAPER_SPEED_LOOP])
def test_a_standing_start_on_a_straight_matches_the_integrated_powertrain(authority: float) -> None:
    path = _straight(2000.0)
    with pytest.warns(UserWarning, match=r"max_speed_mps = 360\.0 km/h is above the top speed"):
        profile = envelope_profile(CAR, 100.0, 6.0, None, throttle_authority=authority, start_speed_mps=1.0)
    table = speed_table(path, profile)
    for s in (5.0, 50.0, 300.0, 1000.0, 2000.0):
        exact = _rk4_speed(CAR, authority, 1.0, s)
        assert float(table.v_ref(s)) == pytest.approx(exact, rel=5e-3, abs=0.02), s
        assert float(table.v_ref(s)) <= exact + 1e-6                  # the forward pass is conservative
    assert float(table.v_ref(0.0)) == pytest.approx(1.0)


def test_a_cap_above_the_top_speed_warns_and_is_capped() -> None:
    top = top_speed_mps(CAR, PAPER_SPEED_LOOP)
    with pytest.warns(UserWarning, match=r"max_speed_mps = 150\.0 km/h is above the top speed of 'C-Class Hatchback "
                                         r"\(paper\)' at throttle 0\.348, 148\.8 km/h: the profile is capped"):
        profile = envelope_profile(CAR, 150.0 / 3.6, 6.0, None, throttle_authority=PAPER_SPEED_LOOP)
    assert profile.speed_cap_mps == pytest.approx(top)
    assert np.max(speed_table(_straight(8000.0), profile).v_mps) <= top
    with pytest.warns(UserWarning, match=r"max_accel_mps2 = 5\.000 m/s\^2 is above the largest forward acceleration "
                                         r"of 'C-Class Hatchback \(paper\)' at throttle 1\.000, 4\.12\d m/s\^2"):
        envelope_profile(CAR, 30.0, 6.0, 5.0, throttle_authority=1.0)


def test_bad_powertrain_fields_are_refused() -> None:
    with pytest.raises(ValueError, match=r"EnvelopeLimited\.throttle_authority must be a throttle fraction in "
                                         r"\(0, 1\], 'speed_loop'"):
        EnvelopeLimited(30.0, 7.0, throttle_authority=1.5)
    with pytest.raises(ValueError, match=r"max_accel_mps2 = None \(the powertrain's limit alone\) needs a "
                                         r"throttle_authority"):
        EnvelopeLimited(30.0, 7.0, None)
    with pytest.raises(ValueError, match=r"needs a car: an env binds its own"):
        speed_table(_straight(100.0), EnvelopeLimited(30.0, 7.0, None, throttle_authority="speed_loop"))


def test_a_profile_without_powertrain_keeps_its_parameters() -> None:
    legacy = EnvelopeLimited(40.0 / 3.6, 0.7 * 9.81)
    assert profile_parameters(legacy) == {                            # as asdict gave before the powertrain fields
        "max_speed_mps": 40.0 / 3.6, "max_lateral_accel_mps2": 0.7 * 9.81, "max_accel_mps2": 2.0,
        "max_decel_mps2": 3.0, "vehicle_limit_mps2": None, "vehicle_name": "the car"}
    assert set(dataclasses.asdict(legacy)) - set(profile_parameters(legacy)) == {
        "throttle_authority", "vehicle", "start_speed_mps"}
    bound = envelope_profile(CAR, 20.0, 6.0, throttle_authority=1.0)
    assert profile_parameters(bound)["vehicle"] == CAR.name


def test_gym_make_binds_the_env_car_and_warns_beyond_it() -> None:
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits

    with pytest.warns(UserWarning, match=r"150\.0 km/h is above the top speed of 'C-Class Hatchback \(paper\)' at "
                                         r"throttle 0\.348, 148\.8 km/h"):
        env = gym.make("vtrack/Track-v0", speed_profile=speed_profile_from_limits("envelope", 150.0))
    table = env.unwrapped.speed_tables[0]
    assert table.v_mps[0] == pytest.approx(1.0)                       # Track-v0 starts at rest: a standing start
    assert table.profile.throttle_authority == pytest.approx(PAPER_SPEED_LOOP, abs=1e-6)
    env.close()
    with pytest.warns(UserWarning, match=r"250\.0 km/h is above the top speed of 'Compact SUV.*' at throttle "
                                         r"1\.000, 220\.3 km/h"):
        gym.make("vtrack/Track-v0", vehicle="suv",
                 speed_profile=EnvelopeLimited(250.0 / 3.6, 6.0, None, throttle_authority=1.0)).close()


def test_a_file_profile_beyond_the_powertrain_warns_with_the_worst_station(tmp_path) -> None:
    s = np.arange(0.0, 400.0, 2.0)
    v = np.minimum(5.0 + 0.5 * s, 30.0)                               # 5 -> 30 m/s within 50 m: ~8 m/s^2
    file = tmp_path / "fast.csv"
    np.savetxt(file, np.column_stack([s, np.zeros_like(s), v]), fmt="%.3f", delimiter=",",
               header="x_m, y_m, v_mps")
    with pytest.warns(UserWarning, match=r"the FileSpeed profile on .* asks for \d+\.\d{3} m/s\^2 forward "
                                         r"acceleration at s = [0-9.]+-[0-9.]+ m \(reaching [0-9.]+ km/h\), above the "
                                         r"[0-9.]+ m/s\^2 of 'C-Class Hatchback \(paper\)' at throttle 0\.348"):
        gym.make("vtrack/Track-v0", track=str(file), speed_profile=FileSpeed()).close()


def test_the_default_profiles_of_pinned_ids_do_not_warn() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        for env_id in ("vtrack/Track-v0", "vtrack/DLC120-v0", "vtrack/ISO4138-Circle-v0"):
            gym.make(env_id).close()


def test_the_cli_names_the_cars_top_speed(tmp_path, capsys) -> None:
    from vtrack_gym.cli import main

    x = 150.0 * np.cos(np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False))
    y = 150.0 * np.sin(np.linspace(0.0, 2.0 * math.pi, 400, endpoint=False))
    loop = tmp_path / "loop.csv"
    np.savetxt(loop, np.column_stack([x, y]), fmt="%.4f", delimiter=",", header="x_m, y_m")
    with pytest.warns(UserWarning, match=r"above the top speed of 'C-Class Hatchback \(paper\)' at throttle 0\.348, "
                                         r"148\.8 km/h: the profile is capped at 148\.8 km/h"):
        code = main(["eval", "--policy", "pure_pursuit", "--track", str(loop), "--max-speed-kmh", "160",
                     "--max-lateral-g", "0.5", "--store", str(tmp_path / "s.db")])
    assert code == 0, capsys.readouterr().err


def test_the_pd_flc_follows_the_default_profile_closed_loop() -> None:
    """The default `--track` profile on the shipped handling course at a 100 km/h cap, from rest: the speed loop
    stays within the bound the docs state (RMS < 1 m/s, max < 2 m/s)."""
    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits

    env = gym.make("vtrack/Track-v0", speed_profile=speed_profile_from_limits("envelope", 100.0))
    table = env.unwrapped.speed_tables[0]
    assert env.unwrapped.current_path.closed and table.v_mps[0] == pytest.approx(1.0)
    assert table.v_mps[-1] > 5.0                                      # the lap ends at its flying speed
    trace = rollout(vtrack_gym.make_policy("pure_pursuit", env), env, seed=0)
    m = evaluate_trace(trace)
    env.close()
    assert trace.termination == "completed"
    assert m["rms_e_v_mps"] < 1.0
    assert m["max_e_v_mps"] < 2.0
    # past the finish line the station reads the next lap's start: the reference holds the finish speed
    assert trace["target_speed_mps"][-1] == pytest.approx(table.v_mps[-1])


def test_the_vector_env_binds_the_same_profile() -> None:
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits

    profile = speed_profile_from_limits("envelope", 60.0)
    single = gym.make("vtrack/Track-v0", speed_profile=profile)
    vec = gym.make_vec("vtrack/Track-v0", num_envs=2, speed_profile=profile)
    np.testing.assert_array_equal(vec.unwrapped.sim.tracks.speed_tables[0].v_mps,
                                  single.unwrapped.speed_tables[0].v_mps)
    vec.reset(seed=0)
    for _ in range(50):
        vec.step(np.zeros(2))
    single.close()
    vec.close()
