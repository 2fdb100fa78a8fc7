"""The scenario registry, ``vtrack/Track-v0`` on a user's track with a speed profile, per-side road widths and the
success verdicts (issue 16)."""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.envs.observation import OBS
from vtrack_gym.envs.scenarios import DLC120, LEGACY_IDS, SCENARIOS, Scenario
from vtrack_gym.envs.track_sources import TrackSource
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.tracks import ConstantSpeed, CurvatureLimited, load_track, speed_table
from vtrack_gym.tracks import Path as TrackPath

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import own_tracks

PROFILE = CurvatureLimited(40.0 / 3.6, 0.7 * 9.81)


class Zero:
    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        return np.zeros(1, dtype=np.float32), None


@pytest.fixture(scope="module")
def circuit_csv(tmp_path_factory) -> Path:
    """The "hairpins" circuit of benchmarks/own_tracks.py (6 and 7 m hairpins) as a CSV with widths."""
    return own_tracks.write_circuit_csv(tmp_path_factory.mktemp("tracks") / "hairpins.csv",
                                        own_tracks.circuits()["hairpins"])


def test_ids_are_generated_from_the_registry_with_aliases() -> None:
    from gymnasium.envs.registration import registry

    for sc in SCENARIOS.values():
        spec = registry[f"vtrack/{sc.name}"]
        assert spec.kwargs == {"scenario": sc.name}
        assert spec.max_episode_steps == (None if sc.time_limit_s is None else round(sc.time_limit_s / 0.01))
    for legacy in LEGACY_IDS:
        assert registry[legacy].entry_point == registry[f"vtrack/{legacy}"].entry_point
        assert registry[legacy].kwargs == registry[f"vtrack/{legacy}"].kwargs
    assert vtrack_gym.ENV_IDS == LEGACY_IDS
    with pytest.raises(ValueError, match=r"Scenario\.success must be a SuccessCriterion"):
        Scenario(name="x", success="fast")
    with pytest.raises(ValueError, match=r"TrackSource\.half_width_m must be in"):
        TrackSource(half_width_m=-1.0)
    with pytest.raises(TypeError):
        Scenario("x")  # every part is keyword-only


def test_alias_and_namespaced_id_give_identical_episodes_and_the_same_truncation() -> None:
    traces = [rollout(vtrack_gym.make_policy("lqr", gym.make(i)), i, seed=0) for i in ("DLC120-v0", "vtrack/DLC120-v0")]
    assert traces[0].termination == traces[1].termination == "completed"
    for name in ("e_y_m", "v_mps", "x_m"):
        np.testing.assert_array_equal(traces[0][name], traces[1][name])
    # the TimeLimit wrapper from spec.max_episode_steps truncates at the env's own step
    env = gym.make("vtrack/DLC120-v0")
    assert env.spec.max_episode_steps == env.unwrapped._sim.max_steps == round(DLC120.time_limit_s / 0.01)
    env.reset(seed=0)
    for _ in range(20_000):
        _, _, term, trunc, _ = env.step(np.zeros(1, dtype=np.float32))
        if term or trunc:
            break
    assert term and not trunc  # zero steering still drives to the end of the DLC before the time limit


def _whole_trajectory_cones(env, trace) -> int:
    from vtrack_gym.tracks import gate_violations

    c = env.unwrapped.config.vehicle.chassis
    return gate_violations(env.unwrapped.current_path, trace["x_m"], trace["y_m"], trace["psi_rad"],
                           c.body_length_m, c.body_width_m, c.cg_to_front_end_m)


def test_zero_steering_is_not_a_success_on_dlc120_but_mpc_is() -> None:
    env = gym.make("DLC120-v0")
    zero = rollout(Zero(), env, seed=0)
    assert zero.termination == "completed" and not zero.success
    assert evaluate_trace(zero)["success"] == 0.0
    cones = env.unwrapped.success_metrics()["cones_hit"]
    assert cones > 0 and cones == _whole_trajectory_cones(env, zero)  # the live count is the whole-trajectory one
    mpc = rollout(vtrack_gym.make_policy("mpc", env), env, seed=0)
    assert mpc.termination == "completed" and mpc.success and env.unwrapped.success_metrics()["cones_hit"] == 0
    assert _whole_trajectory_cones(env, mpc) == 0


def test_track_env_follows_the_speed_profile_and_completes_a_lap(circuit_csv: Path) -> None:
    env = gym.make("vtrack/Track-v0", track=str(circuit_csv), speed_profile=PROFILE)
    path = env.unwrapped.current_path
    table = speed_table(path, PROFILE)
    obs, info = env.reset(seed=0)
    assert obs.shape == (OBS.size,) and OBS.names[-1] == f"v_ref_preview_{OBS.n_speed_preview}"
    policy = vtrack_gym.make_policy("mpc", env)
    v_min = np.inf
    while True:
        action, _ = policy.predict(obs)
        obs, _, term, trunc, info = env.step(action)
        s = info["station_m"]
        assert obs[OBS.TARGET_SPEED] == pytest.approx(float(table.v_ref(s)), rel=1e-5)
        expect = table.preview(s, OBS.speed_preview_distances(obs[OBS.V_X]))[0]
        np.testing.assert_allclose(obs[OBS.speed_preview], expect, rtol=1e-4)
        v_min = min(v_min, info["target_speed_mps"])
        if term or trunc:
            break
    assert info["termination"] == "completed" and info["success"] is True
    assert v_min < 7.0  # the hairpins: sqrt(0.7 g x ~6 m)


