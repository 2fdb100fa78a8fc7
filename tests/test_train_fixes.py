"""`vtrack train` / `vtrack export` fixes, through the CLI (``vtrack_gym.cli.main``) and ``train``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("yaml")
torch = pytest.importorskip("torch")
torch.set_num_threads(1)

from vtrack_gym.cli import main  # noqa: E402

FAST = ["--num-envs", "2", "--eval-freq", "0", "--no-progress", "--no-final-eval", "--set", "batch_size=64"]
"""Options of a smoke-size CLI run (2 cars, no evaluation)."""
PPO_SMALL = ["--set", "n_steps=32", "--set", "batch_size=64", "--set", "n_epochs=1"]
"""PPO hyperparameters of a smoke-size run (64 transitions per rollout with 2 cars)."""


def test_warm_start_keeps_fixed_observation_scales(tmp_path: Path) -> None:
    """With the fixed observation scales (the recipe's ``callback``) the exported agent carries the fixed table
    after a warm start, not the expert data's statistics (e_y 0.25 m per unit)."""
    from vtrack_gym.agents.obs_scaling import fixed_statistics

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--env", "vtrack/TrainingMix20Hz-v0", "--bc-expert", "lqr", "--bc-steps",
                 "50", "--bc-dagger-rounds", "0", "--timesteps", "64", "--run-dir", str(run), *FAST,
                 *PPO_SMALL]) == 0
    assert json.loads((run / "config.json").read_text())["hyperparams"]["callback"].endswith(".FixedObservationScaling")
    spec = json.loads((run / "agent.json").read_text())
    arrays = np.load(run / "agent.npz", allow_pickle=False)
    mean, var = fixed_statistics(spec["env"]["observation_names"])
    np.testing.assert_allclose(arrays["obs_mean"], mean, rtol=1e-6)
    np.testing.assert_allclose(arrays["obs_var"], var, rtol=1e-6)
    assert float(np.sqrt(arrays["obs_var"][spec["env"]["observation_names"].index("e_y")])) == pytest.approx(0.25)


def test_run_dir_holding_a_run_is_refused_or_overwritten(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A second `vtrack train` into a run folder is refused before anything is written; ``--overwrite`` removes
    the earlier run's files (and only those) first, so nothing of the two runs is mixed."""
    from vtrack_gym.agents.train import train

    run = tmp_path / "run"
    argv = ["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(run), *FAST, *PPO_SMALL]
    assert main(argv) == 0
    (run / "notes.txt").write_text("mine\n")
    (run / "logs" / "mine.txt").write_text("mine\n")
    for stale in ("best_agent.json", "best_agent.npz", "best_model.zip", "bc.json", "evaluations.jsonl"):
        (run / stale).write_text("from an earlier run\n")
    before = {f: f.read_bytes() for f in run.rglob("*") if f.is_file()}
    capsys.readouterr()
    assert main([*argv, "--set", "n_epochs=2"]) == 2
    err = capsys.readouterr().err
    assert f"--run-dir {run} already holds a `vtrack train` run" in err and "--overwrite" in err
    assert {f: f.read_bytes() for f in run.rglob("*") if f.is_file()} == before  # nothing written or removed
    with pytest.raises(ValueError, match="already holds a `vtrack train` run"):
        train("ppo", timesteps=64, run_dir=run, num_envs=2, overrides={"n_steps": 32, "batch_size": 64},
              eval_freq=0, final_eval=False, progress_bar=False)

    assert main([*argv, "--set", "n_epochs=2", "--overwrite"]) == 0
    for stale in ("best_agent.json", "best_agent.npz", "best_model.zip", "bc.json", "evaluations.jsonl"):
        assert not (run / stale).exists(), stale
    assert (run / "notes.txt").read_text() == "mine\n" and (run / "logs" / "mine.txt").read_text() == "mine\n"
    assert json.loads((run / "config.json").read_text())["hyperparams"]["n_epochs"] == 2
    assert len(list((run / "logs").glob("events.out.tfevents.*"))) <= 1
    assert len((run / "logs" / "progress.csv").read_text().splitlines()) == 2  # header + this run's one rollout
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "again")]) == 0


