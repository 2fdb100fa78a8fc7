"""DAgger through the public entry points: ``vtrack train --algo dagger`` on a tiny budget (tracking and race), the
race split's registry, and the shipped DAgger agents loaded by name."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.agents.expert_identity import expert_identity
from vtrack_gym.baselines.decoupled import for_control
from vtrack_gym.baselines.registry import make_policy, policy_class
from vtrack_gym.baselines.resolve import default_policy_names, race_agent_names, shipped_names
from vtrack_gym.cli import main
from vtrack_gym.evaluation.identity.fingerprint import policy_hash
from vtrack_gym.tracks.race_circuits import HELD_OUT_IDS, RACE_SPLIT, race_circuit

pytest.importorskip("stable_baselines3")


def test_cli_dagger_tracking_runs_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two rounds (the expert's, then the clone's) of 20 vector steps of 2 cars: the run folder, the per-round
    record, the expert recorded by content (its policy_hash on the training env) and an agent that drives
    DLC120-v0 in steer_accel."""
    run = tmp_path / "run"
    assert main(["train", "--algo", "dagger", "--env", "vtrack/TrainingMixNominal-v0", "--dagger-rounds", "1",
                 "--bc-steps", "20", "--num-envs", "2", "--run-dir", str(run)]) == 0
    summary = json.loads(capsys.readouterr().out)
    record = json.loads((run / "dagger.json").read_text())
    assert [r["driver"] for r in record["rounds"]] == ["lqr", "clone"]
    assert all(r["transitions"] == 40 for r in record["rounds"])
    config = json.loads((run / "config.json").read_text())
    assert config["algo"] == "dagger" and config["control"] == "steer_accel" and config["dagger"]["rounds"] == 1
    training = gym.make("vtrack/TrainingMixNominal-v0", control="steer_accel")
    expert_hash = policy_hash(vtrack_gym.make_policy("lqr", training, preset="default"), training)
    recorded = {"label": "lqr[default]", "policy_hash": expert_hash, "package_version": vtrack_gym.__version__}
    assert config["expert"] == recorded and summary["expert"] == recorded
    env = gym.make("DLC120-v0", control="steer_accel")
    policy = vtrack_gym.make_policy(summary["agent"], env)
    assert policy.action_dim == 2 and policy.provenance["warm_start"].startswith(
        f"DAgger of lqr[default] (policy_hash {expert_hash}, vtrack_gym {vtrack_gym.__version__}) on "
        "vtrack/TrainingMixNominal-v0 (2 rounds")
    assert env.action_space.contains(policy.predict(env.reset(seed=0)[0])[0])


def test_expert_identity_tells_apart_two_experts_of_one_preset_name() -> None:
    """The lqr[default] pairing with the PD-FLC alone (the first dagger_accel's expert) and with today's speed law
    share a name, not an identity; the identity needs the env's observation layout."""
    env = gym.make("vtrack/TrainingMixNominal-v0", control="steer_accel")
    steering = policy_class("lqr").from_env(env, preset="default")   # what make_policy pairs with a speed law
    old, new = (expert_identity(for_control(steering, env, law), env, "lqr[default]") for law in ("pdflc", "pdflc_ff"))
    assert old.label == new.label and old.policy_hash != new.policy_hash
    assert new.policy_hash == policy_hash(vtrack_gym.make_policy("lqr", env), env)
    assert new.text() == f"lqr[default] (policy_hash {new.policy_hash}, vtrack_gym {vtrack_gym.__version__})"
    with pytest.raises(ValueError, match="observation layout"):
        expert_identity(steering, None, "lqr[default]")


def test_cli_dagger_refuses_rl_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["train", "--algo", "dagger", "--timesteps", "100", "--run-dir", str(tmp_path / "r")]) == 2
    assert "--timesteps" in capsys.readouterr().err
    assert main(["train", "--algo", "dagger", "--env", "DLC120-v0", "--run-dir", str(tmp_path / "r")]) == 2
    assert "recipes for" in capsys.readouterr().err
    assert main(["train", "--algo", "sac", "--dagger-rounds", "2", "--run-dir", str(tmp_path / "r")]) == 2
    assert "--algo dagger only" in capsys.readouterr().err


