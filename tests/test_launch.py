"""The ``launch=`` make kwarg: how the reference leaves a standing start in the longitudinal control modes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym  # noqa: F401  (registers the ids)
from vtrack_gym.envs.launch import LAUNCH_SHARE
from vtrack_gym.vehicle.longitudinal import forward_accel_limit_mps2
from vtrack_gym.vehicle.params import VehicleParams


def test_the_powertrain_launch_ramps_the_reference_at_a_share_of_full_throttle() -> None:
    env = gym.make("LateralTracking-v0", control="steer_accel", launch="powertrain")
    table = env.unwrapped.speed_tables[0]
    v = table.v_mps
    s = np.arange(v.size) * table.ds_m
    assert v[0] == pytest.approx(1.0) and v.max() == pytest.approx(40.0 / 3.6)
    ramp = v < v.max() - 1e-9
    accel = np.diff(v[ramp] ** 2) / (2.0 * np.diff(s[ramp]))      # v^2 linear in s: a constant acceleration
    car = VehicleParams()
    least = float(np.min(forward_accel_limit_mps2(car, np.linspace(0.0, 40.0 / 3.6, 64))))
    np.testing.assert_allclose(accel, LAUNCH_SHARE * least, rtol=1e-9)
    _, info = env.reset(seed=0)
    assert info["target_speed_mps"] == pytest.approx(1.0)


def test_the_step_launch_is_the_ids_own_reference() -> None:
    plain = gym.make("LateralTracking-v0", control="steer_accel")
    step = gym.make("LateralTracking-v0", control="steer_accel", launch="step")
    np.testing.assert_array_equal(plain.unwrapped.speed_tables[0].v_mps, step.unwrapped.speed_tables[0].v_mps)
    assert plain.reset(seed=0)[1]["target_speed_mps"] == pytest.approx(40.0 / 3.6)


@pytest.mark.parametrize(("env_id", "kwargs", "match"), [
    ("LateralTracking-v0", {"control": "steer"}, "longitudinal control modes"),
    ("DLC120-v0", {"control": "steer_accel"}, "holds one set speed from rest"),
    ("LateralTracking-v0", {"control": "steer_accel", "launch": "soft"}, "launch must be one of 'step', 'powertrain'"),
])
def test_launch_is_refused_where_it_does_not_apply(env_id: str, kwargs: dict, match: str) -> None:
    kwargs = {"launch": "powertrain", **kwargs}
    with pytest.raises(ValueError, match=match):
        gym.make(env_id, **kwargs)


def test_the_vector_env_takes_launch() -> None:
    envs = gym.make_vec("LateralTracking-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        control="steer_accel", launch="powertrain")
    _, info = envs.reset(seed=0)
    np.testing.assert_allclose(info["target_speed_mps"], [1.0, 1.0])


def test_rows_record_the_launch() -> None:
    """A row of the ramp is never ranked with one of the step: the launch is part of the env's identity."""
    from vtrack_gym.evaluation.identity.env_identity import env_identity

    ramp = env_identity(gym.make("LateralTracking-v0", control="steer_accel", launch="powertrain"))
    step = env_identity(gym.make("LateralTracking-v0", control="steer_accel", launch="step"))
    plain = env_identity(gym.make("LateralTracking-v0", control="steer_accel"))
    assert ramp[1]["protocol"] == {"launch": "powertrain"}
    assert step == plain and "protocol" not in plain[1]


@pytest.mark.slow
def test_cli_eval_drives_the_launch(tmp_path, capsys) -> None:
    """``vtrack eval --control steer_accel --launch powertrain``: the decoupled lqr laps LateralTracking-v0 with
    an RMS speed error under 0.5 m/s, and its row records the launch."""
    from vtrack_gym.cli import main

    store = tmp_path / "store"
    assert main(["eval", "--policy", "lqr", "--env", "LateralTracking-v0", "--control", "steer_accel",
                 "--launch", "powertrain", "--store", str(store)]) == 0
    assert "rms_e_v_mps" in capsys.readouterr().out
    from vtrack_gym.evaluation.storage.store import ResultStore

    row = ResultStore(store, read_only=True).rows()[-1]
    assert row["options"] == {"control": "steer_accel", "protocol": {"launch": "powertrain"}}
    assert row["metrics"]["rms_e_v_mps"] < 0.5