def test_ctrl_c_saves_and_exports_the_model_as_it_is(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """A KeyboardInterrupt during learning (raised from a callback, as Ctrl+C would) saves the model, exports the
    agent, marks config.json interrupted with the timesteps reached and exits 130; the folder stays usable."""
    from stable_baselines3.common.callbacks import BaseCallback

    from vtrack_gym.agents import train as train_module

    class CtrlC(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps >= 128:
                raise KeyboardInterrupt
            return True

    make = train_module._make_callbacks
    monkeypatch.setattr(train_module, "_make_callbacks", lambda *a, **k: [*make(*a, **k), CtrlC()])
    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "640", "--run-dir", str(run), "--num-envs", "2",
                 "--eval-freq", "0", "--no-progress", *PPO_SMALL]) == 130
    err = capsys.readouterr().err
    assert "interrupted at 128 timesteps" in err and str(run / "agent.json") in err
    config = json.loads((run / "config.json").read_text())
    assert config["interrupted"] is True and config["timesteps_done"] == 128
    assert config["interrupted_during"] == "learning"
    assert json.loads((run / "agent.json").read_text())["provenance"]["timesteps"] == 128
    assert not (run / "evaluations.jsonl").exists()  # no final evaluation after Ctrl+C
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "again")]) == 0
    assert main(["eval", "--policy", str(run / "agent.json"), "--env", "DLC120-v0", "--store",
                 str(tmp_path / "s.sqlite")]) == 0
    monkeypatch.setattr(train_module, "_make_callbacks", make)
    assert main(["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(tmp_path / "done"), *FAST,
                 *PPO_SMALL]) == 0
    done = json.loads((tmp_path / "done" / "config.json").read_text())
    assert done["interrupted"] is False and done["timesteps_done"] == 64


