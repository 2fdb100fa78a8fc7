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
