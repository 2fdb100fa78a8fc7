"""RL agent pipeline: train (tiny) -> export -> load without torch -> evaluate; refusal of foreign files."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)

from vtrack_gym.baselines.numpy_policy import NumpyPolicy, load_agent  # noqa: E402

TINY = {
    "ppo": {"n_steps": 128, "batch_size": 256, "n_epochs": 2},
    "sac": {"learning_starts": 500, "buffer_size": 10_000, "gradient_steps": 1, "batch_size": 64},
    "td3": {"learning_starts": 500, "buffer_size": 10_000, "gradient_steps": 1, "batch_size": 64},
}


def _train_tiny(algo: str, run_dir: Path, timesteps: int = 3000) -> dict:
    from vtrack_gym.agents.train import train

    return train(algo, timesteps=timesteps, seed=0, run_dir=run_dir, num_envs=4, overrides=TINY[algo],
                 eval_freq=0, final_eval=False, progress_bar=False, command=f"pytest tiny {algo}")


@pytest.fixture(scope="module")
def ppo_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("ppo_run")
    return _train_tiny("ppo", run_dir)


def _obs_batch() -> np.ndarray:
    """Varied raw observations: starts of the random-track env plus perturbed copies."""
    from vtrack_gym.agents.sb3_vec_env import TrackingSB3VecEnv

    venv = TrackingSB3VecEnv("LateralTrackingRandom-v0", num_envs=8)
    venv.seed(3)
    obs = venv.reset()
    for _ in range(50):
        obs, *_ = venv.step(np.full((8, 1), 0.05, dtype=np.float32))
    venv.close()
    rng = np.random.default_rng(0)
    noisy = obs + rng.normal(size=obs.shape).astype(np.float32) * (np.abs(obs) + 0.1)
    return np.concatenate([obs, noisy]).astype(np.float32)


def _check_agreement(summary: dict, policy: NumpyPolicy) -> float:
    obs = _obs_batch()
    sb3_actions, _ = summary["model"].predict(summary["vecnormalize"].normalize_obs(obs), deterministic=True)
    np_actions, state = policy.predict(obs)
    assert state is None
    assert np_actions.shape == sb3_actions.shape == (len(obs), 1)
    assert np_actions.dtype == np.float32
    err = float(np.max(np.abs(np_actions - sb3_actions)))
    assert err <= 1e-5
    single, _ = policy.predict(obs[0])
    assert single.shape == (1,)
    assert abs(float(single[0]) - float(np_actions[0, 0])) <= 1e-6
    return err


TORCH_FREE_SCRIPT = textwrap.dedent("""
    import sys, json
    import numpy as np
    from vtrack_gym.baselines.numpy_policy import load_agent
    from vtrack_gym.evaluation.rollouts.rollout import rollout
    from vtrack_gym.evaluation.scoring.metrics import paper_metrics
    policy = load_agent(sys.argv[1])
    trace = rollout(policy, "DLC120-v0", seed=0, max_steps=300)
    m = paper_metrics(trace)
    print(json.dumps({"torch": "torch" in sys.modules, "sb3": "stable_baselines3" in sys.modules,
                      "steps": trace.n_steps, "max_e_y_m": m["max_e_y_m"],
                      "finite": bool(np.isfinite(trace["e_y_m"]).all())}))