@pytest.mark.parametrize("algo,settings,reason", [
    ("sac", ["use_sde=true"], "clip_mean=0"),
    ("ppo", ["use_sde=true", "policy_kwargs={squash_output: true}"], "squash_output"),
    ("ppo", ["policy_kwargs={net_arch: [0]}"], "hidden_sizes[0] must be an integer in [1, 4096]"),
    ("sac", ["policy_kwargs={net_arch: [0]}"], "hidden_sizes[0] must be an integer in [1, 4096]"),
    ("ppo", ["policy=CnnPolicy"], "policy must be MlpPolicy"),
])
def test_unexportable_settings_are_refused_before_training(algo: str, settings: list[str], reason: str,
                                                           tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """Settings whose agent `vtrack export` cannot write are refused with the reason before learning (exit 2),
    and nothing is written."""
    run = tmp_path / "run"
    argv = ["train", "--algo", algo, "--timesteps", "64", "--run-dir", str(run), *FAST]
    for item in settings:
        argv += ["--set", item]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert reason in err and "INFO training" not in err
    assert not run.exists()


@pytest.mark.parametrize("algo,item,message", [
    ("ppo", "gamma=0", "gamma must be a number in (0, 1]"),
    ("sac", "gamma=1.5", "gamma must be a number in (0, 1]"),
    ("ppo", "gamma=true", "gamma must be a number in (0, 1]"),
    ("ppo", "gae_lambda=-0.1", "gae_lambda must be a number in [0, 1]"),
    ("ppo", "clip_range=0", "clip_range must be a number > 0"),
    ("ppo", "ent_coef=-0.01", "ent_coef must be a number >= 0"),
    ("sac", "ent_coef=automatic", "ent_coef must be a number >= 0, 'auto' or 'auto_X'"),
    ("sac", "ent_coef=auto_", "ent_coef must be a number >= 0, 'auto' or 'auto_X'"),
    ("sac", "ent_coef=auto_inf", "ent_coef must be a number >= 0, 'auto' or 'auto_X'"),
    ("sac", "tau=0", "tau must be a number in (0, 1]"),
    ("td3", "tau=2", "tau must be a number in (0, 1]"),
    ("sac", "train_freq=0", "train_freq must be an integer in [1,"),
    ("sac", "batch_size=0", "batch_size must be an integer in [1, 131072] (buffer_size = 1000000"),
    ("sac", "buffer_size=100", "batch_size must be an integer in [1, 100] (buffer_size = 100"),
    ("ppo", "batch_size=1", "batch_size must be an integer in [2, 512] (n_steps x n_envs = 256 x 2 = 512"),
    ("ppo", "batch_size=4096", "--set batch_size=N, or more --num-envs or n_steps"),
    ("ppo", "batch_size=1.5", "batch_size must be an integer in [2, 512]"),
    ("td3", "learning_starts=-1", "learning_starts must be an integer in [0,"),
])
def test_out_of_range_hyperparameters_are_refused(algo: str, item: str, message: str, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """Values that crash SB3 or train nonsense are refused before anything is written, naming key and range."""
    run = tmp_path / "run"
    argv = ["train", "--algo", algo, "--timesteps", "64", "--run-dir", str(run), "--num-envs", "2", "--eval-freq",
            "0", "--no-progress", "--no-final-eval", "--set", item]
    if "batch_size" not in item and "buffer_size" not in item:
        argv += ["--set", "batch_size=64"]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not run.exists()


def test_timesteps_rounding_and_learning_starts_are_reported(tmp_path: Path,
                                                             caplog: pytest.LogCaptureFixture) -> None:
    """PPO's whole rollouts: the real number of steps is recorded and said; SAC/TD3 with learning_starts >=
    --timesteps warn that the agent is never updated."""
    run = tmp_path / "ppo"
    with caplog.at_level("INFO", logger="vtrack_gym"):
        assert main(["train", "--algo", "ppo", "--timesteps", "100", "--run-dir", str(run), *FAST, *PPO_SMALL]) == 0
    assert "--timesteps 100 becomes 128" in caplog.text
    assert "training PPO for 128 steps (100 rounded up to whole rollouts)" in caplog.text  # what SB3 runs
    config = json.loads((run / "config.json").read_text())
    assert config["timesteps"] == 100 and config["timesteps_effective"] == 128 and config["timesteps_done"] == 128
    assert any("becomes 128" in w for w in config["warnings"])
    caplog.clear()
    with caplog.at_level("WARNING", logger="vtrack_gym"):
        assert main(["train", "--algo", "td3", "--timesteps", "64", "--run-dir", str(tmp_path / "td3"), *FAST,
                     "--set", "buffer_size=1000", "--set", "policy_kwargs={net_arch: [8]}"]) == 0
    assert "learning_starts = 10000 >= --timesteps 64: the agent will never be updated" in caplog.text


def test_off_policy_timesteps_round_to_whole_collections() -> None:
    """SAC/TD3 collect train_freq vector steps of n_envs cars between updates: that many steps at a time."""
    from vtrack_gym.agents.recipes import check_hyperparams

    params = {"buffer_size": 1000, "batch_size": 64, "learning_starts": 0}
    assert check_hyperparams("sac", {**params, "train_freq": 4}, 8, 100)["timesteps_effective"] == 128
    assert check_hyperparams("td3", {**params, "train_freq": [2, "step"]}, 8, 100)["timesteps_effective"] == 112
    assert check_hyperparams("sac", {**params, "train_freq": [1, "episode"]}, 8, 100)["timesteps_effective"] == 104


def test_shipped_hyperparameters_pass_the_checks() -> None:
    """Every recipe of the hyperparameter files (and its warm-start variant) is within the checked ranges."""
    import yaml

    from vtrack_gym.agents.train import ALGOS, HYPERPARAMS_DIR, check_hyperparams, load_hyperparams

    for algo in ALGOS:
        for env_id in yaml.safe_load((HYPERPARAMS_DIR / f"{algo}.yaml").read_text()):
            params, _ = load_hyperparams(algo, env_id)
            finetune = params.pop("bc_finetune", None) or {}
            for variant in (params, {**params, **finetune}):
                notes = check_hyperparams(algo, variant, variant["n_envs"], 2**22)
                assert notes["timesteps_effective"] == 2**22 and not notes["warnings"], (algo, env_id)


def test_export_model_checks_normalisation_algo_and_period(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """`vtrack export --model`: refused without --vecnormalize when a vecnormalize.pkl lies next to the model, a
    mismatched --algo or a --vecnormalize that is not a VecNormalize pickle are clear errors (exit 2), the decision
    period is --control-period-s or the env's own (said), and raw observations are said."""
    import shutil

    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(run), *FAST, *PPO_SMALL]) == 0
    model = str(run / "model.zip")
    base = ["export", "--trust-code", "--env", "vtrack/TrainingMix-v0"]
    capsys.readouterr()
    assert main([*base, "--model", model, "--algo", "ppo", "--vecnormalize", str(run / "vecnormalize.pkl"),
                 "--out", str(tmp_path / "a")]) == 2   # the run folder records its 0.05 s: the env's own is refused
    err = " ".join(capsys.readouterr().err.split())
    assert "trained deciding every 0.05 s" in err and "decides every 0.01 s" in err
    at_period = [*base, "--control-period-s", "0.05"]
    assert main([*at_period, "--model", model, "--algo", "ppo", "--out", str(tmp_path / "a")]) == 2
    assert "vecnormalize.pkl next to it" in capsys.readouterr().err and not (tmp_path / "a.json").exists()
    assert main([*at_period, "--model", model, "--algo", "sac", "--vecnormalize", str(run / "vecnormalize.pkl"),
                 "--out", str(tmp_path / "a")]) == 2
    assert "holds a PPO model, not --algo sac" in capsys.readouterr().err
    assert main([*at_period, "--model", model, "--algo", "ppo", "--vecnormalize", model,
                 "--out", str(tmp_path / "a")]) == 2
    assert f"--vecnormalize {model} is not a VecNormalize pickle" in capsys.readouterr().err
    not_zip = tmp_path / "junk.zip"
    not_zip.write_bytes(b"not even a zip")
    assert main([*base, "--model", str(not_zip), "--algo", "td3", "--out", str(tmp_path / "a")]) == 2
    assert "not a loadable SB3 TD3 model" in capsys.readouterr().err

    assert main([*base, "--model", model, "--algo", "ppo", "--vecnormalize", str(run / "vecnormalize.pkl"),
                 "--control-period-s", "0.05", "--out", str(tmp_path / "a")]) == 0
    assert "decision period" not in capsys.readouterr().err
    a, ref = np.load(tmp_path / "a.npz"), np.load(run / "agent.npz")
    assert all(np.array_equal(a[k], ref[k]) for k in ref.files)
    assert json.loads((tmp_path / "a.json").read_text())["env"] == json.loads((run / "agent.json").read_text())["env"]

    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(model, alone / "model.zip")
    assert main([*base, "--model", str(alone / "model.zip"), "--algo", "ppo", "--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "decision period 0.01 s, vtrack/TrainingMix-v0's own" in err and "takes raw observations" in err
    spec = json.loads((tmp_path / "b.json").read_text())
    assert spec["obs_norm"]["enabled"] is False and spec["env"]["control_period_s"] == pytest.approx(0.01)
    assert main(["export", "--run-dir", str(run), "--control-period-s", "0.05", "--out", str(tmp_path / "c")]) == 2
    assert "go with --model" in capsys.readouterr().err