def test_cli_dagger_race_runs_on_training_circuits(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """One race of 200 steps per round, expert then clone, on the split's first circuits: an agent that reads the
    race observation without ``lap_fraction`` and binds to a held-out race id by name."""
    run = tmp_path / "race"
    assert main(["train", "--algo", "dagger", "--env", "vtrack/Race-v0", "--dagger-rounds", "1",
                 "--dagger-circuits", "1", "--bc-steps", "200", "--run-dir", str(run)]) == 0
    summary = json.loads(capsys.readouterr().out)
    record = json.loads((run / "dagger.json").read_text())
    assert [r["states"] for r in record["rounds"]] == [200, 400]
    config = json.loads((run / "config.json").read_text())
    assert config["circuits"] == list(RACE_SPLIT["train"])
    first = RACE_SPLIT["train"][0]
    on_first = gym.make("vtrack/Race-v0", track=race_circuit(first), laps=1)
    expert = make_policy("centreline", on_first, grip_scale=0.7)
    assert config["expert"] == summary["expert"] == {
        "label": f"centreline[grip_scale=0.7] on {first}", "policy_hash": policy_hash(expert, on_first),
        "package_version": vtrack_gym.__version__}
    spec = json.loads(Path(summary["agent"]).read_text())
    assert spec["provenance"]["warm_start"].startswith(f"DAgger of centreline[grip_scale=0.7] on {first} (policy_hash ")
    assert "lap_fraction" not in spec["env"]["observation_names"]
    assert spec["env"]["observation_names"][-2:] == ["edge_left_m", "edge_right_m"]
    env = gym.make("vtrack/RaceRing-v0")
    action, _ = vtrack_gym.make_policy(summary["agent"], env).predict(env.reset(seed=0)[0])
    assert env.action_space.contains(action)


def test_the_race_split_is_a_registry_of_closed_training_circuits() -> None:
    assert set(RACE_SPLIT) == {"train", "validation", "held_out", "held_out_ids"}
    assert RACE_SPLIT["held_out_ids"] == HELD_OUT_IDS
    groups = [set(RACE_SPLIT[k]) for k in ("train", "validation", "held_out", "held_out_ids")]
    assert sum(len(g) for g in groups) == len(set().union(*groups))       # no name in two groups
    assert len(RACE_SPLIT["validation"]) >= 4 and len(RACE_SPLIT["held_out"]) >= 4
    assert len(set(RACE_SPLIT["train"])) == len(RACE_SPLIT["train"]) >= 8
    path = race_circuit(RACE_SPLIT["train"][0])
    assert path.closed and 300.0 < path.length_m < 900.0 and not path.self_intersects(clearance_m=7.0)
    again = race_circuit(RACE_SPLIT["train"][0])
    assert np.array_equal(path.table, again.table)    # a pure function of the name
    with pytest.raises(ValueError, match="rc-<k>"):
        race_circuit("handling_course")


@pytest.mark.parametrize("barred", ["rc-24", "rc-2000", "vtrack/RaceRing-v0"])
def test_race_dagger_refuses_validation_and_held_out_circuits(tmp_path: Path, barred: str) -> None:
    from vtrack_gym.agents.race_dagger import RaceDaggerConfig, train_race_dagger

    config = RaceDaggerConfig(rounds=0, circuits_per_round=1, steps=10)
    with pytest.raises(ValueError, match=f"validation or held-out circuits or ids.*{barred}"):
        train_race_dagger(config, circuits=("rc-0", barred), run_dir=tmp_path / "run")
    assert not (tmp_path / "run").exists()


def test_race_agents_are_listed_for_the_race_ids_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """An agent that reads the race's fields is scored by default on the race ids only."""
    import vtrack_gym.baselines.resolve as resolve

    assert "dagger_accel" not in race_agent_names()
    assert "dagger_accel" in default_policy_names({"steer_accel"}, ["DLC120-v0"])
    assert "dagger_accel" in default_policy_names({"steer_accel"}, list(HELD_OUT_IDS))
    monkeypatch.setattr(resolve, "race_agent_names", lambda: ("dagger_accel",))   # as if it read edge_left_m
    assert "dagger_accel" not in default_policy_names({"steer_accel"}, ["DLC120-v0"])
    assert "dagger_accel" in default_policy_names({"steer_accel"}, list(HELD_OUT_IDS))
    assert "dagger_accel" in shipped_names()


def drive_accel(env_id: str, agent: str = "dagger_accel", **make_kwargs: object) -> dict:
    """One seed-0 episode of ``agent`` on ``env_id`` in ``steer_accel`` (``make_kwargs``: more ``gym.make``
    options): verdict, max |e_y| [m], RMS speed error [m/s]."""
    env = gym.make(env_id, control="steer_accel", **make_kwargs)
    policy = vtrack_gym.make_policy(agent, env)
    obs, info = env.reset(seed=0)
    e_y, e_v, done, state, start = [], [], False, None, True
    while not done:   # the state and episode start reach a baseline's memory (the expert's speed law)
        action, state = policy.predict(obs, state, episode_start=np.array([start]))
        obs, _, term, trunc, info = env.step(action)
        start = False
        e_y.append(info["e_y_m"])
        e_v.append(info["speed_error_mps"])
        done = term or trunc
    return {"success": bool(info["success"]), "termination": info["termination"],
            "max_e_y": float(np.max(np.abs(e_y))), "rms_e_v": float(np.sqrt(np.mean(np.square(e_v))))}


def test_dagger_accel_is_shipped_with_two_outputs_and_its_recipe() -> None:
    env = gym.make("DLC120-v0", control="steer_accel")
    policy = vtrack_gym.make_policy("dagger_accel", env)
    assert policy.action_dim == 2 and policy.spec["hidden_sizes"] == [64, 64]
    prov = policy.provenance
    assert "train --algo dagger --env vtrack/TrainingMixNominal-v0 --seed 0" in prov["command"]
    assert prov["warm_start"].startswith("DAgger of lqr[default] on vtrack/TrainingMixNominal-v0 (9 rounds")
    shipped = Path(vtrack_gym.__file__).parent / "baselines" / "shipped"
    assert (shipped / "dagger_accel.npz").stat().st_size < 100_000


def test_dagger_accel_completes_the_lane_change_at_120_kmh() -> None:
    """DLC120-v0 in steer_accel, seed 0: max |e_y| 0.195 m, RMS speed error 0.046 m/s, under the 0.5 m/s a
    controller must hold (the decoupled mpc: 0.157 m, 0.029 m/s; its expert, the decoupled lqr: 0.185 m,
    0.018 m/s)."""
    result = drive_accel("DLC120-v0")
    assert result["success"], result
    assert result["max_e_y"] < 0.2 and result["rms_e_v"] < 0.5, result


def test_dagger_accel_laps_the_handling_course() -> None:
    """LateralTracking-v0 in steer_accel (the held 40 km/h from standstill), seed 0: max |e_y| 0.086 m, no more
    than its expert's (the decoupled lqr: 0.089 m; it holds the speed through the corners the PD-FLC alone drove
    slower, 0.080 m then); RMS speed error 0.95 m/s, the launch the powertrain cannot follow (the lqr: 0.98)."""
    result, expert = drive_accel("LateralTracking-v0"), drive_accel("LateralTracking-v0", "lqr")
    assert result["success"] and expert["success"], (result, expert)
    assert result["max_e_y"] <= expert["max_e_y"] and result["rms_e_v"] < 1.3, (result, expert)


def test_dagger_accel_holds_the_speed_on_the_handling_course_it_can_launch_on() -> None:
    """LateralTracking-v0 with launch="powertrain" (a reference the car can follow from standstill), seed 0: the
    lap completed with an RMS speed error of 0.092 m/s, under the 0.5 m/s a controller must hold; max |e_y|
    0.093 m (the decoupled lqr: 0.088 m)."""
    result = drive_accel("LateralTracking-v0", launch="powertrain")
    assert result["success"], result
    assert result["rms_e_v"] < 0.5 and result["max_e_y"] < 0.1, result