def test_the_step_from_rest_is_warned_in_a_longitudinal_mode_naming_the_cars_figures() -> None:
    """The id's own step reference (kept: the pinned episodes) is warned of, with the time and distance the car's
    full throttle needs and the ramp it can follow; the steer mode, the ramp and a start at speed are not."""
    import warnings

    with pytest.warns(UserWarning, match=r"11\.11 m/s from t = 0.*C-Class Hatchback \(paper\) needs 2\.70 s and "
                                         r"15\.0 m at full throttle.*4\.09 m/s\^2.*launch='powertrain'"):
        gym.make("LateralTracking-v0", control="steer_accel")
    with pytest.warns(UserWarning, match="control='steer_rate_accel'"):
        gym.make("LateralTracking-v0", control="steer_rate_accel", launch="step")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        gym.make("LateralTracking-v0")
        gym.make("LateralTracking-v0", control="steer_accel", launch="powertrain")
        gym.make("DLC120-v0", control="steer_accel")


def test_the_full_throttle_launch_is_the_integral_of_the_cars_acceleration() -> None:
    """2.7 s and 15 m from rest to 40 km/h for the paper's car (the Control modes page), and the same figures from
    a plain Euler run of dv/dt = a(v) at 1 ms."""
    from vtrack_gym.envs.launch import full_throttle_launch

    car = VehicleParams()
    seconds, metres = full_throttle_launch(car, 40.0 / 3.6)
    v = s = t = 0.0
    while v < 40.0 / 3.6:
        a = float(forward_accel_limit_mps2(car, v))
        v, s, t = v + a * 1e-3, s + v * 1e-3, t + 1e-3
    assert seconds == pytest.approx(t, abs=2e-3) and metres == pytest.approx(s, rel=2e-3)
    with pytest.raises(ValueError, match=r"cannot reach 200\.00 m/s"):
        full_throttle_launch(car, 200.0)


def test_the_trajectory_suite_drives_the_held_speed_from_rest_on_the_powertrain_ramp() -> None:
    from vtrack_gym.evaluation.suite.suites import get_suite, with_control

    episodes = get_suite("trajectory").episodes_for()
    assert {ep.env_id: ep.launch for ep in episodes if ep.launch != "step"} == {"LateralTracking-v0": "powertrain"}
    assert {ep.launch for ep in with_control(episodes, "steer")} == {"step"}      # steer: the PD-FLC's own start


def test_cli_benchmark_launch_needs_a_longitudinal_mode(tmp_path, capsys) -> None:
    """Refused before any work (no store file made) in ``steer``, and on a suite with no held speed from rest."""
    from vtrack_gym.cli import main

    store = tmp_path / "store"
    assert main(["benchmark", "--suite", "paper", "--policies", "lqr", "--launch", "powertrain",
                 "--no-figures", "--store", str(store)]) != 0
    assert "longitudinal control mode" in capsys.readouterr().err
    assert main(["benchmark", "--suite", "maneuvers", "--policies", "lqr", "--control", "steer_accel", "--launch",
                 "powertrain", "--no-figures", "--store", str(store)]) != 0
    assert "none of these episodes does" in capsys.readouterr().err
    assert not store.exists()


@pytest.mark.slow
def test_cli_benchmark_gives_the_launch_to_the_held_speed_from_rest(tmp_path, capsys) -> None:
    """``vtrack benchmark --suite paper --control steer_accel --launch powertrain``: the lap takes the ramp (its
    row records it, RMS speed error under 0.5 m/s), the lane change at speed runs as it is."""
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore

    store = tmp_path / "store"
    assert main(["benchmark", "--suite", "paper", "--policies", "lqr", "--control", "steer_accel", "--launch",
                 "powertrain", "--no-figures", "--workers", "1", "--store", str(store)]) == 0
    rows = {r["env_id"]: r for r in ResultStore(store, read_only=True).rows()}
    assert rows["LateralTracking-v0"]["options"] == {"control": "steer_accel", "protocol": {"launch": "powertrain"}}
    assert rows["DLC120-v0"]["options"] == {"control": "steer_accel"}
    assert rows["LateralTracking-v0"]["metrics"]["rms_e_v_mps"] < 0.5
