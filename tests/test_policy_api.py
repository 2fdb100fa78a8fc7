"""One make_policy, scoring your own policy (Python and CLI give the same rows), agent files that know their env,
the CLI's checks before any work, and the SB3 adapter's per-index contract (issue 17, items 2-7)."""

from __future__ import annotations

import json
import logging
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import vtrack_gym
from vtrack_gym.cli import build_parser, main
from vtrack_gym.envs import OBS

SHIPPED = Path(vtrack_gym.__file__).parent / "baselines" / "shipped"


class SteerOnErrors:
    """A user's policy: proportional steering on the lateral and heading errors (what the test scores)."""

    def __init__(self, env: gym.Env | None = None) -> None:
        self.gain_e_y, self.gain_e_phi = 0.08, 0.9

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=np.float64)
        a = -(self.gain_e_y * obs[..., OBS.E_Y] + self.gain_e_phi * obs[..., OBS.E_PHI])
        return np.clip(a, -1.0, 1.0).astype(np.float32)[..., None], state


from vtrack_gym.evaluation.scoring.metrics import CLOCK_MEASURED  # noqa: E402

WALL = "wall_time_per_step_s"


def _results(metrics: dict) -> str:
    """The metrics without the wall time (a measurement of the machine, not of the episode), NaN-safe."""
    return json.dumps({k: v for k, v in metrics.items() if k not in CLOCK_MEASURED}, sort_keys=True, default=float)


def _comparable(row) -> tuple:
    """Everything of a row but the wall time and the creation stamp."""
    return (row.suite, row.env_id, row.policy_id, row.policy_hash, row.seed, row.termination,
            _results(row.metrics), json.dumps(row.options, sort_keys=True))


def test_make_policy_resolves_every_kind_of_spec(tmp_path, monkeypatch):
    from vtrack_gym.baselines.numpy_policy import NumpyPolicy
    from vtrack_gym.baselines.registry import make_policy as make_baseline

    monkeypatch.chdir(tmp_path)
    for name in ("smc", "ppo", "sac", "mpc"):  # files and directories named like policies never shadow the names
        (tmp_path / name).mkdir()
    (tmp_path / "lqr").mkdir()
    (tmp_path / "lqr" / "x").write_text("not a policy")
    env = gym.make("DLC120-v0")
    assert type(vtrack_gym.make_policy("mpc", env)).__name__ == "MPC"
    assert type(vtrack_gym.make_policy("lqr", env)).__name__ == "LQR"
    assert vtrack_gym.make_policy("smc:paper", env).config == make_baseline("smc", env, preset="paper").config
    assert vtrack_gym.make_policy("smc", env, preset="hand").config == make_baseline("smc", env, preset="hand").config
    for name in ("ppo", "ppo_bc", "sac", "sac_bc"):
        agent = vtrack_gym.make_policy(name, env)
        assert isinstance(agent, NumpyPolicy) and agent.policy_id == name
    by_file = vtrack_gym.make_policy(str(SHIPPED / "ppo.json"), env)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(by_file.predict(obs)[0], vtrack_gym.make_policy("ppo", env).predict(obs)[0])
    listed = (r"pure_pursuit, mpc_osqp, nmpc, raceline, centreline, raceline_coupled, nmpc_coupled, bc_accel, "
              r"dagger_accel, dagger_race, dagger_race_v2, ppo")
    with pytest.raises(ValueError, match=r"unknown policy 'nope'.*" + listed):
        vtrack_gym.make_policy("nope", env)
    with pytest.raises(ValueError, match="unknown preset 'x'"):
        vtrack_gym.make_policy("smc:x", env)
    with pytest.raises(ValueError, match="--trust-code"):
        vtrack_gym.make_policy("os:system", env)
    with pytest.raises(ValueError, match="preset 'paper' applies to the baselines"):
        vtrack_gym.make_policy("ppo", env, preset="paper")