""")


def _torch_free_rollout(agent: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", TORCH_FREE_SCRIPT, str(agent)], capture_output=True, text=True,
                         timeout=120, env={**os.environ, "OMP_NUM_THREADS": "1"}, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_ppo_train_export_load_without_torch(ppo_run):
    run_dir = Path(ppo_run["run_dir"])
    for name in ("config.json", "model.zip", "vecnormalize.pkl", "agent.json", "agent.npz", "logs/progress.csv"):
        assert (run_dir / name).is_file(), name
    config = json.loads((run_dir / "config.json").read_text())
    assert config["algo"] == "ppo" and config["seed"] == 0 and config["command"] == "pytest tiny ppo"
    assert config["package_version"] and len(config["hyperparams_sha256"]) == 64
    policy = load_agent(run_dir / "agent")
    assert policy.spec["output"] == "clip" and policy.spec["activation"] == "tanh"
    assert policy.spec["provenance"]["timesteps"] >= 3000
    _check_agreement(ppo_run, policy)
    res = _torch_free_rollout(run_dir / "agent.json")
    assert res == {**res, "torch": False, "sb3": False, "finite": True}
    assert 1 <= res["steps"] <= 300


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_offpolicy_train_export_agreement(algo, tmp_path):
    summary = _train_tiny(algo, tmp_path / algo)
    policy = load_agent(tmp_path / algo / "agent.npz")
    assert policy.spec["output"] == "tanh" and policy.spec["activation"] == "relu"
    _check_agreement(summary, policy)
    if algo == "sac":
        res = _torch_free_rollout(tmp_path / algo / "agent")
        assert not res["torch"] and res["finite"]


def test_paper_evaluation_callback_writes_capped_rows(tmp_path):
    from vtrack_gym.agents.train import train

    summary = train("ppo", timesteps=1024, seed=1, run_dir=tmp_path, num_envs=4, overrides=TINY["ppo"],
                    eval_freq=512, case1_max_steps=200, case1_full_every=0, final_eval=False, progress_bar=True)
    rows = [json.loads(line) for line in (tmp_path / "evaluations.jsonl").read_text().splitlines()]
    assert rows and summary["timesteps"] >= 1024
    case1 = rows[0]["results"]["LateralTracking-v0"]
    assert case1["step_cap"] == 200 and case1["steps"] <= 200
    assert "DLC120-v0" in rows[0]["results"]


def test_hyperparams_are_plain_yaml():
    from vtrack_gym.agents.train import ALGOS, load_hyperparams

    for algo in ALGOS:
        params, digest = load_hyperparams(algo)
        assert len(digest) == 64 and params["n_envs"] >= 1 and params["n_timesteps"] >= 1
    with pytest.raises(ValueError, match="no hyperparameters"):
        load_hyperparams("ppo", "DLC120-v0")
    with pytest.raises(ValueError, match="algo"):
        load_hyperparams("dqn")


# ------------------------------------------------------------------------------------------------ refusals
def _copy_agent(ppo_run, dst: Path) -> Path:
    src = Path(ppo_run["run_dir"]) / "agent"
    dst.mkdir(parents=True, exist_ok=True)
    for suffix in (".json", ".npz"):
        (dst / f"agent{suffix}").write_bytes(src.with_suffix(suffix).read_bytes())
    return dst / "agent"


class _Payload:
    """Unpickling this would create the marker file (we only ever pickle it)."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_refuses_pickle_payload(ppo_run, tmp_path):
    agent = _copy_agent(ppo_run, tmp_path)
    marker = tmp_path / "PWNED"
    npz = agent.with_suffix(".npz")
    npz.write_bytes(pickle.dumps(_Payload(str(marker))))
    with pytest.raises(ValueError, match="npz"):
        load_agent(agent)
    # a pickle hidden as an object array inside a well-formed npz
    arrays = dict(np.load(Path(ppo_run["run_dir"]) / "agent.npz"))
    obj = np.empty(1, dtype=object)
    obj[0] = _Payload(str(marker))
    arrays["w0"] = obj
    np.savez(npz, **arrays)
    with pytest.raises(ValueError):
        load_agent(agent)
    # the json itself replaced by a pickle
    agent.with_suffix(".json").write_bytes(pickle.dumps(_Payload(str(marker))))
    with pytest.raises(ValueError, match="JSON"):
        load_agent(agent)
    assert not marker.exists()


def test_refuses_sb3_zip_and_other_suffixes(ppo_run, tmp_path):
    model_zip = Path(ppo_run["run_dir"]) / "model.zip"
    with pytest.raises(ValueError, match="SB3"):
        load_agent(model_zip)
    with pytest.raises(ValueError):
        load_agent(Path(ppo_run["run_dir"]) / "vecnormalize.pkl")
    agent = _copy_agent(ppo_run, tmp_path)
    agent.with_suffix(".npz").write_bytes(model_zip.read_bytes())  # an SB3 zip renamed to .npz
    with pytest.raises(ValueError, match="members"):
        load_agent(agent)


def _tampered_json(ppo_run, tmp_path, edit) -> Path:
    agent = _copy_agent(ppo_run, tmp_path)
    spec = json.loads(agent.with_suffix(".json").read_text())
    edit(spec)
    agent.with_suffix(".json").write_text(json.dumps(spec))
    return agent