def test_vector_track_env_takes_the_same_arguments(circuit_csv: Path) -> None:
    envs = gym.make_vec("vtrack/Track-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        track=str(circuit_csv), speed_profile=PROFILE)
    single = gym.make("vtrack/Track-v0", track=str(circuit_csv), speed_profile=PROFILE)
    obs, _ = envs.reset(seed=3)
    s_obs, _ = single.reset(seed=4)
    for _ in range(200):
        obs, *_ = envs.step(np.full((2, 1), 0.01, dtype=np.float32))
        s_obs, *_ = single.step(np.array([0.01], dtype=np.float32))
    np.testing.assert_array_equal(obs[1], s_obs)


def test_track_argument_forms_and_speed_profile_forms(circuit_csv: Path) -> None:
    path = load_track(str(circuit_csv))
    by_path = gym.make("vtrack/Track-v0", track=path, speed_profile=12.0)
    assert by_path.unwrapped.scenario.speed_profile == ConstantSpeed(12.0)
    assert by_path.unwrapped.current_path is path
    builtin = gym.make("vtrack/Track-v0", track="double_lane_change")
    assert builtin.unwrapped.scenario.speed_profile == CurvatureLimited(40.0 / 3.6, 0.7 * 9.81)
    with pytest.raises(ValueError, match="no speed column"):
        gym.make("vtrack/Track-v0", track=path, speed_profile="file")
    with pytest.raises(ValueError, match="track file not found"):
        gym.make("vtrack/Track-v0", track="nope.csv")


@pytest.mark.parametrize(("steer", "side"), [(0.05, "left"), (-0.05, "right")])
def test_per_station_widths_decide_off_road_per_side(steer: float, side: str) -> None:
    x = np.arange(0.0, 400.0, 2.0)
    widths = np.column_stack([np.full(x.size, 1.0), np.full(x.size, 3.0)])  # left 1 m, right 3 m
    path = TrackPath.from_points(x, np.zeros_like(x), widths_m=widths, name="straight")
    env = gym.make("vtrack/Track-v0", track=path, speed_profile=10.0)
    env.reset(seed=0)
    e_y = []
    while True:
        _, _, term, trunc, info = env.step(np.array([steer], dtype=np.float32))
        e_y.append(info["e_y_m"])
        if term or trunc:
            break
    assert info["termination"] == "off_road" and not info["success"]
    if side == "left":
        assert e_y[-1] > 1.0 and max(e_y[:-1]) <= 1.0
    else:
        assert e_y[-1] < -3.0 and min(e_y[:-1]) >= -3.0


def test_cli_track_option_records_provenance(circuit_csv: Path, tmp_path: Path, capsys) -> None:
    from vtrack_gym.cli import main
    from vtrack_gym.evaluation.storage.store import ResultStore
    from vtrack_gym.tracks import file_digest

    store = tmp_path / "board.db"
    assert main(["eval", "--policy", "lqr", "--track", str(circuit_csv), "--store", str(store)]) == 0
    assert main(["benchmark", "--policies", "stanley", "--track", str(circuit_csv), "--speed-profile", "constant",
                 "--max-speed-kmh", "20", "--no-figures", "--store", str(store)]) == 0
    same_name = tmp_path / "other" / circuit_csv.name  # same file name, other content
    same_name.parent.mkdir()
    same_name.write_text(circuit_csv.read_text().replace(",4.500", ",4.400"))  # a narrower left side
    assert main(["eval", "--policy", "lqr", "--track", str(same_name), "--store", str(store)]) == 0
    rows = ResultStore(store, read_only=True).rows()
    assert len(rows) == 3 and len({r["env_id"] for r in rows}) == 3  # never mixed on the board
    first, bench, other = rows
    assert first["options"]["track_sha256"] == file_digest(circuit_csv) != other["options"]["track_sha256"]
    assert first["options"]["speed_profile"] == {"kind": "EnvelopeLimited", "max_speed_mps": 40.0 / 3.6,
                                                 "max_lateral_accel_mps2": 0.7 * 9.81, "max_accel_mps2": None,
                                                 "max_decel_mps2": 3.0, "vehicle_limit_mps2": None,
                                                 "vehicle_name": "the car", "throttle_authority": "speed_loop"
                                                 }  # the CLI's default profile: the car's powertrain, as its
    #                                                  speed loop can drive it
    assert bench["options"]["speed_profile"] == {"kind": "ConstantSpeed", "v_mps": 20.0 / 3.6}
    assert first["metrics"]["success"] == 1.0 and first["termination"] == "completed"
    capsys.readouterr()
    for argv in (["--env", "DLC120-v0", "--track", str(circuit_csv)], []):  # exactly one of --env, --track
        with pytest.raises(SystemExit) as exc:
            main(["eval", "--policy", "lqr", *argv])
        assert exc.value.code == 2 and "--track" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:   # out of its range: refused while parsing
        main(["eval", "--policy", "lqr", "--track", str(circuit_csv), "--max-lateral-g", "0"])
    assert exc.value.code == 2 and "--max-lateral-g: must be a number" in capsys.readouterr().err


@pytest.mark.parametrize("name", own_tracks.POLICIES)
def test_every_default_baseline_laps_a_circuit_with_6m_hairpins(name: str, circuit_csv: Path) -> None:
    if name == "mpc_osqp":
        pytest.importorskip("osqp")
    result = own_tracks.drive(circuit_csv, name)
    assert result["termination"] == "completed" and result["success"] is True
    assert result["max_e_y_m"] < 4.0  # inside the narrower (right) half width of the road