def test_import_stays_light_and_names_resolve_lazily():
    code = ("import sys, vtrack_gym; f = (vtrack_gym.make_policy, vtrack_gym.evaluate); "
            "print(sorted(m for m in ('numba', 'torch', 'stable_baselines3', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_evaluate_and_cli_trust_code_give_the_same_rows(tmp_path, capsys):
    from vtrack_gym.evaluation.storage.store import ResultStore

    spec = f"{__name__}:SteerOnErrors"
    py_store = tmp_path / "py.sqlite"
    rows = vtrack_gym.evaluate(SteerOnErrors(), "DLC120-v0", seeds=[0, 1], store=py_store, policy_id=spec)
    assert [r.seed for r in rows] == [0, 1] and all(r.suite == "custom" for r in rows)
    assert all(np.isfinite(r.metrics["max_e_y_m"]) for r in rows)
    factory_rows = vtrack_gym.evaluate(SteerOnErrors, "DLC120-v0", seeds=[0, 1], policy_id=spec)  # a factory
    assert [_comparable(r) for r in factory_rows] == [_comparable(r) for r in rows]

    cli_store = tmp_path / "cli.sqlite"
    argv = ["eval", "--policy", spec, "--env", "DLC120-v0", "--seeds", "0,1", "--store", str(cli_store)]
    assert main(argv) == 2
    assert "--trust-code" in capsys.readouterr().err
    assert not cli_store.exists()
    assert main([*argv, "--trust-code"]) == 0
    assert "--trust-code: importing and running your module" in capsys.readouterr().err
    stored = ResultStore(cli_store).rows("custom")
    assert len(stored) == 2
    assert [(r["seed"], r["termination"], _results(r["metrics"])) for r in stored] == \
        [(r["seed"], r["termination"], _results(r["metrics"])) for r in ResultStore(py_store).rows("custom")]
    assert [r["policy_hash"] for r in stored] == [r.policy_hash for r in rows]


def test_evaluate_suites_envs_and_bad_input(tmp_path):
    env = gym.make("DLC120-v0")
    on_env = vtrack_gym.evaluate(SteerOnErrors(), env, seeds=[0])
    by_id = vtrack_gym.evaluate(SteerOnErrors(), "DLC120-v0", seeds=[0])
    assert [_comparable(r)[1:] for r in on_env] == [_comparable(r)[1:] for r in by_id]
    paper = vtrack_gym.evaluate(lambda e: vtrack_gym.make_policy("lqr", e), "paper")
    assert [(r.suite, r.env_id, r.seed, r.termination) for r in paper] == \
        [("paper", "LateralTracking-v0", 0, "completed"), ("paper", "DLC120-v0", 0, "completed")]
    with pytest.raises(ValueError, match="unknown suite or env 'nope'"):
        vtrack_gym.evaluate(SteerOnErrors(), "nope")
    with pytest.raises(ValueError, match="seeds must be a sequence"):
        vtrack_gym.evaluate(SteerOnErrors(), "DLC120-v0", seeds=3)
    with pytest.raises(ValueError, match="predict"):
        vtrack_gym.evaluate(object(), "DLC120-v0")


def test_sb3_model_with_vecnormalize_scores_like_its_export(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    vn = VecNormalize(TrackingSB3VecEnv("LateralTrackingRandom-v0", 4), norm_reward=False)
    vn.seed(0)
    vn.reset()
    for _ in range(50):  # non-trivial statistics
        vn.step(np.zeros((4, 1), dtype=np.float32))
    vn.training = False
    model = PPO("MlpPolicy", vn, seed=0, device="cpu", policy_kwargs={"net_arch": [16]})
    model.save(tmp_path / "model.zip")
    vn.save(str(tmp_path / "vecnormalize.pkl"))
    assert main(["export", "--trust-code", "--model", str(tmp_path / "model.zip"), "--algo", "ppo", "--env",
                 "LateralTrackingRandom-v0", "--vecnormalize", str(tmp_path / "vecnormalize.pkl"), "--out",
                 str(tmp_path / "agent")]) == 0
    capsys.readouterr()
    spec = json.loads((tmp_path / "agent.json").read_text())
    assert spec["env"]["observation_names"] == list(OBS.names)
    assert spec["env"]["control_period_s"] == 0.01 and spec["env"]["max_road_wheel_angle_rad"] == 0.6

    env = gym.make("DLC120-v0")
    agent = vtrack_gym.make_policy(str(tmp_path / "agent.json"), env)
    obs, _ = env.reset(seed=0)
    # the numpy agent evaluates the same actor in float64 from float32 weights: actions agree to float32 rounding
    np.testing.assert_allclose(agent.predict(obs)[0], model.predict(vn.normalize_obs(obs), deterministic=True)[0],
                               atol=1e-6)
    sb3_rows = vtrack_gym.evaluate(model, "DLC120-v0", seeds=[0], vecnormalize=vn)
    agent_rows = vtrack_gym.evaluate(agent, "DLC120-v0", seeds=[0])
    assert sb3_rows[0].termination == agent_rows[0].termination
    assert sb3_rows[0].metrics["duration_s"] == agent_rows[0].metrics["duration_s"]


def test_agent_files_know_their_env(tmp_path, caplog):
    from vtrack_gym.envs.observation import ObservationLayout

    ppo = json.loads(  # the imitation agent: 33-entry layout, trained at 100 Hz
        (SHIPPED / "ppo_bc.json").read_text())
    shipped = ObservationLayout()  # the shipped agents' layout: OBS without the speed preview appended to it
    assert ppo["env"] == {"observation_names": list(shipped.names), "control_period_s": 0.01,
                          "max_road_wheel_angle_rad": 0.6}
    other = gym.make("DLC120-v0", layout=ObservationLayout(n_preview=10))
    with pytest.raises(ValueError, match="another observation layout: entry 23 is 'kappa_preview_11'"):
        vtrack_gym.make_policy("ppo_bc", other)
    swapped = dict(ppo, env=dict(ppo["env"], observation_names=[shipped.names[1], shipped.names[0],
                                                                *shipped.names[2:]]))
    (tmp_path / "swapped.json").write_text(json.dumps(swapped))
    shutil.copy(SHIPPED / "ppo_bc.npz", tmp_path / "swapped.npz")
    with pytest.raises(ValueError, match="entry 0 is 'e_phi' for the agent and 'e_y' in this env"):
        vtrack_gym.make_policy(str(tmp_path / "swapped.json"), gym.make("DLC120-v0"))
    legacy = {k: v for k, v in ppo.items() if k != "env"}  # a file written before the env record
    (tmp_path / "legacy.json").write_text(json.dumps(legacy))
    shutil.copy(SHIPPED / "ppo_bc.npz", tmp_path / "legacy.npz")
    assert vtrack_gym.make_policy(str(tmp_path / "legacy.json"), gym.make("DLC120-v0")).obs_dim == 33
    with pytest.raises(ValueError, match="takes 33 observations; this env's layout has 23"):
        vtrack_gym.make_policy(str(tmp_path / "legacy.json"), other)
    for bad, match in ((dict(ppo["env"], observation_names=list(shipped.names[:-1])), "32 names, obs_dim is 33"),
                       (dict(ppo["env"], control_period_s=-1.0), r"control_period_s must be a number in \(0, 1.0\]"),
                       (dict(ppo["env"], code="x"), "env must be an object with keys")):
        (tmp_path / "bad.json").write_text(json.dumps(dict(ppo, env=bad)))
        shutil.copy(SHIPPED / "ppo_bc.npz", tmp_path / "bad.npz")
        with pytest.raises(ValueError, match=match):
            vtrack_gym.make_policy(str(tmp_path / "bad.json"), gym.make("DLC120-v0"))
    fast = dict(ppo, env=dict(ppo["env"], control_period_s=0.005))  # trained deciding faster than the env asks
    (tmp_path / "fast.json").write_text(json.dumps(fast))
    shutil.copy(SHIPPED / "ppo_bc.npz", tmp_path / "fast.npz")
    with caplog.at_level("WARNING"):
        vtrack_gym.make_policy(str(tmp_path / "fast.json"), gym.make("DLC120-v0"))
    assert "control_period_s = 0.005, this env has 0.01" in caplog.text
    caplog.clear()
    slow = dict(ppo, env=dict(ppo["env"], control_period_s=0.05))  # the from-scratch recipes' 20 Hz decisions
    (tmp_path / "slow.json").write_text(json.dumps(slow))
    shutil.copy(SHIPPED / "ppo_bc.npz", tmp_path / "slow.npz")
    with caplog.at_level("DEBUG", logger="vtrack_gym"):  # a CLI test in this process may have set it to INFO
        vtrack_gym.make_policy(str(tmp_path / "slow.json"), gym.make("DLC120-v0"))
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert "trained deciding every 0.05 s; this env asks every 0.01 s" in caplog.text
    told = [r for r in caplog.records if "trained deciding" in r.getMessage()]
    assert [r.levelno for r in told] == [logging.DEBUG]  # by design for the shipped agents: shown with vtrack -v


def test_cli_checks_names_and_extras_before_any_work(tmp_path, capsys, monkeypatch):
    import importlib.util

    store = tmp_path / "s.sqlite"
    assert main(["benchmark", "--policies", "smc,nope", "--no-figures", "--store", str(store)]) == 2
    err = capsys.readouterr().err
    names = ("mpc_osqp, nmpc, raceline, centreline, raceline_coupled, nmpc_coupled, bc_accel, dagger_accel, "
             "dagger_race, dagger_race_v2, ppo, ppo_bc, sac, sac_bc, sac_race")
    assert "unknown policy 'nope'" in err and names in err and not store.exists()
    assert main(["plot", "--policies", "smc,nope", "--env", "DLC120-v0", "--out", str(tmp_path / "f")]) == 2
    assert "unknown policy 'nope'" in capsys.readouterr().err and not (tmp_path / "f").exists()
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "osqp" else real(name, *a))
    assert main(["benchmark", "--no-figures", "--store", str(store)]) == 2
    err = capsys.readouterr().err
    assert 'osqp (the mpc_osqp baseline)' in err and 'pip install "vtrack_gym[benchmark]"' in err
    assert not store.exists()
    assert main(["eval", "--policy", "mpc_osqp", "--env", "DLC120-v0", "--store", str(store)]) == 2
    assert "vtrack_gym[benchmark]" in capsys.readouterr().err


def test_leaderboard_lists_the_store_suites(tmp_path, capsys):
    store = tmp_path / "s.sqlite"
    assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--store", str(store)]) == 0
    capsys.readouterr()
    assert main(["leaderboard", "--store", str(store)]) == 2
    err = capsys.readouterr().err
    assert "no suite 'paper'" in err and "custom (1 episodes)" in err and "--suite NAME" in err
    assert main(["leaderboard", "--store", str(store), "--suite", "custom"]) == 0
    out, err = capsys.readouterr()
    assert "| DLC120-v0 | lqr |" in out and "suites present: custom (1 episodes)" in err


def test_outputs_never_go_over_docs_or_the_benchmark_figures():
    parser = build_parser()
    assert parser.parse_args(["reproduce"]).out == Path("vtrack_results")
    assert parser.parse_args(["reproduce", "--quick"]).out == Path("vtrack_results")
    assert parser.parse_args(["plot"]).out != parser.parse_args(["benchmark"]).figures


def test_verbose_logs_every_episode(tmp_path):
    argv = [sys.executable, "-m", "vtrack_gym.cli", "eval", "--policy", "lqr", "--env", "DLC120-v0",
            "--store", str(tmp_path / "s.sqlite")]
    quiet = subprocess.run(argv, capture_output=True, text=True, cwd=tmp_path)
    loud = subprocess.run([*argv[:3], "-v", *argv[3:]], capture_output=True, text=True, cwd=tmp_path)
    assert quiet.returncode == loud.returncode == 0
    assert "lqr on DLC120-v0 seed 0" not in quiet.stderr
    assert "DEBUG lqr on DLC120-v0 seed 0: completed" in loud.stderr


def test_sb3_vec_env_methods_act_on_the_given_indices():
    pytest.importorskip("stable_baselines3")
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("DLC120-v0", 3)
    venv.seed(0)
    obs0 = venv.reset()
    for _ in range(20):
        obs, *_ = venv.step(np.full((3, 1), 0.2, dtype=np.float32))
    assert not np.allclose(obs, obs0)
    single = gym.make("DLC120-v0")
    expected, _ = single.reset(seed=7, options={"initial_lateral_offset_m": 0.5})
    (got,) = venv.env_method("reset", seed=7, options={"initial_lateral_offset_m": 0.5}, indices=[1])
    np.testing.assert_array_equal(got, expected)
    after = venv.venv.sim.obs
    np.testing.assert_array_equal(after[1], expected)
    np.testing.assert_array_equal(after[[0, 2]], obs[[0, 2]])  # the other cars are untouched
    assert venv.get_attr("control_period_s", indices=[0, 2]) == [0.01, 0.01]
    with pytest.raises(ValueError, match="shared by all 3 sub-envs"):
        venv.set_attr("render_mode", "rgb_array", indices=[0])
    with pytest.raises(ValueError, match="shared by all 3 sub-envs"):
        venv.env_method("render", indices=1)
    venv.set_attr("render_mode", None, indices=[0, 1, 2])
    with pytest.raises(IndexError, match=r"\[3\] out of range"):
        venv.get_attr("render_mode", indices=[3])