@pytest.mark.parametrize("edit, match", [
    (lambda s: s.update(extra=1), "unexpected keys"),
    (lambda s: s.pop("algo"), "missing keys"),
    (lambda s: s.update(algo="dqn"), "algo"),
    (lambda s: s.update(format="pickle"), "format"),
    (lambda s: s.update(format_version=2), "format_version"),
    (lambda s: s.update(hidden_sizes=[64, 32]), "shape"),
    (lambda s: s.update(hidden_sizes=[64] * 20), "hidden_sizes"),
    (lambda s: s.update(hidden_sizes=[64, True]), "hidden_sizes"),
    (lambda s: s.update(activation="__import__('os')"), "activation"),
    (lambda s: s.update(output="tanh"), "output"),
    (lambda s: s.update(obs_dim=34), "shape"),
    (lambda s: s["obs_norm"].update(enabled=False), "members"),
    (lambda s: s["obs_norm"].update(eps=-1.0), "eps"),
    (lambda s: s["provenance"].update(code="x"), "provenance"),
])
def test_refuses_tampered_json(ppo_run, tmp_path, edit, match):
    agent = _tampered_json(ppo_run, tmp_path, edit)
    with pytest.raises(ValueError, match=match):
        load_agent(agent)


def test_refuses_nonstandard_json_and_oversize(ppo_run, tmp_path):
    agent = _copy_agent(ppo_run, tmp_path)
    text = agent.with_suffix(".json").read_text().replace('"eps": 1e-08', '"eps": NaN')
    agent.with_suffix(".json").write_text(text)
    with pytest.raises(ValueError, match="NaN"):
        load_agent(agent)
    agent.with_suffix(".json").write_text(" " * (70 * 1024))
    with pytest.raises(ValueError, match="limit"):
        load_agent(agent)


@pytest.mark.parametrize("tamper, match", [
    (lambda a: a.update(w0=a["w0"].astype(np.float64)), "float32"),
    (lambda a: a.update(w0=a["w0"][:, :10]), "shape"),
    (lambda a: a.update(b1=np.full_like(a["b1"], np.nan)), "NaN"),
    (lambda a: a.update(evil=np.zeros(1, np.float32)), "members"),
    (lambda a: a.pop("obs_mean"), "members"),
    (lambda a: a.update(obs_var=-np.ones_like(a["obs_var"])), "obs_var"),
    (lambda a: a.update(action_low=np.ones_like(a["action_low"])), "action_low"),
])
def test_refuses_tampered_npz(ppo_run, tmp_path, tamper, match):
    agent = _copy_agent(ppo_run, tmp_path)
    arrays = dict(np.load(agent.with_suffix(".npz"), allow_pickle=False))
    tamper(arrays)
    np.savez(agent.with_suffix(".npz"), **arrays)
    with pytest.raises(ValueError, match=match):
        load_agent(agent)


def test_refuses_zip_with_code(ppo_run, tmp_path):
    agent = _copy_agent(ppo_run, tmp_path)
    with zipfile.ZipFile(agent.with_suffix(".npz"), "a") as zf:
        zf.writestr("__init__.py", "open('PWNED', 'w')\n")
    with pytest.raises(ValueError, match="members"):
        load_agent(agent)


def test_predict_rejects_bad_observations(ppo_run):
    policy = load_agent(Path(ppo_run["run_dir"]) / "agent")
    with pytest.raises(ValueError, match="shape"):
        policy.predict(np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        policy.predict(np.full(policy.obs_dim, np.nan))


def test_shipped_factories(ppo_run, tmp_path):
    from vtrack_gym.baselines.shipped import shipped_agent_factories

    assert isinstance(shipped_agent_factories(), dict)
    assert shipped_agent_factories(tmp_path / "missing") == {}
    _copy_agent(ppo_run, tmp_path / "ship")
    factories = shipped_agent_factories(tmp_path / "ship")
    assert list(factories) == ["agent"]
    assert isinstance(factories["agent"](None), NumpyPolicy)


def test_module_cli_records_command(tmp_path, capsys):
    from vtrack_gym.cli import main

    argv = ["train", "--algo", "ppo", "--timesteps", "512", "--num-envs", "2", "--eval-freq", "0", "--run-dir",
            str(tmp_path), "--no-progress", "--no-final-eval", "--set", "batch_size=256"]
    assert main(argv) == 0
    config = json.loads((tmp_path / "config.json").read_text())
    assert config["command"].startswith("vtrack train --algo ppo")  # recorded as the CLI command
    assert json.loads((tmp_path / "agent.json").read_text())["provenance"]["command"] == config["command"]
    assert '"timesteps": 512' in capsys.readouterr().out


def test_selection_score_prefers_completed_lane_change():
    from vtrack_gym.agents.train import selection_score

    dlc = {"completed": True, "max_e_y_m": 0.3, "termination": "completed"}
    capped_ok = {"completed": False, "termination": "max_steps", "step_cap": 3000}
    assert selection_score({"DLC120-v0": dlc, "LateralTracking-v0": capped_ok}) == 0.3
    full_lap_done = {"completed": True, "termination": "completed", "step_cap": None}
    assert selection_score({"DLC120-v0": dlc, "LateralTracking-v0": full_lap_done}) == 0.3
    for lap in ({"completed": False, "termination": "off_road", "step_cap": 3000},
                {"completed": False, "termination": "time_limit", "step_cap": None}):
        assert selection_score({"DLC120-v0": dlc, "LateralTracking-v0": lap}) == float("inf")
    spun = {**dlc, "completed": False, "termination": "spin_out"}
    assert selection_score({"DLC120-v0": spun, "LateralTracking-v0": full_lap_done}) == float("inf")


def test_periodic_evaluation_keeps_best_checkpoint_when_one_qualifies(tmp_path):
    from vtrack_gym.agents.train import train

    train("ppo", timesteps=1024, seed=2, run_dir=tmp_path, num_envs=4, overrides=TINY["ppo"], eval_freq=512,
          case1_max_steps=100, case1_full_every=0, final_eval=False, progress_bar=False)
    rows = [json.loads(line) for line in (tmp_path / "evaluations.jsonl").read_text().splitlines()]
    assert all("selection_score" in r and "new_best" in r for r in rows)
    # an untrained agent cannot complete the lane change: no row qualifies, so no best checkpoint is written
    qualified = [r for r in rows if r["new_best"]]
    assert (tmp_path / "best_agent.json").is_file() == bool(qualified)


@pytest.mark.parametrize("algo,extra", [
    ("ppo", {"use_sde": True, "sde_sample_freq": 4}),
    ("sac", {"use_sde": True, "policy_kwargs": {"net_arch": [32, 32], "activation_fn": "relu", "clip_mean": 0.0}}),
])
def test_gsde_policies_export_and_agree(algo, extra, tmp_path):
    from vtrack_gym.agents.train import train

    summary = train(algo, timesteps=1500, seed=0, run_dir=tmp_path, num_envs=4, overrides={**TINY[algo], **extra},
                    eval_freq=0, final_eval=False, progress_bar=False)
    _check_agreement(summary, load_agent(tmp_path / "agent"))


def test_sac_gsde_with_clipped_mean_is_refused(tmp_path):
    from vtrack_gym.agents.train import train

    with pytest.raises(ValueError, match="clip_mean=0"):
        train("sac", timesteps=600, seed=0, run_dir=tmp_path, num_envs=4,
              overrides={**TINY["sac"], "use_sde": True, "policy_kwargs": {"net_arch": [32, 32]}},
              eval_freq=0, final_eval=False, progress_bar=False)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_behaviour_cloning_warm_start(algo, tmp_path):
    """The warm start clones the expert on the training env, is evaluated at timestep 0, and exports cleanly."""
    from vtrack_gym.agents.imitation import BCConfig
    from vtrack_gym.agents.train import train

    bc = BCConfig(expert="lqr", steps=60, dagger_rounds=1, epochs=3, batch_size=64, critic_steps=50)
    summary = train(algo, timesteps=600 if algo == "ppo" else 200, seed=0, run_dir=tmp_path, num_envs=4,
                    overrides=TINY[algo], eval_freq=10_000, case1_max_steps=50, case1_full_every=0,
                    final_eval=False, progress_bar=False, bc=bc)
    record = json.loads((tmp_path / "bc.json").read_text())
    assert record["transitions"] == 2 * 60 * 4 and record["config"]["expert"] == "lqr"  # expert + 1 DAgger round
    assert len(record["fit"]["actor_mse"]) == 2 and max(record["fit"]["actor_mse"]) < 0.05
    assert record["replay_buffer_prefilled"] == (480 if algo == "sac" else 0)
    config = json.loads((tmp_path / "config.json").read_text())
    assert config["bc"]["expert"] == "lqr"
    assert config["hyperparams"]["learning_rate"] == 1.0e-5  # bc_finetune applied
    first = json.loads((tmp_path / "evaluations.jsonl").read_text().splitlines()[0])
    assert first["timesteps"] == 0  # the cloned agent, before any RL update
    _check_agreement(summary, load_agent(tmp_path / "agent"))


def test_bc_config_validates_fields():
    from vtrack_gym.agents.imitation import BCConfig

    with pytest.raises(ValueError, match=r"BCConfig.steps must be an int in \[10"):
        BCConfig(steps=1)
    with pytest.raises(ValueError, match=r"BCConfig\.noise_std"):
        BCConfig(noise_std=float("nan"))
